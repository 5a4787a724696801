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

__all__ = ["Selection", "select_model"]


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
            given twice starts from its first row's).
        model_space: the models' :class:`~eea.encoding.ModelSpace` or its name (default: the
            evaluator's).

    Returns:
        A :class:`Selection`.

    Raises:
        ValueError: if ``models`` is not ``(N, 9)`` (``(N, 12)``) with N >= 1, there are no experiments,
            ``generations < 1``, ``scan_cycles < 0`` or ``start`` is not ``(N, E, 3)``.
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
        if start.shape != (len(models), len(experiments), 3):
            raise ValueError(f"start must be (N, E, 3) = ({len(models)}, {len(experiments)}, 3), got {start.shape}")
    genomes, first, inverse = np.unique(space.encode(models), axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    profile = Profile()
    angles, _ = profile.fit(genomes, experiments, evaluator, rng, generations,
                            start=None if start is None else start[first])
    sims = evaluator.similarities(genomes, experiments, angles)
    if scan_cycles:
        profile.scan_angles(genomes, angles, sims, experiments, evaluator, scan_cycles)
    profile.polish_angles(genomes, angles, sims, experiments, evaluator)
    fitness = model_fitness_from_similarities(sims)[inverse]
    return Selection(models, fitness, angles[inverse], int(np.argmax(fitness)))
