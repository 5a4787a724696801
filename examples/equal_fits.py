"""Does the truth beat a finished run's final model when both get the same angle fit?

A run under unknown initial angles ends on a wrong model either because the search never
proposed the truth with angles good enough to win (a search failure) or because the truth,
however well its angles are fitted, explains the experiments no better (identifiability).
This script tells the two apart for finished runs from their ``rounds.csv`` and
``config.json`` alone, so it works on ``docs/results`` where no checkpoint is kept: it
simulates the target again under each round's action and true initial angles (the
rebuilt experiments reproduce the run's exactly), then fits the angles of the true
morphology and of the run's final model equally, from scratch
(:meth:`eea.inference.profile.Profile.fit`), at three budgets:

* ``fit5`` and ``fit15``: 5 or 15 generations of the profile's random perturbations from
  8 random starts per experiment (a newcomer's fit in a run is of this order),
* ``hard``: 30 generations, then 2 cycles of :meth:`eea.inference.profile.Profile.scan_angles` and
  :meth:`eea.inference.profile.Profile.polish_angles`,

each averaged over ``--fits`` fit seeds. It prints, per budget, the truth's MOD_FIT minus
the final model's (positive: the truth wins) and the final model's deficit 1 - MOD_FIT,
and the truth's mean loss when one angle is 0.1 rad off its true value (the caudal fin's
0.025 rad): the cone of docs/studies/unknown_angles.md, "The angle cone".

    python examples/equal_fits.py docs/results/lph_keep3_scan1/profile/1.28s/seed{2,4}

Costs about 5000 simulations per run and fit seed at 10 experiments (about 10 s
on one core at 1.28 s).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from eea.encoding import encode_models
from eea.evaluation import Evaluator
from eea.experiment import CAUDAL_LIMIT_RAD, Experiment
from eea.inference.profile import Profile
from eea.record import read_config
from eea.replay import replay_run

#: Fit budgets: (name, random-perturbation generations, scan + polish afterwards).
BUDGETS = (("fit5", 5, False), ("fit15", 15, False), ("hard", 30, True))
#: How far each flipper's angle is moved for the cone (rad): pectorals, caudal fin.
CONE_OFFSET_RAD = np.array([0.1, 0.1, 0.025])


def rebuild(run_dir) -> tuple[list[Experiment], np.ndarray, np.ndarray, float]:
    """A finished run's experiments, the true morphology, the final model and its OBJ_FIT.

    Returns:
        ``(experiments, truth, final, objective_fitness)``: the E experiments
        (:func:`eea.replay.rebuild_experiments`), ``(9,)`` true and final morphologies
        (simulator units), and the run's last ``objective_fitness``.

    Raises:
        ValueError: if ``run_dir`` is not a run directory or has no rounds yet.
    """
    result, experiments = replay_run(run_dir)
    return (experiments, result.target_morphology.to_array(), result.best_morphology.to_array(),
            float(result.rounds[-1]["objective_fitness"]))


def fitted(evaluator, genomes, experiments, seed: int, generations: int, hard: bool) -> np.ndarray:
    """``(P,)`` MOD_FIT of distinct ``(P, 45)`` genomes, each with its own angles fitted from scratch."""
    profile = Profile()
    angles, fitness = profile.fit(genomes, experiments, evaluator, np.random.default_rng(seed), generations)
    if hard:
        sims = evaluator.similarities(genomes, experiments, angles)
        profile.scan_angles(genomes, angles, sims, experiments, evaluator, 2)
        profile.polish_angles(genomes, angles, sims, experiments, evaluator)
        fitness = sims.mean(axis=1)
    return fitness


def cone_loss(evaluator, truth_genome, experiments) -> np.ndarray:
    """``(3,)`` the truth's mean similarity lost with one flipper's angle off by CONE_OFFSET_RAD."""
    true = np.stack([e.true_angles for e in experiments])
    moved = np.repeat(true[None], 3, axis=0)
    moved[np.arange(3), :, np.arange(3)] += CONE_OFFSET_RAD[:, None]
    moved[..., 2] = np.clip(moved[..., 2], -CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD)
    return 1.0 - evaluator.similarities(np.repeat(truth_genome, 3, axis=0), experiments, moved).mean(axis=1)


def compare(run_dir, fits: int) -> dict:
    """The numbers one output line shows, for one run."""
    experiments, truth, final, obj = rebuild(run_dir)
    genomes = encode_models(np.stack([truth, final]))
    if (genomes[0] == genomes[1]).all():
        raise ValueError(f"{run_dir}: the final model is the truth; nothing to compare")
    evaluator = Evaluator(len(experiments[0].imu_log), params=read_config(run_dir).sim_params)   # the run's physics
    true = np.stack([e.true_angles for e in experiments])
    out = {"obj": obj, "at_true": float(evaluator.similarities(genomes[:1], experiments, true[None]).mean()),
           "cone": cone_loss(evaluator, genomes[:1], experiments)}
    for name, generations, hard in BUDGETS:
        fitness = np.mean([fitted(evaluator, genomes, experiments, s, generations, hard) for s in range(fits)], axis=0)
        out[name] = (float(fitness[0] - fitness[1]), float(1.0 - fitness[1]))
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", type=Path, help="finished run directories (rounds.csv + config.json)")
    parser.add_argument("--fits", type=int, default=2, help="fit seeds averaged per budget (default 2)")
    args = parser.parse_args(argv)
    if args.fits < 1:
        parser.error(f"--fits must be >= 1, got {args.fits}")
    print("truth - final model MOD_FIT under equal fits (final model's deficit 1 - MOD_FIT in brackets); "
          "cone: the truth's loss with one angle 0.1 rad off (caudal 0.025)")
    for run_dir in args.runs:
        r = compare(run_dir, args.fits)
        fits = " ".join(f"{name} {r[name][0]:+.5f} ({r[name][1]:.5f})" for name, _, _ in BUDGETS)
        print(f"{run_dir} OBJ {r['obj']:.3f}: truth at true angles {r['at_true']:.6f}; cone L/R/C "
            f"{' / '.join(f'{v:.5f}' for v in r['cone'])}; {fits}")


if __name__ == "__main__":
    main()
