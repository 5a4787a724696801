"""One EEA round as one function (paper section 3.2, Figure 3).

:func:`run_round` is the body of :func:`eea.run` and of ``aquafish/benchmarks/eea_round.py``::

    exploration   evolve the action the candidate models disagree on most (eq. 1)
    target        perform it on the damaged robot from random initial angles
    estimation    evolve models that reproduce all experiments (eq. 3), with the
                  inference strategy choosing the models' initial angles

and returns a frozen :class:`RoundRecord`; :func:`eea.record.round_row` turns it into a
``rounds.csv`` row. The long-lived pieces of a run (the target, the strategy, the two
phases, the evaluator) travel together as :class:`RoundParts`.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Callable, Sequence

import numpy as np

from eea.behaviour import summarise
from eea.config import EEAConfig
from eea.estimation import Estimation
from eea.experiment import Experiment
from eea.exploration import Exploration
from eea.inference import InferenceStrategy
from eea.search.lineages import LineageStrategies, Lineages, make_estimation, make_strategy
from eea.target import Target

__all__ = ["PhaseReporter", "RoundParts", "RoundRecord", "run_round"]

#: ``on_phase(name, generations)`` is called when a phase starts (names ``"exploration"``,
#: ``"target"``, ``"estimation"``; generations None for the target) and may return a
#: per-generation callback ``(generation, best fitness so far)``.
PhaseReporter = Callable[[str, "int | None"], "Callable[[int, float], None] | None"]


@dataclasses.dataclass(frozen=True)
class RoundParts:
    """The long-lived pieces one round works with; build them with :meth:`from_config`.

    Attributes:
        config: the run's settings.
        target: the damaged robot (draws the true initial angles from the run's generator).
        strategy: the context inference strategy (one per lineage with ``config.estimation.lineages``
            >= 2, :class:`eea.search.lineages.LineageStrategies`).
        exploration: the exploration phase (a fresh action GA per round).
        estimation: the estimation phase (its model search carries over rounds; N
            independent ones, :class:`eea.search.lineages.Lineages`, with ``config.estimation.lineages``
            N >= 2).
        evaluator: batched, cached simulation of the models.
    """

    config: EEAConfig
    target: Target
    strategy: InferenceStrategy | LineageStrategies
    exploration: Exploration
    estimation: Estimation | Lineages
    evaluator: object

    @classmethod
    def from_config(cls, config: EEAConfig, rng: np.random.Generator, evaluator,
                    estimation: Estimation | Lineages | None = None) -> "RoundParts":
        """The parts of a run of ``config``, each built from its own section: the one place that
        wires a run's components from a config.

        Args:
            config: the run's settings.
            rng: the run's generator (the target's angles; a fresh estimation's initial population).
            evaluator: the run's :class:`eea.evaluation.Evaluator`.
            estimation: the estimation phase, e.g. restored from a checkpoint (None: a fresh one,
                :func:`eea.search.lineages.make_estimation` of ``config.estimation``).
        """
        if estimation is None:
            estimation = make_estimation(config.estimation, config.ga, config.model_space, rng)
        return cls(config, Target(config.damage, config.steps, rng, config.sim_params),
                   make_strategy(config.inference, config.ga, config.estimation.lineages),
                   Exploration.from_settings(config.exploration, config.ga), estimation, evaluator)

    def perform(self, index: int, action) -> Experiment:
        """Experiment ``index``: ``action`` ``(3,)`` performed on the target from fresh random
        initial angles, its behaviour summary, the strategy's context for it, and the motion
        the target started it with (its ``start_motion`` after ``perform``)."""
        imu_log, true_angles = self.target.perform(action)
        return Experiment(index, action, imu_log,
                          summarise(imu_log, self.config.behaviour_summary), true_angles,
                          self.strategy.new_context(true_angles), self.target.start_motion)


@dataclasses.dataclass(frozen=True, eq=False)
class RoundRecord:
    """What one round did (frozen).

    Attributes:
        number: the round's number, 1-based.
        action_genome: ``(18,)`` uint8 genome of the action performed.
        action: ``(3,)`` the action: left, right pectoral speed (rev/s), caudal (Hz).
        action_fitness: its ACT_FIT (eq. 1) among the candidate models.
        experiments: every experiment after the round, oldest first, with the contexts
            the strategy inferred; the newest is this round's.
        best_genome: ``(45,)`` uint8 fittest model of the round's last estimation generation.
        model_fitness: its MOD_FIT (eq. 3).
        simulations: model simulations of the run so far (cumulative, cache hits excluded).
        exploration_simulations: of which this round's exploration ran.
        exploration_s, target_s, estimation_s: wall seconds of each phase.
    """

    number: int
    action_genome: np.ndarray
    action: np.ndarray
    action_fitness: float
    experiments: tuple[Experiment, ...]
    best_genome: np.ndarray
    model_fitness: float
    simulations: int
    exploration_simulations: int
    exploration_s: float
    target_s: float
    estimation_s: float

    @property
    def experiment(self) -> Experiment:
        """This round's experiment (the newest)."""
        return self.experiments[-1]

    @property
    def wall_s(self) -> float:
        """Wall seconds of the whole round."""
        return self.exploration_s + self.target_s + self.estimation_s


def run_round(number: int, experiments: Sequence[Experiment], parts: RoundParts, rng: np.random.Generator,
              on_phase: PhaseReporter | None = None) -> RoundRecord:
    """Run round ``number``: exploration, one target experiment, estimation.

    Args:
        number: the round's number (1-based), recorded.
        experiments: the experiments of the earlier rounds, oldest first (not modified).
        parts: the run's :class:`RoundParts`.
        rng: the run's generator (every random draw of the round).
        on_phase: optional progress reporter (:data:`PhaseReporter`).

    Returns:
        The :class:`RoundRecord`.
    """
    config, evaluator = parts.config, parts.evaluator
    report = on_phase or (lambda name, generations: None)
    started, before = time.perf_counter(), evaluator.simulations
    models = parts.estimation.ranked_models(config.exploration.models, config.exploration.diversity)
    action_genome, action, action_fitness = parts.exploration.run(
        models, evaluator, rng, report("exploration", config.exploration.generations))
    explored, exploration_sims = time.perf_counter(), evaluator.simulations - before
    report("target", None)
    experiment = parts.perform(len(experiments), action)
    performed = time.perf_counter()
    result = parts.estimation.run((*experiments, experiment), parts.strategy, evaluator, rng,
                                  config.estimation.generations,
                                  report("estimation", config.estimation.generations))
    return RoundRecord(number, action_genome, action, float(action_fitness), result.experiments,
                       result.best_genome, float(result.best_fitness), int(evaluator.simulations),
                       int(exploration_sims), explored - started, performed - explored,
                       time.perf_counter() - performed)
