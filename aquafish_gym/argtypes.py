"""``argparse`` types shared by every package's command line: a bad value is refused while the
command line is parsed, before any work, with a message that names the flag and what is allowed
(``argument --seed: must be an int >= 0, got '-1'``)."""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from aquafish_gym.checks import DuplicateKeyError, json_loads_unique_keys, short_repr
from aquafish_gym.files import InputFileError, read_input

__all__ = ["CONFIG_HELP", "EPISODE_DURATION_HELP", "PROCESSES_HELP", "WORKERS_HELP", "add_alias", "add_config_option",
           "add_episode_duration", "add_no_progress", "add_processes", "add_workers", "csv_list", "damage_list",
           "int_at_least", "is_comma_separated", "json_object", "path", "positive_float", "SEED_LIMIT", "seed_below"]

#: How every command's ``--workers`` help begins: processes that evaluate in parallel within one
#: run (a run's population, a case study's steps); ``--processes`` is the other count.
WORKERS_HELP = "evaluation processes inside one run"
#: How every command's ``--processes`` help begins: whole runs (study runs, recovery cells) at once.
PROCESSES_HELP = "runs at once"
#: How every command's ``--episode-duration-s`` help begins (the length of a gait's episodes).
EPISODE_DURATION_HELP = "simulated seconds of every episode"
#: How every command's ``--config`` help begins (:func:`add_config_option`).
CONFIG_HELP = "a TOML file of this command's settings"


def int_at_least(minimum: int):
    """An argparse ``type``: an integer >= ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"must be an int >= {minimum}, got {short_repr(text)}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be an int >= {minimum}, got {short_repr(text)}")
        return value

    parse.__name__ = f"int >= {minimum}"
    return parse


#: Seeds a command takes: ``0 .. SEED_LIMIT - 1``, the range of NumPy's and Python's global
#: generators, which a gait, a PPO policy and their episodes are seeded with.
SEED_LIMIT = 2**32


def seed_below(limit: int = SEED_LIMIT):
    """An argparse ``type``: a seed, an integer in ``[0, limit)`` (default :data:`SEED_LIMIT`; a
    procedure's seeds, case study, benchmark cell and mission, lie below
    :data:`aquafish.oracle.PROCEDURE_SEED_LIMIT`), refused while the command line is parsed
    (``argument --seed: must be an int >= 0 and <= 4294967295, got '4294967296'``), not inside NumPy."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = None
        if value is None or not 0 <= value < limit:
            shown = text if len(text) <= 40 else text[:37] + "..."
            raise argparse.ArgumentTypeError(f"must be an int >= 0 and <= {limit - 1}, got {shown!r}")
        return value

    parse.__name__ = "seed"  # one type on every command (tests/aquafish/test_cli_flags.py); the limit is its own
    parse.limit = limit
    return parse


def path(text: str) -> Path:
    """An argparse ``type``: a non-empty path (``Path("")`` would mean the current directory)
    without a NUL byte (which no file name holds; a config file can write one)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty; give a path")
    if "\0" in text:
        raise argparse.ArgumentTypeError(f"holds a NUL byte, which no file name can: {short_repr(text)}")
    return Path(text)


def positive_float(text: str) -> float:
    """An argparse ``type``: a finite number > 0 (``nan``, ``inf``, 0 and negatives are refused)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {short_repr(text)}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {short_repr(text)}")
    return value


def json_object(text: str) -> dict:
    """An argparse ``type``: a JSON object, inline (``'{"lineages": 1}'``) or the content of a
    ``.json`` file named by ``text``; a key given twice is refused."""

    source = text
    if text.strip().endswith(".json") and not text.lstrip().startswith("{"):
        try:
            source = read_input(Path(text)).decode("utf-8")
        except InputFileError as err:
            raise argparse.ArgumentTypeError(f"cannot read {err}") from None
        except UnicodeDecodeError:
            raise argparse.ArgumentTypeError(f"cannot read {text}: it is not UTF-8 text") from None
        except OSError as err:
            raise argparse.ArgumentTypeError(f"cannot read {text}: {err.strerror or err}") from None
    try:
        value = json_loads_unique_keys(source)
    except DuplicateKeyError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    except InputFileError as err:  # nested too deeply, an integer too long
        raise argparse.ArgumentTypeError(f"{text + ': ' if source is not text else ''}the JSON {err}") from None
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(f"is not valid JSON ({err}): {short_repr(text)}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object ({{\"name\": value, ...}}), got {short_repr(text)}")
    return value


def waterline(text: str) -> float | None:
    """An argparse ``type``: a free-surface height in units, or ``deep`` (None: deep water).

    The range is checked by :class:`~aquafish_gym.SimParams`.
    """
    if text.strip().lower() in ("deep", "none"):
        return None
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a height in units or 'deep', got {short_repr(text)}") from None


def csv_list(kind=str, choices=None):
    """An argparse ``type``: a non-empty comma-separated list of ``kind`` values, as a tuple
    (each one of ``choices``, when given)."""

    def parse(text: str) -> tuple:
        try:
            values = tuple(kind(v.strip()) for v in text.split(",") if v.strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected comma-separated {kind.__name__} values, "
                                             f"got {short_repr(text)}") from None
        if not values:
            raise argparse.ArgumentTypeError(f"expected at least one comma-separated {kind.__name__} value, "
                                             f"got {short_repr(text)}")
        if kind is float and not all(math.isfinite(v) for v in values):
            raise argparse.ArgumentTypeError(f"expected finite numbers, got {short_repr(text)}")
        unknown = [v for v in values if choices is not None and v not in choices]
        if unknown:
            raise argparse.ArgumentTypeError(f"unknown {', '.join(map(short_repr, unknown))}; "
                                             f"valid: {', '.join(choices)}")
        return values

    parse.__name__ = f"comma-separated {kind.__name__} list"
    parse.comma_separated = True
    return parse


