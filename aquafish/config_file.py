"""Config files of the ``aquafish`` commands: ``aquafish COMMAND --config run.toml``.

A command whose parser has ``--config`` (:func:`aquafish_gym.argtypes.add_config_option`:
``eea``, ``study``, ``case-study``, ``recovery``, ``mission``, ``damages``, ``baselines``, ``gait``
(whose NEAT INI file is ``--neat-config``), ``rl``) reads a flat TOML file whose keys are its
long flags without the dashes, with underscores or dashes (``estimation_generations = 15`` or
``"estimation-generations" = 15``); for ``aquafish recovery``::

    budget = "smoke"
    damages = ["reversed_left_pectoral", "sampled:3"]   # a comma-separated flag takes a list
    seeds = [0, 1]                                       # (or the text "0,1")
    no_progress = true                                   # a switch takes true or false
    out = "runs/smoke"

The file becomes command-line flags (``--budget=smoke --damages=reversed_left_pectoral,sampled:3
--seeds=0,1 --no-progress --out=runs/smoke``) placed before the flags given, and the whole is
parsed once: every value goes through its flag's own type, choices and checks, the flags given
override the file, and a value from the file counts as given (``aquafish eea``'s flags over a
``--budget`` or ``--method``, :func:`eea.cli.given_flags`). A value means what the flag means:
a relative path is relative to the current directory, not to the file.

A bad file is one line, ``aquafish COMMAND: error: config file run.toml: ...``, exit status 2:
unreadable (a FIFO, a device or a file over :data:`~aquafish_gym.files.MAX_INPUT_BYTES` too,
:func:`aquafish_gym.files.read_input`), not TOML (the line), nested, a table (the file is
flat), an unknown key (the closest or the valid ones), an old name of a flag (the canonical
one), ``config`` itself, or a value its flag refuses (the flag's own message); ``--config``
given twice is refused too. After the command succeeds, its output directory gets
:data:`RECORD_FILE`: the file's content, the command line and every flag's effective value.

This is command-line plumbing (:func:`aquafish.cli.main` calls :func:`parse_command_line` and
:func:`write_record`), not the API.
"""

from __future__ import annotations

import argparse
import dataclasses
import difflib
import json
import os
import sys
import tomllib
from pathlib import Path

from aquafish_gym.argtypes import is_comma_separated
from aquafish_gym.checks import short_repr
from aquafish_gym.files import InputFileError, read_input

__all__ = ["RECORD_FILE", "ConfigFileError", "LoadedConfig", "config_argv", "config_keys", "parse_command_line",
           "read_config", "write_record"]

#: What a run given ``--config`` writes into its output directory after it succeeds.
RECORD_FILE = "config_file.json"
#: Keys a config file may not hold, and why.
REFUSED_KEYS = {"config": "a config file cannot name another; give --config on the command line",
                "debug": "it is not a setting of the run; give --debug on the command line"}
#: Unknown keys are answered with every valid key up to this many, else with a pointer to --help.
_LIST_AT_MOST = 30


class ConfigFileError(ValueError):
    """A config file that cannot be used; the message names the file and, where there is one, the key."""


@dataclasses.dataclass(frozen=True)
class LoadedConfig:
    """A config file as a command line applied it.

    Attributes:
        path: the file, as given to ``--config``.
        values: its keys and values, as read.
        argv: the flags it became (placed before the flags given).
        given: the command line after the command's name, as given (``--config`` included).
    """

    path: Path
    values: dict
    argv: tuple[str, ...]
    given: tuple[str, ...]


def _long_flags(action: argparse.Action) -> list[str]:
    return [s for s in action.option_strings if s.startswith("--")]


