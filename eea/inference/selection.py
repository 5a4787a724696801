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

from aquafish_gym.checks import check_int
from eea.encoding import SERVO_GAIN_BOUNDS, decode_gains, encode_gains, get_model_space
from eea.evaluation import Evaluator
from eea.experiment import Experiment, angle_errors_deg
from eea.fitness import model_fitness_from_similarities
from eea.inference.profile import Profile

__all__ = ["CAUDAL_FAULTS", "FAULT_GAIN_LEVELS", "FLIPPER_FAULT_SCALES", "GAIN_POLISH_MARGIN", "GAIN_POLISH_STEP",
           "Selection", "check_fault_hypotheses", "fault_hypotheses", "gain_neighbours", "polish_gains", "select_model"]

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

#: How far the gain polish of :func:`check_fault_hypotheses` moves one servo gain a step (gain units).
GAIN_POLISH_STEP = 0.125
#: How much better (MOD_FIT) a neighbour must fit than the current model for the gain polish to
#: move: above the few millionths by which two equal fits from shared angles differ, below the
#: 0.0005-0.002 a step toward a weak servo's true gain gains (docs/self_modeling.md).
GAIN_POLISH_MARGIN = 1e-4

#: ``(3, 16)`` every level of each servo gain's grid in the ``morphology+servos`` space, ascending
#: (the distinct gains a fine sweep of each range encodes to).
_GAIN_LEVELS = np.stack([np.unique(g) for g in decode_gains(encode_gains(
    SERVO_GAIN_BOUNDS[:, 0] + np.linspace(0.0, 1.0, 161)[:, None] * np.ptp(SERVO_GAIN_BOUNDS, axis=1))).T])


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
                 generations: int = 30, scan_cycles: int = 2, polish: bool = True, start=None,
                 model_space=None) -> Selection:
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
        polish: end with the compass polish (:meth:`eea.inference.profile.Profile.polish_angles`,
            about 60-90 simulations a model and experiment); False scores the angles the fit
            and the scan found.
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
    if polish:
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


def gain_neighbours(model) -> np.ndarray:
    """The models one gain step away from ``model``: the moves of the gain polish of
    :func:`check_fault_hypotheses`.

    For each servo (left pectoral, right pectoral, caudal) and each direction, the gain is
    moved to the level of the ``morphology+servos`` gain grid (:mod:`eea.encoding`) nearest to
    ``gain -/+`` :data:`GAIN_POLISH_STEP` on that side of it (so from -1 up is -0.75, the
    grid's next pectoral level); a gain at its bound has no move past it. The dimensions stay.

    Args:
        model: ``(12,)`` a ``morphology+servos`` model whose gains are grid levels.

    Returns:
        ``(M, 12)``, 3 <= M <= 6: left down, left up, right down, right up, caudal down, caudal
        up, those that exist.

    Raises:
        ValueError: not 12 finite values.
    """
    model = np.asarray(model, dtype=np.float64)
    if model.shape != (12,) or not np.all(np.isfinite(model)):
        raise ValueError(f"model must be the 12 finite values of a morphology+servos model, got {model.tolist()!r}")
    rows = []
    for servo, levels in enumerate(_GAIN_LEVELS):
        gain = model[9 + servo]
        for direction in (-1.0, 1.0):
            side = levels[(levels - gain) * direction > 1e-9]
            if len(side):
                moved = model.copy()
                moved[9 + servo] = side[np.argmin(np.abs(side - (gain + direction * GAIN_POLISH_STEP)))]
                rows.append(moved)
    return np.array(rows)


