"""Rehearsal: choose among candidate gaits by swimming each on the self-model from the robot's heading.

A new gait is evolved from fixed start headings, but when it takes over, the robot points
wherever its experiments left it, and how well a gait turns back to the heading and holds it
depends on that start. The robot knows its yaw (its IMU), not its flipper angles (the pectoral
servos turn without position feedback). So before it swims on, it tries each candidate gait on
its self-model, from rest at its own yaw, from a few draws of the flipper angles, and keeps the
one that goes furthest along +y (the mission's heading) on average: :func:`rehearse`. The
candidates are the fittest genomes of every generation of the evolution
(:class:`TopGenomes`, :func:`gait.neat_evolution.evolve_from_population`'s ``keep_top``).

Not in the paper: a model-predictive choice in the spirit of Intelligent Trial and Error's
(Cully et al., Nature 2015) use of a model's predictions to pick what to try on the robot.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Sequence

import neat
import numpy as np

from aquafish_gym.checks import check_int, check_seconds
from gait.batch_fitness import BatchEvaluator
from gait.shared_pool import SharedPool
from gait.controller import NEATController
from gait.fitness_task import FitnessTask
from gait.robots import as_robot

__all__ = ["Rehearsal", "TopGenomes", "rehearse"]


class TopGenomes(neat.reporting.BaseReporter):
    """A neat-python reporter that keeps a copy of the ``top`` fittest genomes of every evaluated
    generation (each genome once, by its key, in the order first kept).

    ``kept`` maps a genome's key to its copy; ``generations`` maps it to the evaluation it was
    first kept in, counted from 0 (the first generation this reporter saw evaluated).

    Args:
        top: genomes kept per generation (>= 1).

    Raises:
        ValueError: ``top`` not an integer >= 1.
    """

    def __init__(self, top: int):
        self.top = check_int("top", top, 1)
        self.kept: dict[int, object] = {}
        self.generations: dict[int, int] = {}
        self._evaluated = 0

    def post_evaluate(self, config, population, species, best_genome) -> None:
        ranked = sorted(population.values(), key=lambda g: g.fitness, reverse=True)[:self.top]
        for genome in ranked:
            if genome.key not in self.kept:
                self.kept[genome.key] = copy.deepcopy(genome)
                self.generations[genome.key] = self._evaluated
        self._evaluated += 1


@dataclasses.dataclass(frozen=True)
class Rehearsal:
    """The outcome of :func:`rehearse`.

    Attributes:
        controller: the chosen candidate.
        index: its index in the candidates.
        scores: ``(N,)`` each candidate's mean displacement along +y over the draws (units).
    """

    controller: NEATController
    index: int
    scores: np.ndarray


def rehearse(candidates: Sequence[NEATController], robot, *, start_yaw_deg: float, duration_s: float, seed: int,
             draws: int = 4, workers: int = 1, shared: SharedPool | None = None) -> Rehearsal:
    """Swim every candidate on ``robot`` from rest turned by ``start_yaw_deg`` and keep the one that
    goes furthest along +y, on average over ``draws`` starts (flipper angles drawn from seeds
    ``seed``, ``seed + 1``, ...; the same for every candidate). The swims are a
    :class:`~gait.fitness_task.FitnessTask` scored on the vector env
    (:class:`~gait.batch_fitness.BatchEvaluator`), as a generation of NEAT is; ties go to the
    first candidate.

    Args:
        candidates: N >= 1 NEAT controllers of one NEAT config and clock period (e.g. a
            :class:`~gait.neat_evolution.GaitResult`'s ``candidates``).
        robot: the robot to rehearse on (the self-model), anything :func:`gait.as_robot` takes.
        start_yaw_deg: the start's heading, degrees counter-clockwise from +y, in [-180, 180].
        duration_s: seconds of every swim (> 0).
        seed: the first draw's seed.
        draws: swims per candidate (>= 1).
        workers: evaluation processes (>= 1).
        shared: a :class:`~gait.shared_pool.SharedPool` that swims the worlds (``workers`` is
            then the pool's); the same scores as without.

    Returns:
        The :class:`Rehearsal`.

    Raises:
        ValueError: no candidates, candidates of different configs or clock periods, or a bad
            setting (named, as :class:`~gait.fitness_task.FitnessTask` raises).
    """
    candidates = list(candidates)
    if not candidates:
        raise ValueError("rehearse needs at least one candidate controller")
    config, period = candidates[0].config, candidates[0].clock_period_s
    if any(c.config is not config or c.clock_period_s != period for c in candidates):
        raise ValueError("rehearse's candidates must share one NEAT config and clock period (one evolution's)")
    task = FitnessTask(as_robot(robot), check_int("seed", seed, 0), None, check_seconds("duration_s", duration_s),
                       period, check_int("draws", draws, 1), start_yaws_deg=(start_yaw_deg,))
    genomes = [(k, copy.deepcopy(c.genome)) for k, c in enumerate(candidates)]
    with BatchEvaluator(task, check_int("workers", workers, 1), keep_fitness=False, shared=shared) as evaluate:
        evaluate(genomes, config)
    scores = np.array([g.fitness for _, g in genomes])
    index = int(np.argmax(scores))
    return Rehearsal(candidates[index], index, scores)
