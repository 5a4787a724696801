"""Estimation over fault hypotheses about the design: :class:`HypothesisSearch` (not the paper's; in measurement).

A robot knows the morphology it was built to. The check that ends a ``morphology+servos`` run
(:mod:`eea.fault_check`) fits the initial angles of fault hypotheses about that design and keeps
the best, and on the missions and case studies measured so far it replaced the search's own
model every time (docs/main_job.md): the search's generations mostly serve the exploration,
whose actions are chosen where the search's models disagree. This search (``--estimation-search
hypotheses``) evolves nothing: every generation it offers the same candidates, the design's
fault hypotheses (:func:`eea.inference.selection.fault_hypotheses` at the healthy morphology),
and the inference strategy fits their angles to every experiment (the ``profile`` strategy
keeps each candidate's best angles, so a generation refines them). The estimation phase ranks
them by MOD_FIT (eq. 3), and the exploration's candidate models are the best of them: the
next experiment is chosen where the likeliest hypotheses disagree (eq. 1 over them), which is
what the check has to decide between.

Population: the 97 hypotheses (duplicates on the model grid removed), the healthy design
first, then each one farthest (:func:`eea.diversity.model_distance`) from those before it, so
the first round's exploration, before any ranking, sees the most different hypotheses
(``population_size`` follows from the hypotheses; ``config.estimation.population`` is not
used). ``restart`` does nothing; ``best_genome`` is the best of the last generation told.

Settings: :class:`HypothesisSettings` (none of its own), ``config.estimation.search`` of an
:class:`eea.config.EEAConfig` with ``estimation_search="hypotheses"``, which needs
``model_space="morphology+servos"``.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from aquafish_gym import Morphology
from eea.diversity import model_distance
from eea.encoding import get_model_space
from eea.ga import TellRecord
from eea.inference.selection import fault_hypotheses

__all__ = ["HYPOTHESIS_SPACE", "HypothesisSearch", "HypothesisSettings", "hypothesis_genomes"]

#: The model space the hypotheses live in (they hold servo gains).
HYPOTHESIS_SPACE = "morphology+servos"


@dataclasses.dataclass(frozen=True)
class HypothesisSettings:
    """The hypothesis search's settings (``config.estimation.search`` of an ``EEAConfig`` with
    ``estimation_search="hypotheses"``): none of its own."""

    #: The search's registry name (:data:`eea.search.MODEL_SEARCHES`).
    name: ClassVar[str] = "hypotheses"


def hypothesis_genomes(design=None) -> np.ndarray:
    """The search's population: the distinct genomes of the fault hypotheses about ``design``.

    Args:
        design: ``(9,)`` the design morphology (simulator units); None: the healthy robot's.

    Returns:
        ``(H, 57)`` uint8 ``morphology+servos`` genomes, H <= 97: the healthy design (all gains 1)
        first, then greedily the hypothesis farthest from every one before it (the largest
        least :func:`eea.diversity.model_distance`; ties: the hypotheses' order).

    Raises:
        ValueError: as :func:`eea.inference.selection.fault_hypotheses` raises.
    """
    design = Morphology.healthy().to_array() if design is None else np.asarray(design, dtype=np.float64)
    space = get_model_space(HYPOTHESIS_SPACE)
    genomes = space.encode(fault_hypotheses(design))
    _, first = np.unique(genomes, axis=0, return_index=True)
    genomes = genomes[np.sort(first)]
    healthy = space.encode(np.r_[design, 1.0, 1.0, 1.0][None])[0]
    start = int(np.flatnonzero((genomes == healthy).all(axis=1))[0])
    order, least = [start], model_distance(genomes, genomes[start])
    least[start] = -1.0
    for _ in range(len(genomes) - 1):
        row = int(np.argmax(least))
        order.append(row)
        least = np.minimum(least, model_distance(genomes, genomes[row]))
        least[order] = -1.0
    return genomes[order]


class HypothesisSearch(TellRecord):
    """Offers the same fault hypotheses every generation (module docstring); ``best_genome``,
    ``best_fitness`` and ``generation`` are :class:`eea.ga.TellRecord`'s.

    Args:
        genomes: ``(H, 57)`` the hypotheses' genomes, H >= 2 (default: :func:`hypothesis_genomes`).

    Raises:
        ValueError: genomes that are not ``(H >= 2, 57)`` bits.
    """

    name: ClassVar[str] = "hypotheses"

    def __init__(self, genomes=None) -> None:
        space = get_model_space(HYPOTHESIS_SPACE)
        genomes = hypothesis_genomes() if genomes is None else np.asarray(genomes)
        if genomes.ndim != 2 or genomes.shape[1] != space.n_bits or len(genomes) < 2 \
                or not np.isin(genomes, (0, 1)).all():
            raise ValueError(f"the hypotheses must be (H >= 2, {space.n_bits}) bits, got shape {genomes.shape}")
        self.model_space = space
        self.n_bits = space.n_bits
        self._population = genomes.astype(np.uint8)
        self.population_size = len(self._population)
        self._generation, self._best_genome, self._best_fitness, self._asked = 0, None, -np.inf, False

    @classmethod
    def from_settings(cls, estimation, ga, model_space, rng: np.random.Generator) -> "HypothesisSearch":
        """The hypotheses about the healthy design (``estimation``'s population, ``ga`` and ``rng``
        are not used: nothing is drawn or bred).

        Raises:
            ValueError: if ``estimation.search`` is not a :class:`HypothesisSettings`, or the model
                space is not ``morphology+servos``.
        """
        if not isinstance(estimation.search, HypothesisSettings):
            raise ValueError(f"a hypothesis search needs HypothesisSettings, got {estimation.search!r}")
        if get_model_space(model_space).name != HYPOTHESIS_SPACE:
            raise ValueError(f"estimation_search='hypotheses' needs model_space={HYPOTHESIS_SPACE!r} (the hypotheses "
                             f"hold servo gains), got {get_model_space(model_space).name!r}")
        return cls()

    @property
    def population(self) -> np.ndarray:
        """``(H, 57)`` uint8: the hypotheses, as every ``ask`` returns them."""
        return self._population.copy()

    def ask(self) -> np.ndarray:
        """The hypotheses, to be evaluated.

        Raises:
            RuntimeError: if they were asked and not told (ask twice).
        """
        self._start_ask()
        return self.population

    def tell(self, fitness) -> None:
        """Record the hypotheses' fitness (higher is better).

        Raises:
            RuntimeError: if ``ask`` was not called since the last ``tell``.
            ValueError: if ``fitness`` is not ``(H,)`` finite values.
        """
        self._check_tell()
        f = np.asarray(fitness, dtype=np.float64)
        if f.shape != (self.population_size,) or not np.all(np.isfinite(f)):
            raise ValueError(f"fitness must be ({self.population_size},) finite values, got shape {f.shape}")
        best = int(np.argmax(f))
        self._best_genome, self._best_fitness = self._population[best].copy(), float(f[best])
        self._asked = False
        self._generation += 1

    def restart(self) -> None:
        """Nothing to restart: the candidates are fixed."""

    def seed_at(self, genome) -> None:
        """A warm start (:func:`eea.search.lineages.warm_start`) at a known ``(57,)`` model: the
        hypotheses become those about its morphology as the design, the model itself first
        (the mission's self-model from before the damage; the healthy robot's gives the default
        hypotheses with it first).

        Raises:
            ValueError: a genome of another length, or one asked and not told.
        """
        genome = np.asarray(genome, dtype=np.uint8)
        if genome.shape != (self.n_bits,):
            raise ValueError(f"a warm start needs one ({self.n_bits},) genome, got shape {genome.shape}")
        if self._asked:
            raise RuntimeError("seed_at() between ask() and tell(): tell the pending generation first")
        design = self.model_space.decode(genome[None])[0][:9]
        rest = hypothesis_genomes(design)
        rest = rest[~(rest == genome).all(axis=1)]
        self._population = np.vstack([genome[None], rest])
        self.population_size = len(self._population)

    def state_dict(self) -> dict:
        """The hypotheses, the last best and the generation count, with ``"search": "hypotheses"``."""
        return {"search": self.name, "genomes": self._population.copy(), "generation": self._generation,
                "best_genome": None if self._best_genome is None else self._best_genome.copy(),
                "best_fitness": self._best_fitness}

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator | None = None) -> "HypothesisSearch":
        """Rebuild from :meth:`state_dict` (``rng`` is unused).

        Raises:
            ValueError: if ``state`` is not a hypothesis search's.
        """
        if state.get("search") != cls.name:
            raise ValueError("state is not a HypothesisSearch state_dict")
        search = cls(state["genomes"])
        search._generation = int(state["generation"])
        best = state["best_genome"]
        search._best_genome = None if best is None else np.asarray(best, dtype=np.uint8)
        search._best_fitness = float(state["best_fitness"])
        return search
