"""Context inference: which initial flipper angles the models start from (paper 3.3, 3.4, 4).

The target's initial angles are unknown (its servos have no position feedback). A
strategy decides, for every (model, experiment) simulation of the estimation phase, the
initial angles, and may refine each experiment's :class:`~eea.experiment.Context`. All
strategies share one interface, :class:`InferenceStrategy`, and are chosen by name from
:data:`INFERENCE_STRATEGIES` with :func:`make_inference`; each has a settings class
(:data:`INFERENCE_SETTINGS`), ``config.inference`` of a config that runs it:

==============  ======  =============================================================
name            paper   initial angles of the models
==============  ======  =============================================================
``known``       4.1     the target's true angles (an oracle; the ideal baseline)
``none``        4.2     the zero state: pectorals arms-back (0), caudal 0
``in_band``     3.3     PERFORM(): with probability = confidence from the stored ranges,
                        else random; after every estimation generation the angles of
                        the K best models give the newest experiment's smallest inclusive
                        arc per flipper; confidence 0.5 during its round, 1.0 after
``out_of_band`` 3.4     every ``period`` generations (0, 35, 70) an inner GA over the
                        newest experiment's angles, scored by the mean similarity of a
                        sample of the best models to the target; confidence 1.0 at once
``profile``     --      not the paper's: every model keeps its own best angles per
                        experiment, searched for it each generation (:mod:`eea.inference.profile`)
==============  ======  =============================================================

The hooks a strategy implements and their order are in :mod:`eea.inference.strategy`; the
paper's four strategies are in :mod:`eea.inference.paper`, ``profile`` in :mod:`eea.inference.profile`.
"""

from __future__ import annotations

from eea.inference.paper import (InBand, InBandSettings, Known, KnownSettings, NoInference, NoneSettings, OutOfBand,
                                 OutOfBandSettings)
from eea.inference.profile import Profile, ProfileSettings
from eea.inference.strategy import InferenceStrategy

__all__ = ["INFERENCE_NAMES", "INFERENCE_SETTINGS", "INFERENCE_STRATEGIES", "InferenceSettings", "make_inference"]

#: Registry of strategies by name (``config.inference.name``, the flag ``--inference``).
INFERENCE_STRATEGIES: dict[str, type[InferenceStrategy]] = {
    cls.name: cls for cls in (Known, NoInference, InBand, OutOfBand, Profile)
}
INFERENCE_NAMES: tuple[str, ...] = tuple(INFERENCE_STRATEGIES)
#: The settings class of every strategy by name (``config.inference`` is one of them).
INFERENCE_SETTINGS: dict[str, type] = {
    cls.name: cls for cls in (KnownSettings, NoneSettings, InBandSettings, OutOfBandSettings, ProfileSettings)
}
#: The type of ``config.inference``: one strategy's settings.
InferenceSettings = KnownSettings | NoneSettings | InBandSettings | OutOfBandSettings | ProfileSettings


def make_inference(settings, ga=None) -> InferenceStrategy:
    """Build a strategy from its settings, or the strategy called ``settings`` with its defaults.

    Args:
        settings: a strategy's settings (one of :data:`INFERENCE_SETTINGS`, e.g. ``config.inference``),
            or a name of :data:`INFERENCE_NAMES`.
        ga: the run's :class:`eea.ga.GASettings` (``config.ga``; the out-of-band inner GA's; None:
            the defaults).

    Raises:
        ValueError: on an unknown name; the message lists the valid names.
    """
    name = settings if isinstance(settings, str) else getattr(settings, "name", None)
    try:
        cls = INFERENCE_STRATEGIES[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown inference {name!r}; valid names: {', '.join(INFERENCE_NAMES)}") from None
    if isinstance(settings, str):
        settings = INFERENCE_SETTINGS[name]()
    return cls.from_settings(settings, ga)