def check_fault_hypotheses(model, design, experiments: Sequence[Experiment], evaluator: Evaluator, seed: int, *,
                           levels: Sequence[float] = FAULT_GAIN_LEVELS, screen_generations: int = 3,
                           screen_scan_cycles: int = 1, screen_polish_top: int = 24, refit: int = 8,
                           refit_rounds: int = 2, generations: int = 10,
                           scan_cycles: int = 2, polish: int = 2, polish_steps: int = 3,
                           screen_angles=None) -> Selection:
    """A found self-model against fault hypotheses about the design, fitted equally hard.

    The search of a self-model in ``morphology+servos`` can settle on a model that explains the
    experiments with a wrong servo sign and a morphology bent to fit (docs/studies/recovery.md):
    under its own fitted angles the truth scores a higher MOD_FIT than that model, but the
    search does not get there. This check fits the initial angles of ``model`` and of every
    hypothesis of :func:`fault_hypotheses` ``(design, levels)`` equally hard on all the
    experiments and keeps the highest MOD_FIT (eq. 3), in stages (not the paper's):

    1. a screen: every candidate's angles fitted by :func:`select_model` with
       ``screen_generations`` and ``screen_scan_cycles``, without its compass polish; then the
       compass polish (:meth:`eea.inference.profile.Profile.polish_angles`) on the
       ``screen_polish_top`` best of them only (given to all 98, it was about half of the
       screen's simulations);
    2. ``refit_rounds`` rounds in which the ``refit`` best of the screen are fitted again
       (``generations``, ``scan_cycles``) from new random starts and from the angles each of
       them holds so far; each keeps the better of its fits. The initial angles are the
       target's, whichever model is fitted, so a candidate that missed an experiment's angles
       takes them from another that found them.

    3. a gain polish (:func:`polish_gains`, its fits drawn from ``seed + refit_rounds + 1``
       on): from each of the ``polish`` best distinct candidates, coordinate ascent over the
       servo gains, one gain moved a step (:func:`gain_neighbours`) when the move fits better
       than the current model by more than :data:`GAIN_POLISH_MARGIN`, also after the two
       have shared their angles; at most ``polish_steps`` steps. A polish that moved appends
       its end point as a new candidate. The hypotheses' gains are coarse levels (-1, -0.5, 0,
       0.5, 1; the caudal servo's 0 and 0.5); the polish takes a weak servo at 0.26 or 0.7
       toward the grid's 0.25 or 0.75, where the nearest hypothesis may be a shortened flipper
       instead.

    The chosen model is the highest MOD_FIT at the end (one of those refitted or polished). A
    single fit of a candidate can miss one experiment's angles and lose 0.001-0.004 of MOD_FIT,
    as much as separates the best candidates; the rounds of shared starts take that noise out
    of the ranking (docs/self_modeling.md). A polish step refits the current model beside its
    neighbours and duels the best of them from both their angles, so a neighbour must beat a
    fit as hard as its own, with the same angles to hand, not an older or unluckier one.

    Args:
        model: ``(12,)`` the found self-model (``morphology+servos`` values).
        design: ``(9,)`` the robot's design morphology.
        experiments: the run's target experiments, E >= 1.
        evaluator: an :class:`~eea.evaluation.Evaluator` of the ``morphology+servos`` space and
            the run's length and behaviour summary.
        seed: stage ``i`` (0: the screen, then the refit rounds, then the polish's fits in
            order) draws its random starts from ``numpy.random.default_rng(seed + i)``.
        levels: the hypotheses' pectoral gains.
        screen_generations: the screen's fit, as ``generations`` of :func:`select_model`.
        screen_scan_cycles: the screen's fit, as ``scan_cycles`` of :func:`select_model`.
        screen_polish_top: the screen's best candidates given the compass polish, >= 0 (0:
            none; at least ``1 + H``: all, the check before 2026-11-28's leaner screen). On
            the 12 windowed missions 24 keeps the model the polish of all 98 keeps, at about
            28 % fewer of the check's simulations (docs/main_job.md).
        refit: candidates fitted again, >= 1.
        refit_rounds: rounds of the refit, >= 1.
        generations: the refit's fit, as :func:`select_model`'s.
        scan_cycles: the refit's fit, as :func:`select_model`'s (the polish's too).
        polish: candidates whose gains are polished, >= 0 (0: no polish).
        polish_steps: the most steps of each polish, >= 1.
        screen_angles: None (the screen fits every candidate's angles), or ``(1 + H, E, 3)``
            angles (rad) the candidates already hold, e.g. the ones a ``hypotheses`` search's
            strategy fitted round by round (:mod:`eea.search.hypotheses`): the screen scores them
            as they are (one simulation per candidate and experiment) and fits nothing (in
            measurement).

    Returns:
        A :class:`Selection` of the ``1 + H + P`` candidates (98 + P with the default levels):
        row 0 is ``model``, then :func:`fault_hypotheses` in its order, then the P <= ``polish``
        polished models that moved from where they started; each one's best MOD_FIT and its
        angles; ``index`` the chosen one (``model`` itself when nothing fits better).

    Raises:
        ValueError: a model that is not 12 values, ``refit`` or ``refit_rounds`` below 1,
            ``screen_polish_top`` or ``polish`` below 0 or ``polish_steps`` below 1, or as
            :func:`fault_hypotheses` and :func:`select_model` raise.
    """
    model = np.asarray(model, dtype=np.float64)
    if model.shape != (12,):
        raise ValueError(f"model must be the 12 values of a morphology+servos self-model, got shape {model.shape}")
    if refit < 1 or refit_rounds < 1:
        raise ValueError(f"refit and refit_rounds must be >= 1, got {refit} and {refit_rounds}")
    if polish < 0 or polish_steps < 1:
        raise ValueError(f"polish must be >= 0 and polish_steps >= 1, got {polish} and {polish_steps}")
    check_int("screen_polish_top", screen_polish_top, 0)
    candidates = np.vstack([model[None], fault_hypotheses(design, levels)])
    if screen_angles is None:
        screen = select_model(candidates, experiments, evaluator, np.random.default_rng(seed),
                              generations=screen_generations, scan_cycles=screen_scan_cycles, polish=False,
                              model_space="morphology+servos")
        fitness, angles = screen.model_fitness.copy(), screen.angles.copy()
    else:
        angles = np.array(screen_angles, dtype=np.float64)
        if angles.shape != (len(candidates), len(experiments), 3) or not np.all(np.isfinite(angles)):
            raise ValueError(f"screen_angles must be (1 + H, E, 3) = ({len(candidates)}, {len(experiments)}, 3) "
                             f"finite angles, got shape {angles.shape}")
        fitness = model_fitness_from_similarities(evaluator.similarities(
            get_model_space("morphology+servos").encode(candidates), experiments, angles))
    if screen_polish_top:
        top = np.argsort(-fitness, kind="stable")[:screen_polish_top]
        genomes = get_model_space("morphology+servos").encode(candidates[top])
        polished = angles[top].copy()
        sims = evaluator.similarities(genomes, experiments, polished)
        Profile().polish_angles(genomes, polished, sims, experiments, evaluator)
        fitness[top], angles[top] = model_fitness_from_similarities(sims), polished
    best = np.argsort(-fitness, kind="stable")[:refit]
    for stage in range(1, refit_rounds + 1):
        starts = np.repeat(angles[best][:, None], len(best), axis=1)  # (S, K, E, 3): set s = candidate s's angles
        again = select_model(candidates[best], experiments, evaluator, np.random.default_rng(seed + stage),
                             generations=generations, scan_cycles=scan_cycles, start=starts,
                             model_space="morphology+servos")
        better = again.model_fitness > fitness[best]
        fitness[best[better]], angles[best[better]] = again.model_fitness[better], again.angles[better]
    return polish_gains(candidates, fitness, angles, experiments, evaluator, seed + refit_rounds + 1, polish=polish,
                        polish_steps=polish_steps, generations=generations, scan_cycles=scan_cycles)


