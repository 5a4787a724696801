"""Does rehearsing on the self-model from the robot's own heading pick a better new gait?

A mission's new gait is the best genome of NEAT continued from the prior's population on the
new self-model, its four 20 s episodes started turned by -135, -45, 45 and 135 degrees
(:func:`aquafish.mission._new_gait`, before its rehearsal). When it takes over, the robot points wherever its
experiments left it, and the gait's speed over the minutes that follow depends strongly on
that heading. The robot knows its heading (its IMU's yaw), so it could try each candidate
gait on its self-model from that heading first and take the one that swims best there.

This is the probe that led to the mission's rehearsal (:func:`gait.rehearsal.rehearse`, 2026-11-28);
it ran on missions made before it, whose new gait was the evolution's best genome. For every
mission directory given (a finished ``aquafish mission`` with the oracle, so that
``oracle_speed`` is known), this evolves the mission's new gait again on the mission's own
recovered self-model (``recovered/self_model.json``; same seed, so the same best genome as such
a mission's ``recovered/best_controller.json``, which is checked), keeping the ``--top`` best
genomes of every generation as candidates. Then, for the mission's own heading at takeover and
for -90, -45, 0, 45 and 90 degrees:

* ``best``: the evolution's best genome (the mission's gait);
* ``rehearsed``: the candidate whose ``--rehearse-s`` swim on the self-model, from that
  heading at rest, goes furthest along the mission's heading (one start's flipper angles,
  drawn from the mission seed, or the mean of ``--rehearse-draws`` starts from seeds S, S+1, ...:
  the robot does not know its flipper angles);

each swum ``--swim-s`` seconds on the true damaged robot from that heading (flipper angles
drawn from seeds 1000, 1001, ...: ``--angle-draws`` of them), scored by the displacement along
the mission's heading per second after the first ``--skip-s`` seconds, as a share of the
mission's ``oracle_speed``. The defaults (78 s, 6 s left out) are the span a 300 s mission's
``speed_after`` covers. Rows go to ``--out`` (JSON lines, one per mission; resumable).

    python docs/studies/probes/new_gait_rehearsal.py runs/missions/window_*_s? --out runs/new_gait_rehearsal.jsonl
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np

import gait
from aquafish.case_study import PRESETS
from aquafish.mission import MISSION_PRESETS
from gait.neat_evolution import evolve_from_population
from gait.rehearsal import rehearse
from gait.robots import Robot
from gait.rollout import rollout

TEST_YAWS_DEG = (-90.0, -45.0, 0.0, 45.0, 90.0)


def swim_speed(controller, robot, yaw, seed, swim_s, skip_s) -> float:
    r = rollout(controller, robot, seed=seed, episode_duration_s=swim_s, initial_yaw_deg=yaw)
    first = int(np.searchsorted(r.times_s, skip_s - 1e-9))
    return float((r.trajectory[-1] - r.trajectory[first])[1] / (swim_s - r.times_s[first]))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    parser.add_argument("--top", type=int, default=3, help="candidates kept from every generation")
    parser.add_argument("--rehearse-s", type=float, default=78.0)
    parser.add_argument("--swim-s", type=float, default=78.0)
    parser.add_argument("--skip-s", type=float, default=6.0)
    parser.add_argument("--angle-draws", type=int, default=3, help="test swims per heading")
    parser.add_argument("--rehearse-draws", type=int, default=1,
                        help="rehearsal swims per candidate, each from other flipper angles (seeds S, S+1, ...)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    out = Path(args.out)
    done = {json.loads(line)["mission"] for line in out.read_text().splitlines()} if out.is_file() else set()
    settings = MISSION_PRESETS["quick"]
    for directory in args.missions:
        if directory in done:
            continue
        report = json.loads((Path(directory) / "mission.json").read_text())
        seed, damage = report["seed"], report["damage"]
        model = Robot.from_dict(json.loads((Path(directory) / "recovered" / "self_model.json").read_text())["robot"])
        truth = gait.as_robot(damage)
        t0 = time.perf_counter()
        # the mission's new gait, keeping candidates
        yaws = tuple(settings.new_gait_start_yaws_deg)
        result = evolve_from_population(model, Path(report["self_model_dir"]) / "gait",
                                        PRESETS[settings.case_preset].gait_generations, seed=seed,
                                        episode_duration_s=settings.gait_episode_s, episodes_per_genome=len(yaws),
                                        start_yaws_deg=yaws, keep_top=args.top)
        with tempfile.TemporaryDirectory() as tmp:
            result.best_controller.save(Path(tmp) / "best.json")
            same = ((Path(tmp) / "best.json").read_text()
                    == (Path(directory) / "recovered" / "best_controller.json").read_text())
        evolve_s = time.perf_counter() - t0
        rows = []
        for yaw in (report["robot_yaw_at_new_gait_deg"],) + TEST_YAWS_DEG:
            chosen = rehearse(result.candidates, model, start_yaw_deg=float(yaw), duration_s=args.rehearse_s,
                              seed=seed, draws=args.rehearse_draws).controller
            picks = {"best": result.best_controller, "rehearsed": chosen}
            speeds = {name: [swim_speed(c, truth, yaw, 1000 + k, args.swim_s, args.skip_s)
                             for k in range(args.angle_draws)] for name, c in picks.items()}
            rows.append({"yaw_deg": yaw, "candidates": len(result.candidates),
                         "rehearsed_is_best": chosen.genome.key == result.best_controller.genome.key,
                         **{f"{name}_share": round(float(np.mean(v)) / report["oracle_speed"], 3)
                            for name, v in speeds.items()}})
            print(directory, rows[-1], flush=True)
        line = {"mission": directory, "damage": damage, "seed": seed, "same_gait_as_mission": same,
                "oracle_speed": report["oracle_speed"], "evolve_s": evolve_s,
                "wall_s": time.perf_counter() - t0, "headings": rows,
                "best_mean": float(np.mean([r["best_share"] for r in rows])),
                "rehearsed_mean": float(np.mean([r["rehearsed_share"] for r in rows])),
                "best_own": rows[0]["best_share"], "rehearsed_own": rows[0]["rehearsed_share"]}
        with out.open("a") as f:
            f.write(json.dumps(line) + "\n")


if __name__ == "__main__":
    main()
