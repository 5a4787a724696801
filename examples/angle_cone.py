"""How narrow the true morphology's MOD_FIT peak is in its initial angles (docs/studies/unknown_angles.md).

For a finished ``profile`` run (its directory still holding the checkpoint ``state.pkl``)
this takes the run's experiments and prints

* the true morphology's similarity (eq. 2) at each experiment's true angles (1: the target
  is the same simulator) and what it loses, averaged over the experiments, when one
  flipper's angle is moved by 1, 2, 3, 5, 10 and 20 degrees (the caudal fin by a quarter of
  that, its sweep being +-30 degrees);
* the run's final model (the profile's best), its MOD_FIT (eq. 3) under its remembered
  angles and after :meth:`eea.inference.profile.Profile.polish_angles`;
* the truth judged under the final model's angles, and after the same polish: whether the
  truth, proposed with the incumbent's angles and polished, beats the incumbent.

    python examples/angle_cone.py runs/lph_keep3/profile/1.28s/seed10

Costs about 2000 simulations (a few seconds on one core at 1.28 s).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from aquafish_gym import get_damage
from eea.checkpoint import load_state
from eea.encoding import decode_models, encode_models, genomes_from_keys, MODEL_BITS
from eea.config import EEAConfig
from eea.evaluation import Evaluator
from eea.experiment import CAUDAL_LIMIT_RAD, Experiment, angle_errors_deg
from eea.fitness import objective_fitness
from eea.inference.profile import Profile

#: Angle offsets of the scan (degrees); the caudal fin's are a quarter of these.
OFFSETS_DEG = np.array([1.0, 2.0, 3.0, 5.0, 10.0, 20.0])
_FLIPPER_SCALE = np.array([1.0, 1.0, 0.25])


def cone(evaluator, truth_genome, experiments) -> np.ndarray:
    """``(3, len(OFFSETS_DEG))`` mean similarity lost by the truth when one flipper's true
    angle (rows: left, right pectoral, caudal) is moved by each offset, over the experiments."""
    true = np.stack([e.true_angles for e in experiments])
    loss = np.empty((3, len(OFFSETS_DEG)))
    for flipper in range(3):
        moved = np.repeat(true[None], len(OFFSETS_DEG), axis=0)                     # (O, E, 3)
        moved[:, :, flipper] += np.radians(OFFSETS_DEG * _FLIPPER_SCALE[flipper])[:, None]
        moved[..., 2] = np.clip(moved[..., 2], -CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD)
        sims = evaluator.similarities(np.repeat(truth_genome, len(OFFSETS_DEG), axis=0), experiments, moved)
        loss[flipper] = 1.0 - sims.mean(axis=1)
    return loss


def polished(evaluator, genome, angles, experiments) -> tuple[float, float, np.ndarray]:
    """MOD_FIT of ``genome`` under ``(E, 3)`` angles, before and after the polish, and the polished angles."""
    angles = np.array(angles, dtype=np.float64)[None]
    sims = evaluator.similarities(genome, experiments, angles)
    before = float(sims.mean())
    Profile().polish_angles(genome, angles, sims, experiments, evaluator)
    return before, float(sims.mean()), angles[0]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a finished profile run's directory (with state.pkl)")
    args = parser.parse_args(argv)
    state = load_state(args.run)
    if state is None or state.config.get("inference") != "profile":
        raise SystemExit(f"{args.run}: no checkpoint of a profile run (state.pkl) here")
    experiments = [Experiment.from_state_dict(e) for e in state.experiments]
    evaluator = Evaluator(len(experiments[0].imu_log),
                          params=EEAConfig.from_dict(state.config).sim_params)   # the run's physics
    truth = get_damage(state.config["damage"]).apply().to_array()
    truth_genome = encode_models(truth[None])
    memory, best = state.inference["memory"], state.inference["best"]
    best_genome = genomes_from_keys([best], MODEL_BITS)
    true = np.stack([e.true_angles for e in experiments])

    at_true = evaluator.similarities(truth_genome, experiments, true[None])[0]
    print(f"{args.run}: {len(experiments)} experiments, {evaluator.steps} steps")
    print(f"truth at its true angles: similarity {at_true.min():.6f} - {at_true.max():.6f}")
    print("similarity lost by the truth, mean over experiments, one flipper moved by (deg):")
    print(f"{'':>8} " + " ".join(f"{d:>8g}" for d in OFFSETS_DEG) + "   (caudal: a quarter of these)")
    for name, row in zip(("left", "right", "caudal"), cone(evaluator, truth_genome, experiments)):
        print(f"{name:>8} " + " ".join(f"{v:8.5f}" for v in row))
    incumbent = decode_models(best_genome)[0]
    before, after, _ = polished(evaluator, best_genome, memory[best][0], experiments)
    print(f"final model (OBJ_FIT {objective_fitness(incumbent, truth):.3f}): MOD_FIT {before:.5f}, polished {after:.5f}")
    t_before, t_after, t_angles = polished(evaluator, truth_genome, memory[best][0], experiments)
    error = angle_errors_deg(t_angles, true)
    print(f"truth under the final model's angles: MOD_FIT {t_before:.5f}, polished {t_after:.5f} "
          f"({'beats' if t_after > after else 'loses to'} the polished final model); "
          f"median angle error after the polish L / R / C {' / '.join(f'{v:.1f}' for v in np.median(error, 0))} deg")


if __name__ == "__main__":
    main()
