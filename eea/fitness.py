"""Fitness functions of the EEA: equations 1, 3 and 4 of the paper.

* :func:`action_fitness` (eq. 1, exploration): how much an action makes the candidate
  models disagree.
* :func:`model_fitness` (eq. 3, estimation): how well a candidate model reproduces the
  target's recorded experiments.
* :func:`objective_fitness` (eq. 4, section 4): an oracle distance between a model's and
  the target's dimensions; recorded, never used by the search.

Behaviour summaries are ``(3, F)`` arrays from :func:`eea.behaviour.behaviour_summary`
and similarity is :func:`eea.behaviour.similarity` (eq. 2).
"""

from __future__ import annotations

import numpy as np

from aquafish_gym import MORPHOLOGY_BOUNDS
from eea.behaviour import MAX_COEFFICIENT, similarity

__all__ = ["action_fitness", "model_fitness", "model_fitness_from_similarities", "objective_fitness",
           "robust_action_fitness"]


def action_fitness(summaries, max_coefficient: float = MAX_COEFFICIENT):
    """Disagreement among candidate models under one action, paper equation 1.

    ``ACT_FIT(a) = sum_{i<j} [1 - sim(B_ia, B_ja)] / C(M, 2)``: the mean dissimilarity
    over the M(M-1)/2 unordered pairs of models.

    Args:
        summaries: ``(M, 3, F)`` behaviour summaries of the M candidate models under one
            action, or ``(A, M, 3, F)`` (any leading dimensions) for A actions at once.
        max_coefficient: MAX of equation 2.

    Returns:
        A float in [0, 1] for ``(M, 3, F)``; ``(A,)`` float64 for ``(A, M, 3, F)``.

    Raises:
        ValueError: if ``summaries`` is not ``(..., M, 3, F)`` with M >= 2, or as
            :func:`eea.behaviour.similarity` raises.
    """
    s = np.asarray(summaries, dtype=np.float64)
    if s.ndim < 3:
        raise ValueError(f"summaries must have shape (..., M, 3, F), got {s.shape}")
    m = s.shape[-3]
    if m < 2:
        raise ValueError(f"action fitness needs M >= 2 models to compare, got M = {m}")
    total = np.zeros(s.shape[:-3])
    for i in range(m - 1):  # pairs (i, j > i); memory stays O(M) summaries per action
        total = total + (1.0 - similarity(s[..., i : i + 1, :, :], s[..., i + 1 :, :, :],
                                          max_coefficient)).sum(axis=-1)
    result = total / (m * (m - 1) / 2)
    return float(result) if result.ndim == 0 else result


def robust_action_fitness(summaries, max_coefficient: float = MAX_COEFFICIENT):
    """Disagreement among models that the unknown initial angles do not explain (not the paper's).

    Equation 1 scores an action by how much the candidate models disagree from one fixed
    (zero) state, but the target starts from unknown angles, and a response that changes
    as much with the angles as with the morphology tells the models apart only in
    appearance. With the models simulated from K angle sets::

        ACT_FIT_robust(a) = 1/K sum_k ACT_FIT_k(a) - 1/M sum_i SPREAD_i(a)

    where ``ACT_FIT_k`` is equation 1 over the M models from angle set k (between-model
    disagreement), ``SPREAD_i`` is equation 1 over model i's K responses (the
    disagreement of a model with itself caused by the angles alone). The spread is the
    candidate models' own: when they all share a wrong, large flipper, moving it is penalised
    although it would expose the error (study record, "Two lineages from round 1"; a weight
    on the spread was retired, docs/studies/retired_variants.md).

    Args:
        summaries: ``(K, M, 3, F)`` summaries of M models from K angle sets under one
            action, or ``(A, K, M, 3, F)`` (any leading dimensions) for A actions; K, M >= 2.
        max_coefficient: MAX of equation 2.

    Returns:
        A float in [-1, 1] for one action; ``(A,)`` float64 for several.

    Raises:
        ValueError: if ``summaries`` is not ``(..., K, M, 3, F)`` with K, M >= 2.
    """
    s = np.asarray(summaries, dtype=np.float64)
    if s.ndim < 4 or s.shape[-4] < 2:
        raise ValueError(f"summaries must have shape (..., K, M, 3, F) with K >= 2 angle sets, got {s.shape}")
    between = np.mean(action_fitness(s, max_coefficient), axis=-1)                        # over K
    spread = np.mean(action_fitness(np.swapaxes(s, -4, -3), max_coefficient), axis=-1)    # over M
    result = between - spread
    return float(result) if np.ndim(result) == 0 else result


