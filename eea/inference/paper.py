"""The paper's context inference strategies (paper 3.3, 3.4, 4).

:class:`Known` (4.1), :class:`NoInference` (4.2), :class:`InBand` (3.3) and :class:`OutOfBand`
(3.4), all implementing :class:`~eea.inference.strategy.InferenceStrategy`. They are chosen by
name from :data:`eea.inference.INFERENCE_STRATEGIES` (:mod:`eea.inference.registry`, where
the table of all strategies is).

Settings: :class:`KnownSettings`, :class:`NoneSettings`, :class:`InBandSettings` and
:class:`OutOfBandSettings`, each ``config.inference`` of an :class:`eea.config.EEAConfig` that
runs the strategy (its ``name``); the inner GA of out-of-band breeds with the run's shared
:class:`eea.ga.GASettings` (``config.ga``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import ClassVar, Sequence

import numpy as np

from aquafish_gym.checks import check_int

from eea.arc import TWO_PI, smallest_inclusive_arc, smallest_inclusive_interval, widen_arc
from eea.encoding import decode_fields, encode_fields
from eea.ga import BitGA, GASettings
from eea.experiment import CAUDAL_LIMIT_RAD, PERIODS, Context, Experiment, with_newest_context
from eea.inference.strategy import InferenceStrategy

__all__ = ["InBand", "InBandSettings", "Known", "KnownSettings", "NoInference", "NoneSettings",
           "OutOfBand", "OutOfBandSettings"]


@dataclasses.dataclass(frozen=True)
class KnownSettings:
    """The ideal baseline's settings (``config.inference`` with ``inference="known"``;
    :class:`Known`): none."""

    #: The strategy's registry name (:data:`eea.inference.INFERENCE_STRATEGIES`).
    name: ClassVar[str] = "known"


@dataclasses.dataclass(frozen=True)
class NoneSettings:
    """The no-inference baseline's settings (``config.inference`` with ``inference="none"``;
    :class:`NoInference`): none."""

    #: The strategy's registry name (:data:`eea.inference.INFERENCE_STRATEGIES`).
    name: ClassVar[str] = "none"


@dataclasses.dataclass(frozen=True)
class InBandSettings:
    """In-band inference's settings (``config.inference`` with ``inference="in_band"``;
    :class:`InBand`).

    Args:
        k_best: models whose angles define the inferred arc, >= 1 (paper: K = 3;
            ``EEAConfig`` caps it at ``estimation_population``).
        confidence: confidence of the newest experiment during its round, in [0, 1] (paper: 0.5).
        widen: widen the arc by this fraction of its width on each side, >= 0 (0 = off).

    Raises:
        ValueError: naming the field as ``EEAConfig.<field>`` (``k_best``, ``in_band_confidence``,
            ``in_band_widen``) if one is out of range.
    """

    #: The strategy's registry name (:data:`eea.inference.INFERENCE_STRATEGIES`).
    name: ClassVar[str] = "in_band"

    k_best: int = 3
    confidence: float = 0.5
    widen: float = 0.0

    def __post_init__(self) -> None:
        check_int("EEAConfig.k_best", self.k_best, 1)
        value = self.confidence
        if not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:  # NaN fails
            raise ValueError(f"EEAConfig.in_band_confidence must be in [0, 1], got {value!r}")
        object.__setattr__(self, "confidence", float(value))
        value = self.widen
        if not isinstance(value, (int, float)) or not 0.0 <= value <= math.inf:
            raise ValueError(f"EEAConfig.in_band_widen must be in [0, {math.inf}], got {value!r}")
        object.__setattr__(self, "widen", float(value))


@dataclasses.dataclass(frozen=True)
class OutOfBandSettings:
    """Out-of-band inference's settings (``config.inference`` with ``inference="out_of_band"``,
    the flags ``--oob-*``; :class:`OutOfBand`).

    Args:
        period: infer angles every this many estimation generations, >= 1 (paper: 35).
        sample: best distinct models that score candidate angles, >= 1 (paper: 5;
            ``EEAConfig`` caps it at ``estimation_population``).
        population: candidate angle sets per inner GA generation, >= 1.
        generations: inner GA generations per inference, >= 1.
        bits: bits per angle of the inner GA's genome, in [2, 30].

    Raises:
        ValueError: naming the field as ``EEAConfig.oob_<field>`` if one is out of range.
    """

    #: The strategy's registry name (:data:`eea.inference.INFERENCE_STRATEGIES`).
    name: ClassVar[str] = "out_of_band"

    period: int = 35
    sample: int = 5
    population: int = 10
    generations: int = 10
    bits: int = 8

    def __post_init__(self) -> None:
        for name, low in (("period", 1), ("sample", 1), ("population", 1), ("generations", 1), ("bits", 2)):
            check_int(f"EEAConfig.oob_{name}", getattr(self, name), low, 30 if name == "bits" else None)


class Known(InferenceStrategy):
    """Ideal baseline (paper 4.1): models start from the target's true angles."""

    name = "known"

    def new_context(self, true_angles):
        return Context.exact(true_angles)


