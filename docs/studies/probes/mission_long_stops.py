"""A mission whose stops before each target experiment may last longer than the preset's.

The `quick` mission stops the robot for at most 5 s before each experiment; the surface swimmer
is then still drifting (0.03-0.27 units/s, turning up to 5 degrees/s), while the models it is
compared with start from rest. This runs one mission (the lean self-model search, warm-started,
the new gait from the mission's heading) with the stops allowed up to ``--stop-max-s`` seconds,
reusing the design prior ``runs/missions/prior_sS/self_model`` that ``aquafish mission --damage
none --onset-s 0 --duration-s 60 --budget quick --seed S --out runs/missions/prior_sS
--no-oracle --no-video`` makes, and prints the alarm, recovery, speeds and the self-model found.
About 12 minutes on one core beside another mission.

    python docs/studies/probes/mission_long_stops.py --damage reversed_left_pectoral --seed 1 \\
        --stop-max-s 20 --out runs/missions_stop20/rlp_s1
"""

from __future__ import annotations

import argparse
import dataclasses
import json

import aquafish.mission as mission

LEAN = {"lineages": 1, "profile_refine": 0, "profile_library": 0, "exploration_angles": 2, "estimation_generations": 15}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--damage", required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--stop-max-s", type=float, default=20.0, help="longest stop (s; the quick preset's: 5)")
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    mission.MISSION_PRESETS["quick"] = dataclasses.replace(mission.MISSION_PRESETS["quick"], stop_max_s=args.stop_max_s)
    report = mission.run_mission(args.damage, args.out, onset_s=30, duration_s=300, preset="quick", seed=args.seed,
                                 workers=1, self_model=f"runs/missions/prior_s{args.seed}/self_model",
                                 self_model_fields=LEAN, video=False, progress=False)
    print(json.dumps({k: report[k] for k in ("alarm_s", "recovered_s", "speed_after", "oracle_speed",
                                               "self_model_after")}))


if __name__ == "__main__":
    main()
