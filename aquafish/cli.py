"""``aquafish`` command line (argparse sub-commands).

Each package contributes its sub-commands through an ``add_commands(subparsers)``
function in its ``cli`` module; a sub-command's handler is stored as ``func`` and receives
the parsed ``argparse.Namespace``. These modules import no optional dependency
(stable-baselines3, torch, ray) at module level: a handler that needs one imports it
itself, so every sub-command is listed whatever extras are installed.

:func:`main` is the one error boundary of the command line: a bad setting, a file that
cannot be written or read, a corrupt or foreign file, a busy run directory or a request
that cannot fit in memory ends the command with one line on standard error,
``aquafish COMMAND: error: ...`` naming the flag or the path, what was wrong and what to
do, and exit status 2, without a traceback. ``--debug`` (before or after the command)
re-raises instead, to show the traceback.

A command with ``--config FILE`` (:func:`aquafish_gym.argtypes.add_config_option`) reads its
settings from that TOML file too, the flags given overriding it (:mod:`aquafish.config_file`):
:func:`main` applies the file while it parses the command line, and after the command succeeds
records it in the command's output directory.
"""

from __future__ import annotations

import argparse
import csv
import errno
import importlib
import os
import pickle
import sys
import zlib
from concurrent.futures.process import BrokenProcessPool

import aquafish
from aquafish.config_file import parse_command_line, write_record

#: Modules that contribute sub-commands, in help order.
COMMAND_MODULES = ("aquafish_gym.cli", "aquafish.bench_cli", "eea.cli", "gait.cli", "aquafish.studies_cli",
                   "aquafish.recovery_cli", "aquafish.mission_cli", "aquafish.heldout_cli", "aquafish.tables_cli",
                   "aquafish.doctor_cli")

#: Exit status of a command that failed safe (bad input, unusable file, busy directory).
EXIT_ERROR = 2
#: Exit status when standard output was closed by its reader (128 + SIGPIPE, as a shell reports it).
EXIT_BROKEN_PIPE = 141

#: What the boundary turns into one line: bad settings and unusable files.
EXPECTED_ERRORS = (ValueError, OSError, pickle.UnpicklingError, EOFError, csv.Error, zlib.error, MemoryError,
                   BrokenProcessPool)

_OS_HINTS = {
    errno.ENOTDIR: "a part of the path is a file, not a directory",
    errno.EISDIR: "it is a directory, not a file",
    errno.EACCES: "no permission; choose another path or fix the permissions",
    errno.EPERM: "no permission; choose another path or fix the permissions",
    errno.EROFS: "the file system is read-only; choose another path",
    errno.ENOSPC: "the disk is full; free space or choose another path",
    errno.EDQUOT: "the disk quota is exceeded; free space or choose another path",
    errno.ENOENT: "it does not exist",
    errno.EEXIST: "it already exists",
}


class OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose usage errors are one line (not the usage block, which for
    ``aquafish eea`` runs to dozens of lines) and point to ``--help``."""

    def error(self, message: str):
        """Print ``PROG: error: MESSAGE (see PROG --help)`` and exit with status 2."""
        self.exit(EXIT_ERROR, f"{self.prog}: error: {_one_line(message)} (see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``aquafish`` parser with every sub-command of :data:`COMMAND_MODULES`, each with ``--debug``."""
    parser = OneLineParser(prog="aquafish", description="Self-modeling aquatic robot: simulate, self-model (EEA), "
                                                        "evolve gaits, transfer.")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an error")
    parser.add_argument("--version", action="version", version=f"%(prog)s {aquafish.__version__}",
                        help="print the installed version and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name in COMMAND_MODULES:
        importlib.import_module(name).add_commands(sub)
    for command in sub.choices.values():
        command.add_argument("--debug", action="store_true", dest="debug_command", default=False,
                             help="show the traceback of an error")
    return parser


#: The longest error line: a longer message (a value quoted whole) keeps its start and its end
#: (what to do), the middle cut.
MAX_MESSAGE_CHARS = 1000


def _one_line(text: str) -> str:
    line = " ".join(str(text).split())
    if len(line) <= MAX_MESSAGE_CHARS:
        return line
    keep = (MAX_MESSAGE_CHARS - 40) // 2
    return f"{line[:keep]} ... ({len(line) - 2 * keep} characters cut) ... {line[-keep:]}"


def describe_error(err: BaseException) -> str:
    """One line for an error of :data:`EXPECTED_ERRORS`: what went wrong, on which path, and what to do."""
    if isinstance(err, OSError) and not isinstance(err, BrokenProcessPool):
        path = err.filename if err.filename is not None else None
        reason = err.strerror or str(err) or type(err).__name__
        hint = _OS_HINTS.get(err.errno or -1)
        where = f" {os.fsdecode(path)}" if path is not None else ""
        if err.filename2 is not None:
            where += f" -> {os.fsdecode(err.filename2)}"
        return _one_line(f"cannot use{where}: {reason}" + (f" ({hint})" if hint and hint.lower() != reason.lower() else ""))
    if isinstance(err, MemoryError):
        return _one_line(f"out of memory{': ' + str(err) if str(err) else ''}; lower the population, the duration "
                         "or the number of workers")
    if isinstance(err, BrokenProcessPool):
        return _one_line(f"a worker process died ({err}); it may have run out of memory or been killed: run again "
                         "(finished work is kept) or with fewer workers")
    if isinstance(err, (pickle.UnpicklingError, EOFError, zlib.error)):
        return _one_line(f"a file is truncated or corrupt ({type(err).__name__}: {err}); run again with --debug to "
                         "see which")
    return _one_line(str(err) or type(err).__name__)


def how_to_continue(args: argparse.Namespace) -> str:
    """What the line after an interrupt tells to do: ``run the same command to continue``, or what
    the command's handler says (its ``how_to_continue(args)`` attribute: ``aquafish gait``, whose
    directory holds checkpoints, continues with ``--resume latest``)."""
    hint = getattr(getattr(args, "func", None), "how_to_continue", None)
    try:
        text = hint(args) if hint is not None else None
    except Exception:  # noqa: BLE001  (a hint must not hide the interrupt)
        text = None
    return text or "run the same command to continue"


def main(argv: list[str] | None = None) -> int:
    """Run ``aquafish ARGV``; return the command's exit status (0).

    A config file (``--config FILE``) is applied while ``ARGV`` is parsed
    (:func:`aquafish.config_file.parse_command_line`) and, once the command succeeded, recorded
    in its output directory (:func:`aquafish.config_file.write_record`).

    Raises:
        SystemExit: status 2 after a one-line error on standard error (a usage error, or an
            error of :data:`EXPECTED_ERRORS` raised by the command), status 130 after an
            interrupt, status 0 after ``--help`` or ``--version``. A closed standard output (a
            reader such as ``head`` that stopped reading) ends the command quietly with
            :data:`EXIT_BROKEN_PIPE`, the status a shell gives a process killed by SIGPIPE.
    """
    parser = build_parser()
    args, config = parse_command_line(parser, sys.argv[1:] if argv is None else argv)
    debug = args.debug or getattr(args, "debug_command", False) or os.environ.get("AQUAFISH_DEBUG") == "1"
    try:
        result = args.func(args)
        if config is not None and not result:
            write_record(parser, args, config)
    except BrokenPipeError:
        # the reader of standard output went away (``aquafish bench ... | head``): stop quietly, as
        # a shell tool does on SIGPIPE; stdout is pointed at /dev/null so the interpreter's final
        # flush does not raise again
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except KeyboardInterrupt:
        if debug:
            raise
        parser.exit(130, f"aquafish {args.command}: interrupted; finished work is kept, {how_to_continue(args)}\n")
    except EXPECTED_ERRORS as err:
        if debug:
            raise
        parser.exit(EXIT_ERROR, f"aquafish {args.command}: error: {describe_error(err)}\n")
    return int(result or 0)


if __name__ == "__main__":
    sys.exit(main())
