"""``aquafish eea`` sub-command (argparse).

``aquafish eea --inference out_of_band --damage left_pectoral_half --duration 1.28
--rounds 25 --seed 0 --out DIR`` runs (or resumes) one EEA run; every
:class:`~eea.config.EEAConfig` field is a flag (``--estimation-population 50``) with the
dataclass default.

``aquafish plot`` (:func:`eea.plot.plot_runs`) is added by ``aquafish.studies_cli``.
"""

from __future__ import annotations

import argparse
import dataclasses

from eea.config import ESTIMATION_SEARCHES, FIELD_HELP, EEAConfig
from eea.inference import INFERENCE_NAMES, OOB_EXPERIMENTS

__all__ = ["add_commands"]

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
        if field.name == "estimation_search":
            kwargs["choices"] = ESTIMATION_SEARCHES
        if field.name == "oob_experiments":
            kwargs["choices"] = OOB_EXPERIMENTS
        parser.add_argument(*flags, **kwargs)


def _run_eea(args: argparse.Namespace) -> int:
    from eea.run import run

    fields = {f.name: getattr(args, f.name) for f in dataclasses.fields(EEAConfig)}
    result = run(EEAConfig(**fields), args.out, progress=not args.no_progress)
    last = result.rounds[-1]
    print(f"{args.out}: {len(result.rounds)} rounds, objective fitness {last['objective_fitness']:.4f}, "
          f"model fitness {last['model_fitness']:.4f}, {last['simulations']} simulations")
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
