"""Tasks whose output directories come back to the driver as data: Ray without a shared file system.

A :class:`DirTask` is a top-level function, its arguments, and which of those arguments are
directories: ``outputs`` (the task writes them: a study's run directory, a recovery cell) and
``inputs`` (it only reads them: a recovery seed's shared rows). :func:`run_dir_tasks` runs
such tasks

* on the local backend as they are, writing in place (a process pool through
  :func:`aquafish.backends.run_tasks`, or one at a time in this process), exactly as before;
* on Ray (``backend="ray"``) in a node-local temporary directory (:func:`_in_scratch`): the
  files an argument's directory holds on the driver so far are sent with the task (so an
  interrupted run resumes from them), the task runs on the copies, and the finished output
  directories come back with the task's value as ``{relative path: bytes}``. The driver writes
  them into its own output directory (:func:`unpack_dir`: a hidden sibling directory renamed
  into place, so a directory is never half written, whatever happens while a result arrives).
  No node needs the driver's output directory: no shared file system.

The task writes its ``.aquafish-command`` markers as it would in place (they are files of its
directory, shipped back with the rest), so a later run, local or on Ray, recognises and resumes
the directory. Paths to the node's temporary directory that the task records in a text file
(a case study's ``report.json`` names its ``shared_dir``) or returns are replaced by the
driver's paths, so the driver's files read as a local run's.

A task whose worker (or node) is lost is retried by Ray (``max_retries``,
:data:`aquafish.backends.MAX_RETRIES`), and the driver logs one line per retried task when it
finishes, and one per task lost on every try (which is then left unfinished: running the
command again finishes it). An error the task raises itself (a corrupt file, say) is not
retried: it ends the command with its one line, as on the local pool (naming the driver's
files, not the node's temporary ones).
"""

from __future__ import annotations

import dataclasses
import logging
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable, Iterator

from aquafish import backends
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import LOCK_FILE, FileError

__all__ = ["DirTask", "SCRATCH_PREFIX", "pack_dir", "remove_stale_scratch", "run_dir_tasks", "unpack_dir"]

_log = logging.getLogger(__name__)

#: An :func:`~aquafish_gym.files.atomic_write` temporary (``.NAME.PID.XXXXXXXX.tmp``): never shipped.
_TEMPORARY = re.compile(r"^\..+\.[a-z0-9_]{8}\.tmp$")
#: The hidden siblings :func:`unpack_dir` writes (``.NAME.PID.XXXXXXXX.part``) or moves a
#: replaced directory to (``.old``) before it removes it.
_SIBLING = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.[a-z0-9_]{8}\.(?:part|old)$")
#: The start of a Ray task's temporary directory (:func:`_in_scratch`), followed by its worker's pid.
SCRATCH_PREFIX = "aquafish-task-"
_SCRATCH = re.compile(rf"^{SCRATCH_PREFIX}(?P<pid>\d+)-[a-z0-9_]{{8}}$")


@dataclasses.dataclass(frozen=True)
class DirTask:
    """A task whose directory arguments can travel: ``fn(*args)``.

    Attributes:
        fn: a top-level function (process pools and Ray ship it by name).
        args: its picklable arguments; those named by ``outputs`` and ``inputs`` are directory paths.
        outputs: indices of ``args`` that are directories the task writes (on Ray: sent with
            the task as they are so far, and sent back finished).
        inputs: indices of ``args`` that are directories the task only reads (on Ray: sent
            with the task; whatever the task writes there is dropped).
        label: names the task in a logged line (``"cell left_pectoral_half seed 0"``).
    """

    fn: Callable
    args: tuple
    outputs: tuple[int, ...] = ()
    inputs: tuple[int, ...] = ()
    label: str = ""


