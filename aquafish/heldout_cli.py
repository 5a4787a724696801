"""``aquafish heldout``: the registry of held-out sets, and spending a sealed set once
(:mod:`aquafish.heldout`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from aquafish_gym.argtypes import add_no_progress, add_processes, add_workers, path

#: The registry the command reads by default, relative to the current directory
#: (:data:`aquafish.heldout.REGISTRY_PATH`; not imported here, to keep the command line light).
DEFAULT_REGISTRY = Path("benchmarks/heldout.toml")


def _list(args: argparse.Namespace) -> int:
    from aquafish.heldout import format_sets, list_sets

    print(format_sets(list_sets(args.registry)), end="")
    return 0


def _show(args: argparse.Namespace) -> int:
    from aquafish.heldout import format_set, load_registry

    sets = load_registry(args.registry)
    if args.name not in sets:
        raise ValueError(f"no set {args.name!r} in {args.registry}; its sets: {', '.join(sets) or 'none'}")
    print(format_set(args.name, sets[args.name]), end="")
    return 0


def _run(args: argparse.Namespace) -> int:
    from aquafish.heldout import spend

    entry = spend(args.name, args.out, args.registry, processes=args.processes, workers=args.workers,
                  progress=not args.no_progress)
    print(f"set {args.name!r} spent at commit {entry['commit']}: {entry['result']}")
    print(f"records in {entry['records']}; commit them and {args.registry}, and publish the result")
    return 0


def add_commands(sub) -> None:
    h = sub.add_parser("heldout", help="the held-out sets (benchmarks/heldout.toml): list them, show one, or spend a "
                                       "sealed set once on the method frozen at a commit (aquafish.heldout)")
    actions = h.add_subparsers(dest="action", required=True, metavar="ACTION")

    def registry_option(parser: argparse.ArgumentParser) -> None:
        parser.add_argument("--registry", type=path, default=DEFAULT_REGISTRY, metavar="PATH",
                            help=f"the registry of held-out sets (default: {DEFAULT_REGISTRY}, relative to the "
                                 "current directory)")

    def debug_option(parser: argparse.ArgumentParser) -> None:
        # ``aquafish`` gives every command --debug; an action's own lets it come after the action too
        # (SUPPRESS: not given, it leaves the command's value as it is)
        parser.add_argument("--debug", action="store_true", dest="debug_command", default=argparse.SUPPRESS,
                            help="show the traceback of an error")

    ls = actions.add_parser("list", help="every set: name, kind, status, cells or missions, commit")
    registry_option(ls)
    debug_option(ls)
    ls.set_defaults(func=_list)

    show = actions.add_parser("show", help="one set's table and its number of cells or missions")
    show.add_argument("name", metavar="NAME", help="the set")
    registry_option(show)
    debug_option(show)
    show.set_defaults(func=_show)

    run = actions.add_parser("run", help="spend a sealed set: refuse unless the method (aquafish/, aquafish_gym/, "
                                         "eea/, gait/) is committed, mark the set spent at HEAD, run it, record its "
                                         "result; a validation or spent set is refused (an interrupted run resumes "
                                         "at the same commit into the same --out)")
    run.add_argument("name", metavar="NAME", help="the sealed set")
    run.add_argument("--out", required=True, type=path,
                     help="the set's run directory, its records (e.g. docs/results/heldout/NAME)")
    registry_option(run)
    debug_option(run)
    add_processes(run, 1, note="cells at once, a recovery set's (a missions set runs one at a time)")
    add_workers(run, None, "the runner's", note="a cell's or a mission's")
    add_no_progress(run, "cell")
    run.set_defaults(func=_run)
