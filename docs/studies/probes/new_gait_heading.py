"""Does a mission's new gait hold the mission's heading over minutes? The gait alone, on the true model.

A mission's new gait continues the prior's NEAT population on the new self-model
(:func:`gait.evolve_from_population`). Here the self-model is the true damaged robot, so what
is measured is the gait's fitness and nothing of the identification: each variant of the new
gait's fitness is evolved from the same prior population with the ``quick`` case study's
NEAT population (30) and, unless the variant says otherwise, its 12 generations, then swims ``--swim-s`` seconds
on the damaged robot from start headings of -90, -45, 0, 45 and 90 degrees (the robot's
heading when its new gait takes over is whatever the experiments left). Its score is the
displacement along the mission's heading (+y) per second, as a share of the oracle's speed
(a gait evolved from scratch on the damaged robot, scored as the mission scores it).

Variants (``--variants``):

* ``heading20``: every episode starts headed along +y, 20 s (the mission's new gait up to now);
* ``heading60``: the same, 60 s episodes (three times the simulation);
* ``spread45``: the two episodes start turned by -45 and +45 degrees, 20 s, scored along +y,
  so the gait is selected to turn to the mission's heading (its observation holds the yaw);
* ``spread90``: the same from -90 and +90 degrees;
* ``spread4``: four episodes a genome (twice the simulation), from -135, -45, 45 and 135 degrees;
* ``spread4_g24``: the same for 24 generations (four times the simulation);
* ``spread4_40s``: the same as ``spread4`` with 40 s episodes (four times the simulation);
* ``spread4_here``: ``spread4`` and a fifth episode from the test swim's own start heading (one
  gait evolved per test heading: the robot knows its yaw when the new gait takes over);
* ``oracle_straight``: not a new gait but the oracle itself (``--out``'s ``oracle_gait``,
  evolved 20 s from +y), swum the same way: does the yardstick hold the heading for minutes?

The prior is the design prior ``runs/missions/prior_sS/self_model`` that ``aquafish mission
--damage none --onset-s 0 --duration-s 60 --budget quick --seed S --out runs/missions/prior_sS
--no-oracle --no-video`` makes. Resumable: each variant's controller is kept in ``--out``,
and its scores in ``summary.json`` (swims of 270 s) or, with other ``--swim-s``/``--skip-s``,
``summary_{swim}s_skip{skip}s.json``: ``--swim-s 78 --skip-s 6`` scores the span a 300 s
mission's ``speed_after`` covers (its new gait takes over near 222 s; 6 s left out).

    python docs/studies/probes/new_gait_heading.py --damage reversed_left_pectoral --seed 0 \\
        --out runs/new_gait_heading/rlp_s0
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import gait
from aquafish.case_study import PRESETS
from aquafish.mission import MISSION_PRESETS, mission_oracle_speed
from gait.neat_evolution import evolve_from_population
from gait.rollout import rollout

SPREAD4 = (-135.0, -45.0, 45.0, 135.0)
HERE = "here"  # in a variant's start headings: the test swim's own start heading
#: name: (episode seconds, start headings in degrees, episodes a genome, generations)
VARIANTS = {"heading20": (20.0, (0.0,), 2, 12), "heading60": (60.0, (0.0,), 2, 12),
            "spread45": (20.0, (-45.0, 45.0), 2, 12), "spread90": (20.0, (-90.0, 90.0), 2, 12),
            "spread4": (20.0, SPREAD4, 4, 12), "spread4_g24": (20.0, SPREAD4, 4, 24),
            "spread4_40s": (40.0, SPREAD4, 4, 12), "spread4_here": (20.0, SPREAD4 + (HERE,), 5, 12),
            "oracle_straight": None}
START_YAWS_DEG = (-90.0, -45.0, 0.0, 45.0, 90.0)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--damage", required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--variants", default=",".join(VARIANTS))
    parser.add_argument("--swim-s", type=float, default=270.0, help="seconds each test swim lasts")
    parser.add_argument("--skip-s", type=float, default=0.0,
                        help="seconds at the start of each test swim left out of its speed (a mission's speed_after "
                             "leaves out 6 s)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    case = PRESETS["quick"]
    robot = gait.as_robot(args.damage)
    oracle_speed = mission_oracle_speed(args.damage, MISSION_PRESETS["quick"], args.seed, out)  # the missions' oracle
    # the default swims' summary is summary.json; other lengths keep their own beside it
    summary = out / ("summary.json" if (args.swim_s, args.skip_s) == (270.0, 0.0)
                     else f"summary_{args.swim_s:g}s_skip{args.skip_s:g}s.json")
    old = json.loads(summary.read_text())["variants"] if summary.is_file() else {}
    rows = {"damage": args.damage, "seed": args.seed, "oracle_speed": oracle_speed, "variants": {}}
    for name in args.variants.split(","):
        if name in old:
            rows["variants"][name] = old[name]
            continue
        speeds = []
        for k, yaw in enumerate(START_YAWS_DEG):
            if name == "oracle_straight":
                path = out / "oracle_gait" / "best_controller.json"
            else:
                duration, yaws, episodes, generations = VARIANTS[name]
                path = out / (f"{name}_{yaw:+.0f}.json" if HERE in yaws else f"{name}.json")
                if not path.is_file():
                    result = evolve_from_population(
                        robot, Path(f"runs/missions/prior_s{args.seed}/self_model/gait"), generations, seed=args.seed,
                        episode_duration_s=duration, episodes_per_genome=episodes,
                        start_yaws_deg=tuple(yaw if y == HERE else y for y in yaws))
                    result.best_controller.save(path)
            controller = gait.load_controller(path)
            r = rollout(controller, robot, seed=args.seed + 100 + k, episode_duration_s=args.swim_s,
                        initial_yaw_deg=yaw)
            first = int(np.searchsorted(r.times_s, args.skip_s - 1e-9))
            speeds.append(float((r.trajectory[-1] - r.trajectory[first])[1] / (args.swim_s - r.times_s[first])))
        share = np.asarray(speeds) / oracle_speed
        rows["variants"][name] = {"speed_along_heading": speeds, "share_of_oracle": share.round(3).tolist(),
                                  "mean_share": float(share.mean()), "min_share": float(share.min())}
        print(name, f"mean {share.mean():.2f} min {share.min():.2f}", share.round(2).tolist(), flush=True)
        rows["variants"] |= {k: v for k, v in old.items() if k not in rows["variants"]}
        summary.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