class NoInference(InferenceStrategy):
    """No-inference baseline (paper 4.2): models start from the zero state."""

    name = "none"

    def new_context(self, true_angles):
        return Context.exact(np.zeros(3))


class InBand(InferenceStrategy):
    """In-Band inference (paper 3.3): angles inferred inside the estimation GA.

    The newest experiment starts with every angle possible and confidence
    ``confidence`` (0.5: half the models start from the stored ranges, half from random
    angles). After every generation the ``k_best`` fittest models' angles for it give the
    smallest inclusive arc per pectoral flipper (may wrap through 0) and the smallest
    interval for the caudal fin, optionally widened by ``widen`` of the width on each side
    (paper 4.3 tried 0.2). At the end of the round the confidence is locked at 1.0.

    Raises:
        ValueError: if ``k_best < 1``, ``confidence`` is outside [0, 1] or ``widen < 0``.
    """

    name = "in_band"

    def __init__(self, k_best: int = 3, confidence: float = 0.5, widen: float = 0.0) -> None:
        if k_best < 1 or not 0.0 <= confidence <= 1.0 or not widen >= 0.0:
            raise ValueError(f"InBand needs k_best >= 1, confidence in [0, 1], widen >= 0; "
                             f"got {k_best}, {confidence}, {widen}")
        self.k_best, self.confidence, self.widen = int(k_best), float(confidence), float(widen)

    @classmethod
    def from_settings(cls, settings: InBandSettings, ga=None) -> "InBand":
        """Built from its :class:`InBandSettings` (``config.inference``).

        Args:
            settings: the strategy's settings.
            ga: unused (in-band inference has no GA of its own).
        """
        return cls(settings.k_best, settings.confidence, settings.widen)

    def new_context(self, true_angles):
        return Context.unknown(self.confidence)

    def begin_round(self, experiments):
        return with_newest_context(experiments, experiments[-1].context.with_confidence(self.confidence))

    def after_generation(self, genomes, angles, fitness, experiments):
        best = np.argsort(-np.asarray(fitness), kind="stable")[: self.k_best]
        return with_newest_context(experiments,
                                   self.infer_context(angles[best, -1, :], experiments[-1].context.confidence))

    def infer_context(self, best_angles: np.ndarray, confidence: float) -> Context:
        """Context holding ``(K, 3)`` angles: smallestInclusive() per flipper (paper 3.3)."""
        starts, widths = [], []
        for column, period in zip(np.asarray(best_angles).T, PERIODS):
            if period is None:
                start, width = smallest_inclusive_interval(column)
            else:
                start, width = smallest_inclusive_arc(column, period)
            if self.widen > 0:
                start, width = widen_arc(start, width, self.widen, period)
            if period is None:  # intersect with the caudal sweep
                end = min(start + width, CAUDAL_LIMIT_RAD)
                start = max(start, -CAUDAL_LIMIT_RAD)
                width = max(end - start, 0.0)
            starts.append(start)
            widths.append(width)
        return Context(tuple(starts), tuple(widths), confidence)

    def end_round(self, experiments):
        return with_newest_context(experiments, experiments[-1].context.with_confidence(1.0))


