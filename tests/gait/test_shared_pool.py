"""gait.shared_pool: jobs that share one process pool give what they give one after the other."""

import math
import random
import threading

import numpy as np
import pytest

from gait.shared_pool import SharedPool


def _job(seed: int, pool, rounds: int = 3):
    """Draws from the global generators between pool calls, as a NEAT evolution does between generations."""
    random.seed(seed)
    np.random.seed(seed)
    out = []
    for _ in range(rounds):
        values = [random.random(), float(np.random.random())]
        out.append((values, pool.map(math.sqrt, values) if pool is not None else [math.sqrt(v) for v in values]))
    return out, threading.current_thread().name


def test_jobs_at_once_draw_and_compute_as_one_after_the_other():
    random.seed(99)
    alone = [_job(1, None)[0], _job(2, None)[0]]
    after_alone = random.random()
    random.seed(99)
    with SharedPool(2) as pool:
        together = pool.run_each([lambda: _job(1, pool), lambda: _job(2, pool)])
        assert [t[0] for t in together] == alone                        # own random streams kept across hand-overs
        assert {t[1] for t in together} != {threading.current_thread().name}   # they ran in their own threads
        assert random.random() == after_alone                           # the caller has the last job's state
        assert pool.map(abs, [-1, 2]) == [1, 2]                         # usable outside a job too


def test_a_jobs_exception_reaches_the_caller_after_the_others_end():
    ended = []

    def fails():
        raise ValueError("bad job")

    def works():
        ended.append(pool.map(abs, [-3]))
        return 1

    with SharedPool(1) as pool:
        with pytest.raises(ValueError, match="bad job"):
            pool.run_each([fails, works])
    assert ended == [[3]]


def test_workers_must_be_a_positive_integer():
    with pytest.raises(ValueError, match="workers"):
        SharedPool(0)
