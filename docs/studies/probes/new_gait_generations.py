"""How many generations does the straight kind of new gait need? (a lever for a mission's compute)

A mission's recovery evolves two kinds of new gait from the prior gait's population, each for
the case preset's generations, and a rehearsal on the self-model picks among the fittest genomes
of every generation of both (:func:`aquafish.mission.new_gait_kinds`). The straight kind starts
from a population evolved to swim straight, and its rehearsed winner has come from its first
generations. This probe replays a finished mission to its takeover (``mission_replay.py``),
runs both kinds on the recovered self-model as the mission did (checking the rehearsal's
distances against the record: both kinds for a mission made with both, the heading-holding kind
for one made before), and for each N of ``--generations`` takes the straight kind's candidates
of its first N generations only (NEAT's first N generations do not depend on how many follow,
and a candidate's rehearsal does not depend on the others, so this is the procedure run with N
generations), chooses as the mission does, and swims the chosen gait on the true damaged robot
from the takeover state over ``speed_after``'s span (units/s). One JSON line per mission; about
3-4 minutes a mission on one core.

    python docs/studies/probes/new_gait_generations.py runs/missions/kinds_sampled_13_s0 \\
        runs/missions/prior_s0/self_model --out runs/new_gait_generations.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from aquafish.mission import MISSION_PRESETS, NEW_GAIT_KINDS, load_prior, new_gait_kinds, span_speed
from eea.record import load_experiments
from gait.robots import Robot
from mission_replay import emit_line, replay_to_takeover


def recorded_distances(report: dict) -> dict[str, list[float]]:
    """The rehearsal's distances (units) per kind as the mission recorded them."""
    rehearsal = report["rehearsal"]
    if "kinds" in rehearsal:
        return {kind: v["distances_units"] for kind, v in rehearsal["kinds"].items()}
    return {"heading_holding": rehearsal["distances_units"]}  # a mission made with one kind


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mission_dir", type=Path)
    ap.add_argument("prior_dir", type=Path)
    ap.add_argument("--generations", default="2,4,6,8,12", help="comma-separated N: the straight kind's generations")
    ap.add_argument("--out", type=Path, default=None, help="append the JSON line to this file")
    a = ap.parse_args(argv)
    report = json.loads((a.mission_dir / "mission.json").read_text())
    settings = MISSION_PRESETS[report["preset"]]
    seed = report["seed"]
    prior = load_prior(a.prior_dir)
    model = Robot.from_dict(json.loads((a.mission_dir / "recovered" / "self_model.json").read_text())["robot"])
    experiments = load_experiments(a.mission_dir / "recovered" / "experiments.npz")
    mission = replay_to_takeover(report, prior, experiments)
    snap, yaw = mission.snapshot(), mission.yaw_deg()  # unrounded, as the mission's own procedure had it
    t0 = time.perf_counter()
    kinds = new_gait_kinds(model, prior, settings, seed, 1, False, yaw)
    seconds = time.perf_counter() - t0
    for kind, recorded in recorded_distances(report).items():
        if not np.allclose(np.round(kinds[kind][1].scores, 4), recorded):
            raise SystemExit(f"the {kind} kind's rehearsal differs from the record: "
                             f"{np.round(kinds[kind][1].scores, 4).tolist()} against {recorded}")
    after_s = report["recovered_s"] + settings.warmup_s
    swims: dict[int, float | None] = {}   # by the genome's key: the same gait swims the same

    def swim(controller) -> float | None:
        key = controller.genome.key
        if key not in swims:
            swims[key] = span_speed(mission.swim_from(snap, controller, report["duration_s"], "probe"), after_s)
        return swims[key]

    by_n = {}
    for n in (int(x) for x in a.generations.split(",")):
        best = {}
        for kind in NEW_GAIT_KINDS:
            result, rehearsal = kinds[kind]
            allowed = [k for k, g in enumerate(result.candidate_generations) if kind != "straight" or g <= n]
            i = max(allowed, key=lambda k: rehearsal.scores[k])  # argmax: the first of equals, as rehearse
            best[kind] = (i, float(rehearsal.scores[i]), result.candidates[i])
        chosen = max(NEW_GAIT_KINDS, key=lambda k: best[k][1])  # a tie: the first kind, as the mission
        by_n[n] = {"kind": chosen, "straight_winner": best["straight"][0],
                   "straight_candidates": sum(g <= n for g in kinds["straight"][0].candidate_generations),
                   "units_per_s": swim(best[chosen][2])}
    mission.env.close()
    line = {"mission": a.mission_dir.name, "damage": report["damage"], "seed": seed, "takeover_yaw_deg": yaw,
            "recorded_speed_after": report["speed_after"], "oracle_best": (report.get("oracle_in_window") or {}).get("best"),
            "kinds": {kind: {"generations": r.candidate_generations, "distances_units": np.round(h.scores, 4).tolist(),
                             "chosen": h.index} for kind, (r, h) in kinds.items()},
            "by_straight_generations": by_n, "compute_s": round(seconds, 1)}
    emit_line(line, a.out)


if __name__ == "__main__":
    main()
