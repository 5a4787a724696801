"""Estimation phase of the EEA: evolve models that explain the experiments (paper 3.2-3.4).

Settings: :class:`EstimationSettings`, the section ``config.estimation`` of
:class:`eea.config.EEAConfig` (population, generations, lineages and the search's own settings).

A model search (:mod:`eea.search`; the paper's bit-string GA over 45-bit model
genomes, 57-bit with servo gains in the ``morphology+servos`` model space, population 25,
100 generations per round) whose fitness is MOD_FIT (eq. 3), a
model's mean similarity (eq. 2) to the target over all recorded experiments, simulated from
the initial angles the inference strategy chooses for each (model, experiment). One search
lives for the whole run: each round continues from where the previous round ended (the
GA's models carry over; CMA-ES restarts its distribution at the best model, since a new
experiment changes the landscape it had converged on; :mod:`eea.search.cma` describes the
global share and the carried covariance), and the final hypothesis of a round is the
fittest model of its last generation.

The phase also hands the exploration its candidate models (:meth:`Estimation.ranked_models`):
the paper's are the distinct models of the last generation, best first. With a minimum
distance (``config.exploration.diversity``, the flag ``--exploration-diversity``, not the
paper's) they are picked instead from every model the round evaluated, best first, skipping
any closer than that to one already picked (:func:`eea.diversity.diverse_ranked`; why:
docs/self_modeling.md, "Exploration's candidate models").
"""

from __future__ import annotations

import dataclasses
from typing import Callable, Sequence

import numpy as np

from aquafish_gym.checks import check_int
from eea.compat import upgrade_estimation_state
from eea.diversity import diverse_ranked
from eea.encoding import genome_keys, genomes_from_keys, get_model_space, model_space_of
from eea.experiment import Experiment
from eea.fitness import model_fitness_from_similarities
from eea.inference import InferenceStrategy
from eea.search import (SEARCH_NAMES, SEARCH_SETTINGS, GASearchSettings, ModelSearch, SearchSettings,
                        check_model_search, make_model_search, model_search_from_state)

__all__ = ["Estimation", "EstimationResult", "EstimationSettings", "distinct_ranked"]


@dataclasses.dataclass(frozen=True)
class EstimationSettings:
    """The estimation phase's settings (the ``EEAConfig`` section ``config.estimation``).

    Args:
        population: models per generation, >= 2 (paper: 25; the flag ``--estimation-population``).
        generations: generations per round, >= 1 (paper: 100; ``--estimation-generations``).
        lineages: 1 (the paper's) or N >= 2 independent estimations sharing each round's
            experiment (:mod:`eea.search.lineages`; ``--lineages``).
        search: the model search and its own settings, one of :data:`eea.search.SEARCH_SETTINGS`:
            :class:`~eea.search.GASearchSettings` (the paper's GA, the default) or
            :class:`~eea.search.CMASettings` (``--estimation-search cma``, the flags ``--cma-*``).

    Raises:
        ValueError: naming the field as ``EEAConfig.<flag name>`` if one is out of range, or a
            ``search`` that is no search's settings (the message lists the valid names).
    """

    population: int = 25
    generations: int = 100
    lineages: int = 1
    search: SearchSettings = dataclasses.field(default_factory=GASearchSettings)

    def __post_init__(self) -> None:
        check_int("EEAConfig.estimation_population", self.population, 2)
        check_int("EEAConfig.estimation_generations", self.generations, 1)
        check_int("EEAConfig.lineages", self.lineages, 1)
        if type(self.search) not in SEARCH_SETTINGS.values():
            raise ValueError(f"EEAConfig.estimation_search: {self.search!r} is no search's settings; valid "
                             f"names: {', '.join(SEARCH_NAMES)}")


def distinct_ranked(genomes: np.ndarray, fitness: np.ndarray | None) -> np.ndarray:
    """Distinct rows of ``(P, n_bits)`` genomes, best first (ties and ``fitness=None``: row order).

    Returns:
        ``(R, n_bits)`` uint8, R <= P.
    """
    genomes = np.asarray(genomes, dtype=np.uint8)
    order = np.arange(len(genomes)) if fitness is None else np.argsort(-np.asarray(fitness), kind="stable")
    keys = genome_keys(genomes)
    seen, rows = set(), []
    for i in order:
        key = keys[i]
        if key not in seen:
            seen.add(key)
            rows.append(i)
    return genomes[rows]


@dataclasses.dataclass(frozen=True, eq=False)
class EstimationResult:
    """What one estimation phase returns.

    Attributes:
        experiments: the experiments with the contexts the strategy inferred, oldest first.
        best_genome: ``(45,)`` uint8 fittest model of the last generation.
        best_fitness: its MOD_FIT (eq. 3).
    """

    experiments: tuple[Experiment, ...]
    best_genome: np.ndarray
    best_fitness: float


