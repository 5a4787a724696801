"""The equal angle fit that picks one model among candidates (not the paper's).

Every candidate model gets its own initial angles fitted for every experiment, equally hard
for all (:meth:`eea.inference.profile.Profile.fit` from random starts, then
:meth:`~eea.inference.profile.Profile.scan_angles` and :meth:`~eea.inference.profile.Profile.polish_angles`), and
the one with the highest MOD_FIT (eq. 3) is chosen. No oracle is used. The round's selection
of ``--lineages`` (:mod:`eea.search.lineages`) uses it.
"""

from __future__ import annotations

import dataclasses
from typing import Sequence

import numpy as np

from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.experiment import Experiment, angle_errors_deg
from eea.fitness import model_fitness_from_similarities
from eea.inference.profile import Profile

__all__ = ["CAUDAL_FAULTS", "FAULT_GAIN_LEVELS", "FLIPPER_FAULT_SCALES", "Selection", "check_fault_hypotheses",
           "fault_hypotheses", "select_model"]

#: The pectoral servo gains of :func:`fault_hypotheses`: reversed, half reversed, dead, weak, healthy.
FAULT_GAIN_LEVELS: tuple[float, ...] = (-1.0, -0.5, 0.0, 0.5, 1.0)
#: The flipper faults of :func:`fault_hypotheses`: a pectoral flipper's length (``*_y``) times 0.5
#: (shortened; the sampled faults shorten it to 0.25-0.75), or all three of its dimensions times 0 (lost).
FLIPPER_FAULT_SCALES: tuple[tuple[str, tuple[float, float, float]], ...] = (("shortened", (1.0, 0.5, 1.0)),
                                                                          ("lost", (0.0, 0.0, 0.0)))
#: The caudal faults of :func:`fault_hypotheses`: (name, caudal gain, caudal fin dimensions' factors):
#: the servo dead or weak (the sampled faults' weak caudal gain is 0.2-0.8), the fin's length
#: (``caudal_y``) halved, or the fin lost.
CAUDAL_FAULTS: tuple[tuple[str, float, tuple[float, float, float]], ...] = (
    ("dead", 0.0, (1.0, 1.0, 1.0)), ("weak", 0.5, (1.0, 1.0, 1.0)),
    ("shortened", 1.0, (1.0, 0.5, 1.0)), ("lost", 1.0, (0.0, 0.0, 0.0)))


@dataclasses.dataclass(frozen=True)
class Selection:
    """The outcome of :func:`select_model`.

    Attributes:
        models: ``(N, 9)`` the candidate models (simulator units, ``MORPHOLOGY_FIELDS``; ``(N, 12)``
            with the servo gains in the ``morphology+servos`` model space).
        model_fitness: ``(N,)`` each model's MOD_FIT (eq. 3) on the pooled experiments under
            its own fitted angles.
        angles: ``(N, E, 3)`` those angles (rad), per model and experiment.
        index: the chosen model's row (the highest MOD_FIT; the first of equals).
    """

    models: np.ndarray
    model_fitness: np.ndarray
    angles: np.ndarray
    index: int

    @property
    def model(self) -> np.ndarray:
        """``(9,)`` (or ``(12,)``) the chosen model."""
        return self.models[self.index]

    def angle_errors_deg(self, experiments: Sequence[Experiment]) -> np.ndarray:
        """``(N, 3)`` each model's median error of its fitted angles over the experiments.

        Degrees, flippers (left, right pectoral, caudal), as
        :func:`eea.experiment.angle_errors_deg` (the short way round for the pectorals);
        the experiments' true angles are an oracle the selection does not use.

        Raises:
            ValueError: if the experiments are not the E the angles were fitted on.
        """
        if len(experiments) != self.angles.shape[1]:
            raise ValueError(f"the angles were fitted on {self.angles.shape[1]} experiments, got {len(experiments)}")
        n, e = self.angles.shape[:2]
        true = np.tile(np.stack([x.true_angles for x in experiments]), (n, 1))
        return np.median(angle_errors_deg(self.angles.reshape(n * e, 3), true).reshape(n, e, 3), axis=1)


