"""Model searches of the estimation phase: one ask/tell interface, chosen by name.

The estimation phase (:class:`eea.estimation.Estimation`) evolves model genomes (45 bits in
the paper's ``morphology`` model space, 57 in ``morphology+servos``: :class:`eea.encoding.ModelSpace`)
through any object that satisfies :class:`ModelSearch`; :data:`MODEL_SEARCHES` maps the
names ``--estimation-search`` accepts (``config.estimation.search.name``) to the classes, and
:data:`SEARCH_SETTINGS` maps them to their settings classes:

=======  ==========================================  =======================================
name     class                                       search
=======  ==========================================  =======================================
``ga``   :class:`~eea.search.model_ga.ModelGA`       the paper's bit-string GA (section 4)
``cma``  :class:`~eea.search.cma.CMAModelSearch`     CMA-ES over the nine dimensions (and
                                                     the three gains; not the paper's)
``hypotheses`` :class:`~eea.search.hypotheses.HypothesisSearch`  no search: the design's fault
                                                     hypotheses, ranked (not the paper's; in
                                                     measurement)
=======  ==========================================  =======================================

Misuse raises :class:`RuntimeError` naming it, as in pyribs: ``tell`` without a pending
``ask``, ``ask`` twice without ``tell``, ``best_genome`` before the first ``tell``.
"""

from __future__ import annotations

from typing import ClassVar, Protocol

import numpy as np

from eea.search.cma import CMAModelSearch, CMASettings
from eea.search.hypotheses import HypothesisSearch, HypothesisSettings
from eea.search.model_ga import GASearchSettings, ModelGA

__all__ = ["MODEL_SEARCHES", "SEARCH_NAMES", "SEARCH_SETTINGS", "ModelGA", "ModelSearch", "SearchSettings",
           "check_model_search", "make_model_search", "model_search_from_state"]


class ModelSearch(Protocol):
    """What the estimation phase needs of a model search (maximises fitness).

    Attributes:
        name: the registry name (``config.estimation.search.name``).
        n_bits: genome length, 45 (57 in the ``morphology+servos`` model space).
        population_size: P, genomes per generation.
    """

    name: ClassVar[str]
    n_bits: int
    population_size: int

    @property
    def population(self) -> np.ndarray:
        """``(P, 45)`` uint8: the population the next (or pending) ``ask`` returns."""

    def ask(self) -> np.ndarray:
        """``(P, 45)`` uint8 genomes to evaluate. Raises RuntimeError if asked twice."""

    def tell(self, fitness) -> None:
        """``(P,)`` fitness of the last asked genomes. Raises RuntimeError without an ask."""

    @property
    def best_genome(self) -> np.ndarray:
        """``(45,)`` uint8 fittest genome of the last told generation."""

    @property
    def best_fitness(self) -> float:
        """Its fitness."""

    def restart(self) -> None:
        """Called at the start of every round (a new experiment changes the landscape)."""

    def state_dict(self) -> dict:
        """Everything needed to resume, with ``"search": name``."""


#: What :func:`check_model_search` looks for on a search's class.
_MEMBERS = ("name", "n_bits", "population_size", "population", "ask", "tell", "best_genome", "best_fitness",
            "restart", "state_dict", "from_state_dict", "from_settings")


def check_model_search(search) -> None:
    """Check that ``search`` has every member of :class:`ModelSearch` (looked up on its class,
    so no property is evaluated).

    Raises:
        ValueError: naming the missing members.
    """
    missing = [m for m in _MEMBERS if not hasattr(type(search), m) and not hasattr(search, m)]
    if missing:
        raise ValueError(f"{type(search).__name__} is not a ModelSearch: it lacks {', '.join(missing)}")


#: Registry of model searches by name (``config.estimation.search.name``).
MODEL_SEARCHES: dict[str, type] = {cls.name: cls for cls in (ModelGA, CMAModelSearch, HypothesisSearch)}
SEARCH_NAMES: tuple[str, ...] = tuple(MODEL_SEARCHES)
#: The settings class of every search by name (``config.estimation.search`` is one of them).
SEARCH_SETTINGS: dict[str, type] = {cls.name: cls for cls in (GASearchSettings, CMASettings, HypothesisSettings)}
#: The type of ``config.estimation.search``: one search's settings.
SearchSettings = GASearchSettings | CMASettings | HypothesisSettings


def _search_class(name) -> type:
    try:
        return MODEL_SEARCHES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown estimation search {name!r}; valid names: {', '.join(SEARCH_NAMES)}") from None


def make_model_search(estimation, ga, model_space, rng: np.random.Generator) -> ModelSearch:
    """A fresh search of the kind ``estimation.search`` names, sized and tuned by its settings.

    Args:
        estimation: an :class:`eea.estimation.EstimationSettings` (``config.estimation``): the
            population and the search's settings (:data:`SEARCH_SETTINGS`).
        ga: the run's :class:`eea.ga.GASettings` (``config.ga``).
        model_space: the run's model space (a name or an :class:`eea.encoding.ModelSpace`).
        rng: the run's generator (the initial population).

    Raises:
        ValueError: on an unknown search name (the message lists the valid names).
    """
    return _search_class(getattr(estimation.search, "name", None)).from_settings(estimation, ga, model_space, rng)


def model_search_from_state(state: dict, rng: np.random.Generator) -> ModelSearch:
    """Rebuild a search from its ``state_dict`` (a state without ``"search"`` is the GA's).

    Raises:
        ValueError: on an unknown search name or an invalid state.
    """
    return _search_class(state.get("search", ModelGA.name)).from_state_dict(state, rng)
