"""Context inference (:mod:`eea.inference`): which initial flipper angles the models start from.

The target's initial angles are unknown (its servos have no position feedback). A strategy
decides, for every (model, experiment) simulation of the estimation phase, the initial angles,
and may refine each experiment's :class:`~eea.experiment.Context` (paper 3.3, 3.4, 4):

* :mod:`eea.inference.strategy` -- :class:`InferenceStrategy`, the interface (hooks, their order).
* :mod:`eea.inference.paper` -- the paper's strategies: :class:`Known`, :class:`NoInference`,
  :class:`InBand`, :class:`OutOfBand`, and their settings (:class:`KnownSettings`,
  :class:`NoneSettings`, :class:`InBandSettings`, :class:`OutOfBandSettings`: ``config.inference``
  of an :class:`eea.config.EEAConfig` that runs the strategy).
* :mod:`eea.inference.profile` -- :class:`Profile`, per-model angles (not the paper's), and its
  angle fit (random perturbations, per-flipper scan, compass polish; every trial also feeds
  the strategy's angle library, so the fit stays a method of the strategy), and its settings
  :class:`ProfileSettings` (``config.inference`` of a profile run).
* :mod:`eea.inference.registry` -- the strategies by name: :data:`INFERENCE_STRATEGIES`,
  :data:`INFERENCE_NAMES`, :data:`INFERENCE_SETTINGS`, :func:`make_inference` (``config.inference``;
  the table of all strategies is there).
* :mod:`eea.inference.selection` -- :func:`~eea.inference.selection.select_model`, the equal
  angle fit that picks one model among candidates (the round's selection of
  :mod:`eea.search.lineages`); not imported here.

This package imports only the core (never :mod:`eea.search`).
"""

from eea.inference.paper import (InBand, InBandSettings, Known, KnownSettings, NoInference, NoneSettings, OutOfBand,
                                 OutOfBandSettings)
from eea.inference.profile import Profile, ProfileSettings
from eea.inference.registry import (INFERENCE_NAMES, INFERENCE_SETTINGS, INFERENCE_STRATEGIES, InferenceSettings,
                                    make_inference)
from eea.inference.strategy import Experiments, InferenceStrategy

__all__ = ["Experiments", "INFERENCE_NAMES", "INFERENCE_SETTINGS", "INFERENCE_STRATEGIES", "InBand", "InBandSettings",
           "InferenceSettings", "InferenceStrategy", "Known", "KnownSettings", "NoInference", "NoneSettings", "OutOfBand",
           "OutOfBandSettings", "Profile", "ProfileSettings", "make_inference"]
