"""Where a batch of independent tasks runs: a local process pool, or Ray tasks on a cluster.

A study's runs (:mod:`aquafish.study`) and a recovery benchmark's cells
(:mod:`aquafish.recovery`) are such tasks; :func:`aquafish.shipping.run_dir_tasks` wraps
:func:`run_tasks` for tasks that write run directories, so that on Ray they need no shared
file system. :func:`connect_ray` fails in about a second, with one line
(:class:`ClusterError`), without Ray (the ``[cluster]`` extra), without a cluster at the
address, or without the token a token-authenticated cluster asks for.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import sys
from concurrent.futures import as_completed
from pathlib import Path
from typing import Callable, Iterator

from aquafish_gym.rundir import spawn_pool

__all__ = ["BACKENDS", "CLUSTER_EXTRA_INSTALL", "MAX_RETRIES", "RAY_TOKEN_HELP", "ClusterError", "check_address",
           "check_backend", "connect_ray", "run_tasks"]

#: The backends a batch of tasks can run on.
BACKENDS = ("local", "ray")
#: How many times Ray runs a task again whose worker process or node was lost.
MAX_RETRIES = 3

_log = logging.getLogger(__name__)

#: How to install what ``backend="ray"`` needs.
CLUSTER_EXTRA_INSTALL = "pip install 'aquafish[cluster]'"

#: What a token-authenticated Ray cluster (Ray >= 2.5x, ``RAY_AUTH_MODE=token``) asks of a client.
RAY_TOKEN_HELP = ("set RAY_AUTH_MODE=token and the cluster's token in RAY_AUTH_TOKEN (or in a file named by "
                  "RAY_AUTH_TOKEN_PATH, or ~/.ray/auth_token; `ray get-auth-token` on the head prints it)")


class ClusterError(ValueError):
    """The Ray backend cannot be used: Ray is not installed, no cluster answers at the address,
    or the cluster refuses this client (its token). The message says what to do."""


def check_backend(backend: str, address: str | None = None) -> str:
    """``backend`` if it is one of :data:`BACKENDS`, and ``address`` only with ``"ray"``.

    Args:
        backend: the backend asked for.
        address: the Ray cluster's address asked for (``--address``), or None.

    Raises:
        ValueError: any other name, naming the allowed ones; an ``address`` with the local
            backend, which would ignore it.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if address is not None and backend != "ray":
        raise ValueError(f"--address {_shown(address)} names a Ray cluster, which --backend {backend} does not use "
                         "(it would be ignored); give --backend ray to run on that cluster, or leave --address out")
    return backend


def _shown(text: str) -> str:
    """``text`` for a message: at most 80 characters, quoted when empty or not printable."""
    text = str(text)
    short = text if len(text) <= 80 else text[:80] + "..."
    return short if short and short.isprintable() and " " not in short else repr(short)


def check_address(address: str, source: str = "--address") -> str:
    """``address`` if it has the form of a Ray address: ``auto``, ``local``, ``HOST:PORT`` (PORT
    in 1-65535; the head's GCS port, 6379 unless it was started with another) or
    ``ray://HOST:PORT`` (Ray Client).

    Args:
        address: the address.
        source: where it came from, for the message (``--address`` or ``RAY_ADDRESS``).

    Raises:
        ClusterError: one line naming ``source``, the address and the forms allowed.
    """
    text = address.removeprefix("ray://")
    host, _, port = text.rpartition(":")
    if address in ("auto", "local") or (host.strip("[]") and port.isascii() and port.isdigit()
                                        and 1 <= int(port) <= 65535 and "/" not in text and text.isprintable()):
        return address
    raise ClusterError(f"{source} {_shown(address)} is not a Ray cluster address: give 'auto' (the cluster started on "
                       "this machine), HOST:PORT (the head's GCS port, 6379 by default) or ray://HOST:PORT (Ray "
                       "Client)")


