"""How far the unknown initial angles move a response, next to how far a wrong morphology does.

The paper's inference strategies exist because the initial flipper angles change the robot's
response. How much they do decides what inference can win: if another start moves the truth's
behaviour summary as far as a random morphology does, the experiments tell morphologies apart
only once the angles are fitted. For every experiment length, over ``--actions`` random actions
(each with its own random true angles), this prints the mean dissimilarity ``1 - sim``
(eq. 2, the run's summary) of the target's response at its true angles against

* ``other angles``: the target itself from another random start (what the unknown angles alone do);
* ``zero angles``: the target from angles 0, 0, 0 (the paper's ``none`` baseline, Figure 6);
* ``design``: the undamaged robot at the true angles (what the damage does);
* ``OBJ_FIT 0.9`` and ``OBJ_FIT 0.8``: ``--models`` models near the truth, every dimension moved
  by 10 % (20 %) of its range up or down at random (clipped to the range; OBJ_FIT, eq. 4, about
  0.9 and 0.8: where ``known`` and the paper's out-of-band end), at the true angles;
* ``random model``: ``--models`` random model genomes at the true angles (what a wrong
  morphology does when the angles are known; the models of a run's first generation);
* ``no left length``: the truth with its left pectoral's length 0 (a vanished flipper, whose
  angle no longer matters: the model grid's zero level, a suspected attractor under unknown
  angles);
* every model group also from other random starts (``<group>@other``: a wrong morphology and
  wrong angles, what a search sees while its angles are wrong);

the ratio of the first to the models at OBJ_FIT 0.9, and the share of actions on which another
start moves the target further than the median model at OBJ_FIT 0.8 does at known angles
(then the angles hide the difference between a model at 0.8 and the truth). Deep water (the
paper's robot) unless ``--surface``; ``--rates`` summarises the angular rates (a gyroscope's
signal) instead of the angles, ``--max`` sets eq. 2's MAX.

    python docs/studies/probes/angle_sensitivity.py                     # left_pectoral_half, 1.28-10.24 s
    python docs/studies/probes/angle_sensitivity.py --damage caudal_half --durations 1.28
    python docs/studies/probes/angle_sensitivity.py --rates --max 1000 --durations 1.28   # a gyroscope

Cost: ``actions * (4 + 8 * models)`` simulations per duration (3,360 with the defaults), about two
minutes on one core for all four durations.
"""

from __future__ import annotations

import argparse

import numpy as np

from aquafish_gym import ACTION_BOUNDS, MORPHOLOGY_BOUNDS, Morphology, SimParams, get_damage, simulate_batch
from aquafish_gym.params import DT_S
from eea.behaviour import MAX_COEFFICIENT, behaviour_summary, similarity
from eea.encoding import MODEL_BITS, decode_models
from eea.experiment import random_angles
from eea.fitness import objective_fitness

#: The paper's four experiment lengths (s), section 4.
PAPER_DURATIONS_S = (1.28, 2.56, 5.12, 10.24)