def damage_list(text: str) -> tuple[str, ...]:
    """An argparse ``type``: a non-empty comma-separated list of damages, as a tuple of strings.

    A comma inside a JSON fault's brackets or braces does not split
    (``none,{"gains":[1,-0.5,1]},sampled:3`` is three damages); each damage is checked by
    :func:`aquafish_gym.get_damage` where it is used.
    """
    values, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            values.append(text[start:i])
            start = i + 1
    values.append(text[start:])
    values = tuple(v.strip() for v in values if v.strip())
    if not values:
        raise argparse.ArgumentTypeError(f"expected at least one comma-separated damage, got {short_repr(text)}")
    return values


damage_list.comma_separated = True


def is_comma_separated(kind) -> bool:
    """Is ``kind`` an argparse ``type`` that parses a comma-separated list (:func:`csv_list`,
    :func:`damage_list`)? A config file gives such a flag a TOML list (its items joined by commas).

    Args:
        kind: a flag's ``type`` (any callable, or None).

    Returns:
        True for a comma-separated list's type.
    """
    return bool(getattr(kind, "comma_separated", False))


def add_no_progress(parser: argparse.ArgumentParser, unit: str) -> argparse.Action:
    """Add ``--no-progress`` to a long-running command's parser (every one has it, under this one
    name): no progress display at all (:func:`aquafish_gym.progress.progress_bar`).

    Args:
        parser: the (sub-)command's parser.
        unit: what one line of progress reports when standard error is not a terminal
            (``"round"``, ``"generation"``, ...).

    Returns:
        The argparse action.
    """
    return parser.add_argument("--no-progress", action="store_true",
                               help=f"no progress (default: a bar on a terminal, one line per {unit} otherwise)")


def add_config_option(parser: argparse.ArgumentParser) -> argparse.Action:
    """Add ``--config FILE`` to a command's parser: a TOML file whose keys are the command's long
    flags without the dashes (``estimation_generations = 15``), read as if its flags came first
    on the command line, so that the flags given override it.

    The flag only declares the option (stored as ``config_file``); :func:`aquafish.cli.main`
    reads the file and applies it (:mod:`aquafish.config_file`) before the command line is
    parsed, for every command whose parser has it.

    Args:
        parser: the (sub-)command's parser.

    Returns:
        The argparse action.
    """
    return parser.add_argument("--config", type=path, default=None, dest="config_file", metavar="FILE",
                               help=f"{CONFIG_HELP}: one key per long flag, without the dashes (seed = 3, "
                                    "estimation_generations = 15, damages = [\"a\", \"b\"], no_progress = true); "
                                    "flags given on the command line override it")


def _help(lead: str, note: str, default, default_text: str | None) -> str:
    return lead + (f" ({note})" if note else "") + f" (default: {default if default_text is None else default_text})"


def add_workers(parser: argparse.ArgumentParser, default: int | None, default_text: str | None = None,
                note: str = "") -> argparse.Action:
    """Add ``--workers N`` (:data:`WORKERS_HELP`, an int >= 1) to a command's parser.

    Args:
        parser: the (sub-)command's parser.
        default: the value when not given (None: the command's own choice, e.g. all cores).
        default_text: how the help names the default (default: ``default``).
        note: what is evaluated, said after :data:`WORKERS_HELP`.

    Returns:
        The argparse action.
    """
    return parser.add_argument("--workers", type=int_at_least(1), default=default,
                               help=_help(WORKERS_HELP, note, default, default_text))


def add_processes(parser: argparse.ArgumentParser, default: int | None, default_text: str | None = None,
                  note: str = "") -> argparse.Action:
    """Add ``--processes N`` (:data:`PROCESSES_HELP`, an int >= 1) to a command's parser; the
    arguments and the return value are :func:`add_workers`'."""
    return parser.add_argument("--processes", type=int_at_least(1), default=default,
                               help=_help(PROCESSES_HELP, note, default, default_text))


def add_episode_duration(parser: argparse.ArgumentParser, default: float | None, default_text: str | None = None,
                         note: str = "") -> argparse.Action:
    """Add ``--episode-duration-s SECONDS`` (:data:`EPISODE_DURATION_HELP`, a finite number > 0)
    to a command's parser; the arguments and the return value are :func:`add_workers`'."""
    return parser.add_argument("--episode-duration-s", type=positive_float, default=default, metavar="SECONDS",
                               help=_help(EPISODE_DURATION_HELP, note, default, default_text))


def add_alias(parser: argparse.ArgumentParser, action: argparse.Action, *old: str) -> None:
    """Accept ``old`` spellings of ``action``'s flag, so that published commands keep working.

    An old spelling stores into the same attribute with the same type and choices (a
    ``store_true`` flag stays one), is not listed in ``--help`` and sets no default; the
    canonical flag's help names it.

    Args:
        parser: the (sub-)command's parser that holds ``action``.
        action: the canonical flag (what ``parser.add_argument`` returned).
        old: the old option strings, e.g. ``"--preset"``.
    """
    if isinstance(action, argparse._StoreTrueAction):
        kwargs = dict(action="store_true")
    else:
        kwargs = dict(type=action.type, choices=action.choices, metavar=action.metavar, nargs=action.nargs)
    parser.add_argument(*old, dest=action.dest, default=argparse.SUPPRESS, help=argparse.SUPPRESS, **kwargs)
    if action.help not in (None, argparse.SUPPRESS):
        action.help = f"{action.help} (old name: {', '.join(old)})"
