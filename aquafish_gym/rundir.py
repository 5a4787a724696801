"""Fail-safe run directories: output checks, an advisory lock, fingerprints, validated reads and
worker pools that die with their parent.

Every command of the project that writes results goes through these helpers, so that it

* checks that its output can be written *before* any work starts and before anything is
  created (:func:`check_output_dir`, :func:`check_output_file`);
* holds an advisory lock on its run directory while it writes (:func:`run_lock`, POSIX
  ``fcntl.flock``: the kernel releases it when the process dies, even by ``kill -9``), so a
  second writer fails at once with :class:`BusyError`;
* refuses to resume, extend or reuse output made with other settings
  (:func:`check_fingerprint` raises :class:`MismatchError` naming the fields that differ);
* reads its own files back through :func:`read_json` and :func:`read_pickle`, which turn a
  truncated or garbled file into a :class:`FileError` naming the file;
* starts process pools whose workers die with the parent (:func:`die_with_parent` as the
  pool initializer);
* refuses settings whose memory cannot fit up front (:func:`check_memory`).

Deliberately neutral like :mod:`aquafish_gym.files` (standard library only), so that every
package can use it. All the errors are ``ValueError`` subclasses: the ``aquafish`` command
line prints them as one line and exits with status 2.
"""

from __future__ import annotations

import contextlib
import ctypes
import gzip
import json
import math
import os
import pickle
import signal
import sys
import threading
import time
import zlib
from pathlib import Path
from typing import Any, Iterator, Mapping

try:
    import fcntl
except ImportError:  # not POSIX: no lock (the project's machines are Linux)
    fcntl = None  # type: ignore[assignment]

__all__ = ["BusyError", "FileError", "LOCK_FILE", "MismatchError", "available_memory", "check_fingerprint",
           "check_memory", "check_output_dir", "check_output_file", "die_with_parent", "differences",
           "format_bytes", "read_json", "read_pickle", "run_lock"]

#: The lock file :func:`run_lock` keeps in a run directory (it holds the writer's pid).
LOCK_FILE = ".aquafish.lock"


class FileError(ValueError):
    """A file that exists but cannot be used: truncated, garbled, or not what it should be.

    Attributes:
        path: the file.
        problem: what is wrong with it.
    """

    def __init__(self, path: str | os.PathLike, problem: str,
                 fix: str = "delete it (or the run directory) and run again, or restore it from a copy"):
        self.path, self.problem = Path(path), problem
        super().__init__(f"{self.path}: {problem}; {fix}")


class BusyError(ValueError):
    """Another process holds the lock of a run directory."""


class MismatchError(ValueError):
    """A directory or checkpoint holds output made with other settings."""


# -- where output goes --------------------------------------------------------------------------


