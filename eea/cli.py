"""``aquafish eea`` sub-command (argparse), and an optional ``plot`` sub-command.

``aquafish eea --inference out_of_band --damage left_pectoral_half --duration 1.28
--rounds 25 --seed 0 --out DIR`` runs (or resumes) one EEA run; every
:class:`~eea.config.EEAConfig` field is a flag (``--estimation-population 50``) with the
dataclass default.

:func:`add_commands` adds only ``eea``: ``aquafish plot`` is provided by
``aquafish.studies_cli`` (two sub-commands of one name would clash). :func:`add_plot_command`
adds this package's own ``plot DIR... [--png FILE]`` (:func:`eea.plot.plot_runs`) to a parser
that has none.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from eea.config import FIELD_HELP, EEAConfig
from eea.inference import INFERENCE_NAMES

__all__ = ["add_commands", "add_plot_command"]

_SHORT_FLAGS = {"duration_s": ("--duration",)}


def _add_config_flags(parser: argparse.ArgumentParser) -> None:
    defaults = EEAConfig()
    for field in dataclasses.fields(EEAConfig):
        default = getattr(defaults, field.name)
        flags = (f"--{field.name.replace('_', '-')}", *_SHORT_FLAGS.get(field.name, ()))
        kwargs = {"type": type(default), "default": default, "dest": field.name,
                  "help": f"{FIELD_HELP[field.name]} (default: %(default)s)"}
        if field.name == "inference":
            kwargs["choices"] = INFERENCE_NAMES
        parser.add_argument(*flags, **kwargs)


def _run_eea(args: argparse.Namespace) -> int:
    from eea.run import run

    fields = {f.name: getattr(args, f.name) for f in dataclasses.fields(EEAConfig)}
    result = run(EEAConfig(**fields), args.out, progress=not args.no_progress)
    last = result.rounds[-1]
    print(f"{args.out}: {len(result.rounds)} rounds, objective fitness {last['objective_fitness']:.4f}, "
          f"model fitness {last['model_fitness']:.4f}, {last['simulations']} simulations")
    return 0


def _plot(args: argparse.Namespace) -> int:
    from eea.plot import plot_runs

    png = args.png if args.png is not None else Path(args.dirs[0]) / "objective_fitness.png"
    print(plot_runs(args.dirs, png))
    print(f"saved {png}")
    return 0


def add_commands(subparsers) -> None:
    """Add the ``eea`` sub-command to an argparse ``subparsers`` object."""
    eea = subparsers.add_parser("eea", help="run (or resume) the self-modeling EEA",
                                description="Run the Estimation-Exploration Algorithm on the simulated damaged "
                                            "robot (paper sections 3.2-3.4, 4); resumes DIR if it holds the same run.")
    eea.add_argument("--out", required=True, metavar="DIR", help="run directory (config.json, rounds.csv, state.pkl)")
    eea.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    _add_config_flags(eea)
    eea.set_defaults(func=_run_eea)


def add_plot_command(subparsers) -> None:
    """Add ``plot DIR... [--png FILE]`` (mean objective fitness against round, per strategy)."""
    plot = subparsers.add_parser("plot", help="plot mean objective fitness against round",
                                 description="Mean (solid) and std (dashed) objective fitness against EEA round, one "
                                             "line per inference strategy found in the runs under DIR...")
    plot.add_argument("dirs", nargs="+", metavar="DIR", help="run directories or directories containing runs")
    plot.add_argument("--png", type=Path, default=None, help="output image (default: FIRST_DIR/objective_fitness.png)")
    plot.set_defaults(func=_plot)