class OutOfBand(InferenceStrategy):
    """Out-of-Band inference (paper 3.4): a separate GA over the newest experiment's angles.

    Before estimation generations 0, ``period``, 2 ``period``, ... an inner
    :class:`~eea.ga.BitGA` (``population`` x ``generations``) evolves the newest
    experiment's three initial angles, encoded with ``bits`` bits each (pectorals on
    [0, 2 pi) in steps of 2 pi / 2**bits, caudal on the sweep). A candidate's fitness is
    the mean similarity (eq. 2) to the target's response of the ``sample`` best distinct
    models when started from it; every candidate generation is one batched
    evaluation.
    From the second inference of a round on, the current angles seed the inner GA, so an
    inference never forgets a better earlier answer for the same models. The context is
    set to the best angles with confidence 1.0 (all models use them).

    Raises:
        ValueError: if any count is < 1 (``bits`` < 2).
    """

    name = "out_of_band"

    def __init__(self, period: int = 35, sample: int = 5, population: int = 10, generations: int = 10,
                 bits: int = 8, ga_options: dict | None = None) -> None:
        if min(period, sample, population, generations) < 1 or bits < 2:
            raise ValueError(f"OutOfBand needs period, sample, population, generations >= 1 and bits >= 2; "
                             f"got {period}, {sample}, {population}, {generations}, {bits}")
        self.period, self.sample, self.population = int(period), int(sample), int(population)
        self.generations, self.bits = int(generations), int(bits)
        self.ga_options = dict(ga_options or {})
        step = TWO_PI / 2 ** self.bits
        self.field_bits = (self.bits,) * 3
        self.bounds = np.array([[0.0, TWO_PI - step], [0.0, TWO_PI - step], [-CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD]])

    @classmethod
    def from_settings(cls, settings: OutOfBandSettings, ga: GASettings | None = None) -> "OutOfBand":
        """Built from its :class:`OutOfBandSettings` (``config.inference``) and the run's GA
        settings (``config.ga``; mutation ``mutation_bits / (3 * bits)``).

        Args:
            settings: the strategy's settings.
            ga: the run's :class:`eea.ga.GASettings` (None: the defaults).
        """
        ga = GASettings() if ga is None else ga
        return cls(settings.period, settings.sample, settings.population, settings.generations, settings.bits,
                   ga.options(3 * settings.bits))

    def new_context(self, true_angles):
        return Context.exact(np.zeros(3))  # replaced by the first inference (generation 0)

    def begin_round(self, experiments):
        return with_newest_context(experiments, experiments[-1].context.with_confidence(1.0))

    def before_generation(self, generation, ranked_genomes, experiments, evaluator, rng, genomes=None):
        if generation % self.period:
            return experiments
        experiments = tuple(experiments)
        best = self.infer_angles(ranked_genomes[: self.sample], experiments[-1:], evaluator, rng,
                                 seed_current=generation > 0)  # the newest experiment: fresh at generation 0
        return experiments[:-1] + (experiments[-1].with_context(Context.exact(best[0])),)

    def _current_genome(self, experiment: Experiment) -> np.ndarray:
        """``(1, 3 * bits)`` genome of the experiment's current angles (nearest levels)."""
        current = experiment.context.estimate()
        step = TWO_PI / 2 ** self.bits  # nearest pectoral level on the circle (2 pi - eps -> 0)
        current[:2] = np.mod(np.rint(current[:2] / step), 2 ** self.bits) * step
        current = np.clip(current, self.bounds[:, 0], self.bounds[:, 1])
        return encode_fields(current, self.field_bits, self.bounds)[None]

    def infer_angles(self, models: np.ndarray, experiments: Sequence[Experiment], evaluator,
                     rng: np.random.Generator, seed_current: bool = False) -> np.ndarray:
        """The paper's optAng(): the best initial angles of each experiment for the models.

        One inner GA per experiment, run in lockstep: inner generation g evaluates every
        GA's candidates in one :meth:`Evaluator.similarities` call, candidate q of every GA
        sharing the rows of candidate q (each experiment's similarity depends only on its
        own angles).

        Args:
            models: ``(S, 45)`` model genomes that score the candidates (mean similarity).
            experiments: the E experiments whose angles are inferred.
            evaluator: an :class:`eea.evaluation.Evaluator`.
            rng: draws every inner GA's randomness.
            seed_current: whether the experiments' current angles join the inner GAs' first
                populations.

        Returns:
            ``(E, 3)`` radians (pectorals in [0, 2 pi), caudal in the sweep).
        """
        gas = [BitGA(3 * self.bits, self.population, rng, initial=self._current_genome(e) if seed_current else None,
                     **self.ga_options) for e in experiments]
        s, e = len(models), len(experiments)
        for _ in range(self.generations):
            candidates = np.stack([decode_fields(ga.ask(), self.field_bits, self.bounds) for ga in gas], axis=1)
            angles = np.repeat(candidates, s, axis=0)                                   # (Q*S, E, 3)
            sims = evaluator.similarities(np.tile(models, (len(candidates), 1)), experiments, angles)
            scores = sims.reshape(len(candidates), s, e).mean(axis=1)                    # (Q, E)
            for j, ga in enumerate(gas):
                ga.tell(scores[:, j])
        return np.stack([decode_fields(ga.best_genome, self.field_bits, self.bounds) for ga in gas])
