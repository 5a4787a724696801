"""Why did a run end where it did: a search failure or an inference failure?

A run's final model is the fittest one the estimation found *under the initial angles its
inference strategy chose*. Scoring the true morphology (an oracle, like OBJ_FIT) on the
same experiments separates two failures:

* the true morphology fits the run's experiments better than the final model does: the
  estimation search missed it (a search failure);
* the final model fits better: the inferred angles favour a wrong morphology, and no
  search, however good, would move to the truth (an inference failure, a trap).

Scoring both models under the *true* angles as well shows what exact inference would have
given. :func:`diagnose_run` computes the four numbers (MOD_FIT, paper eq. 3) from a run's
checkpoint; ``aquafish diagnose DIR...`` prints them per run.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from aquafish_gym import Morphology, get_damage
from eea.checkpoint import load_state
from eea.encoding import encode_models
from eea.fitness import model_fitness_from_similarities
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.record import load_result

__all__ = ["RunDiagnosis", "diagnose_run"]


@dataclasses.dataclass(frozen=True)
class RunDiagnosis:
    """MOD_FIT (eq. 3) of the final and the true morphology on a run's experiments.

    Attributes:
        out_dir: the run directory.
        inference: the run's inference strategy.
        experiments: number of target experiments E.
        final_inferred: the final model under the inferred angles (the middle of each
            experiment's context ranges, as ``rounds.csv`` records them).
        true_inferred: the true (damaged) morphology under the inferred angles.
        final_true_angles: the final model under the true angles.
        true_true_angles: the true morphology under the true angles (1.0 unless the
            damage has servo faults, which models do not simulate).
    """

    out_dir: Path
    inference: str
    experiments: int
    final_inferred: float
    true_inferred: float
    final_true_angles: float
    true_true_angles: float

    @property
    def verdict(self) -> str:
        """``"search"`` if the truth fits the inferred angles better than the final model, else ``"inference"``."""
        return "search" if self.true_inferred > self.final_inferred else "inference"


def diagnose_run(out_dir: str | os.PathLike, workers: int = 1) -> RunDiagnosis:
    """Score the final and the true morphology on a finished (or partial) run's experiments.

    Runs ``4 E`` simulations at most (fewer when models coincide), ``E`` = the number of
    experiments in the run's checkpoint.

    Args:
        out_dir: an EEA run directory with a checkpoint (``state.pkl``).
        workers: simulation processes.

    Returns:
        The :class:`RunDiagnosis`.

    Raises:
        ValueError: if ``out_dir`` is not a run directory or has no finished round.
    """
    result = load_result(out_dir)
    state = load_state(out_dir)
    if state is None or not result.rounds:
        raise ValueError(f"{out_dir} has no finished round to diagnose")
    experiments = [Experiment.from_state_dict(e) for e in state.experiments]
    inferred = np.stack([e.context.estimate() for e in experiments])[None]   # (1, E, 3)
    true = np.stack([e.true_angles for e in experiments])[None]
    final = encode_models(result.best_morphology.to_array()[None])
    truth = encode_models(get_damage(result.config.damage).apply(Morphology.healthy()).to_array()[None])
    with Evaluator(result.config.steps, workers=workers, max_batch_robots=result.config.max_batch_robots) as ev:
        def fit(genome, angles):
            return float(model_fitness_from_similarities(ev.similarities(genome, experiments, angles))[0])

        return RunDiagnosis(Path(out_dir), result.config.inference, len(experiments), fit(final, inferred),
                            fit(truth, inferred), fit(final, true), fit(truth, true))