def polish_gains(models, model_fitness, angles, experiments: Sequence[Experiment], evaluator: Evaluator, seed: int, *,
                 polish: int = 2, polish_steps: int = 3, generations: int = 10, scan_cycles: int = 2) -> Selection:
    """The gain polish, the last stage of :func:`check_fault_hypotheses`: coordinate ascent over
    the servo gains from the ``polish`` best distinct candidates.

    A step fits the current model and its :func:`gain_neighbours` from the current model's
    angles (:func:`select_model` with ``generations`` and ``scan_cycles``); the current model
    keeps its better fit. The best neighbour is then fitted again beside the current model in a
    duel, each from both of their angles (a candidate that found better angles by luck hands
    them to the other, as in the refit rounds), and becomes the current model only if it
    still fits better by more than :data:`GAIN_POLISH_MARGIN`; at most ``polish_steps`` steps.

    Args:
        models: ``(N, 12)`` the candidates (``morphology+servos`` values).
        model_fitness: ``(N,)`` their MOD_FITs so far.
        angles: ``(N, E, 3)`` their fitted angles (rad).
        experiments: the E experiments.
        evaluator: as :func:`select_model`'s, in the ``morphology+servos`` space.
        seed: the i-th fit (a step, then its duel, candidate after candidate) draws its random
            starts from ``numpy.random.default_rng(seed + i)``.
        polish: candidates polished, >= 0.
        polish_steps: the most steps of each, >= 1.
        generations: as :func:`select_model`'s.
        scan_cycles: as :func:`select_model`'s.

    Returns:
        A :class:`Selection`: the N candidates (a polish that did not move keeps its better fit
        in its own row), then the end point of each polish that moved; ``index`` the highest
        MOD_FIT.

    Raises:
        ValueError: ``polish`` below 0 or ``polish_steps`` below 1, or as :func:`select_model`.
    """
    if polish < 0 or polish_steps < 1:
        raise ValueError(f"polish must be >= 0 and polish_steps >= 1, got {polish} and {polish_steps}")
    models, fitness = np.asarray(models, dtype=np.float64), np.array(model_fitness, dtype=np.float64)
    angles = np.array(angles, dtype=np.float64)
    fits = 0

    def fit(trial, starts):
        nonlocal fits
        fits += 1
        return select_model(trial, experiments, evaluator, np.random.default_rng(seed + fits - 1),
                            generations=generations, scan_cycles=scan_cycles, start=starts,
                            model_space="morphology+servos")

    moved = []  # (model, MOD_FIT, angles) of each polish that left its start
    for row in _best_distinct(models, fitness, polish):
        current, best, current_angles, steps = models[row], fitness[row], angles[row], 0
        for _ in range(polish_steps):
            trial = np.vstack([current[None], gain_neighbours(current)])
            again = fit(trial, np.repeat(current_angles[None], len(trial), axis=0))
            if again.model_fitness[0] > best:
                best, current_angles = again.model_fitness[0], again.angles[0]
            step = 1 + int(np.argmax(again.model_fitness[1:]))
            if again.model_fitness[step] <= best + GAIN_POLISH_MARGIN:
                break
            pair = np.vstack([current[None], trial[step][None]])
            duel = fit(pair, np.stack([np.stack([current_angles] * 2), np.stack([again.angles[step]] * 2)]))
            if duel.model_fitness[0] > best:
                best, current_angles = duel.model_fitness[0], duel.angles[0]
            challenger, challenger_angles = again.model_fitness[step], again.angles[step]
            if duel.model_fitness[1] > challenger:
                challenger, challenger_angles = duel.model_fitness[1], duel.angles[1]
            if challenger <= best + GAIN_POLISH_MARGIN:
                break
            current, best, current_angles, steps = trial[step], challenger, challenger_angles, steps + 1
        if not steps:
            fitness[row], angles[row] = best, current_angles
        else:
            moved.append((current, best, current_angles))
    if moved:
        models = np.vstack([models] + [m[None] for m, _, _ in moved])
        fitness = np.concatenate([fitness, [f for _, f, _ in moved]])
        angles = np.concatenate([angles] + [a[None] for _, _, a in moved])
    return Selection(models, fitness, angles, int(np.argmax(fitness)))


def _best_distinct(models: np.ndarray, fitness: np.ndarray, n: int) -> list[int]:
    """The rows of the ``n`` highest ``fitness`` among distinct ``models`` (the first row of equal ones)."""
    rows: list[int] = []
    for row in np.argsort(-fitness, kind="stable"):
        if len(rows) == n:
            break
        if not any(np.array_equal(models[row], models[r]) for r in rows):
            rows.append(int(row))
    return rows
