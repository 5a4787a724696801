"""Estimation phase of the EEA: evolve models that explain the experiments (paper 3.2-3.4).

A :class:`~eea.ga.BitGA` over 45-bit model genomes (population 25, 100 generations per
round in the paper); a model's fitness is MOD_FIT (eq. 3), its mean similarity (eq. 2) to
the target over all recorded experiments, simulated from the initial angles the inference
strategy chooses for each (model, experiment). One GA lives for the whole run: each round
continues from the population the previous round ended with (the models carry over), and
the final hypothesis of a round is the fittest model of its last generation.

``EEAConfig.estimation_search = "cma"`` replaces the GA by CMA-ES over the nine dimensions
(:class:`~eea.cma_search.CMAModelSearch`, same ask/tell interface; not the paper's). Its
distribution is restarted at the best model at the start of every round, since a new
experiment changes the fitness landscape it had converged on.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from eea.cma_search import CMAModelSearch
from eea.encoding import MODEL_BITS
from eea.experiment import Experiment
from eea.ga import BitGA
from eea.inference import InferenceStrategy

__all__ = ["Estimation", "distinct_ranked"]


def distinct_ranked(genomes: np.ndarray, fitness: np.ndarray | None) -> np.ndarray:
    """Distinct rows of ``(P, n_bits)`` genomes, best first (ties and ``fitness=None``: row order).

    Returns:
        ``(R, n_bits)`` uint8, R <= P.
    """
    genomes = np.asarray(genomes, dtype=np.uint8)
    order = np.arange(len(genomes)) if fitness is None else np.argsort(-np.asarray(fitness), kind="stable")
    seen, rows = set(), []
    for i in order:
        key = genomes[i].tobytes()
        if key not in seen:
            seen.add(key)
            rows.append(i)
    return genomes[rows]


class Estimation:
    """The estimation phase: a model GA carried over rounds, evaluated through an Evaluator.

    Args:
        ga: a :class:`~eea.ga.BitGA` over ``MODEL_BITS`` = 45 bits, or a
            :class:`~eea.cma_search.CMAModelSearch` (any search with that ask/tell interface).

    Raises:
        ValueError: if the GA's genomes are not 45 bits long.
    """

    def __init__(self, ga: BitGA) -> None:
        if ga.n_bits != MODEL_BITS:
            raise ValueError(f"the estimation GA must evolve {MODEL_BITS}-bit model genomes, got {ga.n_bits} bits")
        self.ga = ga
        self._genomes: np.ndarray | None = None  # last evaluated generation (P, 45)
        self._fitness: np.ndarray | None = None  # and its fitness (P,)

    @classmethod
    def from_config(cls, config, rng: np.random.Generator) -> "Estimation":
        """A fresh random population sized and tuned by an :class:`eea.config.EEAConfig`."""
        if config.estimation_search == "cma":
            return cls(CMAModelSearch(config.estimation_population, rng, sigma0=config.cma_sigma,
                                      elitism=1 if config.elitism else 0))
        return cls(BitGA(MODEL_BITS, config.estimation_population, rng, crossover_rate=config.crossover_rate,
                         mutation_rate=config.mutation_bits / MODEL_BITS, tournament_size=config.tournament_size,
                         elitism=config.elitism))

    def run(self, experiments: Sequence[Experiment], strategy: InferenceStrategy, evaluator,
            rng: np.random.Generator, generations: int,
            on_generation: Callable[[int, float], None] | None = None) -> tuple[np.ndarray, float]:
        """Evolve the models for ``generations`` generations against all experiments.

        Per generation: ``strategy.before_generation``; the population's initial angles
        ``strategy.angles`` ``(P, E, 3)``; one :meth:`Evaluator.similarities` call
        ``(P, E)``; fitness = its mean over E (MOD_FIT, eq. 3); ``strategy.after_generation``;
        ``ga.tell``. ``strategy.begin_round``/``end_round`` bracket the phase.

        Args:
            experiments: the E >= 1 recorded experiments, newest last.
            strategy: the context inference strategy.
            evaluator: an :class:`eea.evaluation.Evaluator`.
            rng: the run's generator (PERFORM()'s draws).
            generations: number of generations, >= 1.
            on_generation: called with (generation, best fitness so far) after each one.

        Returns:
            ``(best_genome (45,) uint8, best_fitness)``: the fittest model of the last
            generation and its MOD_FIT.

        Raises:
            ValueError: if there are no experiments or ``generations < 1``.
        """
        if not experiments:
            raise ValueError("estimation needs at least one experiment")
        if generations < 1:
            raise ValueError(f"generations must be >= 1, got {generations}")
        strategy.begin_round(experiments)
        if hasattr(self.ga, "restart"):  # CMA-ES re-opens its converged distribution
            self.ga.restart()
        for generation in range(generations):
            strategy.before_generation(generation, self.ranked_models(), experiments, evaluator, rng)
            genomes = self.ga.ask()
            angles = strategy.angles(experiments, len(genomes), rng)
            fitness = evaluator.similarities(genomes, experiments, angles).mean(axis=1)
            strategy.after_generation(genomes, angles, fitness, experiments)
            self.ga.tell(fitness)
            self._genomes, self._fitness = genomes, fitness
            if on_generation is not None:
                on_generation(generation, self.ga.best_fitness)
        strategy.end_round(experiments)
        return self.ga.best_genome, self.ga.best_fitness

    def ranked_models(self, limit: int | None = None) -> np.ndarray:
        """Distinct models of the last evaluated generation, best first, at most ``limit``.

        Before any evaluation: the distinct genomes of the initial population, in order.

        Returns:
            ``(R, 45)`` uint8.
        """
        if self._genomes is None:
            ranked = distinct_ranked(self.ga.ask(), None)
        else:
            ranked = distinct_ranked(self._genomes, self._fitness)
        return ranked if limit is None else ranked[:limit]

    def state_dict(self) -> dict:
        """GA state and the last evaluated generation, for the run checkpoint."""
        return {"ga": self.ga.state_dict(), "genomes": self._genomes, "fitness": self._fitness}

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator) -> "Estimation":
        """Rebuild from :meth:`state_dict`, drawing from ``rng`` from now on."""
        search = CMAModelSearch if state["ga"].get("search") == "cma" else BitGA
        estimation = cls(search.from_state_dict(state["ga"], rng))
        estimation._genomes, estimation._fitness = state["genomes"], state["fitness"]
        return estimation
