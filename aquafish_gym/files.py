"""Atomic file writes and bounded reads: every result file and figure of the project is written
through here, and every input file (a fault, a config, a controller, a record) is read through here.

:func:`atomic_write` writes a temporary file in the target's directory, flushes it to disk
and renames it over the target (``os.replace``), so a reader, or a run killed at any
moment, sees either the previous file or the complete new one, never half of one.
:func:`save_figure` renders a matplotlib figure in memory and writes it the same way.

:func:`read_input` reads a file the user names: only a regular file (a FIFO, a device such as
``/dev/zero`` or a directory is refused without blocking) and at most
:data:`MAX_INPUT_BYTES`; :func:`parse_json` parses JSON text nested at most
:data:`MAX_JSON_DEPTH` deep and refuses an integer too long to convert, so that no input
blocks, fills the memory or ends in a ``RecursionError``. Both raise :class:`InputFileError`
(a ``ValueError``) with a one-line message.

This module is deliberately neutral (standard library only; matplotlib only inside
:func:`save_figure`), so that every package of the project can use it.
"""

from __future__ import annotations

import io
import itertools
import json
import os
import re
import stat
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["InputFileError", "MAX_INPUT_BYTES", "MAX_JSON_DEPTH", "atomic_write", "check_json_depth", "parse_json",
           "read_input", "save_figure"]

#: The largest input file :func:`read_input` reads (bytes): the project's own JSON and TOML
#: files are well under a megabyte.
MAX_INPUT_BYTES = 64 * 2**20
#: How deeply JSON input may nest (objects and arrays): the project's files nest under 10 deep.
MAX_JSON_DEPTH = 100


class InputFileError(ValueError):
    """An input that cannot be read safely: no regular file, too large, or nested too deeply.

    Attributes:
        path: the file (None for text that came from no file).
        problem: what is wrong with it (the message is ``"PATH: PROBLEM"``, or ``PROBLEM``).
    """

    def __init__(self, path: str | os.PathLike | None, problem: str):
        self.path, self.problem = (None if path is None else Path(path)), problem
        name = None if path is None else os.fsdecode(path)
        shown = name if name is None or name.isprintable() else repr(name)  # a NUL byte, a newline: quoted
        super().__init__(problem if path is None else f"{shown}: {problem}")

    def __reduce__(self):
        return type(self), (self.path, self.problem)


def _file_kind(mode: int) -> str:
    return ("a directory" if stat.S_ISDIR(mode) else "a FIFO (named pipe)" if stat.S_ISFIFO(mode)
            else "a character device" if stat.S_ISCHR(mode) else "a block device" if stat.S_ISBLK(mode)
            else "a socket" if stat.S_ISSOCK(mode) else "not a regular file")


