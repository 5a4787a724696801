"""The similarity landscape over one experiment's initial pectoral angles (docs/studies/unknown_angles.md).

Takes a finished EEA run, one of its target experiments and the true (damaged) morphology,
and simulates the truth from a grid of left x right pectoral initial angles around the
true ones (the caudal fin at its true angle). Prints the grid of ``1 - sim`` (eq. 2,
x 10^4) and its local maxima: the peak at the true angles (sim = 1) and every other basin
an angle search can end in. ``--model final`` maps the run's final model instead, whose
best angles are wherever its own peak is.

    python docs/studies/probes/angle_landscape.py runs/reduced_profile_robust4_cma/profile/1.28s/seed4 --experiment 9

Costs ``grid**2`` simulations (1296 with the default 36: about 20 s on one core).
"""

from __future__ import annotations

import argparse

import numpy as np

from eea.checkpoint import load_state
from eea.encoding import encode_models
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.record import load_result


def local_maxima(grid: np.ndarray) -> list[tuple[int, int]]:
    """Cells of a periodic 2-D grid at least as high as their 8 neighbours, highest first."""
    neighbours = [np.roll(np.roll(grid, di, 0), dj, 1) for di in (-1, 0, 1) for dj in (-1, 0, 1) if di or dj]
    peaks = np.argwhere(np.all([grid >= n for n in neighbours], axis=0))
    return sorted(map(tuple, peaks), key=lambda ij: -grid[ij])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", help="an EEA run directory (config.json, rounds.csv, state.pkl)")
    parser.add_argument("--experiment", type=int, default=0, help="index of the target experiment (default 0)")
    parser.add_argument("--grid", type=int, default=36, help="angles per pectoral flipper, >= 4 (default 36: 10°)")
    parser.add_argument("--model", choices=("truth", "final"), default="truth",
                        help="map the true morphology (default) or the run's final model")
    args = parser.parse_args(argv)
    result, state = load_result(args.run), load_state(args.run)
    if state is None:
        parser.error(f"{args.run} has no checkpoint (state.pkl)")
    experiments = [Experiment.from_state_dict(e) for e in state.experiments]
    if not 0 <= args.experiment < len(experiments):
        parser.error(f"--experiment must be in [0, {len(experiments) - 1}], got {args.experiment}")
    if args.grid < 4:
        parser.error(f"--grid must be >= 4, got {args.grid}")
    experiment = experiments[args.experiment]
    truth = result.target_morphology.to_array()
    morphology = truth if args.model == "truth" else result.best_morphology.to_array()
    n = args.grid
    offsets = np.linspace(-np.pi, np.pi, n, endpoint=False)
    left, right = np.meshgrid(offsets, offsets, indexing="ij")
    angles = np.repeat(experiment.true_angles[None, None], n * n, axis=0)       # (n*n, 1, 3)
    angles[:, 0, 0] = np.mod(angles[:, 0, 0] + left.ravel(), 2 * np.pi)
    angles[:, 0, 1] = np.mod(angles[:, 0, 1] + right.ravel(), 2 * np.pi)
    with Evaluator(result.config.steps, workers=1, max_batch_robots=result.config.runtime.max_batch_robots,
                   params=result.config.sim_params, summary=result.config.behaviour_summary) as evaluator:
        sims = evaluator.similarities(np.repeat(encode_models(morphology[None]), n * n, axis=0), [experiment],
                                      angles)[:, 0].reshape(n, n)
    print(f"{args.run}, experiment {args.experiment}: action {np.round(experiment.action, 3)} (rev/s, rev/s, Hz), "
          f"true angles {np.round(np.degrees(experiment.true_angles), 1)} deg; model: {args.model}")
    step = max(1, n // 12)
    print("1 - sim (x 1e4); rows: left pectoral offset from its true angle, columns: right (deg)")
    print("      " + " ".join(f"{np.degrees(o):5.0f}" for o in offsets[::step]))
    for i in range(0, n, step):
        print(f"{np.degrees(offsets[i]):5.0f} " + " ".join(f"{1e4 * (1 - v):5.0f}" for v in sims[i, ::step]))
    peaks = local_maxima(sims)
    print(f"{len(peaks)} local maxima (left, right offset in deg: 1 - sim):")
    print("  " + ", ".join(f"({np.degrees(offsets[i]):.0f}, {np.degrees(offsets[j]):.0f}): {1 - sims[i, j]:.5f}"
                           for i, j in peaks))


if __name__ == "__main__":
    main()
