"""Exploration phase of the EEA: evolve the action the candidate models disagree on most.

Paper section 3.2: a :class:`~eea.ga.BitGA` over 18-bit action genomes (population 25,
25 generations per round); an action's fitness is ACT_FIT (eq. 1), the mean pairwise
dissimilarity of the candidate models' responses to it. The action with the highest
fitness in the final generation is performed on the target.

Choices the paper leaves open, made here:

* Candidate models: the distinct genomes of the estimation population's last evaluated
  generation, best first, at most ``config.exploration.models`` (``--exploration-models``, default 25, i.e. the
  whole population) - duplicates would only add zero-disagreement pairs. Before the first
  estimation they are the distinct genomes of the random initial population. Not the
  paper's: with ``config.exploration.diversity = d > 0`` they are the fittest models of
  the whole last round, each at least d apart (:func:`eea.diversity.diverse_ranked`).
* Context: the next experiment's initial angles are unknown when its action is chosen, so
  every model is simulated from the zero state (pectorals arms-back, caudal 0). A fixed
  context keeps ACT_FIT deterministic and comparable between actions.
* Not the paper's, with ``angle_sets = K >= 2`` (``config.exploration.angles``): every
  model is simulated from K random angle sets, drawn once per round from the run's
  generator and shared by all actions, and an action scores
  :func:`eea.fitness.robust_action_fitness` (the disagreement minus the spread the angles
  cause). It costs K times the simulations of the paper's exploration.
* A new action GA starts every round (actions do not carry over).

Settings: :class:`ExplorationSettings`, the section ``config.exploration`` of
:class:`eea.config.EEAConfig` (the flags ``--exploration-*``); the GA's breeding settings are
the run's shared :class:`eea.ga.GASettings` (``config.ga``).
"""

from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from aquafish_gym.checks import check_int
from eea.encoding import ACTION_BITS, decode_actions
from eea.experiment import random_angles
from eea.fitness import action_fitness, robust_action_fitness
from eea.ga import BitGA, GASettings

__all__ = ["EXPLORATION_ANGLES_RAD", "Exploration", "ExplorationSettings"]

#: Initial angles (rad) of every model simulation during exploration: the zero state.
EXPLORATION_ANGLES_RAD = np.zeros(3)


@dataclasses.dataclass(frozen=True)
class ExplorationSettings:
    """The exploration phase's settings (the ``EEAConfig`` section ``config.exploration``, the
    flags ``--exploration-*``; module docstring).

    Args:
        population: actions per GA generation, >= 1 (paper: 25).
        generations: GA generations per round, >= 1 (paper: 25).
        models: at most this many distinct candidate models, >= 2 (a disagreement needs two).
        angles: 0 (the zero state, the paper's) or K >= 2 random angle sets per round.
        diversity: 0 (the paper's candidates) or d in (0, 1), the candidates' least distance.

    Raises:
        ValueError: naming the field as ``EEAConfig.exploration_<field>`` if one is out of range.
    """

    population: int = 25
    generations: int = 25
    models: int = 25
    angles: int = 0
    diversity: float = 0.0

    def __post_init__(self) -> None:
        for name, low in (("population", 1), ("generations", 1), ("models", 2), ("angles", 0)):
            check_int(f"EEAConfig.exploration_{name}", getattr(self, name), low)
        if self.angles == 1:
            raise ValueError("EEAConfig.exploration_angles must be 0 (the zero state) or >= 2 (a spread needs "
                             "two angle sets), got 1")
        value = self.diversity
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value < 1.0:
            raise ValueError(f"EEAConfig.exploration_diversity must be in [0, 1), got {value!r}")
        object.__setattr__(self, "diversity", float(value))


class Exploration:
    """The exploration phase: one fresh action GA per round.

    Args:
        population: actions per generation (paper: 25).
        generations: generations per round (paper: 25).
        ga_options: keyword arguments of :class:`~eea.ga.BitGA` (crossover_rate,
            mutation_rate, tournament_size, elitism).
        angle_sets: 0 for the paper's zero state, or K >= 2 random angle sets per round
            (the angle-robust action fitness, see the module docstring).

    Raises:
        ValueError: if ``population`` or ``generations`` is < 1, or ``angle_sets`` is 1 or < 0.
    """

    def __init__(self, population: int = 25, generations: int = 25, ga_options: dict | None = None,
                 angle_sets: int = 0) -> None:
        if population < 1 or generations < 1:
            raise ValueError(f"population and generations must be >= 1, got {population}, {generations}")
        if angle_sets < 0 or angle_sets == 1:
            raise ValueError(f"angle_sets must be 0 (zero state) or >= 2, got {angle_sets}")
        self.population, self.generations = int(population), int(generations)
        self.ga_options = dict(ga_options or {})
        self.angle_sets = int(angle_sets)

    @classmethod
    def from_settings(cls, settings: ExplorationSettings, ga: GASettings) -> "Exploration":
        """Sized and tuned by its settings (the section ``config.exploration`` of an
        :class:`eea.config.EEAConfig`) and the run's shared GA settings (``config.ga``, mutation
        ``mutation_bits / 18``).

        Args:
            settings: the exploration's :class:`ExplorationSettings`.
            ga: the run's :class:`eea.ga.GASettings`.
        """
        return cls(settings.population, settings.generations, ga.options(ACTION_BITS), settings.angles)

    def run(self, models: np.ndarray, evaluator, rng: np.random.Generator,
            on_generation: Callable[[int, float], None] | None = None) -> tuple[np.ndarray, np.ndarray, float]:
        """Evolve the most informative action for the candidate ``models``.

        Each generation is one :meth:`Evaluator.summaries` call for all
        (action, model) pairs not yet simulated in this phase.

        Args:
            models: ``(M, 45)`` distinct candidate model genomes. With M < 2 there is no
                disagreement to measure: the first action of a random population is returned
                with fitness 0 and nothing is simulated.
            evaluator: an :class:`eea.evaluation.Evaluator` (its exploration cache is cleared).
            rng: the run's generator.
            on_generation: called with (generation, best fitness so far) after each one.

        Returns:
            ``(action_genome (18,) uint8, action (3,) rev/s, rev/s, Hz, action_fitness)``.
        """
        models = np.asarray(models, dtype=np.uint8)
        ga = BitGA(ACTION_BITS, self.population, rng, **self.ga_options)
        if len(models) < 2:
            genome = ga.ask()[0]
            return genome, decode_actions(genome), 0.0
        evaluator.clear_summaries()
        angle_sets = random_angles(rng, self.angle_sets) if self.angle_sets else None
        for generation in range(self.generations):
            genomes = ga.ask()
            actions = decode_actions(genomes)
            if angle_sets is None:
                summaries = evaluator.summaries(models, genomes, actions, EXPLORATION_ANGLES_RAD)  # (A, M, 3, F)
                ga.tell(np.atleast_1d(action_fitness(summaries, evaluator.max_coefficient)))
            else:
                summaries = np.stack([evaluator.summaries(models, genomes, actions, angles) for angles in angle_sets],
                                     axis=1)                                                # (A, K, M, 3, F)
                ga.tell(np.atleast_1d(robust_action_fitness(summaries, evaluator.max_coefficient)))
            if on_generation is not None:
                on_generation(generation, ga.best_fitness)
        evaluator.clear_summaries()
        return ga.best_genome, decode_actions(ga.best_genome), ga.best_fitness
