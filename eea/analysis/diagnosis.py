"""Why did a run end where it did: a search, an inference or an identifiability failure?

A run's final model is the fittest one the estimation found *under the initial angles its
inference strategy chose*. Scoring the true morphology (an oracle, like OBJ_FIT) on the
same experiments separates three failures:

* ``search``: the true morphology fits the run's experiments better than the final model
  does under the angles the run would give it; the estimation search missed it;
* ``inference``: under those angles the final model fits better, but with each model's own
  best angles (fitted equally hard for both, :meth:`eea.inference.profile.Profile.fit`) the truth
  fits better: the inferred angles favour a wrong morphology (a trap);
* ``identifiability``: even with its own best angles the truth fits no better than the
  final model: once the angles are free, these experiments cannot tell the two apart.

"The angles the run would give" the truth are the inferred ones for the paper's strategies
and the truth's own fitted angles for ``profile``. :func:`diagnose_run` computes these
MOD_FIT numbers (eq. 3) from a run's data, under the true angles too; for ``profile``
also the truth under the angles it would start from if proposed now
(:meth:`eea.inference.profile.Profile.starting_angles`) and, with ``refine`` R > 0, after R
rounds of contender refinement. A run is read as data only (``config.json``, ``rounds.csv``
and ``run_data.npz``, :func:`eea.checkpoint.load_run_data`): its checkpoint, a pickle, is
never loaded, so a run directory received from anyone can be diagnosed. A search failure is
split without a simulation from the models the run scored (:meth:`eea.evaluation.Evaluator.scored_models`): never near the truth,
or ``better_seen`` > 0 scored models with a higher OBJ_FIT (eq. 4) than the final one. A run
whose final model is the truth gets the verdict ``found``. ``aquafish diagnose DIR...`` prints
them per run; docs/studies.md, "Tools for studies", explains the columns.

In the ``morphology+servos`` model space (not the paper's) "the truth" is the damaged
morphology *and* its servo faults' gains (:meth:`eea.encoding.ModelSpace.truth`), and OBJ_FIT
is over the 12 values.

Angles: ``run_error_deg`` is the median error of the run's final inferred angles over its
experiments, ``floor_error_deg`` that of the truth's own fitted angles (the fit above: it
knows the morphology, not the angles), per flipper in degrees as ``rounds.csv``'s inference
error (:attr:`eea.record.RunResult.inference_error_deg`). The fit is a local search from
random starts, so the floor is what this fit attains, not the least error any fit could.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np

from aquafish_gym.rundir import check_fingerprint, refuse_pickles
from eea.checkpoint import RUN_DATA_FILE, load_run_data
from eea.config import EEAConfig
from eea.encoding import get_model_space
from eea.fitness import model_fitness_from_similarities, objective_fitness
from eea.evaluation import Evaluator
from eea.experiment import angle_errors_deg
from eea.inference.profile import Profile
from eea.record import CONFIG_FILE, load_result

__all__ = ["RunDiagnosis", "diagnose_run", "median_error_deg"]


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
            damage has servo faults, which models of the paper's ``morphology`` space do not
            simulate; in ``morphology+servos`` the truth includes the faults' gains, 1.0).
        final_profiled: the final model under its own best angles
            (:meth:`eea.inference.profile.Profile.fit`, started from the inferred angles too).
        true_profiled: the true morphology under its own best angles, fitted as hard.
        per_model: whether the run's strategy gives every model its own angles
            (``profile``); then the truth's angles in the run are its profiled ones.
        true_proposed: ``profile`` runs only (else None): the true morphology under the
            angles it would start from if proposed at the end of the run (see the module
            docstring).
        true_refined: ``profile`` runs with ``refine`` > 0 only (else None): the proposed
            truth after ``refine`` rounds of contender refinement.
        seen: distinct models the run's estimation scored (None: no cache in the checkpoint).
        closest_seen: the highest OBJ_FIT (eq. 4) among them (None with ``seen``).
        better_seen: how many of them have a higher OBJ_FIT than the final model (None with
            ``seen``).
        found: whether the final model is the true morphology (then there is no failure).
        run_error_deg: ``(3,)`` median over the experiments of the distance between the
            run's final inferred angles and the true ones (degrees; left, right pectoral,
            caudal; None if not computed).
        floor_error_deg: ``(3,)`` the same for the truth's own fitted angles (the fit of
            ``true_profiled``): the error the true morphology itself is left with.
        true_fitted_angles: ``(E, 3)`` those fitted angles (rad), or None.
    """

    out_dir: Path
    inference: str
    experiments: int
    final_inferred: float
    true_inferred: float
    final_true_angles: float
    true_true_angles: float
    final_profiled: float
    true_profiled: float
    per_model: bool = False
    true_proposed: float | None = None
    true_refined: float | None = None
    seen: int | None = None
    closest_seen: float | None = None
    better_seen: int | None = None
    found: bool = False
    run_error_deg: np.ndarray | None = dataclasses.field(default=None, compare=False)
    floor_error_deg: np.ndarray | None = dataclasses.field(default=None, compare=False)
    true_fitted_angles: np.ndarray | None = dataclasses.field(default=None, compare=False)

    @property
    def verdict(self) -> str:
        """``"found"`` if the run ended at the truth, else ``"search"``, ``"inference"`` or
        ``"identifiability"`` (see the module docstring)."""
        if self.found:
            return "found"
        final_in_run = self.final_profiled if self.per_model else self.final_inferred
        true_in_run = self.true_profiled if self.per_model else self.true_inferred
        if true_in_run > final_in_run:
            return "search"
        return "inference" if self.true_profiled > self.final_profiled else "identifiability"


