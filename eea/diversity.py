"""Distances between model genomes and diverse selections of them (not the paper's).

Used where a set of models should not be one hypothesis in several near-copies: the
exploration's candidate models (``config.exploration.diversity``, ``--exploration-diversity``,
:meth:`eea.estimation.Estimation.ranked_models`) and the distinct contenders whose angles
profile inference refines (:class:`eea.inference.profile.Profile`).
"""

from __future__ import annotations

import numpy as np

from eea.encoding import model_space_of
from eea.fitness import objective_fitness

__all__ = ["diverse_indices", "diverse_ranked", "model_distance"]


def model_distance(a, b) -> np.ndarray:
    """``1 - OBJ_FIT`` (eq. 4) of model genomes ``a`` against model genome ``b`` as the target.

    The mean range-normalised absolute difference of the decoded dimensions, in [0, 1) (with
    servo gains, 57-bit genomes of ``morphology+servos``: over the 9 dimensions and 3 gains,
    as :func:`eea.fitness.objective_fitness` describes).

    Args:
        a: ``(..., n_bits)`` model genomes (45 bits, or 57).
        b: ``(n_bits,)`` one model genome.

    Returns:
        ``(...)`` float64 distances.

    Raises:
        ValueError: if no model space has genomes of ``b``'s length, or as its decoding raises.
    """
    space = model_space_of(np.shape(b)[-1])
    return 1.0 - objective_fitness(space.decode(a), space.decode(b), space.bounds)


def diverse_indices(genomes: np.ndarray, fitness: np.ndarray, limit: int, min_distance: float) -> np.ndarray:
    """Rows of the fittest genomes, greedily skipping any within ``min_distance`` of one kept.

    Genomes are visited best first (ties: row order); a genome is kept if its
    :func:`model_distance` to every kept one is at least ``min_distance``. The first is
    always kept; duplicates never are (distance 0).

    Args:
        genomes: ``(N, 45)`` model genomes, N >= 0.
        fitness: ``(N,)`` their fitness, higher is better.
        limit: at most this many rows are returned, >= 1.
        min_distance: the minimum distance, in [0, 1); 0 keeps distinct genomes only.

    Returns:
        ``(R,)`` int64 row indices into ``genomes``, best first, R <= limit.

    Raises:
        ValueError: if the shapes disagree, ``limit < 1`` or ``min_distance`` is outside [0, 1).
    """
    genomes = np.asarray(genomes, dtype=np.uint8)
    fitness = np.asarray(fitness, dtype=np.float64)
    if genomes.ndim != 2 or fitness.shape != (len(genomes),):
        raise ValueError(f"genomes (N, 45) and fitness (N,) must agree, got {genomes.shape} and {fitness.shape}")
    if limit < 1:
        raise ValueError(f"limit must be >= 1, got {limit}")
    if not 0.0 <= min_distance < 1.0:
        raise ValueError(f"min_distance must be in [0, 1), got {min_distance!r}")
    kept: list[int] = []
    for i in np.argsort(-fitness, kind="stable"):
        if len(kept) == limit:
            break
        if not kept or np.min(model_distance(genomes[kept], genomes[i])) >= max(min_distance, 1e-12):
            kept.append(int(i))
    return np.asarray(kept, dtype=np.int64)


def diverse_ranked(genomes: np.ndarray, fitness: np.ndarray, limit: int, min_distance: float) -> np.ndarray:
    """The genomes :func:`diverse_indices` keeps, ``(R, 45)`` uint8, best first (same arguments
    and errors)."""
    return np.asarray(genomes, dtype=np.uint8)[diverse_indices(genomes, fitness, limit, min_distance)]