def select_model(models, experiments: Sequence[Experiment], evaluator: Evaluator, rng: np.random.Generator, *,
                 generations: int = 30, scan_cycles: int = 2, start=None, model_space=None) -> Selection:
    """Fit every model's angles equally hard on the experiments; the highest MOD_FIT wins.

    Args:
        models: ``(N, 9)`` candidate morphologies (simulator units), N >= 1; a model given
            twice is fitted once and scores the same. In the ``morphology+servos`` model space
            ``(N, 12)``: the dimensions and the servo gains.
        experiments: the pooled target experiments, E >= 1, all of one length.
        evaluator: an :class:`eea.evaluation.Evaluator` of that length (its similarity is
            the one scored: eq. 2 by default).
        rng: draws the fit's random starts and perturbations.
        generations: random-perturbation generations of :meth:`eea.inference.profile.Profile.fit`, >= 1.
        scan_cycles: cycles of the per-flipper angle scan before the compass polish, >= 0.
        start: optional ``(N, E, 3)`` angles (rad) per model and experiment, tried beside the
            fit's random starts (e.g. the angles a run already found for its model; a model
            given twice starts from its first row's), or ``(S, N, E, 3)``: S such sets.
        model_space: the models' :class:`~eea.encoding.ModelSpace` or its name (default: the
            evaluator's).

    Returns:
        A :class:`Selection`.

    Raises:
        ValueError: if ``models`` is not ``(N, 9)`` (``(N, 12)``) with N >= 1, there are no experiments,
            ``generations < 1``, ``scan_cycles < 0`` or ``start`` is not ``(N, E, 3)`` or
            ``(S, N, E, 3)``.
    """
    space = get_model_space(model_space if model_space is not None else getattr(evaluator, "model_space", "morphology"))
    models = np.asarray(models, dtype=np.float64)
    if models.ndim != 2 or models.shape[1] != len(space.fields) or not len(models):
        raise ValueError(f"models must be (N >= 1, {len(space.fields)}), got shape {models.shape}")
    if not len(experiments):
        raise ValueError("select_model needs at least one experiment")
    if generations < 1:
        raise ValueError(f"generations must be >= 1, got {generations}")
    if scan_cycles < 0:
        raise ValueError(f"scan_cycles must be >= 0, got {scan_cycles}")
    if start is not None:
        start = np.asarray(start, dtype=np.float64)
        if start.shape[-3:] != (len(models), len(experiments), 3) or start.ndim not in (3, 4):
            raise ValueError(f"start must be (N, E, 3) = ({len(models)}, {len(experiments)}, 3) or (S, N, E, 3), "
                             f"got {start.shape}")
    genomes, first, inverse = np.unique(space.encode(models), axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    profile = Profile()
    angles, _ = profile.fit(genomes, experiments, evaluator, rng, generations,
                            start=None if start is None else start[..., first, :, :])
    sims = evaluator.similarities(genomes, experiments, angles)
    if scan_cycles:
        profile.scan_angles(genomes, angles, sims, experiments, evaluator, scan_cycles)
    profile.polish_angles(genomes, angles, sims, experiments, evaluator)
    fitness = model_fitness_from_similarities(sims)[inverse]
    return Selection(models, fitness, angles[inverse], int(np.argmax(fitness)))


def fault_hypotheses(design, levels: Sequence[float] = FAULT_GAIN_LEVELS) -> np.ndarray:
    """Fault hypotheses about a robot of known design: one or two faults, on different parts.

    A robot knows the morphology it was built to (its design). A servo fault leaves that
    morphology as it was and changes only how a servo turns; a flipper fault changes one
    flipper and leaves the servos as they were. These are the candidate models of
    :func:`check_fault_hypotheses`, in this order (``L`` levels, ``L'`` of them other than 1):

    * ``L * L`` pectoral servo faults: the design with every pair of pectoral gains from
      ``levels`` (left gain varying slowest), caudal gain 1;
    * ``2 * 2 * L`` pectoral flipper faults: for the left, then the right pectoral, each fault of
      :data:`FLIPPER_FAULT_SCALES` (shortened, lost), with that flipper's gain 1 and the other
      pectoral's gain at every level (so a lost flipper beside a weak or reversed servo is there);
    * ``4 * (5 + 2 L')`` caudal faults: each of :data:`CAUDAL_FAULTS` (servo dead, weak; fin
      shortened, lost), beside healthy pectorals, then beside one pectoral fault: the left gain
      at each level other than 1, the right gain likewise, then the left flipper shortened, lost,
      the right flipper shortened, lost.

    Args:
        design: ``(9,)`` the robot's flipper dimensions (simulator units, ``MORPHOLOGY_FIELDS``).
        levels: pectoral gains to combine, each in [-1, 1] (default :data:`FAULT_GAIN_LEVELS`).

    Returns:
        ``(L * L + 4 * L + 4 * (5 + 2 L'), 12)`` models of the ``morphology+servos`` space: the
        dimensions and the gains (left, right pectoral, caudal); 97 with the default levels.

    Raises:
        ValueError: ``design`` not 9 finite numbers, no level, or a gain out of [-1, 1].
    """
    design = np.asarray(design, dtype=np.float64)
    if design.shape != (9,) or not np.all(np.isfinite(design)):
        raise ValueError(f"design must be the 9 flipper dimensions as finite numbers, got {design.tolist()!r}")
    gains = np.asarray(levels, dtype=np.float64)
    if gains.ndim != 1 or not len(gains) or not np.all(np.abs(gains) <= 1.0):
        raise ValueError(f"levels must be one or more pectoral gains in [-1, 1], got {levels!r}")
    left, right = np.meshgrid(gains, gains, indexing="ij")
    rows = [np.column_stack([np.tile(design, (left.size, 1)), left.ravel(), right.ravel(), np.ones(left.size)])]
    flippers = []  # the four pectoral flipper faults' morphologies: left shortened, lost, right shortened, lost
    for side in (0, 1):
        for _, scale in FLIPPER_FAULT_SCALES:
            shape = design.copy()
            shape[3 * side:3 * side + 3] *= scale
            flippers.append(shape)
            pectoral = np.ones((len(gains), 2))
            pectoral[:, 1 - side] = gains
            rows.append(np.column_stack([np.tile(shape, (len(gains), 1)), pectoral, np.ones(len(gains))]))
    faulty = [g for g in gains if g != 1.0]
    pectoral_states = ([(design, 1.0, 1.0)] + [(design, g, 1.0) for g in faulty] + [(design, 1.0, g) for g in faulty]
                       + [(shape, 1.0, 1.0) for shape in flippers])
    for _, caudal_gain, scale in CAUDAL_FAULTS:
        for shape, left_gain, right_gain in pectoral_states:
            shape = shape.copy()
            shape[6:9] *= scale
            rows.append(np.r_[shape, left_gain, right_gain, caudal_gain][None])
    return np.vstack(rows)


def check_fault_hypotheses(model, design, experiments: Sequence[Experiment], evaluator: Evaluator, seed: int, *,
                           levels: Sequence[float] = FAULT_GAIN_LEVELS, screen_generations: int = 3,
                           screen_scan_cycles: int = 1, refit: int = 8, refit_rounds: int = 2, generations: int = 10,
                           scan_cycles: int = 2) -> Selection:
    """A found self-model against fault hypotheses about the design, fitted equally hard.

    The search of a self-model in ``morphology+servos`` can settle on a model that explains the
    experiments with a wrong servo sign and a morphology bent to fit (docs/studies/recovery.md):
    under its own fitted angles the truth scores a higher MOD_FIT than that model, but the
    search does not get there. This check fits the initial angles of ``model`` and of every
    hypothesis of :func:`fault_hypotheses` ``(design, levels)`` equally hard on all the
    experiments and keeps the highest MOD_FIT (eq. 3), in stages (not the paper's):

    1. a screen: every candidate's angles fitted by :func:`select_model` with
       ``screen_generations`` and ``screen_scan_cycles``;
    2. ``refit_rounds`` rounds in which the ``refit`` best of the screen are fitted again
       (``generations``, ``scan_cycles``) from new random starts and from the angles each of
       them holds so far; each keeps the better of its fits. The initial angles are the
       target's, whichever model is fitted, so a candidate that missed an experiment's angles
       takes them from another that found them.

    The chosen model is the highest MOD_FIT at the end (always one of those refitted). A
    single fit of a candidate can miss one experiment's angles and lose 0.001-0.004 of MOD_FIT,
    as much as separates the best candidates; the rounds of shared starts take that noise out
    of the ranking (docs/self_modeling.md).

    Args:
        model: ``(12,)`` the found self-model (``morphology+servos`` values).
        design: ``(9,)`` the robot's design morphology.
        experiments: the run's target experiments, E >= 1.
        evaluator: an :class:`~eea.evaluation.Evaluator` of the ``morphology+servos`` space and
            the run's length and behaviour summary.
        seed: stage ``i`` (0: the screen, then the refit rounds) draws its random starts from
            ``numpy.random.default_rng(seed + i)``.
        levels: the hypotheses' pectoral gains.
        screen_generations: the screen's fit, as ``generations`` of :func:`select_model`.
        screen_scan_cycles: the screen's fit, as ``scan_cycles`` of :func:`select_model`.
        refit: candidates fitted again, >= 1.
        refit_rounds: rounds of the refit, >= 1.
        generations: the refit's fit, as :func:`select_model`'s.
        scan_cycles: the refit's fit, as :func:`select_model`'s.

    Returns:
        A :class:`Selection` of the ``1 + H`` candidates (98 with the default levels): row 0
        is ``model``, then :func:`fault_hypotheses` in its order; each one's best MOD_FIT
        and its angles; ``index`` the chosen one (``model`` itself when no hypothesis fits better).

    Raises:
        ValueError: a model that is not 12 values, ``refit`` or ``refit_rounds`` below 1, or as
            :func:`fault_hypotheses` and :func:`select_model` raise.
    """
    model = np.asarray(model, dtype=np.float64)
    if model.shape != (12,):
        raise ValueError(f"model must be the 12 values of a morphology+servos self-model, got shape {model.shape}")
    if refit < 1 or refit_rounds < 1:
        raise ValueError(f"refit and refit_rounds must be >= 1, got {refit} and {refit_rounds}")
    candidates = np.vstack([model[None], fault_hypotheses(design, levels)])
    screen = select_model(candidates, experiments, evaluator, np.random.default_rng(seed),
                          generations=screen_generations, scan_cycles=screen_scan_cycles,
                          model_space="morphology+servos")
    fitness, angles = screen.model_fitness.copy(), screen.angles.copy()
    best = np.argsort(-fitness, kind="stable")[:refit]
    for stage in range(1, refit_rounds + 1):
        starts = np.repeat(angles[best][:, None], len(best), axis=1)  # (S, K, E, 3): set s = candidate s's angles
        again = select_model(candidates[best], experiments, evaluator, np.random.default_rng(seed + stage),
                             generations=generations, scan_cycles=scan_cycles, start=starts,
                             model_space="morphology+servos")
        better = again.model_fitness > fitness[best]
        fitness[best[better]], angles[best[better]] = again.model_fitness[better], again.angles[better]
    return Selection(candidates, fitness, angles, int(np.argmax(fitness)))