def diagnose_run(out_dir: str | os.PathLike, workers: int = 1, *, profile_generations: int = 40,
                 seed: int = 0, refine: int = 0) -> RunDiagnosis:
    """Score the final and the true morphology on a finished (or partial) run's experiments.

    Runs ``4 E`` simulations (``5 E`` for a ``profile`` run), plus about ``2 E (17 + 4 G)``
    to fit both models' own angles (:class:`~eea.inference.profile.Profile` with 4 proposals and 16
    random starts, ``G = profile_generations``), ``E`` = the number of experiments in the
    run's checkpoint; ``2 E (proposals + 1) + refine proposals E`` more with ``refine``.

    Args:
        out_dir: an EEA run directory with its data (``run_data.npz``, written with every
            checkpoint).
        workers: simulation processes.
        profile_generations: generations of the per-model angle fit, >= 1.
        seed: seeds the angle fit (and the random angles of a ``profile`` run's proposed
            truth for experiments nobody has angles for).
        refine: ``profile`` runs: contender-refinement rounds for ``true_refined``, >= 0
            (0: not computed).

    Returns:
        The :class:`RunDiagnosis`.

    Raises:
        ValueError: if ``out_dir`` is not a run directory or has no finished round, or
            ``profile_generations < 1`` or ``refine < 0``; its data file is missing, damaged, of
            another run or out of step with its ``rounds.csv`` (:class:`~aquafish_gym.rundir.FileError`
            or :class:`~aquafish_gym.rundir.MismatchError`, naming it).
    """
    if refine < 0:
        raise ValueError(f"refine must be >= 0, got {refine}")
    with refuse_pickles(f"{out_dir} is diagnosed as data"):
        return _diagnose(out_dir, workers, profile_generations, seed, refine)


