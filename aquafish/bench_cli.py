"""``aquafish bench``: run one of the benchmark scripts in :mod:`aquafish.benchmarks`.

``aquafish bench sim`` runs :mod:`aquafish.benchmarks.sim_throughput`; ``aquafish bench NAME ARGS``
runs ``aquafish.benchmarks.NAME.main(ARGS)`` (e.g. ``aquafish bench eea_round --workers 1,2``). The
benchmark parses ``ARGS`` with :class:`aquafish.cli.OneLineParser` as ``aquafish bench NAME``,
so a bad flag is one line, ``aquafish bench NAME: error: ... (see 'aquafish bench NAME --help')``,
like every other usage error of the command line.
It lives here, in the top-level CLI package, so that the simulator package
:mod:`aquafish_gym` imports nothing from :mod:`aquafish.benchmarks`.
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil

__all__ = ["add_commands", "benchmark_names"]

#: Short names of benchmark modules.
ALIASES = {"sim": "sim_throughput"}


def benchmark_names() -> list[str]:
    """The benchmark modules in :mod:`aquafish.benchmarks` (and the short aliases), sorted."""
    import aquafish.benchmarks

    modules = {m.name for m in pkgutil.iter_modules(aquafish.benchmarks.__path__)}
    return sorted(modules | set(ALIASES))


def _bench(args: argparse.Namespace) -> int:
    from aquafish.cli import OneLineParser  # not at module level: aquafish.cli imports this module

    names = benchmark_names()
    if args.what not in names:
        raise ValueError(f"unknown benchmark {args.what!r}; known: {', '.join(names)}")
    bench_main = importlib.import_module(f"aquafish.benchmarks.{ALIASES.get(args.what, args.what)}").main
    bench_main(args.rest, prog=f"aquafish bench {args.what}", parser_class=OneLineParser)
    return 0


def add_commands(sub) -> None:
    """Add the ``bench`` sub-command to an argparse ``subparsers`` object."""
    b = sub.add_parser("bench", help="run a benchmark script (sim = simulator throughput)")
    b.add_argument("what", help="benchmark name: sim, or a module in aquafish/benchmarks/ (e.g. eea_round)")
    b.add_argument("rest", nargs=argparse.REMAINDER, help="arguments passed to the benchmark")
    b.set_defaults(func=_bench)
