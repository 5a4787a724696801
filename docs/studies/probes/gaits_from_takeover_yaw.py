"""Which gaits swim on a mission's true damaged robot from the yaw its new gait took over at?

For a finished mission (``mission.json``, ``recovered/``, ``oracle_gait/``, ``oracle_new_gait/``)
and its prior (the healthy gait), swims four gaits on the true damaged robot from rest, turned
by the mission's ``robot_yaw_at_new_gait_deg`` and by 0 degrees, for 78 s (the span
``speed_after`` covers), over 8 draws of the flipper angles (seeds 1000-1007), and prints each
one's mean speed along the mission's heading (units/s): the old (healthy) gait, the mission's
new gait, the new-gait procedure run on the truth (``oracle_new_gait``) and the straight 20 s
oracle (``oracle_gait``). A mission whose self-model is the truth has the same new gait as its
procedure on the truth; if the straight oracle swims far faster, the miss is the gait's
evolution, not the self-model.

    python docs/studies/probes/gaits_from_takeover_yaw.py runs/missions/rehearsal_sampled_1001_s5001 \\
        runs/missions/prior_s5001
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from gait.controller import load_controller
from gait.rehearsal import rehearse

SWIM_S = 78.0


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mission")
    parser.add_argument("prior", help="the mission's prior directory (holds self_model/gait)")
    args = parser.parse_args(argv)
    mission, prior = Path(args.mission), Path(args.prior)
    report = json.loads((mission / "mission.json").read_text())
    yaw = report["robot_yaw_at_new_gait_deg"]
    gaits = {"old": prior / "self_model" / "gait", "new": mission / "recovered",
             "procedure_on_truth": mission / "oracle_new_gait", "straight_oracle": mission / "oracle_gait"}
    for name, directory in gaits.items():
        controller = load_controller(directory / "best_controller.json")
        for start in (yaw, 0.0):
            swum = rehearse([controller], report["damage"], start_yaw_deg=start, duration_s=SWIM_S, seed=1000, draws=8)
            print(json.dumps({"mission": str(mission), "gait": name, "start_yaw_deg": round(start, 3),
                              "speed_units_s": round(float(swum.scores[0]) / SWIM_S, 4)}), flush=True)


if __name__ == "__main__":
    main()
