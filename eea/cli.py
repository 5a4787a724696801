"""``aquafish eea`` sub-command (argparse).

``aquafish eea --inference out_of_band --damage left_pectoral_half --duration 1.28
--rounds 25 --seed 0 --out DIR`` runs (or resumes) one EEA run; every
:class:`~eea.config.EEAConfig` field is a flag (``--estimation-population 50``) with the
dataclass default (:func:`add_config_flags`, which ``aquafish study`` uses too).

``aquafish plot`` (:func:`eea.plot.plot_runs`) is added by ``aquafish.studies_cli``.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Iterable

from eea.config import ESTIMATION_SEARCHES, FIELD_HELP, EEAConfig
from eea.inference import INFERENCE_NAMES, OOB_EXPERIMENTS
from eea.profile import INHERIT_RULES

__all__ = ["add_commands", "add_config_flags", "config_flag_names"]

_SHORT_FLAGS = {"duration_s": ("--duration",)}
#: The allowed values of the fields that take a name.
_CHOICES = {"inference": INFERENCE_NAMES, "estimation_search": ESTIMATION_SEARCHES, "oob_experiments": OOB_EXPERIMENTS,
            "profile_inherit": INHERIT_RULES}


def config_flag_names(exclude: Iterable[str] = ()) -> tuple[str, ...]:
    """The :class:`~eea.config.EEAConfig` fields that get a flag, in field order.

    Args:
        exclude: field names to leave out (those a command sets itself).

    Raises:
        ValueError: a name in ``exclude`` is not an ``EEAConfig`` field.
    """
    names = tuple(f.name for f in dataclasses.fields(EEAConfig))
    unknown = sorted(set(exclude) - set(names))
    if unknown:
        raise ValueError(f"not EEAConfig fields: {', '.join(unknown)}")
    return tuple(n for n in names if n not in set(exclude))


def add_config_flags(parser: argparse.ArgumentParser, exclude: Iterable[str] = ()) -> tuple[str, ...]:
    """Add one flag per :class:`~eea.config.EEAConfig` field to ``parser``.

    Field ``estimation_population`` becomes ``--estimation-population`` (``duration_s``
    also ``--duration``), stored under the field's name, with the field's type, its
    dataclass default and :data:`eea.config.FIELD_HELP` as help; named settings
    (``inference``, ``estimation_search``, ``oob_experiments``, ``profile_inherit``) list their
    choices.

    Args:
        parser: the (sub-)command's parser.
        exclude: field names that get no flag.

    Returns:
        The names of the fields that got a flag (:func:`config_flag_names`); read the values
        back with ``{name: getattr(args, name) for name in names}``.

    Raises:
        ValueError: as :func:`config_flag_names`.
    """
    names = config_flag_names(exclude)
    defaults = EEAConfig()
    for name in names:
        default = getattr(defaults, name)
        flags = (f"--{name.replace('_', '-')}", *_SHORT_FLAGS.get(name, ()))
        parser.add_argument(*flags, type=type(default), default=default, dest=name, choices=_CHOICES.get(name),
                            help=f"{FIELD_HELP[name]} (default: %(default)s)")
    return names


def _run_eea(args: argparse.Namespace) -> int:
    from eea.run import run

    fields = {name: getattr(args, name) for name in config_flag_names()}
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
    add_config_flags(eea)
    eea.set_defaults(func=_run_eea)