def config_keys(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    """The keys a config file of ``parser``'s command may hold, with their flags' actions.

    A key is a flag's canonical long name without the dashes (the first long option string of
    a flag that ``--help`` lists; ``duration_s``, not eea's ``--duration``, nor an old name
    :func:`~aquafish_gym.argtypes.add_alias` hides), spelled with underscores. ``--help``,
    ``--config`` and ``--debug`` are no keys.

    Args:
        parser: the command's parser.

    Returns:
        ``{key: action}`` in the order of ``--help``.
    """
    keys = {}
    for action in parser._actions:
        flags = _long_flags(action)
        if not flags or action.help == argparse.SUPPRESS or isinstance(action, argparse._HelpAction):
            continue
        key = flags[0][2:].replace("-", "_")
        if key not in REFUSED_KEYS and action.dest != "config_file":
            keys[key] = action
    return keys


def _other_names(parser: argparse.ArgumentParser, keys: dict[str, argparse.Action]) -> dict[str, str]:
    """Every other long name of a key's flag (an old name, a short form, ``no_video``) -> the key."""
    by_dest = {action.dest: key for key, action in keys.items()}
    names = {}
    for action in parser._actions:
        if action.dest in by_dest:
            for flag in _long_flags(action):
                name = flag[2:].replace("-", "_")
                if name != by_dest[action.dest]:
                    names[name] = by_dest[action.dest]
    return names


def read_config(path: str | os.PathLike) -> dict:
    """The keys and values of the TOML file ``path``, checked to be flat.

    Args:
        path: the config file.

    Returns:
        ``{key: value}`` as in the file (its keys as written).

    Raises:
        ConfigFileError: the file cannot be read (no regular file, or too large:
            :func:`aquafish_gym.files.read_input`), is no UTF-8 TOML (the message says where), or
            holds a table (``[section]`` or ``key = {...}``; the file is flat), or is an ``.ini``
            file (NEAT's, which ``aquafish gait`` takes as ``--neat-config``).
    """
    where = f"config file {os.fsdecode(path)}"
    if Path(path).suffix.lower() == ".ini":
        raise ConfigFileError(f"{where}: an INI file; --config takes a TOML file of the command's flags "
                              "(NEAT's INI file is aquafish gait --neat-config)")
    try:
        values = tomllib.loads(read_input(path).decode("utf-8"))
    except InputFileError as err:
        raise ConfigFileError(f"{where}: cannot read it: it {err.problem}") from None
    except OSError as err:
        raise ConfigFileError(f"{where}: cannot read it: {err.strerror or err}") from None
    except UnicodeDecodeError:
        raise ConfigFileError(f"{where}: not UTF-8 text; a config file is TOML") from None
    except tomllib.TOMLDecodeError as err:
        raise ConfigFileError(f"{where}: not valid TOML: {err}") from None
    except RecursionError:
        raise ConfigFileError(f"{where}: nested too deeply (arrays or tables); the file is flat: one key = value "
                              "line per flag") from None
    except ValueError as err:  # tomllib lets int() refuse an integer of more than 4300 digits
        if "digits" in str(err):
            raise ConfigFileError(f"{where}: holds an integer of more than {sys.get_int_max_str_digits()} digits, "
                                  "more than any setting needs") from None
        raise ConfigFileError(f"{where}: not valid TOML: {short_repr(str(err))}") from None
    for key, value in values.items():
        if isinstance(value, dict) or (isinstance(value, list) and any(isinstance(v, (dict, list)) for v in value)):
            raise ConfigFileError(f"{where}: key {key!r} holds a table or nested list; the file is flat: one "
                                  "key = value line per flag, no [sections]")
    return values


def _text(value) -> str:
    """A TOML scalar as a flag's text (``True`` is no flag value: refused before)."""
    return value if isinstance(value, str) else repr(value) if isinstance(value, float) else str(value)


def _kind(value) -> str:
    """What a TOML value is and its text, for a message: ``a string 'yes'``, ``a date 1979-05-27``."""
    kind = {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "a list"}.get(
        type(value), f"a {type(value).__name__}")
    return f"{kind} {value!r}" if isinstance(value, (str, list)) else f"{kind} {value}"


def config_argv(parser: argparse.ArgumentParser, values: dict, where: str) -> list[str]:
    """The flags that a config file's ``values`` stand for, each value checked by its flag.

    A string or number becomes ``--flag=TEXT``; a list becomes a comma-separated flag's items
    joined by commas (a flag that takes several values gets them one by one); ``true`` becomes
    a switch (``--no-progress``; ``false`` leaves it off) and a ``--video/--no-video`` pair gets
    the one it names. Every text goes through the flag's own type and choices here, so that a
    bad value is blamed on the file and key.

    Args:
        parser: the command's parser.
        values: the file's keys and values (:func:`read_config`).
        where: how messages name the file (``"config file run.toml"``).

    Returns:
        The flags, in the file's order.

    Raises:
        ConfigFileError: an unknown key, an old or other name of a flag, a key the file may not
            hold (:data:`REFUSED_KEYS`), a key given twice (as ``a_b`` and ``a-b``), a value of a
            kind its flag does not take, or a value its flag refuses (the flag's own message).
    """
    keys = config_keys(parser)
    others = _other_names(parser, keys)
    argv, seen = [], {}
    for written, value in values.items():
        key = written.replace("-", "_")
        if key in REFUSED_KEYS:
            raise ConfigFileError(f"{where}: key {written!r} is not allowed: {REFUSED_KEYS[key]}")
        if key in seen:
            raise ConfigFileError(f"{where}: key {written!r} is given twice (also as {seen[key]!r})")
        seen[key] = written
        if key not in keys:
            raise ConfigFileError(f"{where}: {_unknown(key, written, keys, others, parser.prog)}")
        action, flag = keys[key], _long_flags(keys[key])[0]
        at = f"{where}: key {written!r}"
        if isinstance(action, argparse.BooleanOptionalAction):
            if not isinstance(value, bool):
                raise ConfigFileError(f"{at}: {flag} is on or off: give true or false, got {_kind(value)}")
            argv.append(flag if value else f"--no-{flag[2:]}")
            continue
        if action.nargs == 0:  # store_true and the like: a switch
            if not isinstance(value, bool):
                raise ConfigFileError(f"{at}: {flag} is a switch: give true or false, got {_kind(value)}")
            if value:
                argv.append(flag)
            continue
        items = value if isinstance(value, list) else [value]
        if any(isinstance(v, bool) for v in items):
            raise ConfigFileError(f"{at}: {flag} takes a value, not true or false")
        odd = next((v for v in items if not isinstance(v, (str, int, float))), None)
        if odd is not None:
            raise ConfigFileError(f"{at}: {flag} takes a string, a number or a list of them, got {_kind(odd)}")
        several = action.nargs not in (None, argparse.OPTIONAL)
        if isinstance(value, list) and not (several or is_comma_separated(action.type)):
            raise ConfigFileError(f"{at}: {flag} takes one value, not a list")
        texts = [_text(v) for v in value] if isinstance(value, list) else [_text(value)]
        if not several:
            texts = [",".join(texts)]
        try:
            parser._get_values(action, list(texts))  # the flag's own type, nargs and choices checks
        except argparse.ArgumentError as err:
            raise ConfigFileError(f"{at}: {err}") from None
        argv += [flag, *texts] if several else [f"{flag}={texts[0]}"]
    return argv


def _unknown(key: str, written: str, keys: dict, others: dict, prog: str) -> str:
    if key in others:
        on_off = " = true or false" if isinstance(keys[others[key]], argparse.BooleanOptionalAction) else ""
        return f"key {written!r} is another name of {others[key]!r}; write {others[key]}{on_off}"
    close = difflib.get_close_matches(key, list(keys), n=3, cutoff=0.6)
    if close:
        return f"unknown key {written!r} for {prog}; did you mean {' or '.join(close)}?"
    if len(keys) <= _LIST_AT_MOST:
        return f"unknown key {written!r} for {prog}; valid keys: {', '.join(keys)}"
    return f"unknown key {written!r} for {prog}; valid keys: the long flags of '{prog} --help' without the dashes"


def _command_at(parser: argparse.ArgumentParser, argv: list[str]) -> tuple[int, argparse.ArgumentParser] | None:
    """Where the command's name is in ``argv`` (the first word not an option of ``parser``), and its parser."""
    sub = next((a for a in parser._actions if isinstance(a, argparse._SubParsersAction)), None)
    index = next((i for i, word in enumerate(argv) if not word.startswith("-")), None)
    if sub is None or index is None or argv[index] not in sub.choices:
        return None
    return index, sub.choices[argv[index]]


def _config_action(parser: argparse.ArgumentParser) -> argparse.Action | None:
    return next((a for a in parser._actions if a.dest == "config_file" and a.option_strings), None)


def parse_command_line(parser: argparse.ArgumentParser,
                       argv: list[str]) -> tuple[argparse.Namespace, LoadedConfig | None]:
    """Parse ``aquafish ARGV`` with the config file of ``--config``, when the command has one.

    The file's flags (:func:`config_argv`) go right after the command's name, before the flags
    given, and the whole command line is parsed once by ``parser``: the flags given override
    the file, and every value is checked as a flag's.

    Args:
        parser: the ``aquafish`` parser (:func:`aquafish.cli.build_parser`).
        argv: the command line after ``aquafish``.

    Returns:
        The parsed namespace, and the config file applied (None without ``--config``).

    Raises:
        SystemExit: status 2 after one line on standard error, ``aquafish COMMAND: error: ...``,
            for a bad config file (:class:`ConfigFileError`'s message), ``--config`` given more
            than once (the last file would replace the others) or a bad command line;
            status 0 after ``--help``.
    """
    argv = list(argv)
    found = _command_at(parser, argv)
    action = None if found is None else _config_action(found[1])
    if action is None:
        return parser.parse_args(argv), None
    index, command = found
    given = argv[index + 1:]
    full = action.option_strings[0]
    for word in given:  # argparse would take --conf for --config, but only after the file was needed
        name = word.split("=", 1)[0]
        if len(name) > 2 and name != full and full.startswith(name) and name not in command._option_string_actions:
            command.error(f"write {full} in full to give a config file, not {name}")
    # only --config, spelt in full: the rest is parsed once, with the file's flags
    pre = argparse.ArgumentParser(add_help=False, allow_abbrev=False, exit_on_error=False)
    pre.add_argument(*action.option_strings, dest="config_file", action="append", default=None)
    try:
        paths = pre.parse_known_args(given)[0].config_file
    except argparse.ArgumentError as err:
        command.error(str(err))
    if paths is not None and len(paths) > 1:  # the last would silently replace the others
        command.error(f"{full} is given {len(paths)} times ({', '.join(map(short_repr, paths))}); give one config "
                      "file (merge them into one, or give the other settings as flags)")
    path = None if paths is None else paths[0]
    if path is None:
        args = parser.parse_args(argv)
        if args.config_file is not None:  # not expected: every spelling argparse takes for --config is caught above
            command.error(f"write {full} in full to give a config file")
        return args, None
    where = f"config file {path}"
    try:
        checked = action.type(path)
        values = read_config(checked)
        file_argv = config_argv(command, values, where)
    except argparse.ArgumentTypeError as err:
        command.error(f"argument {full}: {err}")
    except ConfigFileError as err:
        command.error(str(err))
    args = parser.parse_args([*argv[:index + 1], *file_argv, *given])
    return args, LoadedConfig(checked, values, tuple(file_argv), tuple(given))


def _json_value(value):
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (tuple, list)):
        return [_json_value(v) for v in value]
    return value if value is None or isinstance(value, (str, int, float, bool)) else str(value)


