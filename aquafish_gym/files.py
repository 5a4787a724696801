"""Atomic file writes: every result file and figure of the project is written through here.

:func:`atomic_write` writes a temporary file in the target's directory, flushes it to disk
and renames it over the target (``os.replace``), so a reader, or a run killed at any
moment, sees either the previous file or the complete new one, never half of one.
:func:`save_figure` renders a matplotlib figure in memory and writes it the same way.

This module is deliberately neutral (standard library only; matplotlib only inside
:func:`save_figure`), so that every package of the project can use it.
"""

from __future__ import annotations

import io
import os
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["atomic_write", "save_figure"]


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