def run_tasks(tasks: list[tuple[Callable, tuple]], *, backend: str = "local", processes: int = 1,
              address: str | None = None, labels: list[str] | None = None) -> Iterator:
    """The values of ``tasks`` (``(function, args)``, top-level functions and picklable
    arguments), as they finish: on a local pool of ``processes`` workers that die with this
    process (:func:`~aquafish_gym.rundir.spawn_pool`), or as Ray tasks of one CPU each
    (``backend="ray"``, :func:`connect_ray` with ``address``; :func:`_ray_values`). A study's
    runs and a recovery benchmark's cells run through it (:func:`aquafish.shipping.run_dir_tasks`).

    Args:
        tasks: the tasks.
        backend: ``"local"`` or ``"ray"``.
        processes: the local pool's size.
        address: the Ray cluster.
        labels: each task's name in a logged line (Ray: a task lost on every try).

    Raises:
        ClusterError: as :func:`connect_ray`.
        ValueError: an unknown ``backend`` (on the first value asked for); a task raised one:
            its own error, also from a Ray task (not Ray's ``RayTaskError`` around it).
    """
    check_backend(backend)
    if not tasks:
        return
    if backend == "ray":
        yield from _ray_values(tasks, address, labels)
        return
    # workers die with this process (a killed study leaves no orphan running its queue), and are
    # spawned, not forked: a fork would copy this process's threads and PyBullet clients
    with spawn_pool(min(processes, len(tasks))) as pool:
        for future in as_completed([pool.submit(fn, *args) for fn, args in tasks]):
            yield future.result()


def _ray_values(tasks: list[tuple[Callable, tuple]], address: str | None, labels: list[str] | None) -> Iterator:
    """The values of ``tasks`` as Ray tasks of one CPU, as they finish.

    Ray retries a task whose worker process or node is lost up to :data:`MAX_RETRIES` times
    (``max_retries``: system failures only; ``retry_exceptions=False``: an error the task raises
    itself is its result, not retried). A task lost on every try is logged in one line and
    yields nothing; the others go on.

    Raises:
        ClusterError: as :func:`connect_ray`.
        Exception: the first error a task raised itself (not Ray's ``RayTaskError`` around it).
    """
    ray = connect_ray(address)
    remotes = {}
    pending = {}
    for i, (fn, args) in enumerate(tasks):
        if fn not in remotes:
            remotes[fn] = ray.remote(num_cpus=1, max_retries=MAX_RETRIES, retry_exceptions=False)(fn)
        pending[remotes[fn].remote(*args)] = i
    while pending:
        done, _ = ray.wait(list(pending), num_returns=1)
        i = pending.pop(done[0])
        try:
            value = ray.get(done[0])
        except ray.exceptions.RayTaskError as err:
            raise _task_cause(err) from err
        except ray.exceptions.RayError as err:  # the worker or its node was lost on every try
            label = labels[i] if labels else f"task {i + 1} of {len(tasks)}"
            _log.warning("%s: lost on the Ray cluster after %d tries (%s); it is left unfinished, run the "
                         "command again to finish it", label, MAX_RETRIES + 1, type(err).__name__)
            continue
        yield value


def _task_cause(err: Exception) -> Exception:
    """The exception a Ray task raised (e.g. a run's :class:`~aquafish_gym.rundir.FileError`),
    so that it reads as on the local pool; ``err`` itself when Ray could not bring it back."""
    cause = getattr(err, "cause", None)
    return cause if isinstance(cause, Exception) else err


def _import_ray():
    try:
        import ray
    except ImportError as err:
        raise ClusterError(f"--backend ray needs Ray, which is not installed ({err}): {CLUSTER_EXTRA_INSTALL}") \
            from None
    return ray