def near_models(truth: np.ndarray, share: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n, 9)`` models with every dimension of ``truth`` moved by ``share`` of its range up or
    down at random, clipped to the range (so OBJ_FIT, eq. 4, is at least ``1 - share``)."""
    bounds = np.asarray(MORPHOLOGY_BOUNDS)
    step = share * (bounds[:, 1] - bounds[:, 0]) * rng.choice([-1.0, 1.0], (n, len(bounds)))
    return np.clip(truth + step, bounds[:, 0], bounds[:, 1])


def rates_log(imu_log: np.ndarray) -> np.ndarray:
    """``(N, steps, 3)`` angular rates (degrees/s) of an IMU log of orientations: the first
    difference over 0.01 s, from the level robot at rest heading +y (0, 0, 0) before step 1."""
    log = np.asarray(imu_log, dtype=np.float64)
    return np.diff(log, axis=1, prepend=np.zeros_like(log[:, :1])) / DT_S


def dissimilarities(truth: np.ndarray, design: np.ndarray, groups: dict[str, np.ndarray], actions: np.ndarray,
                    angles: np.ndarray, other: np.ndarray, model_other: np.ndarray, steps: int, params: SimParams,
                    signed: bool = False, rates: bool = False,
                    max_coefficient: float = MAX_COEFFICIENT) -> dict[str, np.ndarray]:
    """The mean ``1 - sim`` per action of each comparison of the module docstring.

    Args:
        truth, design: ``(9,)`` the target's and the undamaged robot's morphologies.
        groups: name -> ``(M, 9)`` wrong morphologies, each simulated at the true angles and
            from its row of ``model_other``.
        actions: ``(A, 3)`` servo commands.
        angles, other: ``(A, 3)`` the true and another start per action (rad).
        model_other: ``(A, M, 3)`` the models' other starts.
        steps: simulation steps (0.01 s).
        params: the simulator's parameters.
        signed: the signed summary (``signed_dft``) instead of the paper's.
        rates: summarise the angular rates (:func:`rates_log`, a gyroscope's signal) instead of
            the orientation angles.
        max_coefficient: MAX of eq. 2.

    Returns:
        name -> ``(A,)`` dissimilarities: ``other angles``, ``zero angles``, ``design``, and per
        group its mean over its models at the true angles (and their median,
        ``"<group>, median"``) and from the other starts (``"<group>, other angles"``).

    Raises:
        ValueError: a group without one model per other start.
    """
    names = list(groups)
    m = len(model_other[0])
    if any(len(g) != m for g in groups.values()):
        raise ValueError(f"every group needs {m} models (one per other start), got {[len(g) for g in groups.values()]}")
    morph = np.concatenate([np.tile(truth, (3, 1)), design[None], *[np.concatenate([g, g]) for g in groups.values()]])
    summaries = []
    for k in range(len(actions)):
        per_group = np.concatenate([np.tile(angles[k], (m, 1)), model_other[k]])    # at the true angles, then other
        start = np.concatenate([angles[k][None], other[k][None], np.zeros((1, 3)), angles[k][None],
                                np.tile(per_group, (len(names), 1))])
        log = simulate_batch(morph, np.tile(actions[k], (len(morph), 1)), start, steps, params=params)
        summaries.append(behaviour_summary(rates_log(log) if rates else log, signed=signed))
    s = np.stack(summaries)                      # (A, rows, 3, bins)
    d = 1.0 - similarity(s[:, :1], s[:, 1:], max_coefficient)   # (A, rows - 1): against the target at its true angles
    out = {"other angles": d[:, 0], "zero angles": d[:, 1], "design": d[:, 2]}
    for i, name in enumerate(names):
        at_true, at_other = d[:, 3 + 2 * m * i:3 + 2 * m * i + m], d[:, 3 + 2 * m * i + m:3 + 2 * m * (i + 1)]
        out[name], out[f"{name}, median"] = at_true.mean(axis=1), np.median(at_true, axis=1)
        out[f"{name}, other angles"] = at_other.mean(axis=1)
    return out


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--damage", default="left_pectoral_half", help="the target (default: the paper's case study)")
    parser.add_argument("--durations", default=",".join(map(str, PAPER_DURATIONS_S)),
                        help="experiment lengths in s, comma-separated (default: the paper's four)")
    parser.add_argument("--actions", type=int, default=40, help="random actions, >= 1 (default 40)")
    parser.add_argument("--models", type=int, default=10, help="random models, >= 1 (default 10)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the actions, angles and models (default 0)")
    parser.add_argument("--surface", action="store_true", help="the surface swimmer instead of deep water")
    parser.add_argument("--signed", action="store_true", help="the signed summary (signed_dft)")
    parser.add_argument("--rates", action="store_true",
                        help="summarise the angular rates (degrees/s, a gyroscope's signal) instead of the angles")
    parser.add_argument("--max", type=float, default=MAX_COEFFICIENT,
                        help=f"MAX of eq. 2 (default the paper's {MAX_COEFFICIENT:g}; large: no coefficient clips, "
                             "so the columns are mean coefficient distances over MAX)")
    args = parser.parse_args(argv)
    if not args.max > 0:
        parser.error(f"--max must be > 0, got {args.max}")
    if args.actions < 1 or args.models < 1:
        parser.error(f"--actions and --models must be >= 1, got {args.actions} and {args.models}")
    try:
        durations = [float(d) for d in args.durations.split(",")]
    except ValueError:
        parser.error(f"--durations must be numbers of seconds, comma-separated, got {args.durations!r}")
    params = SimParams() if args.surface else SimParams(waterline=None)
    rng = np.random.default_rng(args.seed)
    low, high = np.asarray(ACTION_BOUNDS).T
    actions = rng.uniform(low, high, (args.actions, 3))
    angles, other = random_angles(rng, args.actions), random_angles(rng, args.actions)
    model_other = random_angles(rng, args.actions * args.models).reshape(args.actions, args.models, 3)
    truth, design = get_damage(args.damage).apply().to_array(), Morphology.healthy().to_array()
    groups = {"OBJ_FIT 0.9": near_models(truth, 0.1, args.models, rng), "OBJ_FIT 0.8": near_models(truth, 0.2, args.models, rng),
              "random model": np.atleast_2d(decode_models(rng.integers(0, 2, (args.models, MODEL_BITS)))),
              "no left length": np.tile(np.where(np.arange(9) == 1, 0.0, truth), (args.models, 1))}
    print(f"{args.damage}, {'surface' if args.surface else 'deep water'}, {'signed_dft' if args.signed else 'dft'} of "
          f"{'angular rates' if args.rates else 'orientation angles'}, MAX {args.max:g}, {args.actions} actions, "
          f"{args.models} models a group: mean 1 - sim (eq. 2) against the target at its true angles")
    print("models' mean OBJ_FIT: " + ", ".join(f"{n} {np.mean([objective_fitness(m, truth) for m in g]):.3f}"
                                               for n, g in groups.items()) + f", design {objective_fitness(design, truth):.3f}")
    names = ["other angles", "zero angles", "design", *groups]
    print(f"{'duration':>9} " + " ".join(f"{n:>14}" for n in names) + "".join(f" {n.replace('OBJ_FIT ', '')[:8] + '@other':>14}" for n in groups)
          + "  other / 0.9  other angles > median OBJ_FIT 0.8")
    for duration in durations:
        steps = int(round(duration / DT_S))
        d = dissimilarities(truth, design, groups, actions, angles, other, model_other, steps, params, args.signed,
                            args.rates, args.max)
        further = float(np.mean(d["other angles"] > d["OBJ_FIT 0.8, median"]))
        ratio = d["other angles"].mean() / d["OBJ_FIT 0.9"].mean()
        print(f"{duration:>8.2f}s " + " ".join(f"{d[n].mean():>14.3g}" for n in names)
              + "".join(f" {d[n + ', other angles'].mean():>14.3g}" for n in groups) + f"  {ratio:>11.2f}"
              + f"  {further:>6.0%}")


if __name__ == "__main__":
    main()
