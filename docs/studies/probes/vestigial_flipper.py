"""How much of a run's OBJ_FIT error is a missing flipper that no response can show (docs/studies/unknown_angles.md).

On ``left_pectoral_missing`` the truth's left pectoral is 0 x 0 x 0. A model whose left
flipper has zero length or span has no paddle face either (zero thickness leaves only the
paddle), and its other two dimensions barely change the response, yet eq. 4 counts their
error in full. For every finished run under
the given directories this prints the final model's OBJ_FIT (eq. 4), the part of its error
that is the missing flipper's three dimensions, and ``1 - sim`` (eq. 2) between the final
model's responses with and without that flipper (all three dimensions set to 0) over
``--actions`` random actions and initial angles: how visible the difference is.

    python docs/studies/probes/vestigial_flipper.py docs/results/lib8_left_pectoral_missing

Works from ``rounds.csv`` alone (no checkpoint). Costs ``2 * actions`` simulations per run
(80 with the default 40: about 1 s on one core).
"""

from __future__ import annotations

import argparse

import numpy as np

from aquafish_gym import ACTION_BOUNDS, MORPHOLOGY_BOUNDS, simulate_batch
from eea.behaviour import behaviour_summary, similarity
from eea.experiment import random_angles
from eea.fitness import objective_fitness
from eea.analysis.plot import find_runs

#: The morphology fields of each flipper, in :data:`aquafish_gym.MORPHOLOGY_BOUNDS` order.
FLIPPER_FIELDS = {"left_pectoral": slice(0, 3), "right_pectoral": slice(3, 6), "caudal": slice(6, 9)}


def error_shares(model: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """``(9,)`` each dimension's share of ``1 - OBJ_FIT`` (eq. 4): ``|model_i - truth_i| /
    (max_i - min_i) / 9``; they sum to ``1 - objective_fitness(model, truth)``."""
    bounds = np.asarray(MORPHOLOGY_BOUNDS)
    return np.abs(np.asarray(model) - np.asarray(truth)) / (bounds[:, 1] - bounds[:, 0]) / len(bounds)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="study or run directories (searched recursively)")
    parser.add_argument("--flipper", choices=sorted(FLIPPER_FIELDS), default="left_pectoral",
                        help="the missing flipper (default: left_pectoral)")
    parser.add_argument("--actions", type=int, default=40, help="random actions and angle sets, >= 1 (default 40)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the random actions and angles (default 0)")
    args = parser.parse_args(argv)
    if args.actions < 1:
        parser.error(f"--actions must be >= 1, got {args.actions}")
    rng = np.random.default_rng(args.seed)
    n = args.actions
    low, high = np.asarray(ACTION_BOUNDS).T
    actions = rng.uniform(low, high, (n, len(low)))
    angles = random_angles(rng, n)
    fields = FLIPPER_FIELDS[args.flipper]
    print(f"{'run':<55} {'OBJ_FIT':>7} {'flipper':>7} {'rest':>6}  {args.flipper} (x, y, z)   "
          f"1-sim median / max")
    missed = []
    for run in find_runs(args.dirs):  # runs with a finished round only
        steps = run.config.steps
        truth = run.target_morphology.to_array()
        model = run.best_morphology.to_array()
        error = error_shares(model, truth)
        removed = model.copy()
        removed[fields] = 0.0
        a = behaviour_summary(simulate_batch(np.tile(model, (n, 1)), actions, angles, steps))
        b = behaviour_summary(simulate_batch(np.tile(removed, (n, 1)), actions, angles, steps))
        gap = 1.0 - np.array([similarity(a[i], b[i]) for i in range(n)])
        obj = float(objective_fitness(model, truth))
        missed.append((error[fields].sum(), np.delete(error, np.r_[fields]).sum()))
        print(f"{str(run.out_dir):<55} {obj:>7.3f} {missed[-1][0]:>7.3f} {missed[-1][1]:>6.3f}  "
              f"{np.array2string(model[fields], precision=3):<22} {np.median(gap):.4f} / {gap.max():.4f}")
    flipper, rest = np.mean(missed, axis=0)  # find_runs raises if it finds no run
    print(f"mean error: {flipper:.3f} on the {args.flipper}, {rest:.3f} on the rest "
          f"(OBJ_FIT with the {args.flipper} right: {1 - rest:.3f})")


if __name__ == "__main__":
    main()
