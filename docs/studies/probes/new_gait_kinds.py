"""Would a mission's new gait swim further if the rehearsal also chose among straight gaits?

The mission's new gait today is one kind: NEAT from the prior gait's population, its episodes
started turned by (-135, -45, 45, 135) degrees and scored along the mission's heading
("heading-holding"), then a rehearsal on the self-model from the robot's yaw at takeover picks
one of each generation's fittest genomes. On some missions the straight oracle (20 s episodes
from the heading, the case study's gait) swims much further from the same state than this
procedure does on the truth, on others much less. This probe replays a finished mission to its
takeover (the healthy gait to the recorded alarm, the stop, the recorded experiments; it checks
the replayed yaw and time against the record and that the mission's own procedure gives the
recorded rehearsal), evolves a second kind on the recovered self-model, straight (NEAT from the
same population, the case preset's starts all heading +y, scored along +y), rehearses its
candidates from the same yaw with the same draws, and swims on the true damaged robot from the
takeover state whichever kind's rehearsal winner went further. With ``--truth`` it also runs
the library's new-gait procedure (:func:`aquafish.mission._new_gait`, both kinds since this probe)
on the true damaged robot and swims its gait from the same state: the window's oracle of a
mission made with both kinds, for missions whose self-model is not the truth. One JSON line per
mission. Both kinds come from :func:`aquafish.mission.new_gait_kinds` (its heading-holding kind is
the procedure before); ``compute_s`` is their total seconds (rows recorded before 2026-11-29 give
each kind's).

    python docs/studies/probes/new_gait_kinds.py runs/missions/motion_sampled_5_s2 \\
        runs/missions/prior_s2/self_model --out docs/results/new_gait_kinds/new_gait_kinds.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from aquafish.mission import MISSION_PRESETS, _new_gait, load_prior, new_gait_kinds, span_speed
from gait import as_robot
from eea.record import load_experiments
from gait.robots import Robot
from mission_replay import emit_line, replay_to_takeover


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mission_dir", type=Path)
    ap.add_argument("prior_dir", type=Path)
    ap.add_argument("--out", type=Path, default=None, help="append the JSON line to this file")
    ap.add_argument("--truth", action="store_true", help="also swim the library's procedure run on the truth")
    a = ap.parse_args(argv)
    report = json.loads((a.mission_dir / "mission.json").read_text())
    settings = MISSION_PRESETS[report["preset"]]
    seed, yaw = report["seed"], report["robot_yaw_at_new_gait_deg"]
    prior = load_prior(a.prior_dir)
    model = Robot.from_dict(json.loads((a.mission_dir / "recovered" / "self_model.json").read_text())["robot"])
    experiments = load_experiments(a.mission_dir / "recovered" / "experiments.npz")
    mission = replay_to_takeover(report, prior, experiments)
    snap = mission.snapshot()
    yaw = mission.yaw_deg()  # unrounded, as the mission's own procedure had it
    after_s = report["recovered_s"] + settings.warmup_s
    t0 = time.perf_counter()
    kinds = new_gait_kinds(model, prior, settings, seed, 1, False, yaw)  # heading_holding: the procedure before
    seconds = time.perf_counter() - t0
    held, chosen = kinds["heading_holding"][1], kinds["straight"][1]
    holding, record = held.controller, {"chosen": held.index, "distances_units": np.round(held.scores, 4).tolist()}
    if record["chosen"] != report["rehearsal"]["chosen"] or \
            not np.allclose(record["distances_units"], report["rehearsal"]["distances_units"]):
        raise SystemExit(f"the mission's procedure chose {record['chosen']} here ({record['distances_units']}), "
                         f"{report['rehearsal']['chosen']} in the record ({report['rehearsal']['distances_units']})")
    swim = {name: span_speed(mission.swim_from(snap, c, report["duration_s"], "probe"), after_s)
            for name, c in (("heading_holding", holding), ("straight", chosen.controller))}
    rehearsal = {"heading_holding": float(held.scores.max()), "straight": float(chosen.scores.max())}
    both = max(rehearsal, key=rehearsal.get)
    window = report.get("oracle_in_window") or {}
    line = {"mission": a.mission_dir.name, "damage": report["damage"], "seed": seed, "takeover_yaw_deg": yaw,
            "self_model_is_truth": report["self_model_after"] == report["true_model"],
            "rehearsal_units": rehearsal, "rehearsal_winner": both,
            "swim_units_per_s": swim, "both_kinds_units_per_s": swim[both],
            "recorded_speed_after": report["speed_after"],
            "oracle_straight": window.get("straight"), "oracle_heading_holding": window.get("heading_holding"),
            "oracle_best": window.get("best"),
            "compute_s": round(seconds, 1)}
    if a.truth:
        procedure = _new_gait(as_robot(report["damage"]), prior, settings, seed, 1, False, yaw)[0]
        line["procedure_on_truth_units_per_s"] = span_speed(mission.swim_from(snap, procedure, report["duration_s"],
                                                                              "probe"), after_s)
    mission.env.close()
    emit_line(line, a.out)


if __name__ == "__main__":
    main()