class Estimation:
    """The estimation phase: a model search carried over rounds, evaluated through an Evaluator.

    Args:
        search: a :class:`~eea.search.ModelSearch` over model genomes of one
            :class:`~eea.encoding.ModelSpace`: ``MODEL_BITS`` = 45 bits (the paper's
            ``morphology``), or 57 (``morphology+servos``).

    Attributes:
        model_space: the :class:`~eea.encoding.ModelSpace` of the search's genomes.

    Raises:
        ValueError: if ``search`` does not satisfy the interface or its genomes are not
            45 or 57 bits long.
    """

    def __init__(self, search: ModelSearch) -> None:
        check_model_search(search)
        try:
            self.model_space = (get_model_space(search.model_space) if hasattr(search, "model_space")
                                else model_space_of(search.n_bits))
        except ValueError as err:
            raise ValueError(f"the estimation search must evolve 45-bit model genomes (57 with servo gains): "
                             f"{err}") from None
        self.search = search
        self._genomes: np.ndarray | None = None  # last evaluated generation (P, n_bits)
        self._fitness: np.ndarray | None = None  # and its fitness (P,)
        self._round: dict[bytes, float] = {}     # every model this round evaluated -> its best fitness

    @classmethod
    def from_settings(cls, settings: EstimationSettings, ga, model_space, rng: np.random.Generator) -> "Estimation":
        """A fresh random population of the search ``settings.search`` names
        (:func:`eea.search.make_model_search`).

        Args:
            settings: the estimation's :class:`EstimationSettings` (``config.estimation``).
            ga: the run's :class:`eea.ga.GASettings` (``config.ga``).
            model_space: the run's model space (a name or an :class:`eea.encoding.ModelSpace`).
            rng: the run's generator (the initial population).
        """
        return cls(make_model_search(settings, ga, model_space, rng))

    def run(self, experiments: Sequence[Experiment], strategy: InferenceStrategy, evaluator,
            rng: np.random.Generator, generations: int,
            on_generation: Callable[[int, float], None] | None = None) -> EstimationResult:
        """Evolve the models for ``generations`` generations against all experiments.

        Per generation: ``search.ask``; ``strategy.before_generation``; the population's
        initial angles ``strategy.angles`` ``(P, E, 3)``; one :meth:`Evaluator.similarities` call
        ``(P, E)``; MOD_FIT (eq. 3, :func:`eea.fitness.model_fitness_from_similarities`);
        ``strategy.after_generation``; ``search.tell``. ``search.restart`` and
        ``strategy.begin_round``/``end_round`` bracket the phase. Each hook's experiments
        are passed on to the next.

        Args:
            experiments: the E >= 1 recorded experiments, newest last.
            strategy: the context inference strategy.
            evaluator: an :class:`eea.evaluation.Evaluator`.
            rng: the run's generator (PERFORM()'s draws).
            generations: number of generations, >= 1.
            on_generation: called with (generation, best fitness so far) after each one.

        Returns:
            The :class:`EstimationResult`: the experiments with their final contexts and
            the fittest model of the last generation with its MOD_FIT.

        Raises:
            ValueError: if there are no experiments or ``generations < 1``.
        """
        if not experiments:
            raise ValueError("estimation needs at least one experiment")
        if generations < 1:
            raise ValueError(f"generations must be >= 1, got {generations}")
        experiments = strategy.begin_round(tuple(experiments))
        self.search.restart()
        self._round = {}
        for generation in range(generations):
            ranked = self.ranked_models()
            genomes = self.search.ask()
            experiments = strategy.before_generation(generation, ranked, experiments, evaluator, rng, genomes=genomes)
            angles = strategy.angles(experiments, genomes, rng)
            fitness = model_fitness_from_similarities(evaluator.similarities(genomes, experiments, angles))
            experiments = strategy.after_generation(genomes, angles, fitness, experiments)
            self.search.tell(fitness)
            self._genomes, self._fitness = genomes, fitness
            for key, f in zip(genome_keys(genomes), fitness):
                self._round[key] = max(float(f), self._round.get(key, -np.inf))
            if on_generation is not None:
                on_generation(generation, self.search.best_fitness)
        experiments = strategy.end_round(experiments)
        return EstimationResult(tuple(experiments), self.search.best_genome, self.search.best_fitness)

    def ranked_models(self, limit: int | None = None, min_distance: float = 0.0) -> np.ndarray:
        """Candidate models for the exploration, best first, at most ``limit``.

        With ``min_distance`` 0 (the paper's): the distinct models of the last evaluated
        generation. Otherwise: :func:`eea.diversity.diverse_ranked` over every model the last
        round evaluated (at its best fitness of the round). Before any evaluation, either way:
        the distinct genomes of the initial population, in order.

        Args:
            limit: at most this many models (None: no limit).
            min_distance: in [0, 1), see :func:`eea.diversity.diverse_ranked`.

        Returns:
            ``(R, 45)`` uint8.

        Raises:
            ValueError: if ``min_distance`` is outside [0, 1) or ``limit < 1``.
        """
        if limit is not None and limit < 1:
            raise ValueError(f"limit must be >= 1 or None, got {limit}")
        if not 0.0 <= min_distance < 1.0:
            raise ValueError(f"min_distance must be in [0, 1), got {min_distance!r}")
        if min_distance and self._round:
            keys = list(self._round)
            genomes = genomes_from_keys(keys, self.model_space.n_bits)
            return diverse_ranked(genomes, np.fromiter(self._round.values(), float, len(keys)),
                                  len(keys) if limit is None else limit, min_distance)
        if self._genomes is None:
            ranked = distinct_ranked(self.search.population, None)
        else:
            ranked = distinct_ranked(self._genomes, self._fitness)
        return ranked if limit is None else ranked[:limit]

    def state_dict(self) -> dict:
        """Search state, the last evaluated generation and every model of the last round
        with its fitness, for the run checkpoint."""
        return {"search": self.search.state_dict(), "genomes": self._genomes, "fitness": self._fitness,
                "round": dict(self._round)}

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator) -> "Estimation":
        """Rebuild from :meth:`state_dict`, drawing from ``rng`` from now on.

        Raises:
            ValueError: on an unknown search or an invalid state.
        """
        state = upgrade_estimation_state(state)  # older checkpoints: "ga" for "search", no "round"
        estimation = cls(model_search_from_state(state["search"], rng))
        estimation._genomes, estimation._fitness = state["genomes"], state["fitness"]
        estimation._round = dict(state["round"])
        return estimation