def model_fitness(model_summaries, target_summaries, max_coefficient: float = MAX_COEFFICIENT):
    """How well candidate models reproduce the target, paper equation 3.

    ``MOD_FIT(M_i) = 1/E * sum_e sim(B_{i,a_e}, T_{a_e})``: the mean similarity over the E
    recorded experiments between model i's response and the target's.

    Args:
        model_summaries: ``(P, E, 3, F)`` summaries of P models under each experiment's
            action (any leading dimensions; ``(E, 3, F)`` for one model).
        target_summaries: ``(E, 3, F)`` recorded target summaries, experiment for
            experiment.
        max_coefficient: MAX of equation 2.

    Returns:
        ``(P,)`` float64 in [0, 1] (0-d for a single model).

    Raises:
        ValueError: if ``target_summaries`` is not ``(E, 3, F)`` with E >= 1, the
            trailing ``(E, 3, F)`` of ``model_summaries`` differs from it, or as
            :func:`eea.behaviour.similarity` raises.
    """
    models = np.asarray(model_summaries, dtype=np.float64)
    target = np.asarray(target_summaries, dtype=np.float64)
    if target.ndim != 3 or target.shape[0] < 1:
        raise ValueError(
            f"target_summaries must have shape (E, 3, F) with E >= 1, got {target.shape}"
        )
    if models.ndim < 3 or models.shape[-3:] != target.shape:
        raise ValueError(
            f"model_summaries must have shape (P, {', '.join(map(str, target.shape))}) to "
            f"match target_summaries, got {models.shape}"
        )
    return model_fitness_from_similarities(similarity(models, target, max_coefficient))


def model_fitness_from_similarities(similarities) -> np.ndarray:
    """MOD_FIT (paper equation 3) from the similarities already computed: their mean over E.

    The estimation phase gets cached similarities from :class:`eea.evaluation.Evaluator`
    rather than summaries; this is the one place equation 3 averages them.

    Args:
        similarities: ``(P, E)`` sim(B_{i,a_e}, T_{a_e}) (eq. 2), any leading dimensions.

    Returns:
        ``(P,)`` float64.

    Raises:
        ValueError: if there is no experiment axis or it is empty.
    """
    sims = np.asarray(similarities, dtype=np.float64)
    if sims.ndim < 1 or sims.shape[-1] < 1:
        raise ValueError(f"similarities must have shape (..., E) with E >= 1, got {sims.shape}")
    return sims.mean(axis=-1)


def objective_fitness(model_dims, target_dims, bounds=MORPHOLOGY_BOUNDS):
    """Oracle model quality, paper equation 4 (1 = exact, 0 = every dimension maximally off).

    ``OBJ_FIT = 1 - 1/n * sum_i |model_i - target_i| / (max_i - min_i)``: n = 9 in the
    paper's ``morphology`` model space (the default ``bounds``). In the ``morphology+servos``
    space (not the paper's; :class:`eea.encoding.ModelSpace`, pass its ``bounds``) n = 12:
    the nine dimensions as above and the three servo gains, each gain's term normalised by
    its range as the dimensions' are, 2 for a pectoral gain ([-1, 1]) and 1 for the caudal
    one ([0, 1]), and the mean taken over all 12 terms; the target's gains are its faults'
    (``speed_scale``, 0 where seized: :func:`eea.encoding.servo_gains`). A model with every
    dimension right and the left pectoral gain +1 instead of -1 (``reversed_left_pectoral``)
    scores 1 - (2/2)/12 = 0.9167.

    Args:
        model_dims: ``(..., n)`` model dimensions in simulator units (decoded genomes).
        target_dims: ``(n,)`` the target's true dimensions.
        bounds: ``(n, 2)`` [min, max] of each dimension; default
            ``aquafish_gym.MORPHOLOGY_BOUNDS`` (the model genome's ranges; the
            ``morphology+servos`` space: ``ModelSpace.bounds``, 12 rows).

    Returns:
        ``(...)`` float64 in [0, 1] (a float for a single ``(n,)`` model).

    Raises:
        ValueError: if shapes disagree, bounds rows are not finite with min < max, or a
            model or target dimension is NaN or outside its bounds (by more than 1e-9
            of the range).
    """
    bounds = np.asarray(bounds, dtype=np.float64)
    if bounds.ndim != 2 or bounds.shape[1] != 2 or bounds.shape[0] < 1:
        raise ValueError(f"bounds must have shape (n, 2), got {bounds.shape}")
    if not np.all(np.isfinite(bounds)) or np.any(bounds[:, 1] <= bounds[:, 0]):
        raise ValueError("bounds rows must be finite [min, max] with min < max")
    n = bounds.shape[0]
    model = np.asarray(model_dims, dtype=np.float64)
    target = np.asarray(target_dims, dtype=np.float64)
    if target.shape != (n,):
        raise ValueError(f"target_dims must have shape ({n},), got {target.shape}")
    if model.ndim < 1 or model.shape[-1] != n:
        raise ValueError(f"model_dims must have shape (..., {n}), got {model.shape}")
    lo, hi = bounds[:, 0], bounds[:, 1]
    tol = 1e-9 * (hi - lo)  # floating-point round-off only
    for name, x in (("model_dims", model), ("target_dims", target)):
        inside = (x >= lo - tol) & (x <= hi + tol)  # False for NaN
        if not np.all(inside):
            idx = tuple(int(i) for i in np.argwhere(~inside)[0])
            raise ValueError(
                f"{name}{list(idx)} = {x[idx]!r} is NaN or outside its bounds "
                f"[{lo[idx[-1]]}, {hi[idx[-1]]}]"
            )
    result = 1.0 - (np.abs(model - target) / (hi - lo)).mean(axis=-1)
    return float(result) if result.ndim == 0 else result
