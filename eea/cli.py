"""``aquafish eea`` sub-command (argparse).

``aquafish eea --inference out_of_band --damage left_pectoral_half --duration 1.28
--rounds 25 --seed 0 --out DIR`` runs (or resumes) one EEA run; every setting of
:class:`~eea.config.EEAConfig` is a flag by its flat name (:data:`eea.config.FLAT_FIELDS`:
``--estimation-population 50`` sets ``config.estimation.population``) with its default;
``--budget NAME`` and ``--method NAME`` apply named settings (:mod:`eea.methods`) that the flags
given explicitly override (:func:`add_config_flags` and :func:`config_fields`, which ``aquafish
study`` uses too). A flag of a strategy or search the run does not use (``--oob-period 5``
beside ``--inference known``) is an error at another value than its default; the same field
from a budget is dropped (:meth:`eea.config.EEAConfig.from_flat`)::

    aquafish eea --method profile_lineages --budget reduced --damage caudal_half --out DIR

``aquafish plot`` (:func:`eea.analysis.plot.plot_runs`) is added by ``aquafish.studies_cli``.
"""

from __future__ import annotations

import argparse
from typing import Iterable

from aquafish_gym import argtypes
from eea.behaviour import SUMMARIES
from eea.config import ESTIMATION_SEARCHES, FIELD_HELP, FLAT_DEFAULTS, FLAT_FIELDS, MODEL_SPACE_NAMES, EEAConfig
from eea.methods import BUDGETS, METHODS, budget_fields, method_fields
from eea.inference import INFERENCE_NAMES

__all__ = ["add_commands", "add_config_flags", "config_fields", "config_flag_names", "config_from_args", "given_flags"]

_SHORT_FLAGS = {"duration_s": ("--duration",)}
#: The allowed values of the fields that take a name.
_CHOICES = {"inference": INFERENCE_NAMES, "estimation_search": ESTIMATION_SEARCHES, "model_space": MODEL_SPACE_NAMES,
            "behaviour_summary": SUMMARIES}


#: Flag parsers of fields whose value is not their default's type, and of the fields every
#: command's flag of the same name parses alike (``--seed``, ``--workers``).
_TYPES = {"waterline": argtypes.waterline, "seed": argtypes.seed_below(), "workers": argtypes.int_at_least(1)}
#: Help of the flags every command shares, where the field's own help says it otherwise.
_HELP = {"workers": f"{argtypes.WORKERS_HELP} (simulations; 1 = serial; never changes results)"}


def config_flag_names(exclude: Iterable[str] = ()) -> tuple[str, ...]:
    """The flat names of :class:`~eea.config.EEAConfig` settings (:data:`eea.config.FLAT_FIELDS`)
    that get a flag, in the table's order.

    Args:
        exclude: flat names to leave out (those a command sets itself).

    Raises:
        ValueError: a name in ``exclude`` is not a flat name.
    """
    names = tuple(FLAT_FIELDS)
    unknown = sorted(set(exclude) - set(names))
    if unknown:
        raise ValueError(f"not EEAConfig fields: {', '.join(unknown)}")
    return tuple(n for n in names if n not in set(exclude))


def add_config_flags(parser: argparse.ArgumentParser, exclude: Iterable[str] = ()) -> tuple[str, ...]:
    """Add one flag per flat name of :class:`~eea.config.EEAConfig` (:data:`eea.config.FLAT_FIELDS`) to ``parser``.

    Field ``estimation_population`` becomes ``--estimation-population`` (``duration_s``
    also ``--duration``), stored under the flat name, with the default's type and
    :data:`eea.config.FIELD_HELP` as help (which names the default); named settings
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
    for name in names:
        default = FLAT_DEFAULTS[name]
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
    """The flat :class:`~eea.config.EEAConfig` fields a parsed command line sets, among ``names``.

    The budget's values first, then the method's (``--method``, if given), then every flag
    given explicitly; a field set by none of them is left out (the config's default applies).
    A field that is not in ``names`` (e.g. ``inference`` in a study, whose methods set it)
    is left out too.

    Args:
        args: parsed by a parser that :func:`add_config_flags` set up.
        names: the fields that got a flag (its return value).

    Returns:
        ``{flat name: value}``; build the config with :func:`config_from_args`, which tells the
        flags given (explicit) from the budget's and method's values.
    """
    names = tuple(names)
    method = method_fields(args.method) if getattr(args, "method", None) else {}
    fields = {k: v for k, v in {**budget_fields(args.budget), **method}.items() if k in names}
    fields.update(given_flags(args, names))
    return fields


def given_flags(args: argparse.Namespace, names: Iterable[str]) -> dict:
    """The flat :class:`~eea.config.EEAConfig` fields among ``names`` whose flag the command line gave.

    A value of None is a value given (``--waterline deep`` is deep water, ``None``); a flag not
    given has no attribute on ``args`` (:func:`add_config_flags`).

    Returns:
        ``{field: value}`` in ``names`` order.
    """
    given = vars(args)
    return {n: given[n] for n in names if n in given}


def config_from_args(args: argparse.Namespace, names: Iterable[str], **fields) -> EEAConfig:
    """The config a parsed command line asks for: the flags given (:func:`given_flags`) and
    ``fields`` explicit over the budget's and method's values (:func:`config_fields`), by
    :meth:`eea.config.EEAConfig.from_flat`'s rule.

    Args:
        args: parsed by a parser that :func:`add_config_flags` set up.
        names: the fields that got a flag.
        **fields: flat fields the command sets itself (explicit).

    Raises:
        ValueError: as :meth:`eea.config.EEAConfig.from_flat` (e.g. a flag of a strategy the run
            does not use).
    """
    names = tuple(names)
    return EEAConfig.from_flat({**given_flags(args, names), **fields}, optional=config_fields(args, names))


def _run_eea(args: argparse.Namespace) -> int:
    from eea.run import run

    result = run(config_from_args(args, config_flag_names()), args.out, progress=not args.no_progress)
    last = result.rounds[-1]
    print(f"{args.out}: {len(result.rounds)} rounds, objective fitness {last['objective_fitness']:.4f}, "
          f"model fitness {last['model_fitness']:.4f}, {last['simulations']} simulations")
    check = result.fault_check
    if check is not None:
        gains = ", ".join(f"{g:+.3f}" for g in check.model[9:])
        verdict = ("kept" if check.index == 0 else "replaced by a fault hypothesis about the design"
                   + (", its servo gains polished" if check.polished else ""))
        print(f"fault check: the final model {verdict}; self-model servo gains ({gains}), "
              f"objective fitness {result.self_model_objective_fitness:.4f} ({check.simulations} simulations)")
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