def _first_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (lexically, on the absolute path)."""
    path = Path(os.path.abspath(path))
    while not os.path.lexists(path) and path.parent != path:
        path = path.parent
    return path


def _writable(directory: Path) -> bool:
    return os.access(directory, os.W_OK | os.X_OK)


def check_output_dir(path: str | os.PathLike, flag: str = "--out") -> Path:
    """Check, without creating anything, that ``path`` is or can become a writable directory.

    Args:
        path: the output directory.
        flag: how the message names the setting (``"--out"``).

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: ``path`` is empty, is a file, lies under a file, or is (or would be
            created in) a directory this process may not write.
    """
    text = os.fspath(path) if path is not None else ""
    if not str(text).strip():
        raise ValueError(f"{flag} is empty; give a directory path")
    path = Path(text)
    existing = _first_existing(path)
    if existing == Path(os.path.abspath(path)):
        if not path.is_dir():
            raise ValueError(f"{flag} {path} is a file, not a directory; give a directory path")
        if not _writable(path):
            raise ValueError(f"{flag} {path} is not writable by this user; choose another directory")
        return path
    _check_creatable(path, existing, flag)
    return path


def _check_creatable(path: Path, existing: Path, flag: str) -> None:
    """``path`` can be created under ``existing``, its nearest existing ancestor (ValueError if not)."""
    if not existing.is_dir():
        raise ValueError(f"{flag} {path} cannot be created: {existing} is a file, not a directory; "
                         "choose another path")
    if not _writable(existing):
        raise ValueError(f"{flag} {path} cannot be created: {existing} is not writable by this user; "
                         "choose another directory")


def check_output_file(path: str | os.PathLike, flag: str = "--output") -> Path:
    """Check, without creating anything, that the file ``path`` can be written.

    Its directory must be (or be creatable as) a writable directory, and ``path`` must not be
    a directory.

    Raises:
        ValueError: as :func:`check_output_dir` for the parent, or ``path`` is a directory or empty.
    """
    text = os.fspath(path) if path is not None else ""
    if not str(text).strip():
        raise ValueError(f"{flag} is empty; give a file path")
    path = Path(text)
    if path.is_dir():
        raise ValueError(f"{flag} {path} is a directory; give a file path")
    existing = _first_existing(path.parent)
    _check_creatable(path, existing, flag)
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"{flag} {path} exists and is not writable by this user; choose another file")
    return path


# -- the lock --------------------------------------------------------------------------------------

_HELD: dict[str, list] = {}  # real path of a lock file -> [fd, depth, pid] held by this process
_HELD_GUARD = threading.Lock()


@contextlib.contextmanager
def run_lock(directory: str | os.PathLike, flag: str = "--out", *, name: str = LOCK_FILE) -> Iterator[Path]:
    """Hold the advisory lock of ``directory`` (created if missing) while the block runs.

    The lock is ``fcntl.flock`` on ``directory/.aquafish.lock``, a file that holds the
    writer's pid and is removed when the block ends. The kernel drops the lock when its
    holder exits or is killed, so a crash never leaves a stale lock (a file left by a killed
    writer is simply locked anew). It is re-entrant within one process (a command that locks
    its output and then calls a library function that locks the same directory), never
    across processes.

    Args:
        directory: the run directory.
        flag: names the setting in the message.
        name: the lock file's name (another name locks one output file of a shared directory).

    Yields:
        ``directory`` as a ``Path``.

    Raises:
        BusyError: another process holds the lock (the message names its pid).
        OSError: the directory or the lock file cannot be created.
    """
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    if fcntl is None:
        yield directory
        return
    key = os.path.join(os.path.realpath(directory), name)
    with _HELD_GUARD:
        held = _HELD.get(key)
        if held is not None and held[2] == os.getpid():
            held[1] += 1
        else:
            _HELD[key] = [_acquire(key, directory, flag), 1, os.getpid()]
    try:
        yield directory
    finally:
        with _HELD_GUARD:
            held = _HELD[key]
            held[1] -= 1
            if held[1] == 0:
                del _HELD[key]
                with contextlib.suppress(OSError):
                    os.unlink(key)  # while still locked: a waiting opener of this inode re-checks below
                os.close(held[0])


def _acquire(key: str, directory: Path, flag: str) -> int:
    """Open and ``flock`` the lock file ``key``; the locked inode must still be the file at ``key``."""
    while True:
        fd = os.open(key, os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            os.close(fd)
            who = f" (pid {holder})" if holder.isdigit() else ""
            raise BusyError(f"{flag} {directory} is in use by another aquafish process{who}; wait for it to "
                            f"finish or use another {flag}") from None
        try:
            same = os.stat(key).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            return fd
        os.close(fd)  # the holder removed it as we opened it: lock the new file


# -- fingerprints -----------------------------------------------------------------------------------


def _plain(value: Any) -> Any:
    """``value`` as JSON would give it back (tuples as lists), for comparisons."""
    return json.loads(json.dumps(value))


def differences(recorded: Mapping, wanted: Mapping, *, ignore_unrecorded: bool = True) -> list[str]:
    """The fields on which two fingerprints differ, as ``"field: recorded -> wanted"`` (JSON values).

    Args:
        recorded: the fingerprint found on disk.
        wanted: the fingerprint of the settings asked for.
        ignore_unrecorded: skip a field the recorded fingerprint lacks (written by an older
            version that did not record it).

    Nested mappings are compared field by field and named with dots (``"variant.seed: 0 -> 1"``).
    """
    recorded, wanted = _plain(dict(recorded)), _plain(dict(wanted))
    out = []
    for key in dict.fromkeys([*wanted, *recorded]):
        if key not in recorded and ignore_unrecorded:
            continue
        mine, theirs = recorded.get(key), wanted.get(key)
        if isinstance(mine, dict) and isinstance(theirs, dict):  # nested settings: name the inner field
            out += [f"{key}.{d}" for d in differences(mine, theirs, ignore_unrecorded=ignore_unrecorded)]
        elif mine != theirs:
            out.append(f"{key}: {_short(mine)} -> {_short(theirs)}")
    return out


def _short(value: Any, limit: int = 80) -> str:
    text = json.dumps(value, sort_keys=True)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def check_fingerprint(where: str | os.PathLike, recorded: Mapping, wanted: Mapping, fix: str) -> None:
    """Raise :class:`MismatchError` if ``recorded`` and ``wanted`` differ (see :func:`differences`).

    Args:
        where: the directory or file whose output was made with ``recorded``.
        recorded, wanted: the fingerprints.
        fix: what the user can do (e.g. ``"use another --out or the same settings"``).
    """
    diff = differences(recorded, wanted)
    if diff:
        raise MismatchError(f"{where} holds output made with other settings (recorded -> asked: {'; '.join(diff)}); "
                            f"{fix}")


# -- reading files back --------------------------------------------------------------------------

#: What unpickling a truncated or foreign file can raise.
_PICKLE_ERRORS = (pickle.UnpicklingError, EOFError, AttributeError, ImportError, IndexError, KeyError, TypeError,
                  ValueError, zlib.error, gzip.BadGzipFile, UnicodeDecodeError, ModuleNotFoundError)


def read_json(path: str | os.PathLike, kind: type | None = dict) -> Any:
    """The JSON content of ``path``, checked to be a ``kind`` (default a JSON object).

    Raises:
        FileError: the file is not valid UTF-8 JSON (truncated or garbled) or not a ``kind``.
        OSError: the file cannot be read.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_bytes().decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise FileError(path, f"is not valid JSON ({err})") from None
    if kind is not None and not isinstance(data, kind):
        raise FileError(path, f"holds a JSON {type(data).__name__}, expected a JSON "
                              f"{'object' if kind is dict else kind.__name__}")
    return data


