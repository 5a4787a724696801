"""``aquafish eea`` sub-command (argparse).

``aquafish eea --inference out_of_band --damage left_pectoral_half --duration 1.28
--rounds 25 --seed 0 --out DIR`` runs (or resumes) one EEA run; every
:class:`~eea.config.EEAConfig` field is a flag (``--estimation-population 50``) with the
dataclass default; ``--budget NAME`` and ``--method NAME`` apply named settings
(:mod:`eea.methods`) that the flags given explicitly override (:func:`add_config_flags` and
:func:`config_fields`, which ``aquafish study`` uses too)::

    aquafish eea --method profile_lineages --budget reduced --damage caudal_half --out DIR

``aquafish plot`` (:func:`eea.analysis.plot.plot_runs`) is added by ``aquafish.studies_cli``.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Iterable

from aquafish_gym import argtypes
from eea.behaviour import SUMMARIES
from eea.config import ESTIMATION_SEARCHES, FIELD_HELP, MODEL_SPACE_NAMES, EEAConfig
from eea.methods import BUDGETS, METHODS, budget_fields, method_fields
from eea.inference import INFERENCE_NAMES

__all__ = ["add_commands", "add_config_flags", "config_fields", "config_flag_names", "given_flags"]

_SHORT_FLAGS = {"duration_s": ("--duration",)}
#: The allowed values of the fields that take a name.
_CHOICES = {"inference": INFERENCE_NAMES, "estimation_search": ESTIMATION_SEARCHES, "model_space": MODEL_SPACE_NAMES,
            "behaviour_summary": SUMMARIES}


#: Flag parsers of fields whose value is not their default's type, and of the fields every
#: command's flag of the same name parses alike (``--seed``, ``--workers``).
_TYPES = {"waterline": argtypes.waterline, "seed": argtypes.int_at_least(0), "workers": argtypes.int_at_least(1)}
#: Help of the flags every command shares, where the field's own help says it otherwise.
_HELP = {"workers": f"{argtypes.WORKERS_HELP} (simulations; 1 = serial; never changes results)"}


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
    also ``--duration``), stored under the field's name, with the field's type and
    :data:`eea.config.FIELD_HELP` as help (which names the dataclass default); named settings
    (``inference``, ``estimation_search``, ``model_space``) list their
    choices. Also adds ``--budget NAME`` (:data:`eea.methods.BUDGETS`, default ``paper``) and,
    when ``inference`` gets a flag, ``--method NAME`` (:data:`eea.methods.METHODS`). A flag not
    given leaves no attribute on the parsed namespace (``argparse.SUPPRESS``), so that
    :func:`config_fields` tells it from one given, even one whose value is None
    (``--waterline deep``).

    Args:
        parser: the (sub-)command's parser.
        exclude: field names that get no flag.

    Returns:
        The names of the fields that got a flag (:func:`config_flag_names`); read the values
        back with ``config_fields(args, names)``.

    Raises:
        ValueError: as :func:`config_flag_names`.
    """
    names = config_flag_names(exclude)
    defaults = EEAConfig()
    for name in names:
        default = getattr(defaults, name)
        flags = (f"--{name.replace('_', '-')}", *_SHORT_FLAGS.get(name, ()))
        parser.add_argument(*flags, type=_TYPES.get(name, type(default)), default=argparse.SUPPRESS, dest=name,
                            choices=_CHOICES.get(name),
                            help=f"{_HELP.get(name, FIELD_HELP[name])} (default: {default})")
    parser.add_argument("--budget", choices=list(BUDGETS), default="paper",
                        help="how much search each round gets (eea.methods.BUDGETS): smoke, quick, reduced (the "
                             "studies' setting), medium or paper (the default); flags given explicitly override it")
    if "inference" in names:
        parser.add_argument("--method", choices=list(METHODS), default=None,
                            help="a named method (eea.methods.METHODS): the paper's known, none, in_band, out_of_band, "
                                 "or profile_lineages (the best); flags given explicitly override its fields")
    return names


def config_fields(args: argparse.Namespace, names: Iterable[str]) -> dict:
    """The :class:`~eea.config.EEAConfig` fields a parsed command line sets, among ``names``.

    The budget's values first, then the method's (``--method``, if given), then every flag
    given explicitly; a field set by none of them is left out (the config's default applies).
    A field that is not in ``names`` (e.g. ``inference`` in a study, whose methods set it)
    is left out too.

    Args:
        args: parsed by a parser that :func:`add_config_flags` set up.
        names: the fields that got a flag (its return value).

    Returns:
        ``{field: value}`` to pass to :class:`~eea.config.EEAConfig`.
    """
    names = tuple(names)
    method = method_fields(args.method) if getattr(args, "method", None) else {}
    fields = {k: v for k, v in {**budget_fields(args.budget), **method}.items() if k in names}
    fields.update(given_flags(args, names))
    return fields


def given_flags(args: argparse.Namespace, names: Iterable[str]) -> dict:
    """The :class:`~eea.config.EEAConfig` fields among ``names`` whose flag the command line gave.

    A value of None is a value given (``--waterline deep`` is deep water, ``None``); a flag not
    given has no attribute on ``args`` (:func:`add_config_flags`).

    Returns:
        ``{field: value}`` in ``names`` order.
    """
    given = vars(args)
    return {n: given[n] for n in names if n in given}


def _run_eea(args: argparse.Namespace) -> int:
    from eea.run import run

    result = run(EEAConfig(**config_fields(args, config_flag_names())), args.out, progress=not args.no_progress)
    last = result.rounds[-1]
    print(f"{args.out}: {len(result.rounds)} rounds, objective fitness {last['objective_fitness']:.4f}, "
          f"model fitness {last['model_fitness']:.4f}, {last['simulations']} simulations")
    return 0


def add_commands(subparsers) -> None:
    """Add the ``eea`` sub-command to an argparse ``subparsers`` object."""
    eea = subparsers.add_parser("eea", help="run (or resume) the self-modeling EEA",
                                description="Run the Estimation-Exploration Algorithm on the simulated damaged "
                                            "robot (paper sections 3.2-3.4, 4); resumes DIR if it holds the same run.")
    eea.add_argument("--out", required=True, type=argtypes.path, metavar="DIR", help="run directory (config.json, rounds.csv, state.pkl); its checkpoint state.pkl is a pickle, "
                          "so a run directory is trusted like code: resume only your own or trusted ones")
    argtypes.add_no_progress(eea, "round")
    argtypes.add_config_option(eea)
    add_config_flags(eea)
    eea.set_defaults(func=_run_eea)