def pack_dir(directory: str | os.PathLike) -> dict[str, bytes]:
    """Every file below ``directory``: ``{path relative to it, with "/": content}`` (empty when the
    directory does not exist). The lock file and :func:`~aquafish_gym.files.atomic_write`
    temporaries are left out; symbolic links are not followed.

    Raises:
        OSError: a file cannot be read.
    """
    root = Path(directory)
    files = {}
    if not root.is_dir():
        return files
    for where, dirs, names in os.walk(root):
        dirs.sort()
        for name in sorted(names):
            path = Path(where) / name
            if name == LOCK_FILE or _TEMPORARY.match(name) or _SIBLING.match(name) or path.is_symlink():
                continue
            files[path.relative_to(root).as_posix()] = path.read_bytes()
    return files


def _safe_parts(relative: str, directory: Path) -> tuple[str, ...]:
    """The parts of a shipped file's relative path (FileError for one that would leave the directory)."""
    parts = tuple(relative.split("/"))
    if not relative or relative.startswith("/") or any(p in ("", ".", "..") for p in parts):
        raise FileError(directory / relative, "is not a relative path inside the directory a task sent back",
                        "this is a bug or a tampered result; nothing was written")
    return parts


def unpack_dir(files: dict[str, bytes], directory: str | os.PathLike,
               replace: dict[str, str] | None = None) -> Path:
    """Make ``directory`` hold exactly ``files`` (:func:`pack_dir`'s form), atomically.

    The files are written into a hidden sibling (``.NAME.PID.XXXXXXXX.part``), which is then
    renamed to ``directory``; a directory already there (an unfinished run the task resumed) is
    first moved aside to a hidden sibling and removed after. If anything fails while writing,
    the sibling is removed and ``directory`` is left as it was; a driver killed in the middle
    leaves at most a hidden sibling, which the next :func:`unpack_dir` next to it removes (its
    writer's pid is gone). Parent directories are created.

    Args:
        files: ``{relative path: content}``.
        directory: the directory to write.
        replace: ``{old: new}`` strings replaced in every UTF-8 text file (the task's temporary
            paths by the driver's).

    Returns:
        ``directory`` as a ``Path``.

    Raises:
        FileError: a relative path that is absolute or leaves the directory (nothing is written).
        OSError: the directory cannot be written (it is left as it was).
    """
    directory = Path(directory)
    parts = {relative: _safe_parts(relative, directory) for relative in files}
    directory.parent.mkdir(parents=True, exist_ok=True)
    _remove_dead_siblings(directory)
    staging = Path(tempfile.mkdtemp(dir=directory.parent, prefix=f".{directory.name}.{os.getpid()}.", suffix=".part"))
    try:
        for relative, data in files.items():
            path = staging.joinpath(*parts[relative])
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(path, _replaced(data, replace or {}))
        os.chmod(staging, 0o777 & ~_umask())  # mkdtemp's is private (0o700); a plain mkdir's
        if directory.exists() or directory.is_symlink():
            old = Path(tempfile.mkdtemp(dir=directory.parent, prefix=f".{directory.name}.{os.getpid()}.",
                                        suffix=".old"))
            os.replace(directory, old / directory.name)
            os.replace(staging, directory)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(staging, directory)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return directory


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _replaced(data: bytes, replace: dict[str, str]) -> bytes:
    """``data`` with every ``old`` of ``replace`` replaced (longest first) when it is UTF-8 text."""
    if not replace:
        return data
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        return data  # binary (a pickle, a PNG, a zip): left as it is
    for old in sorted(replace, key=len, reverse=True):
        text = text.replace(old, replace[old])
    return text.encode("utf-8")


def _translate(value: Any, replace: dict[str, str]) -> Any:
    """``value`` with the strings of ``replace`` replaced in every string it holds (dicts, lists, tuples)."""
    if isinstance(value, str):
        for old in sorted(replace, key=len, reverse=True):
            value = value.replace(old, replace[old])
        return value
    if isinstance(value, dict):
        return {_translate(k, replace): _translate(v, replace) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_translate(v, replace) for v in value)
    return value