def write_record(parser: argparse.ArgumentParser, args: argparse.Namespace, config: LoadedConfig) -> Path | None:
    """Record what a finished run given ``--config`` ran with, in its output directory.

    ``OUT/``:data:`RECORD_FILE` (JSON) holds ``command``, ``config_file`` (the path given),
    ``config`` (the file's keys and values as read), ``argv`` (the flags given after the
    command's name, which override the file) and ``flags`` (every flag's effective value, by
    key; a flag of ``aquafish eea`` or ``study`` left to its budget or method is absent: the
    run's ``config.json`` or ``study.json`` holds the value). Written only into a directory that
    the command made (its ``.aquafish-command``); a later run with ``--config`` replaces it.

    Args:
        parser: the ``aquafish`` parser that parsed ``args``.
        args: the parsed command line of the finished run.
        config: the config file applied (:func:`parse_command_line`).

    Returns:
        The file written, or None (no output directory of this command).

    Raises:
        OSError: the file cannot be written.
    """
    from aquafish_gym.files import atomic_write
    from aquafish_gym.rundir import command_of

    out = getattr(args, "out", None)
    if out is None or not Path(out).is_dir() or command_of(out) != args.command:
        return None
    command = _command_at(parser, [args.command])[1]
    flags = {key: _json_value(getattr(args, action.dest)) for key, action in config_keys(command).items()
             if hasattr(args, action.dest)}
    record = {"command": args.command, "config_file": os.fspath(config.path), "config": config.values,
              "argv": list(config.given), "flags": flags}
    path = Path(out) / RECORD_FILE
    atomic_write(path, (json.dumps(record, indent=2, default=str) + "\n").encode())
    return path