def connect_ray(address: str | None = None):
    """Import Ray and connect to the cluster at ``address`` (``None``: ``RAY_ADDRESS`` or a new
    local instance; ``"auto"``: the cluster started on this machine); return the ``ray`` module.

    Before ``ray.init``, a cluster address is checked in about a second: something must listen
    there, and a token-authenticated cluster (Ray's ``RAY_AUTH_MODE=token``) must accept this
    client, which needs ``RAY_AUTH_MODE=token`` and the token in ``RAY_AUTH_TOKEN`` (or a file
    named by ``RAY_AUTH_TOKEN_PATH``, or ``~/.ray/auth_token``) in its environment. Without that,
    ``ray.init`` retries for 20 s, printing a warning per try, and then fails. A Ray Client
    address (``ray://``) is passed to ``ray.init`` unchecked.

    Raises:
        ClusterError: one line that names where the address came from (``--address``, or the
            environment's ``RAY_ADDRESS``): Ray is not installed (the message names the
            ``[cluster]`` extra), the address has no form of a Ray address
            (:func:`check_address`), nothing answers at it, the cluster refuses this client
            (the message says which variables to set), or ``ray.init`` fails.
    """
    ray = _import_ray()
    if ray.is_initialized():
        return ray
    source = "--address" if address is not None else "RAY_ADDRESS"  # Ray reads RAY_ADDRESS without --address
    target = address if address is not None else os.environ.get("RAY_ADDRESS")
    if target is not None and (address is not None or target):
        check_address(target, source)
    if target and not target.startswith("ray://") and target != "local":
        _check_cluster(target, source)
    try:
        ray.init(address=address, include_dashboard=False, log_to_driver=False)
    except Exception as err:  # noqa: BLE001  (Ray raises ValueError, ConnectionError, RuntimeError, its own)
        where = f"at {source} {_shown(target)}" if target else "(a new local one)"
        reason = " ".join(str(err).split()) or type(err).__name__
        raise ClusterError(f"cannot connect to the Ray cluster {where}: {reason[:300]}") from err
    return ray


def _ray_token_available() -> bool:
    """Whether a Ray token is where Ray looks: ``RAY_AUTH_TOKEN``, ``RAY_AUTH_TOKEN_PATH``, ``~/.ray/auth_token``."""
    path = os.environ.get("RAY_AUTH_TOKEN_PATH")
    return bool(os.environ.get("RAY_AUTH_TOKEN")) or (Path(path).is_file() if path else False) \
        or (Path.home() / ".ray" / "auth_token").is_file()


@contextlib.contextmanager
def _quiet_stderr_fd():
    """Send file descriptor 2 to /dev/null (Ray's C++ client logs a warning line per failed connection)."""
    sys.stderr.flush()
    saved = os.dup(2)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)


def _check_cluster(address: str, source: str = "--address") -> None:
    """Fail at once, with what to do, if nothing listens at ``address`` or its cluster refuses this
    client's token (:func:`connect_ray`); other problems are left to ``ray.init``. ``source`` names
    where the address came from in the message (``--address`` or ``RAY_ADDRESS``)."""
    from ray._private.services import canonicalize_bootstrap_address
    from ray._raylet import GcsClient
    from ray.exceptions import AuthenticationError

    try:
        gcs = canonicalize_bootstrap_address(address)  # "auto": the local cluster's, None if there is none
        host, port = gcs.rsplit(":", 1)
        port = int(port)
    except Exception:  # noqa: BLE001  (None, or an address ray.init will reject with its own message)
        return
    try:
        socket.create_connection((host, port), timeout=1).close()
    except OSError as err:
        raise ClusterError(f"no Ray cluster answers at {source} {_shown(address)} ({gcs}: {err.strerror or err}); "
                           "start one with `ray start --head`, or check the address") from None
    if address == "auto" and "RAY_AUTH_MODE" not in os.environ and _ray_token_available():
        return  # ray.init turns token authentication on by itself for a local cluster found so
    try:
        with _quiet_stderr_fd():
            GcsClient(address=gcs)
    except AuthenticationError:
        mode = os.environ.get("RAY_AUTH_MODE", "")
        problem = ("refused this client's token (RAY_AUTH_MODE=token): the token is missing or not the cluster's"
                   if mode.lower() == "token" else
                   "requires token authentication (Ray's InvalidAuthToken) and this client sends no token")
        raise ClusterError(f"the Ray cluster at {source} {_shown(address)} {problem}; {RAY_TOKEN_HELP}") from None
    except Exception:  # noqa: BLE001  (anything else: ray.init reports it)
        return
