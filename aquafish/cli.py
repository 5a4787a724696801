"""``aquafish`` command line (argparse sub-commands).

Each package contributes its sub-commands through an ``add_commands(subparsers)``
function in its ``cli`` module; a sub-command's handler is stored as ``func`` and receives
the parsed ``argparse.Namespace``. These modules import no optional dependency
(stable-baselines3, torch, ray) at module level: a handler that needs one imports it
itself, so every sub-command is listed whatever extras are installed.
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: Modules that contribute sub-commands, in help order.
COMMAND_MODULES = ("aquafish_gym.cli", "aquafish.bench_cli", "eea.cli", "gait.cli", "aquafish.studies_cli",
                   "aquafish.doctor_cli")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="aquafish", description="Self-modeling aquatic robot: simulate, self-model (EEA), evolve gaits, transfer.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_commands(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        result = args.func(args)
    except ValueError as err:
        parser.exit(2, f"aquafish {args.command}: error: {err}\n")
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
