"""The estimation phase's model searches (:mod:`eea.search`).

The core's :class:`eea.estimation.Estimation` evolves model genomes through any object that
satisfies :class:`ModelSearch`, made by name from :data:`MODEL_SEARCHES`
(``config.estimation.search``). This package is their home:

* :mod:`eea.search.registry` -- the :class:`ModelSearch` protocol, :func:`check_model_search`
  and the registry (:data:`MODEL_SEARCHES`, :func:`make_model_search`,
  :func:`model_search_from_state`).
* :mod:`eea.search.model_ga` -- :class:`ModelGA`, the paper's GA (section 4) over model genomes
  (a :class:`eea.ga.BitGA`, which stays in the core: exploration and out-of-band inference use it),
  and its settings :class:`GASearchSettings` (none of its own).
* :mod:`eea.search.cma` -- :class:`CMAModelSearch`, CMA-ES over the nine dimensions (not the paper's),
  and its settings :class:`CMASettings` (``config.estimation.search`` of an
  :class:`eea.config.EEAConfig` with ``estimation_search="cma"``).
* :mod:`eea.search.hypotheses` -- :class:`HypothesisSearch`, no search at all: the design's fault
  hypotheses offered every generation and ranked by the inference strategy's fits (not the
  paper's; in measurement), and its settings :class:`HypothesisSettings` (none of its own).
* :mod:`eea.search.lineages` -- several independent estimations sharing each round's experiment,
  one selected per round by an equal angle fit (``lineages`` >= 2; not the paper's). It builds on
  the core's estimation phase and on :mod:`eea.inference` (each lineage has its own strategy;
  the selection is :func:`eea.inference.selection.select_model`), so it is not imported here:
  import it as :mod:`eea.search.lineages` (the core's :mod:`eea.estimation` imports this package,
  and importing the lineages here would import the estimation back).

This package imports only the core (and :mod:`eea.checkpoint`'s unpickler, for the CMA
search's nested pickle; the hypothesis search the hypotheses of :mod:`eea.inference.selection`);
the lineages also import :mod:`eea.inference` and :mod:`eea.record`.
"""

from eea.search.cma import CMAModelSearch, CMASettings
from eea.search.hypotheses import HypothesisSearch, HypothesisSettings
from eea.search.model_ga import GASearchSettings, ModelGA
from eea.search.registry import (MODEL_SEARCHES, SEARCH_NAMES, SEARCH_SETTINGS, ModelSearch, SearchSettings,
                                 check_model_search, make_model_search, model_search_from_state)

__all__ = ["CMAModelSearch", "CMASettings", "GASearchSettings", "HypothesisSearch", "HypothesisSettings",
           "MODEL_SEARCHES", "ModelGA", "ModelSearch",
           "SEARCH_NAMES", "SEARCH_SETTINGS", "SearchSettings", "check_model_search", "make_model_search", "model_search_from_state"]
