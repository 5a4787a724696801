"""One process pool for several NEAT evolutions at once, each as it would run alone.

A generation of NEAT on the vector env is a few PyBullet worlds (:class:`~gait.batch_fitness.BatchEvaluator`);
an evolution whose generation fits in one world keeps one core busy and leaves the other idle.
:meth:`SharedPool.run_each` runs several such jobs (e.g. the mission's two kinds of new gait and
their rehearsals) in threads that hand the worlds of their generations to one shared process
pool, so the worlds of both fill the cores.

The jobs give exactly what they give one after the other: only one thread runs Python at a time
(a baton, handed over while a thread waits for its worlds), and each thread keeps its own
``random`` and NumPy global random states across the hand-overs (neat-python draws from
``random``'s global generator). A job's draws therefore depend only on its own calls, and a
world's fitness only on its genomes and their places (:mod:`gait.batch_fitness`), never on which
process ran it.
"""

from __future__ import annotations

import random
import threading
from concurrent.futures import ThreadPoolExecutor, wait
from typing import Any, Callable, Sequence

import numpy as np

from aquafish_gym.checks import check_int
from aquafish_gym.rundir import spawn_pool

__all__ = ["SharedPool"]


class SharedPool:
    """A process pool (``workers`` "spawn" processes that die with this one) that the jobs of
    :meth:`run_each` share. Use as a context manager; the pool is shut down on exit.

    Args:
        workers: processes (>= 1).

    Raises:
        ValueError: ``workers`` not an integer >= 1.
    """

    def __init__(self, workers: int):
        self.workers = check_int("workers", workers, 1)
        # every process started now, from this thread: a process started from a job's thread would be
        # killed when that thread ends (Linux's parent-death signal follows the creating thread)
        self._pool = spawn_pool(self.workers, start_now=True)
        self._baton = threading.Lock()
        self._local = threading.local()   # .turn: holds the baton; .states: its random states while it waits
        self._cancelled = False

    def map(self, function: Callable, *iterables) -> list:
        """``[function(*args) for args in zip(*iterables)]``, each call in a pool process (``function``
        and its arguments must pickle). Called from a job of :meth:`run_each`, the baton goes to
        another job while the calls run.

        Raises:
            RuntimeError: the jobs were interrupted (:meth:`run_each`).
            Exception: what a call raised.
        """
        if self._cancelled:
            raise RuntimeError("the shared pool's jobs were interrupted")
        futures = [self._pool.submit(function, *args) for args in zip(*iterables)]
        if getattr(self._local, "turn", False):
            self._end_turn()
            try:
                wait(futures)
            finally:
                self._take_turn()
        return [future.result() for future in futures]

    def run_each(self, jobs: Sequence[Callable[[], Any]]) -> list:
        """Run every job (a function of no arguments) in its own thread and return their results
        in order. Each job starts from the caller's ``random`` and NumPy global random states and
        keeps its own; afterwards the caller has the last job's, as if the jobs had run one
        after the other.

        Raises:
            Exception: the first job's exception (in job order), once all have ended.
            KeyboardInterrupt: pending pool calls are cancelled and the jobs end at their next
                :meth:`map`.
        """
        start = (random.getstate(), np.random.get_state())
        ends: list = [None] * len(jobs)

        def call(k: int):
            self._take_turn(start)
            try:
                return jobs[k]()
            finally:
                ends[k] = (random.getstate(), np.random.get_state())
                self._end_turn()

        threads = ThreadPoolExecutor(max_workers=max(1, len(jobs)), thread_name_prefix="shared-pool-job")
        try:
            futures = [threads.submit(call, k) for k in range(len(jobs))]
            wait(futures)
        except BaseException:
            self._cancelled = True
            self._pool.shutdown(wait=False, cancel_futures=True)
            raise
        finally:
            threads.shutdown(wait=not self._cancelled)
        if ends and ends[-1] is not None:
            random.setstate(ends[-1][0])
            np.random.set_state(ends[-1][1])
        return [future.result() for future in futures]

    def _take_turn(self, states=None) -> None:
        self._baton.acquire()
        states = states if states is not None else self._local.states
        random.setstate(states[0])
        np.random.set_state(states[1])
        self._local.turn = True

    def _end_turn(self) -> None:
        self._local.states = (random.getstate(), np.random.get_state())
        self._local.turn = False
        self._baton.release()

    def __enter__(self) -> "SharedPool":
        return self

    def __exit__(self, *exc) -> None:
        self._pool.shutdown(cancel_futures=True)
