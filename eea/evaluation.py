"""Batched, cached, parallel simulation of candidate models (paper section 3.2; docs/design.md).

Every fitness evaluation of a population goes through :class:`Evaluator`: the missing
(model, action, initial angles) simulations of the whole request are gathered into ONE
batch, split into contiguous chunks (at most ``max_batch_robots`` robots each, and at least
one per worker) and passed to :func:`aquafish_gym.simulate_batch`, serially with
``workers=1`` or on a ``concurrent.futures.ProcessPoolExecutor`` (one PyBullet client per
worker process). A robot's result does not depend on which batch it is in, so results are
identical for any number of workers.

Two caches keep a result from being simulated twice:

* estimation: the similarity (eq. 2) of model *genome* under experiment *index* from
  initial angles *levels* (:func:`eea.experiment.quantise_angles`) to that experiment's
  target summary; kept for the whole run and checkpointed with it;
* exploration: the behaviour summary of a model genome under an action genome from the
  zero state; cleared by :meth:`Evaluator.clear_summaries` at the start of every
  exploration phase (summaries are large; actions rarely repeat across rounds).

Initial angles are snapped to a 1e-6 rad grid before simulating, so a cached value and a
fresh simulation of the same key are bit-for-bit equal.

The model space (``model_space``, :class:`eea.encoding.ModelSpace`) says what a genome holds:
the paper's 9 flipper dimensions (45 bits, healthy servos), or those and 3 servo gains
(57 bits, ``morphology+servos``), with which each model is simulated under its own
``ServoFaults(speed_scale=gains)`` in the same batch (``simulate_batch`` takes one fault set
per robot). The target keeps its own faults (:class:`eea.target.Target`).
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ProcessPoolExecutor
from typing import Sequence

import numpy as np

from aquafish_gym import SimParams, simulate_batch
from aquafish_gym.checks import check_int
from aquafish_gym.rundir import spawn_pool
from eea.behaviour import MAX_COEFFICIENTS, SUMMARIES, similarity, summarise
from eea.encoding import ModelSpace, get_model_space
from eea.experiment import Experiment, check_params, quantise_angles

__all__ = ["Evaluator", "RuntimeSettings"]


def _default_workers() -> int:
    return os.cpu_count() or 1


@dataclasses.dataclass(frozen=True)
class RuntimeSettings:
    """How a run's simulations are spread over processes and batches (the ``EEAConfig`` section
    ``config.runtime``): the evaluator's, and they never change a run's results (a run resumes
    with other values).

    Args:
        workers: worker processes for simulations, >= 1 (1 = serial; default: every CPU;
            the flag ``--workers``).
        max_batch_robots: at most this many robots per ``simulate_batch`` call, >= 1
            (``--max-batch-robots``; 32-64 is fastest).

    Raises:
        ValueError: naming the field as ``EEAConfig.<field>`` if one is < 1 or no integer.
    """

    workers: int = dataclasses.field(default_factory=_default_workers)
    max_batch_robots: int = 64

    def __post_init__(self) -> None:
        check_int("EEAConfig.workers", self.workers, 1)
        check_int("EEAConfig.max_batch_robots", self.max_batch_robots, 1)


def _simulate_chunk(morphologies, actions, angles, steps, params, summary, faults=None, start_motion=None) -> np.ndarray:
    """Worker: behaviour summaries ``(n, 3, F)`` of one contiguous chunk of robots (``faults``:
    None for healthy servos, or one ServoFaults per robot; ``summary``: a name of
    :data:`eea.behaviour.SUMMARIES`; ``start_motion``: None (at rest) or ``(n, 7)``)."""
    return summarise(simulate_batch(morphologies, actions, angles, steps, faults=faults, params=params,
                                    start_motion=start_motion), summary)


def _genome_keys(genomes: np.ndarray) -> list[bytes]:
    """One compact bytes key per ``(P, n_bits)`` genome row."""
    packed = np.packbits(genomes.astype(np.uint8), axis=1)
    return [row.tobytes() for row in packed]


def _genomes_from_keys(keys: list[bytes], n_bits: int) -> np.ndarray:
    """The ``(N, n_bits)`` uint8 genomes of :func:`_genome_keys` keys (its inverse)."""
    packed = np.frombuffer(b"".join(keys), dtype=np.uint8).reshape(len(keys), -(-n_bits // 8))
    return np.unpackbits(packed, axis=1)[:, :n_bits]


class Evaluator:
    """Turns batches of (model genome, action, initial angles) into behaviour results.

    Args:
        steps: simulation steps (0.01 s each) of every simulation.
        workers: worker processes; 1 simulates in this process. The pool is created on
            first use and lives until :meth:`close` (use the evaluator as a context manager).
        max_batch_robots: at most this many robots per ``simulate_batch`` call (default 64, as
            ``EEAConfig``'s: PyBullet's cost per robot grows with the robots in one world, so a
            world of 2,000 steps each robot more than 10x slower than one of 100; docs/performance.md).
        params: simulator parameters of the models (default: the defaults); the caudal
            sweep must be the default one (:func:`eea.experiment.check_params`).
        model_space: what a model genome holds, a :class:`eea.encoding.ModelSpace` or its name
            (default ``"morphology"``, the paper's 45-bit genomes; ``"morphology+servos"``: 57
            bits, each model simulated with its own servo gains).
        summary: the behaviour summary (:data:`eea.behaviour.SUMMARIES`): ``"dft"`` (the
            paper's), ``"signed_dft"`` (the zero-frequency term signed) or ``"gyro_dft"``
            (the angular rates'); eq. 2 compares summaries at its
            :data:`eea.behaviour.MAX_COEFFICIENTS` entry.

    Attributes:
        simulations: number of robot simulations run so far (cache hits excluded).

    Raises:
        ValueError: if ``steps``, ``workers`` or ``max_batch_robots`` is < 1, or on an unknown
            model space or summary.
    """

    def __init__(self, steps: int, *, workers: int = 1, max_batch_robots: int = 64,
                 params: SimParams | None = None,
                 model_space: str | ModelSpace = "morphology", summary: str = "dft") -> None:
        for name, value in (("steps", steps), ("workers", workers), ("max_batch_robots", max_batch_robots)):
            check_int(name, value, 1)
        self.steps, self.workers, self.max_batch_robots = int(steps), int(workers), int(max_batch_robots)
        self.params = check_params(params)
        self.model_space = get_model_space(model_space)
        if summary not in SUMMARIES:
            raise ValueError(f"unknown behaviour summary {summary!r}; valid: {', '.join(SUMMARIES)}")
        self.summary = summary
        #: MAX of eq. 2 for this evaluator's summary (:data:`eea.behaviour.MAX_COEFFICIENTS`).
        self.max_coefficient = MAX_COEFFICIENTS[summary]
        self.simulations = 0
        self._similarity: dict[bytes, float] = {}
        self._summaries: dict[bytes, np.ndarray] = {}
        # experiment index -> the target summary array already checked (_check_summaries); held,
        # so its identity cannot pass to another array
        self._checked: dict[int, np.ndarray] = {}
        self._pool: ProcessPoolExecutor | None = None

    @classmethod
    def for_config(cls, config, workers: int | None = None, model_space: str | ModelSpace | None = None) -> "Evaluator":
        """The evaluator of a run's :class:`~eea.config.EEAConfig`: its steps, batch size, simulator
        parameters, model space and behaviour summary.

        Args:
            config: the run's ``EEAConfig``.
            workers: worker processes (default: ``config.runtime.workers``).
            model_space: another model space than the config's (e.g. ``"morphology+servos"``
                to check a ``morphology`` run's model against servo faults).

        Raises:
            ValueError: as the constructor.
        """
        return cls(config.steps, workers=config.runtime.workers if workers is None else workers,
                   max_batch_robots=config.runtime.max_batch_robots, params=config.sim_params,
                   model_space=config.model_space if model_space is None else model_space,
                   summary=config.behaviour_summary)

    # -- lifecycle --------------------------------------------------------------------
    def close(self) -> None:
        """Shut the worker pool down (if one was started)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self) -> "Evaluator":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- the one batched simulator call -----------------------------------------------
    def simulate(self, morphologies, actions, angles, faults=None, start_motion=None) -> np.ndarray:
        """Simulate N robots in one batch (chunked over workers) and summarise them.

        Args:
            morphologies: ``(N, 9)`` flipper dimensions (simulator units).
            actions: ``(N, 3)`` servo commands (rev/s, rev/s, Hz).
            angles: ``(N, 3)`` initial angles (rad), already on the quantisation grid.
            faults: None (healthy servos) or N :class:`~aquafish_gym.ServoFaults`, one per robot.
            start_motion: None (every robot level and at rest) or ``(N, 7)``, each robot's
                (:attr:`eea.experiment.Experiment.start_motion`).

        Returns:
            ``(N, 3, steps // 2 + 1)`` behaviour summaries (eq. 2's coefficients).

        Raises:
            ValueError: as :func:`aquafish_gym.simulate_batch` raises.
        """
        morphologies, actions, angles = (np.asarray(x, dtype=np.float64) for x in (morphologies, actions, angles))
        n = len(morphologies)
        if n == 0:
            return np.zeros((0, 3, self.steps // 2 + 1))
        n_chunks = min(n, max(self.workers, -(-n // self.max_batch_robots)))
        bounds = np.linspace(0, n, n_chunks + 1).astype(int)
        motion = None if start_motion is None else np.asarray(start_motion, dtype=np.float64)
        chunks = [(morphologies[a:b], actions[a:b], angles[a:b], self.steps, self.params, self.summary,
                   None if faults is None else list(faults[a:b]), None if motion is None else motion[a:b])
                  for a, b in zip(bounds[:-1], bounds[1:])]
        if self.workers == 1:
            parts = [_simulate_chunk(*chunk) for chunk in chunks]
        else:
            if self._pool is None:
                self._pool = spawn_pool(self.workers)
            parts = list(self._pool.map(_simulate_chunk, *zip(*chunks)))
        self.simulations += n
        return np.concatenate(parts)

    def _simulate_models(self, genomes, actions, angles, start_motion=None) -> np.ndarray:
        """:meth:`simulate` of ``(N, model_space.n_bits)`` model genomes (decoded, with their
        servo gains as faults in the ``morphology+servos`` space)."""
        values = self.model_space.decode(genomes)
        return self.simulate(self.model_space.morphologies(values), actions, angles, self.model_space.faults(values),
                             start_motion)

    # -- estimation: similarity to the target, cached for the run ----------------------
    def similarities(self, genomes, experiments: Sequence[Experiment], angles) -> np.ndarray:
        """Similarity (eq. 2) of every model's response to every experiment's target.

        Args:
            genomes: ``(P, n_bits)`` model genomes (45 bits; 57 in ``morphology+servos``).
            experiments: E experiments (their ``index``, ``action``, ``summary`` and
                ``start_motion`` are used: each model starts an experiment as its target did).
            angles: ``(P, E, 3)`` initial angles (rad) of model p in experiment e.

        Returns:
            ``(P, E)`` float64 in [0, 1]; MOD_FIT (eq. 3) is its mean over E.

        Raises:
            ValueError: on shape mismatches or an invalid genome or angle, or an experiment
                whose summary is not this evaluator's ``summary`` of its IMU log.
        """
        genomes = np.asarray(genomes)
        p, e = len(genomes), len(experiments)
        angles = np.asarray(angles, dtype=np.float64)
        n_bits = self.model_space.n_bits
        if genomes.ndim != 2 or genomes.shape[1] != n_bits or angles.shape != (p, e, 3):
            raise ValueError(f"genomes must be (P, {n_bits}) ({self.model_space.name} model genomes) and angles "
                             f"(P, E, 3) = ({p}, {e}, 3), got {genomes.shape} and {angles.shape}")
        levels, values = quantise_angles(angles.reshape(-1, 3))
        gkeys = _genome_keys(genomes)
        level_bytes = [row.tobytes() for row in levels]
        keys = [gkeys[i // e] + experiments[i % e].index.to_bytes(4, "little") + level_bytes[i]
                for i in range(p * e)]
        result = np.empty(p * e)
        missing: dict[bytes, list[int]] = {}
        for i, key in enumerate(keys):
            cached = self._similarity.get(key)
            if cached is None:
                missing.setdefault(key, []).append(i)
            else:
                result[i] = cached
        if missing:
            first = np.array([rows[0] for rows in missing.values()])
            self._check_summaries([experiments[j] for j in np.unique(first % e)])
            actions = np.stack([experiments[j].action for j in first % e])
            moving = not all(experiments[j].at_rest for j in np.unique(first % e))
            motion = np.stack([experiments[j].start_motion for j in first % e]) if moving else None
            summaries = self._simulate_models(genomes[first // e], actions, values[first], motion)
            targets = np.stack([experiments[j].summary for j in first % e])
            sims = similarity(summaries, targets, self.max_coefficient)
            for (key, rows), s in zip(missing.items(), sims.tolist()):
                self._similarity[key] = s
                result[rows] = s
        return result.reshape(p, e)

    def _check_summaries(self, experiments: Sequence[Experiment]) -> None:
        """Refuse targets summarised otherwise than the models are (``summary``): a model would
        be scored against a target it can never match (a signed run's truth below 1 at the true
        angles). Each target summary is checked once (an experiment's later contexts share it)."""
        for x in experiments:
            if self._checked.get(x.index) is x.summary:
                continue
            # to round-off: a checkpoint may be resumed on another machine's FFT
            if not np.allclose(x.summary, summarise(x.imu_log, self.summary),
                               rtol=1e-9, atol=1e-9):
                raise ValueError(f"experiment {x.index}'s summary is not the {self.summary!r} behaviour summary of "
                                 "its IMU log: build the Evaluator with the run's behaviour summary "
                                 f"(summary=config.behaviour_summary; valid: {', '.join(SUMMARIES)})")
            self._checked[x.index] = x.summary

    # -- exploration: responses to candidate actions, cached within a phase ------------
    def summaries(self, genomes, action_genomes, actions, angles) -> np.ndarray:
        """Behaviour summaries of M models under A candidate actions, all from one context.

        Args:
            genomes: ``(M, n_bits)`` model genomes.
            action_genomes: ``(A, 18)`` action genomes (cache keys).
            actions: ``(A, 3)`` the decoded actions (rev/s, rev/s, Hz).
            angles: ``(3,)`` initial angles (rad) of every simulation.

        Returns:
            ``(A, M, 3, steps // 2 + 1)`` behaviour summaries.
        """
        genomes, action_genomes = np.asarray(genomes), np.asarray(action_genomes)
        actions = np.asarray(actions, dtype=np.float64)
        levels, values = quantise_angles(np.asarray(angles, dtype=np.float64)[None])
        m, a = len(genomes), len(action_genomes)
        suffix = levels[0].tobytes()
        gkeys, akeys = _genome_keys(genomes), _genome_keys(action_genomes)
        keys = [akeys[i // m] + gkeys[i % m] + suffix for i in range(a * m)]
        missing = list(dict.fromkeys(k for k in keys if k not in self._summaries))
        if missing:
            where = {k: i for i, k in reversed(list(enumerate(keys)))}
            rows = np.array([where[k] for k in missing])
            out = self._simulate_models(genomes[rows % m], actions[rows // m], np.repeat(values, len(rows), axis=0))
            self._summaries.update(zip(missing, out))
        return np.stack([self._summaries[k] for k in keys]).reshape(a, m, 3, -1)

    def clear_summaries(self) -> None:
        """Forget the exploration summaries (called at the start of every exploration)."""
        self._summaries.clear()

    # -- checkpointing ----------------------------------------------------------------
    def state_dict(self) -> dict:
        """Counter and estimation cache, for the run checkpoint."""
        return {"simulations": self.simulations, "similarity_cache": dict(self._similarity)}

    def load_state_dict(self, state: dict) -> None:
        """Restore what :meth:`state_dict` saved (the exploration cache starts empty)."""
        self.simulations = int(state["simulations"])
        self._similarity = dict(state["similarity_cache"])
        self._summaries.clear()

    @property
    def cache_size(self) -> int:
        """Number of cached estimation similarities."""
        return len(self._similarity)

    def scored_models(self) -> tuple[np.ndarray, np.ndarray]:
        """Every model the estimation cache holds: the models a run has scored, and how well.

        :mod:`eea.analysis.diagnosis` asks whether a run ever proposed a model near the truth.

        Returns:
            ``(genomes, similarities)``: ``(N, n_bits)`` uint8 distinct model genomes, in the order
            they were first scored, and ``(N, E)`` float64, each model's best cached similarity
            (eq. 2) per experiment over the initial angles it was scored under, NaN where it
            was never scored on that experiment; E is one more than the largest experiment
            index in the cache (no models: shapes ``(0, n_bits)`` and ``(0, 0)``); ``n_bits`` is
            the evaluator's model space's.
        """
        n_bits = self.model_space.n_bits
        width = -(-n_bits // 8)  # bytes of a genome's key (_genome_keys), then the experiment index
        rows: dict[bytes, int] = {}
        entries = []
        for key, value in self._similarity.items():
            row = rows.setdefault(key[:width], len(rows))
            entries.append((row, int.from_bytes(key[width:width + 4], "little"), value))
        n_exp = 1 + max((e for _, e, _ in entries), default=-1)
        similarities = np.full((len(rows), n_exp), np.nan)
        for row, e, value in entries:
            if not similarities[row, e] >= value:
                similarities[row, e] = value
        return _genomes_from_keys(list(rows), n_bits), similarities