def read_pickle(path: str | os.PathLike, *, gzipped: bool = False, what: str = "checkpoint",
                fix: str | None = None, unpickler: type[pickle.Unpickler] = pickle.Unpickler) -> Any:
    """Unpickle ``path`` (gzip-compressed if ``gzipped``), turning a damaged file into :class:`FileError`.

    Only for the project's own files: unpickling runs code, so never point it at a file from
    an untrusted source. ``what`` names the kind of file and ``fix`` the remedy in the message;
    ``unpickler`` reads it (a subclass may map renamed modules in ``find_class``, as
    :class:`eea.checkpoint.RenamingUnpickler` does).

    Raises:
        FileError: the file is truncated, garbled, or pickles classes that do not exist.
        OSError: the file cannot be read.
    """
    path = Path(path)
    opener = gzip.open if gzipped else open
    try:
        with opener(path, "rb") as f:
            return unpickler(f).load()
    except _PICKLE_ERRORS as err:
        problem = f"is not a readable {what}: truncated or corrupt ({type(err).__name__}: {err})"
        raise (FileError(path, problem) if fix is None else FileError(path, problem, fix)) from None


# -- worker pools ---------------------------------------------------------------------------------

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Process-pool initializer: end this worker when the process ``parent_pid`` dies.

    On Linux the kernel sends the worker ``SIGKILL`` when its parent dies
    (``prctl(PR_SET_PDEATHSIG)``); elsewhere a daemon thread polls the parent's pid every
    second. A parent that died before this ran is caught too. Pass ``os.getpid()`` of the
    process that creates the pool::

        ProcessPoolExecutor(n, initializer=die_with_parent, initargs=(os.getpid(),))
    """
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0)
        except (OSError, AttributeError):
            _watch_parent(parent_pid)
    else:
        _watch_parent(parent_pid)
    if os.getppid() != parent_pid:
        os._exit(1)


def _watch_parent(parent_pid: int) -> None:
    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(1.0)
        os._exit(1)

    threading.Thread(target=watch, name="die-with-parent", daemon=True).start()


# -- memory ---------------------------------------------------------------------------------------


def available_memory() -> int:
    """Bytes of memory available to a new allocation (``MemAvailable``, else the physical memory)."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return 1 << 40


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human-readable size (``"3.2 GB"``)."""
    if not math.isfinite(n):
        return "an unbounded amount"
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if n < 1000 or unit == "PB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} PB"


def check_memory(what: str, estimate_bytes: float, fix: str, *, share: float = 0.8) -> None:
    """Refuse, before any work, settings whose estimated memory does not fit.

    Args:
        what: the settings, named as the user gave them (``"--population-size 1000000000"``).
        estimate_bytes: the estimate.
        fix: what to lower.
        share: the share of the available memory (:func:`available_memory`) allowed.

    Raises:
        ValueError: the estimate exceeds ``share`` of the available memory (the message gives both).
    """
    available = available_memory()
    if not estimate_bytes <= share * available:
        raise ValueError(f"{what} needs about {format_bytes(estimate_bytes)} of memory, more than the "
                         f"{format_bytes(available)} available; {fix}")