def _remove_dead_siblings(directory: Path) -> None:
    """Remove the hidden siblings of ``directory`` that a killed :func:`unpack_dir` left (their pid is gone)."""
    from aquafish_gym.rundir import _alive

    try:
        entries = list(os.scandir(directory.parent))
    except OSError:
        return
    for entry in entries:
        match = _SIBLING.match(entry.name)
        if match and match.group("name") == directory.name and not _alive(int(match.group("pid"))):
            shutil.rmtree(entry.path, ignore_errors=True)


def _attempt() -> int:
    """Which try of the running Ray task this is (0: the first); 0 outside Ray, or if Ray does
    not tell (``get_current_task_attempt_number`` is Ray's core worker's, not public API)."""
    try:
        import ray

        return int(ray._private.worker.global_worker.core_worker.get_current_task_attempt_number())
    except Exception:  # noqa: BLE001
        return 0


class _Failed(Exception):
    """The error ``error`` that task ``index`` raised in its temporary directories ``scratch``
    (``{argument index: temporary path}``): :func:`run_dir_tasks` raises ``error`` again, naming
    the driver's paths instead."""

    def __init__(self, error: Exception, index: int, scratch: dict[int, str]):
        self.error, self.index, self.scratch = error, index, scratch
        super().__init__(str(error))

    def __reduce__(self):
        return type(self), (self.error, self.index, self.scratch)


def _translate_error(err: Exception, replace: dict[str, str]) -> Exception:
    """``err`` with the paths of ``replace`` replaced in its message (a
    :class:`~aquafish_gym.rundir.FileError` names the driver's file); ``err`` itself when its type
    cannot be built again from its arguments."""
    if isinstance(err, FileError):
        return type(err)(_translate(str(err.path), replace), _translate(err.problem, replace),
                         _translate(err.fix, replace))
    try:
        return type(err)(*_translate(tuple(err.args), replace))
    except Exception:  # noqa: BLE001  (an exception type with other constructor arguments)
        return err


def _in_scratch(index: int, fn: Callable, args: tuple, dirs: dict[int, dict[str, bytes]],
                outputs: tuple[int, ...]) -> tuple[int, Any, dict[int, dict[str, bytes]], dict[int, str], int]:
    """Run ``fn(*args)`` on a node-local copy of its directory arguments (the Ray side of
    :func:`run_dir_tasks`).

    Each argument ``i`` of ``dirs`` (the driver sends only the directory's last name, never its
    path) is replaced by a directory of that name in a new temporary directory, holding the files
    ``dirs[i]`` (the driver's so far); the temporary directory is removed at the end. Its name
    carries this worker's pid (``aquafish-task-PID-XXXXXXXX``): one left by a worker that was
    killed is removed by the next task on the node (:func:`remove_stale_scratch`).

    Returns:
        ``(index, value, {i: files of the output directory i}, {i: the temporary path argument i
        had}, this try's number)``.

    Raises:
        _Failed: ``fn`` raised an exception (carried with ``index`` and the temporary paths).
    """
    attempt = _attempt()
    remove_stale_scratch()
    with tempfile.TemporaryDirectory(prefix=f"{SCRATCH_PREFIX}{os.getpid()}-") as root:
        args = list(args)
        scratch = {}
        for i, files in dirs.items():
            path = Path(root) / f"arg{i}" / Path(args[i]).name
            path.mkdir(parents=True)
            for relative, data in files.items():
                target = path.joinpath(*_safe_parts(relative, path))
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_bytes(data)
            args[i] = str(path)
            scratch[i] = str(path)
        try:
            value = fn(*args)
        except Exception as err:
            raise _Failed(err, index, scratch) from None
        return index, value, {i: pack_dir(scratch[i]) for i in outputs}, scratch, attempt


