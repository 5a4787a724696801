"""PyBullet, imported without its build banner: ``from aquafish_gym.bullet import p``.

PyBullet's C module prints ``pybullet build time: <date>`` when it is imported (with C
stdio, to standard error in the 3.2.x wheels, to standard output in other builds), which
would clutter the output of every ``aquafish`` command. :func:`import_quietly` imports it
with file descriptors 1 and 2 pointed at temporary files, flushes C stdio (which buffers
when the output is a pipe or a file) before restoring them, and passes on everything
printed meanwhile except the banner. Every module of the project imports PyBullet through
this one, so the first import, whichever module makes it, is the quiet one.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import sys
import tempfile
from types import ModuleType

__all__ = ["import_quietly", "p"]

#: The start of the line PyBullet prints on import.
BANNER = b"pybullet build time"


def _flush_c_stdio() -> None:
    """``fflush(NULL)``: write out every C stdio buffer of the process (no-op where libc is not found)."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError, TypeError):  # no C library handle (e.g. Windows)
        pass


def import_quietly(name: str, banner: bytes = BANNER) -> ModuleType:
    """Import module ``name``, dropping the lines starting with ``banner`` it prints to fd 1 or 2.

    Python's ``sys.stdout``/``sys.stderr`` are flushed first; the C-level output of the
    import is captured in temporary files and written back, less the banner lines, to the
    original descriptors. A module already imported is returned as is.

    Args:
        name: module to import.
        banner: start of the output lines to drop.

    Returns:
        The module.

    Raises:
        ImportError: as ``importlib.import_module`` (the output is restored first).
    """
    if name in sys.modules:
        return sys.modules[name]
    for stream in (sys.stdout, sys.stderr):
        if stream is not None:
            stream.flush()
    saved: dict[int, tuple[int, tempfile.TemporaryFile]] = {}
    try:
        for fd in (1, 2):
            try:
                original = os.dup(fd)
            except OSError:  # descriptor closed: nothing to hide or restore
                continue
            capture = tempfile.TemporaryFile()
            saved[fd] = (original, capture)
            os.dup2(capture.fileno(), fd)
        return importlib.import_module(name)
    finally:
        _flush_c_stdio()
        for fd, (original, capture) in saved.items():
            os.dup2(original, fd)
            os.close(original)
            capture.seek(0)
            kept = b"".join(line for line in capture.read().splitlines(keepends=True) if not line.startswith(banner))
            capture.close()
            if kept:
                os.write(fd, kept)


#: The ``pybullet`` module.
p = import_quietly("pybullet")
