"""Fail-safe run directories: output checks, an advisory lock, fingerprints, validated reads and
worker pools that die with their parent.

Every command of the project that writes results goes through these helpers, so that it

* checks that its output can be written *before* any work starts and before anything is
  created (:func:`check_output_dir`, :func:`check_output_file`);
* holds an advisory lock on its run directory while it writes (:func:`run_lock`, POSIX
  ``fcntl.flock``: the kernel releases it when the process dies, even by ``kill -9``), so a
  second writer fails at once with :class:`BusyError`; the lock also records which command
  made the directory (:data:`COMMAND_FILE`), so another command refuses it by name, removes
  the temporary files that killed writers left, and removes a directory it created if the
  command is refused before writing anything;
* refuses to resume, extend or reuse output made with other settings
  (:func:`check_fingerprint` raises :class:`MismatchError` naming the fields that differ);
* reads its own files back through :func:`read_json` and :func:`read_pickle`, which turn a
  truncated or garbled file into a :class:`FileError` naming the file;
* starts process pools whose workers die with the parent (:func:`spawn_pool`, with
  :func:`die_with_parent` as the pool initializer);
* refuses settings whose memory cannot fit up front (:func:`check_memory`).

Deliberately neutral like :mod:`aquafish_gym.files` (standard library only), so that every
package can use it. All the errors are ``ValueError`` subclasses: the ``aquafish`` command
line prints them as one line and exits with status 2.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import gzip
import json
import math
import multiprocessing
import os
import pickle
import re
import signal
import stat
import sys
import threading
import time
import zlib
from concurrent.futures import ProcessPoolExecutor, wait
from pathlib import Path
from typing import Any, Iterator, Mapping

try:
    import fcntl
except ImportError:  # not POSIX: no lock (the project's machines are Linux)
    fcntl = None  # type: ignore[assignment]

__all__ = ["BusyError", "COMMAND_FILE", "FileError", "LOCK_FILE", "MismatchError", "available_memory", "check_fingerprint",
           "check_not_nested", "command_of",
           "check_memory", "check_output_dir", "check_output_file", "die_with_parent", "differences",
           "format_bytes", "make_subdir", "pickles_refused", "read_json", "read_pickle", "refuse_pickles", "run_lock",
           "spawn_pool"]

#: The lock file :func:`run_lock` keeps in a run directory (it holds the writer's pid).
LOCK_FILE = ".aquafish.lock"
#: The file in which :func:`run_lock` records the command that made a run directory (``eea``).
COMMAND_FILE = ".aquafish-command"
#: How a directory written before :data:`COMMAND_FILE` existed tells the command that made it:
#: a manifest that only that command writes.
LEGACY_MANIFESTS = {"config.json": "eea", "state.pkl": "eea", "study.json": "study",
                    "fitness_settings.json": "gait", "run.json": "gait", "model.json": "rl",
                    "report.json": "case-study", "damage_table.json": "damages", "task_table.json": "baselines",
                    "recovery.json": "recovery", "mission.json": "mission"}


class FileError(ValueError):
    """A file that exists but cannot be used: truncated, garbled, or not what it should be.

    Attributes:
        path: the file.
        problem: what is wrong with it.
    """

    def __init__(self, path: str | os.PathLike, problem: str,
                 fix: str = "delete it (or the run directory) and run again, or restore it from a copy"):
        self.path, self.problem, self.fix = Path(path), problem, fix
        super().__init__(f"{self.path}: {problem}; {fix}")

    def __reduce__(self):
        # pickled with its three arguments, so that it crosses a process pool or Ray unchanged
        return type(self), (self.path, self.problem, self.fix)


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


def _not_a_directory(path: Path) -> str:
    """Why the existing (or dangling) ``path`` is no directory: a file, a dangling symbolic link or a loop."""
    if os.path.islink(path):
        try:
            os.stat(path)
        except OSError as err:
            if err.errno == errno.ELOOP:
                return f"is a symbolic link that loops ({path} -> {os.readlink(path)})"
            return f"is a symbolic link to {os.readlink(path)}, which does not exist"
    return "is a file, not a directory"


def _check_names(path: Path, existing: Path, flag: str) -> None:
    """Each component of ``path`` below ``existing`` is a name the file system takes (ValueError if not)."""
    try:
        limit = os.pathconf(existing, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        limit = 255
    for part in Path(os.path.abspath(path)).relative_to(existing).parts:
        if len(os.fsencode(part)) > limit:
            raise ValueError(f"{flag} {path} cannot be created: its component {part[:40]}... is "
                             f"{len(os.fsencode(part))} bytes long, more than the {limit} the file system allows; "
                             "choose a shorter name")


def check_output_dir(path: str | os.PathLike, flag: str = "--out") -> Path:
    """Check, without creating anything, that ``path`` is or can become a writable directory.

    Args:
        path: the output directory.
        flag: how the message names the setting (``"--out"``).

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: ``path`` is empty, is a file or a dangling or looping symbolic link, lies
            under one, has a component longer than the file system allows, or is (or would be
            created in) a directory this process may not write.
    """
    text = os.fspath(path) if path is not None else ""
    if not str(text).strip():
        raise ValueError(f"{flag} is empty; give a directory path")
    path = Path(text)
    existing = _first_existing(path)
    if existing == Path(os.path.abspath(path)):
        if not path.is_dir():
            raise ValueError(f"{flag} {path} {_not_a_directory(path)}; give a directory path")
        if not _writable(path):
            raise ValueError(f"{flag} {path} is not writable by this user; choose another directory")
        return path
    _check_creatable(path, existing, flag)
    return path


def _check_creatable(path: Path, existing: Path, flag: str) -> None:
    """``path`` can be created under ``existing``, its nearest existing ancestor (ValueError if not)."""
    if not existing.is_dir():
        raise ValueError(f"{flag} {path} cannot be created: {existing} {_not_a_directory(existing)}; "
                         "choose another path")
    if not _writable(existing):
        raise ValueError(f"{flag} {path} cannot be created: {existing} is not writable by this user; "
                         "choose another directory")
    _check_names(path, existing, flag)


def check_output_file(path: str | os.PathLike, flag: str = "--out") -> Path:
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

_HELD: dict[str, list] = {}  # real path of a lock file -> [fd, depth, pid, absolute directory] held by this process
_HELD_GUARD = threading.Lock()


@contextlib.contextmanager
def run_lock(directory: str | os.PathLike, flag: str = "--out", *, name: str = LOCK_FILE,
             command: str | None = None) -> Iterator[Path]:
    """Hold the advisory lock of ``directory`` (created if missing) while the block runs.

    The lock is ``fcntl.flock`` on ``directory/.aquafish.lock``, a file that holds the
    writer's pid and is removed when the block ends. It is opened with ``O_NOFOLLOW``: a
    symbolic link planted in its place is refused, never followed. The kernel drops the lock
    when its holder exits or is killed, so a crash never leaves a stale lock (a file left by a
    killed writer is simply locked anew). It is re-entrant within one process (a command that
    locks its output and then calls a library function that locks the same directory), never
    across processes.

    Once locked, the directory is claimed for ``command`` and cleaned:

    * a directory made by another command (:data:`COMMAND_FILE`, or for a directory written
      before that file existed, one of :data:`LEGACY_MANIFESTS`) is refused by name; one
      without a command is claimed for ``command``;
    * a directory inside another command's run directory is refused before anything is
      created (:func:`check_not_nested`), unless that command is this process or one of its
      parents, writing its own sub-directories;
    * the temporary files of :func:`aquafish_gym.files.atomic_write` that a killed writer left
      in it or below it are removed (those of a process still running are kept).

    If the block raises and the directory was created here and holds nothing but the lock's
    own files, it is removed again, with the parents created for it: a command refused
    before it wrote anything leaves nothing behind.

    A directory below one this process holds locked (a case study's EEA run, a mission's
    ``self_model/gait``, a recovery cell run in process) is a sub-directory of that run: it is
    made by :func:`make_subdir`, so that no component of it below the locked run directory is a
    symbolic link or leads outside it.

    Args:
        directory: the run directory.
        flag: names the setting in the message.
        name: the lock file's name (another name locks one output file of a shared directory).
        command: the ``aquafish`` command that writes the directory (``"eea"``, ``"gait"``,
            ...), or None to claim nothing.

    Yields:
        ``directory`` as a ``Path``.

    Raises:
        BusyError: another process holds the lock (the message names its pid), or the lock of
            a run directory ``directory`` lies in (:func:`check_not_nested`).
        MismatchError: the directory was made by another command than ``command``, or lies in
            the run directory of a command that is not running.
        FileError: the lock file is a symbolic link, or a sub-directory of a locked run is
            one (:func:`make_subdir`).
        OSError: the directory or the lock file cannot be created.
    """
    directory = Path(directory)
    check_not_nested(directory, flag)
    parent = _held_parent(directory)
    created = _make_dirs(directory) if parent is None else \
        _make_subdirs(parent, Path(os.path.abspath(directory)).relative_to(parent).parts)[1]
    try:
        with _locked(directory, flag, name):
            if command is not None:
                _claim(directory, command, flag)
            yield directory
    except BaseException:
        _remove_if_unused(created)
        raise


def check_not_nested(directory: str | os.PathLike, flag: str = "--out") -> None:
    """Refuse a ``directory`` that lies inside another command's run directory.

    The parents of ``directory`` (of its real path: a symbolic link does not hide them) are
    walked up to the nearest run directory: one with a held :data:`LOCK_FILE`, a
    :data:`COMMAND_FILE` or one of the :data:`LEGACY_MANIFESTS`. That run directory is fine when
    its lock is held by this process or one of its parents (a command writing its own
    sub-directories, in process or in the pool workers it started); otherwise a command would
    write into a directory it did not make (``aquafish eea --out MISSION/self_model``), or into
    one another process is writing (a case study in a running benchmark's cell).

    Raises:
        BusyError: the run directory's lock is held by another process (its pid named).
        MismatchError: the run directory was made by a command that is not running.
    """
    target = Path(os.path.abspath(directory))
    existing = _first_existing(target)
    real = Path(os.path.realpath(existing))
    for parent in ([real] if existing != target else []) + list(real.parents):
        holder = _lock_holder(parent / LOCK_FILE)
        if holder == "own":
            return
        if holder is not None:
            raise BusyError(f"{flag} {directory} lies inside {parent}, which another aquafish process{holder} is "
                            f"writing; wait for it to finish or use an {flag} outside it")
        made_by = command_of(parent)
        if made_by is not None:
            raise MismatchError(f"{flag} {directory} lies inside {parent}, the run directory of `aquafish {made_by}`; "
                                f"use an {flag} outside it (a command never writes into another command's directory)")


def _lock_holder(lock: Path) -> str | None:
    """Who holds the lock file ``lock``: ``"own"`` (this process or one of its parents), the
    text `` (pid N)`` for another process, or None (no lock file, or one nobody holds)."""
    if fcntl is None or os.path.islink(lock) or not os.path.isfile(lock):
        return None
    try:
        fd = os.open(lock, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            text = os.pread(fd, 32, 0).decode(errors="replace").strip()
            if text.isdigit() and int(text) in _lineage():
                return "own"
            return f" (pid {text})" if text.isdigit() else ""
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)


def _lineage() -> set[int]:
    """This process's pid and its parents' (read from ``/proc``; elsewhere the direct parent only)."""
    pids, pid = {os.getpid()}, os.getppid()
    while pid > 1 and pid not in pids:
        pids.add(pid)
        try:
            with open(f"/proc/{pid}/stat") as f:
                pid = int(f.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            break
    return pids


def _make_dirs(directory: Path) -> list[Path]:
    """Create ``directory`` and its missing parents; return those this call created, deepest
    first. A directory that another process creates at the same moment (two runs of one
    benchmark starting side by side under a parent not yet made) is used as it is."""
    missing = []
    path = Path(os.path.abspath(directory))
    while not os.path.lexists(path) and path.parent != path:
        missing.append(path)
        path = path.parent
    created = []
    for path in reversed(missing):
        try:
            path.mkdir()
        except FileExistsError:
            if path.is_dir() and not path.is_symlink():
                continue  # made by another process since it was found missing
            _remove_if_unused(created[::-1])
            raise
        except BaseException:
            _remove_if_unused(created[::-1])
            raise
        created.append(path)
    return created[::-1]


def make_subdir(parent: str | os.PathLike, *names: str) -> Path:
    """The sub-directory ``parent/NAME/...`` of a run directory, each missing component created,
    never through a link.

    Every component below ``parent`` must be a directory of its own: a symbolic link (to a
    directory or dangling), a file, or a component that resolves outside ``parent`` is refused,
    so a link planted in a run directory can never send a run's writes elsewhere. ``parent``
    itself (the ``--out`` the user gave) may be a link. Every run creates its sub-directories
    through this (a lock below a locked run directory does it too: :func:`run_lock`).

    Args:
        parent: the run directory (it exists).
        names: the relative path below it, as one or more names (``"cells", "caudal_half",
            "seed0"``; ``"a/b"`` is two names).

    Returns:
        ``parent/NAME/...`` as a ``Path``.

    Raises:
        FileError: (a ``ValueError``) naming the component: a symbolic link, not a directory, or
            outside ``parent``; or a name that is absolute, empty, ``.`` or ``..``.
        OSError: a component cannot be created.
    """
    return _make_subdirs(Path(parent), names)[0]


def _make_subdirs(parent: Path, names) -> tuple[Path, list[Path]]:
    """:func:`make_subdir`; also the directories this call created, deepest first."""
    parts = [part for name in names for part in str(name).split("/")]
    if not parts or any(part in ("", ".", "..") for part in parts) or str(names[0]).startswith("/"):
        raise FileError(parent / "/".join(map(str, names)), "is not a sub-directory name of the run directory "
                        f"{parent}", "this is a bug; nothing was written")
    root = os.path.realpath(parent)
    path, created = parent, []
    try:
        for part in parts:
            path = path / part
            try:
                path.mkdir()
                created.append(path)
            except FileExistsError:
                pass
            mode = os.lstat(path).st_mode
            if stat.S_ISLNK(mode):
                raise FileError(path, f"is a symbolic link (to {os.readlink(path)}) inside the run directory "
                                      f"{parent}; a run never writes through a link",
                                "remove the link, or use another --out")
            if not stat.S_ISDIR(mode):
                raise FileError(path, f"is a file inside the run directory {parent}, where a run keeps a directory",
                                "remove it, or use another --out")
        real = os.path.realpath(path)
        if os.path.commonpath([real, root]) != root:
            raise FileError(path, f"resolves to {real}, outside the run directory {parent}",
                            "remove what leads there, or use another --out")
    except BaseException:
        _remove_if_unused(created[::-1])
        raise
    return path, created[::-1]


def _held_parent(directory: Path) -> Path | None:
    """The deepest directory this process holds locked (:func:`run_lock`) that ``directory`` lies
    strictly below (lexically, on absolute paths), or None."""
    path = os.path.abspath(directory)
    with _HELD_GUARD:
        held = [h[3] for h in _HELD.values() if h[2] == os.getpid()]
    below = [h for h in held if path != h and path.startswith(h.rstrip(os.sep) + os.sep)]
    return Path(max(below, key=len)) if below else None


def _remove_if_unused(created: list[Path]) -> None:
    """Remove the directories of ``created`` (deepest first) that hold nothing but the lock's files;
    stop at the first that holds anything else."""
    for path in created:
        try:
            if not set(os.listdir(path)) <= {COMMAND_FILE, LOCK_FILE}:
                return
            for leftover in os.listdir(path):
                os.unlink(path / leftover)
            path.rmdir()
        except OSError:
            return


@contextlib.contextmanager
def _locked(directory: Path, flag: str, name: str) -> Iterator[None]:
    if fcntl is None:
        yield
        return
    key = os.path.join(os.path.realpath(directory), name)
    with _HELD_GUARD:
        held = _HELD.get(key)
        if held is not None and held[2] == os.getpid():
            held[1] += 1
        else:
            _HELD[key] = [_acquire(key, directory, flag), 1, os.getpid(), os.path.abspath(directory)]
            _remove_stale_temporaries(directory)
    try:
        yield
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
        try:
            fd = os.open(key, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o666)
        except OSError as err:
            if err.errno == errno.ELOOP or os.path.islink(key):
                raise FileError(key, "is a symbolic link, not a lock file (a lock is never written through a link)",
                                "remove the link, or use another " + flag) from None
            raise
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            os.close(fd)
            who = f" (pid {holder})" if holder.isdigit() else ""
            raise BusyError(f"{flag} {directory} is in use by another aquafish process{who}; wait for it to "
                            f"finish or use another {flag}") from None
        try:
            same = os.lstat(key).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            return fd
        os.close(fd)  # the holder removed it as we opened it: lock the new file


def command_of(directory: str | os.PathLike) -> str | None:
    """The ``aquafish`` command that made ``directory``: its :data:`COMMAND_FILE`, else the command
    of the first :data:`LEGACY_MANIFESTS` file in it, else None (a new or foreign directory)."""
    directory = Path(directory)
    marker = directory / COMMAND_FILE
    if marker.is_file() and not marker.is_symlink():
        return marker.read_text(errors="replace").strip() or None
    for manifest, command in LEGACY_MANIFESTS.items():
        if (directory / manifest).is_file():
            return command
    return None


def _claim(directory: Path, command: str, flag: str) -> None:
    """Record ``command`` as the maker of ``directory`` (MismatchError if another command made it)."""
    made_by = command_of(directory)
    if made_by is not None and made_by != command:
        raise MismatchError(f"{flag} {directory} holds the output of `aquafish {made_by}`, not of `aquafish {command}`; "
                            f"use another {flag} (a command never writes into another command's directory)")
    if made_by is None or not (directory / COMMAND_FILE).is_file():
        from aquafish_gym.files import atomic_write

        atomic_write(directory / COMMAND_FILE, f"{command}\n".encode())


#: A temporary file of :func:`aquafish_gym.files.atomic_write`: ``.NAME.PID.XXXXXXXX.tmp``
#: (``PID`` its writer's; files of versions that did not record it lack it).
_TEMPORARY = re.compile(r"^\..+?(?:\.(?P<pid>\d+))?\.[a-z0-9_]{8}\.tmp$")


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # another user's process
        return True
    return True


def _remove_stale_temporaries(directory: Path) -> None:
    """Remove the temporary files that writers which are no longer running left in ``directory``
    or its subdirectories (``checkpoints/``; a run in a subdirectory cleans its own when it is
    locked); a temporary without a pid (written by an older version) only directly in it."""
    try:
        subdirs = [e.path for e in os.scandir(directory) if e.is_dir(follow_symlinks=False)]
    except OSError:
        return
    for where in (os.fspath(directory), *subdirs):
        with contextlib.suppress(OSError):
            for entry in os.scandir(where):
                match = _TEMPORARY.match(entry.name)
                if match is None or not entry.is_file(follow_symlinks=False):
                    continue
                pid = match.group("pid")
                if (pid is None and where != os.fspath(directory)) or (pid is not None and _alive(int(pid))):
                    continue
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)


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
        recorded: the fingerprint the output was made with.
        wanted: the fingerprint asked for now.
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

    The file is read by :func:`aquafish_gym.files.read_input` and parsed by
    :func:`aquafish_gym.files.parse_json`: only a regular file of at most
    :data:`~aquafish_gym.files.MAX_INPUT_BYTES`, nested at most
    :data:`~aquafish_gym.files.MAX_JSON_DEPTH` deep.

    Raises:
        FileError: the file is not valid UTF-8 JSON (truncated or garbled), not a ``kind``, no
            regular file, too large, or nested too deeply.
        OSError: the file cannot be read.
    """
    from aquafish_gym.files import InputFileError, parse_json, read_input

    path = Path(path)
    try:
        data = parse_json(read_input(path))
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise FileError(path, f"is not valid JSON ({err})") from None
    except InputFileError as err:
        raise FileError(path, err.problem, "give the right file") from None
    if kind is not None and not isinstance(data, kind):
        raise FileError(path, f"holds a JSON {type(data).__name__}, expected a JSON "
                              f"{'object' if kind is dict else kind.__name__}")
    return data


_REFUSING: list[str] = []  # why pickles are refused now (refuse_pickles), innermost last
_REFUSING_GUARD = threading.Lock()


@contextlib.contextmanager
def refuse_pickles(why: str) -> Iterator[None]:
    """While the block runs, :func:`read_pickle` refuses every file unread, in every thread of
    this process: for work on a directory the command did not make (a finished benchmark cell
    checked again, a run being diagnosed), whose pickles may come from anyone.

    Args:
        why: the reason the refusal gives (``"the finished cell ... is read as data"``).
    """
    with _REFUSING_GUARD:
        _REFUSING.append(why)
    try:
        yield
    finally:
        with _REFUSING_GUARD:
            _REFUSING.remove(why)


def pickles_refused() -> str | None:
    """Why :func:`read_pickle` refuses every file now (:func:`refuse_pickles`), or None: a reader
    that can do without a pickle (from the run's data) asks this first."""
    with _REFUSING_GUARD:
        return _REFUSING[-1] if _REFUSING else None


def read_pickle(path: str | os.PathLike, *, gzipped: bool = False, what: str = "checkpoint",
                fix: str | None = None, unpickler: type[pickle.Unpickler] = pickle.Unpickler) -> Any:
    """Unpickle ``path`` (gzip-compressed if ``gzipped``), turning a damaged file into :class:`FileError`.

    Only for the project's own files: unpickling runs code, so never point it at a file from
    an untrusted source. ``what`` names the kind of file and ``fix`` the remedy in the message;
    ``unpickler`` reads it (a subclass may map renamed modules in ``find_class``, as
    :class:`eea.compat.RenamingUnpickler` does). Inside :func:`refuse_pickles` nothing is read.

    Raises:
        FileError: the file is truncated, garbled, or pickles classes that do not exist; or
            :func:`refuse_pickles` is in force (the file is not opened).
        OSError: the file cannot be read.
    """
    path = Path(path)
    why = pickles_refused()
    if why is not None:
        raise FileError(path, f"is a {what}, a pickle, which runs code when loaded, and {why}: it is refused unread",
                        "run the command that made the directory in it, if you made it yourself")
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
    second. A parent that died before this ran is caught too. Ctrl-C (``SIGINT``, which the
    terminal sends to the parent and its workers alike) ends the worker at once and quietly:
    the parent reports the interrupt, in one line; a worker of a parent that ignores ``SIGINT``
    ignores it too (it inherits that). On Linux "parent" is the thread that
    started the worker: start a pool's workers from a thread that outlives them (a
    ``ProcessPoolExecutor`` starts them in the thread that submits; ``spawn_pool(n,
    start_now=True)`` from the thread that owns the pool). Pass ``os.getpid()`` of the process
    that creates the pool, as :func:`spawn_pool` does::

        ProcessPoolExecutor(n, initializer=die_with_parent, initargs=(os.getpid(),))
    """
    if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
        signal.signal(signal.SIGINT, _exit_quietly)
    # else the parent ignores SIGINT (``trap '' INT``, a background job of a script): the worker,
    # which inherited that, ignores it too, rather than die while its parent goes on without it
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


def spawn_pool(workers: int, start_now: bool = False) -> ProcessPoolExecutor:
    """A ``ProcessPoolExecutor`` of ``workers`` "spawn" processes (PyBullet clients must not be
    forked) that die with this process (:func:`die_with_parent`).

    Args:
        workers: processes (>= 1; the caller validates it).
        start_now: start every process now, from the calling thread, instead of from the thread
            that first submits: a pool that threads share must outlive each of them (on Linux a
            worker is killed when the thread that started it ends; :func:`die_with_parent`).

    Returns:
        The pool; the caller shuts it down (``with spawn_pool(n) as pool:``).
    """
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("spawn"),
                               initializer=die_with_parent, initargs=(os.getpid(),))
    if start_now:
        wait([pool.submit(int, 0) for _ in range(workers)])
    return pool


def _exit_quietly(signum, frame) -> None:
    os._exit(128 + signum)


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
                         f"{format_bytes(share * available)} a run may use ({share:.0%} of the "
                         f"{format_bytes(available)} available); {fix}")