def remove_stale_scratch(directory: str | os.PathLike | None = None) -> list[Path]:
    """Remove the temporary directories of Ray tasks whose worker is gone.

    A task's temporary directory (:func:`_in_scratch`, ``aquafish-task-PID-XXXXXXXX`` in the
    system's temporary folder) is removed when the task ends; a worker killed with its run
    (``kill -9`` of the command, a lost node) leaves it. Every task and every Ray run of
    :func:`run_dir_tasks` first removes those of this user whose pid runs no process on this
    machine; a directory whose pid runs (another task) is left alone.

    Args:
        directory: where to look (default: ``tempfile.gettempdir()``).

    Returns:
        The directories removed.
    """
    root = Path(directory if directory is not None else tempfile.gettempdir())
    removed = []
    try:
        entries = list(os.scandir(root))
    except OSError:
        return removed
    for entry in entries:
        found = _SCRATCH.match(entry.name)
        try:
            if not found or not entry.is_dir(follow_symlinks=False) \
                    or entry.stat(follow_symlinks=False).st_uid != os.getuid():
                continue
        except OSError:
            continue
        if _running(int(found["pid"])):
            continue
        shutil.rmtree(entry.path, ignore_errors=True)
        removed.append(Path(entry.path))
    return removed


def _running(pid: int) -> bool:
    """Whether a process ``pid`` runs on this machine."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return True  # someone else's process (or not a pid to test): leave its directory
    return True


def _names_only(task: DirTask) -> tuple:
    """``task.args`` with each directory argument cut to its last name: no driver path goes to a node."""
    dirs = {*task.outputs, *task.inputs}
    return tuple(Path(a).name if i in dirs else a for i, a in enumerate(task.args))


def run_dir_tasks(tasks: list[DirTask], *, backend: str = "local", processes: int = 1,
                  address: str | None = None) -> Iterator:
    """The values of ``tasks``, as they finish (see the module).

    Args:
        tasks: the tasks.
        backend: ``"local"`` (in place: a pool of ``processes`` workers through
            :func:`aquafish.backends.run_tasks`) or ``"ray"`` (each task in a node-local temporary
            directory, its output directories written here from the bytes it sends back).
        processes: the local pool's size.
        address: the Ray cluster (:func:`aquafish.backends.connect_ray`).

    Yields:
        Each task's value (on Ray with the task's temporary paths replaced by the driver's),
        once its output directories are written. A task lost on Ray on every try yields nothing
        (one line is logged).

    Raises:
        ClusterError: as :func:`aquafish.backends.connect_ray`.
        ValueError: a task raised one (its own error, also from a Ray task).
        OSError: an output directory cannot be written on the driver.
    """
    if backend != "ray":
        yield from backends.run_tasks([(t.fn, t.args) for t in tasks], backend=backend, processes=processes,
                                      address=address)
        return
    remove_stale_scratch()  # a killed Ray run's on this machine (its workers were killed with it)
    shipped = [(_in_scratch, (i, t.fn, _names_only(t), {j: pack_dir(t.args[j]) for j in (*t.outputs, *t.inputs)},
                              t.outputs)) for i, t in enumerate(tasks)]
    results = backends.run_tasks(shipped, backend="ray", address=address, labels=[t.label for t in tasks])
    while True:
        try:
            index, value, outputs, scratch, attempt = next(results)
        except StopIteration:
            return
        except _Failed as failed:  # the task's own error, naming the driver's paths
            task = tasks[failed.index]
            replace = {path: str(task.args[i]) for i, path in failed.scratch.items()}
            raise _translate_error(failed.error, replace) from None
        task = tasks[index]
        replace = {path: str(task.args[i]) for i, path in scratch.items()}
        for i, files in outputs.items():
            unpack_dir(files, task.args[i], replace)
        if attempt > 0:
            _log.warning("%s: its Ray worker was lost; finished on try %d", task.label or task.fn.__name__,
                         attempt + 1)
        yield _translate(value, replace)