def _diagnose(out_dir, workers: int, profile_generations: int, seed: int, refine: int) -> RunDiagnosis:
    result = load_result(out_dir)
    data = load_run_data(out_dir)
    if not result.rounds:
        raise ValueError(f"{out_dir} has no finished round to diagnose")
    path = Path(out_dir) / RUN_DATA_FILE
    if data is None:
        raise ValueError(f"{out_dir} has no {RUN_DATA_FILE}: diagnose reads a run's experiments from it, as data "
                         "(never from the checkpoint state.pkl, a pickle); run the command that made the run again "
                         "(`aquafish eea`, `study` or `case-study`, the same settings) to write it from its checkpoint")
    # through from_dict: a run written before the sections holds a flat config (eea.compat)
    check_fingerprint(path, EEAConfig.from_dict(data.config).result_fields(), result.config.result_fields(),
                      f"its {CONFIG_FILE} does not describe the run's data (edited, or copied from another run); "
                      "restore the run's own config.json")
    if data.rounds_done != len(result.rounds):
        raise ValueError(f"{path} holds {data.rounds_done} rounds, {Path(out_dir) / 'rounds.csv'} "
                         f"{len(result.rounds)}: run the command that made the run again (`aquafish eea`, `study` or "
                         "`case-study`, the same settings) to bring them in step")
    experiments = list(data.experiments)
    inferred = np.stack([e.context.estimate() for e in experiments])[None]   # (1, E, 3)
    true = np.stack([e.true_angles for e in experiments])[None]
    space = result.model_space
    final = space.encode(result.best_model[None])
    true_dims = result.true_model
    truth = space.encode(true_dims[None])
    seen = _seen(data.evaluator, result.config.steps, true_dims, result.best_model, space)
    with Evaluator(result.config.steps, workers=workers, max_batch_robots=result.config.runtime.max_batch_robots,
                   params=result.config.sim_params, model_space=space,
                   summary=result.config.behaviour_summary) as ev:
        def fit(genome, angles):
            return float(model_fitness_from_similarities(ev.similarities(genome, experiments, angles))[0])

        scores = [fit(final, inferred), fit(truth, inferred), fit(final, true), fit(truth, true)]
        both = np.concatenate([final, truth])
        distinct = both[:1] if (both[0] == both[1]).all() else both  # the run may have found the truth
        proposed = refined = None
        if result.config.inference.name == "profile" and data.inference:
            inference = data.chosen_inference  # a lineage run: the chosen lineage's
            remembered = Profile.from_settings(result.config.inference)  # the run's inherit rule
            remembered.load_state_dict(inference)
            proposed = fit(truth, remembered.starting_angles(truth, len(experiments), np.random.default_rng(seed)))
            if refine:
                refined = _refined_truth(inference, distinct, experiments, ev, result.config, refine, seed)
        fitted_angles, fitted = Profile(proposals=4, initial=16).fit(
            distinct, experiments, ev, np.random.default_rng(seed), profile_generations,
            start=np.repeat(inferred, len(distinct), axis=0))
        profiled = np.resize(fitted, 2)  # (final, truth): one fit serves both when they coincide
        return RunDiagnosis(Path(out_dir), result.config.inference.name, len(experiments), *scores,
                            float(profiled[0]), float(profiled[1]), per_model=result.config.inference.name == "profile",
                            true_proposed=proposed, true_refined=refined, found=len(distinct) == 1, **seen,
                            run_error_deg=median_error_deg(inferred[0], true[0]),
                            floor_error_deg=median_error_deg(fitted_angles[-1], true[0]),
                            true_fitted_angles=fitted_angles[-1])


def median_error_deg(angles, true_angles) -> np.ndarray:
    """Median initial-angle error per flipper over experiments.

    Args:
        angles: ``(E, 3)`` initial angles (rad; left, right pectoral, caudal), E >= 1.
        true_angles: ``(E, 3)`` the true ones, likewise.

    Returns:
        ``(3,)`` degrees: the median over the E experiments of the distance, the short way
        round the circle for the pectorals (at most 180) and on the line for the caudal fin,
        as :attr:`eea.record.RunResult.inference_error_deg` measures it.

    Raises:
        ValueError: if the shapes are not both ``(E, 3)`` with E >= 1, or an angle is not finite.
    """
    angles, true_angles = np.asarray(angles, dtype=np.float64), np.asarray(true_angles, dtype=np.float64)
    if angles.ndim != 2 or angles.shape[1] != 3 or angles.shape != true_angles.shape or not len(angles):
        raise ValueError(f"angles and true_angles must both be (E, 3) with E >= 1, got {angles.shape} and "
                         f"{true_angles.shape}")
    return np.median(angle_errors_deg(angles, true_angles), axis=0)


def _seen(cache: dict, steps: int, true_dims: np.ndarray, final_dims: np.ndarray, model_space="morphology") -> dict:
    """``seen``, ``closest_seen`` and ``better_seen`` of :class:`RunDiagnosis` from a checkpoint's
    evaluator state (all None if it has none), read by an evaluator of its own so that the
    diagnosis's simulations, the truth's among them, are not counted."""
    if not cache:
        return {}
    space = get_model_space(model_space)
    evaluator = Evaluator(steps, model_space=space)
    evaluator.load_state_dict(cache)
    genomes, _ = evaluator.scored_models()
    if not len(genomes):
        return {"seen": 0}
    objective = objective_fitness(space.decode(genomes), true_dims, space.bounds)
    final = objective_fitness(final_dims, true_dims, space.bounds)
    return {"seen": len(genomes), "closest_seen": float(objective.max()),
            "better_seen": int((objective > final + 1e-12).sum())}


def _refined_truth(memory: dict, genomes, experiments, evaluator, config, refine: int, seed: int) -> float:
    """The truth's MOD_FIT after one generation with contender refinement; ``genomes`` are the
    distinct (final, truth) models, the truth last (alone if the run found it)."""
    settings = config.inference
    profile = Profile(settings.proposals, settings.initial, refine=refine, contenders=1, library=settings.library)
    profile.load_state_dict(memory)
    profile.before_generation(0, genomes, experiments, evaluator, np.random.default_rng(seed), genomes=genomes)
    angles = profile.angles(experiments, genomes[-1:], None)
    return float(model_fitness_from_similarities(evaluator.similarities(genomes[-1:], experiments, angles))[0])