def read_input(path: str | os.PathLike, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The content of the input file ``path``: a regular file (a symbolic link to one is
    followed) of at most ``limit`` bytes.

    A FIFO, a device (``/dev/zero``, a terminal), a socket or a directory is refused without
    being read and without blocking (the file is opened non-blocking and checked before any
    read); a file larger than ``limit``, or one that grows past it while being read (``/proc``
    files report no size), is refused after ``limit + 1`` bytes.

    Raises:
        InputFileError: not a regular file, larger than ``limit`` bytes, or a name with a NUL byte.
        OSError: the file cannot be opened or read (missing, no permission); its ``filename``
            is ``path``.
    """
    name = os.fsdecode(path)
    if "\0" in name:
        raise InputFileError(path, "holds a NUL byte, which no file name can")
    try:
        mode = os.stat(path).st_mode
        if not stat.S_ISREG(mode):
            raise InputFileError(path, f"is {_file_kind(mode)}; give a regular file")
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0))
    except OSError as err:
        if err.filename is None:
            raise OSError(err.errno, err.strerror or str(err), name) from err
        raise
    try:
        mode = os.fstat(fd).st_mode  # what was opened, should it have been replaced since the stat
        if not stat.S_ISREG(mode):
            raise InputFileError(path, f"is {_file_kind(mode)}; give a regular file")
        chunks, size = [], 0
        while size <= limit:
            try:
                chunk = os.read(fd, min(limit + 1 - size, 1 << 20))
            except OSError as err:
                raise OSError(err.errno, err.strerror or str(err), name) from err
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:
            raise InputFileError(path, f"is larger than {limit:,} bytes, more than an input file of this project "
                                       "holds; give the right file")
        return b"".join(chunks)
    finally:
        os.close(fd)


#: A JSON string (escapes included), and anything but a bracket.
_JSON_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"', re.S)
_NOT_BRACKET = re.compile(r"[^\[\]{}]+")
_STEP = {"[": 1, "{": 1, "]": -1, "}": -1}


def check_json_depth(text: str, limit: int = MAX_JSON_DEPTH) -> None:
    """Refuse JSON ``text`` whose objects and arrays nest more than ``limit`` deep, before it is parsed.

    Raises:
        InputFileError: without a path (the caller names the source):
            ``"is nested more than LIMIT levels deep ..."``.
    """
    if text.count("[") + text.count("{") <= limit:
        return  # too few brackets to nest that deep
    brackets = _NOT_BRACKET.sub("", _JSON_STRING.sub("", text))
    if max(itertools.accumulate(map(_STEP.__getitem__, brackets)), default=0) > limit:
        raise InputFileError(None, f"is nested more than {limit} levels deep (objects and arrays); no input of "
                                   "this project nests so deep")


def parse_json(text: str | bytes, *, source: str | os.PathLike | None = None, object_pairs_hook=None,
               limit: int = MAX_JSON_DEPTH):
    """``json.loads(text)``, refusing what would end in a traceback instead of a message: JSON
    nested more than ``limit`` deep (:func:`check_json_depth`), and an integer of more digits
    than Python converts (``sys.get_int_max_str_digits()``, 4300).

    Args:
        text: the JSON text (bytes are decoded as UTF-8).
        source: the file it came from, named by the messages (None: the message is the problem alone).
        object_pairs_hook: as :func:`json.loads`'s.
        limit: the deepest nesting allowed.

    Raises:
        InputFileError: nested too deeply, or an integer too long (named by ``source``).
        json.JSONDecodeError: ``text`` is not valid JSON.
        UnicodeDecodeError: ``text`` is bytes that are not UTF-8.
    """
    if isinstance(text, (bytes, bytearray)):
        text = bytes(text).decode("utf-8")
    try:
        check_json_depth(text, limit)
        return json.loads(text, object_pairs_hook=object_pairs_hook)
    except InputFileError as err:
        raise InputFileError(source, err.problem) from None
    except json.JSONDecodeError:
        raise
    except RecursionError:
        raise InputFileError(source, f"is nested too deeply (objects and arrays); no input of this project nests "
                                     f"more than {limit} levels deep") from None
    except ValueError as err:
        if "digits" not in str(err):
            raise
        raise InputFileError(source, f"holds an integer of more than {sys.get_int_max_str_digits()} digits, more "
                                     "than any setting of this project needs") from None


def atomic_write(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (temporary file, flush, fsync, ``os.replace``).

    The temporary file ``.NAME.PID.*.tmp`` lives in the same directory as ``path`` (a rename
    is atomic only within one file system) and is removed if anything fails, including a
    ``KeyboardInterrupt``; ``path`` is then left as it was. A process killed mid-write leaves
    it behind: its pid tells :func:`aquafish_gym.rundir.run_lock` that nobody is writing it
    any more, and the next lock of the directory removes it. The parent directory must exist.
    The new file gets the permissions a plain ``open(path, "w")`` would give it
    (``0o666`` less the process umask), not ``mkstemp``'s private ``0o600``.

    Args:
        path: file to create or replace.
        data: the complete new content.

    Raises:
        FileNotFoundError: the parent directory does not exist.
        TypeError: ``data`` is not bytes-like.
        OSError: the file cannot be written or renamed (permissions, disk full, ...); its
            ``filename`` is ``path``.
    """
    path = Path(path)
    try:
        _write_replace(path, data)
    except OSError as err:
        if err.filename is None:  # a failed write() or fsync() names no file: name the one being written
            raise OSError(err.errno, err.strerror or str(err), os.fspath(path)) from err
        raise


def _write_replace(path: Path, data: bytes) -> None:
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            if hasattr(os, "fchmod"):  # POSIX
                os.fchmod(f.fileno(), 0o666 & ~_umask())
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _umask() -> int:
    """The process's file-creation mask (read by setting it and setting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def save_figure(fig: Figure, path: str | os.PathLike, **savefig_kwargs: Any) -> Path:
    """Render ``fig`` to ``path`` atomically; parent directories are created.

    The image is rendered to memory with ``fig.savefig`` in the format given by the file's
    suffix (``.png``, ``.pdf``, ``.svg``, ...; a ``format`` keyword takes precedence), then
    written with :func:`atomic_write`. The figure is not closed.

    Args:
        fig: a matplotlib ``Figure`` (pyplot's or a bare ``matplotlib.figure.Figure``).
        path: image file to write.
        **savefig_kwargs: further ``Figure.savefig`` arguments (``dpi``, ``bbox_inches``, ...).

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: ``path`` has no suffix and no ``format`` is given, or matplotlib does not
            support the format.
        OSError: as :func:`atomic_write`.
    """
    path = Path(path)
    fmt = savefig_kwargs.pop("format", None) or path.suffix.lstrip(".").lower()
    if not fmt:
        raise ValueError(f"cannot tell the image format of {path}: give it a suffix such as .png")
    buffer = io.BytesIO()
    fig.savefig(buffer, format=fmt, **savefig_kwargs)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, buffer.getvalue())
    return path
