"""How well can free initial angles make a wrong model fit the target? (docs/studies/unknown_angles.md).

Performs 5 (``--experiments``) experiments on the ``left_pectoral_half`` target, then fits every candidate
model's initial angles for every experiment equally hard (:class:`eea.inference.profile.Profile`,
4 proposals, 16 random starts, 60 generations) and prints each model's OBJ_FIT (eq. 4) beside
its profiled MOD_FIT (eq. 3). The candidates are the truth, 4 models 3 bits away from it,
and 8 random models, the same in every setting (drawn from their own seed). If random
models come as close to 1 as the truth does, the experiments cannot tell morphologies
apart once the angles are unknown, whatever the inference.

    python docs/studies/probes/angle_identifiability.py --duration 1.28 --actions random
    python docs/studies/probes/angle_identifiability.py --duration 5.12 --actions fast   # full-speed pectorals
"""

from __future__ import annotations

import argparse

import numpy as np

from eea.behaviour import behaviour_summary
from eea.encoding import ACTION_BITS, decode_actions, decode_models, encode_models
from eea.evaluation import Evaluator
from eea.experiment import Context, Experiment
from eea.fitness import model_fitness_from_similarities, objective_fitness
from eea.inference.profile import Profile
from eea.target import Target

#: Full-speed pectoral actions (rev/s, rev/s, Hz) of ``--actions fast``.
FAST_ACTIONS = np.array([[0.5, 0.5, 1.0], [-0.5, 0.5, 0.5], [0.5, -0.5, 1.0], [-0.5, -0.5, 0.25], [0.5, 0.5, 0.0]])


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=1.28, help="experiment length in seconds (default 1.28)")
    parser.add_argument("--actions", choices=("random", "fast"), default="random",
                        help="5 random actions, or 5 full-speed pectoral actions (default random)")
    parser.add_argument("--damage", default="left_pectoral_half")
    parser.add_argument("--generations", type=int, default=60, help="angle-fitting generations (default 60)")
    parser.add_argument("--experiments", type=int, default=5, help="experiments (default 5; fast actions repeat)")
    parser.add_argument("--seed", type=int, default=11)
    args = parser.parse_args(argv)
    steps = round(args.duration / 0.01)
    rng = np.random.default_rng(args.seed)
    target = Target(args.damage, steps, rng)
    experiments = []
    for i in range(args.experiments):
        action = FAST_ACTIONS[i % len(FAST_ACTIONS)] if args.actions == "fast" else decode_actions(rng.integers(0, 2, ACTION_BITS, dtype=np.uint8))
        log, true = target.perform(action)
        experiments.append(Experiment(i, action, log, behaviour_summary(log), true, Context.exact(true)))
    experiments = tuple(experiments)
    truth = encode_models(target.morphology.to_array()[None])
    models_rng = np.random.default_rng(args.seed + 1)  # the same candidates whatever the experiments
    near = np.repeat(truth, 4, axis=0)
    for k in range(4):
        near[k, models_rng.choice(45, 3, replace=False)] ^= 1
    genomes = np.concatenate([truth, near, models_rng.integers(0, 2, (8, 45), dtype=np.uint8)])
    obj = objective_fitness(decode_models(genomes), target.morphology.to_array())
    with Evaluator(steps) as evaluator:
        _, fitted = Profile(proposals=4, initial=16).fit(genomes, experiments, evaluator, np.random.default_rng(0),
                                                         args.generations)
        true_angles = np.stack([e.true_angles for e in experiments])[None]
        at_truth = model_fitness_from_similarities(evaluator.similarities(truth, experiments, true_angles))[0]
    print(f"{args.damage}, {args.experiments} {args.actions} actions of {args.duration} s; the truth at its true angles: MOD_FIT {at_truth:.4f}")
    for name, rows in (("truth", slice(0, 1)), ("3 bits off", slice(1, 5)), ("random", slice(5, 13))):
        print(f"{name:>10}: OBJ_FIT {np.round(obj[rows], 3).tolist()}  profiled MOD_FIT {np.round(fitted[rows], 4).tolist()}")


if __name__ == "__main__":
    main()
