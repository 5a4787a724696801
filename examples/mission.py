"""A mission through the Python API: swim, get damaged, notice, rebuild the self-model where the robot
stands (the EEA warm-started at the old one), evolve a gait from the old population, swim on.

    python examples/mission.py [--damage reversed_left_pectoral] [--budget quick] [--out mission_out]

The same as ``aquafish mission``; the steps are spelled out: the prior (self-model, gait,
monitor calibration), then the mission with it.
"""

import argparse
from pathlib import Path

from aquafish.mission import prepare_prior, run_mission


def main(argv=None) -> None:  # under the __main__ guard: evaluation may spawn worker processes
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--damage", default="reversed_left_pectoral")
    parser.add_argument("--budget", "--preset", default="quick", choices=("smoke", "quick", "medium"))  # --preset: the old name
    parser.add_argument("--onset-s", type=float, default=30.0)
    parser.add_argument("--duration-s", type=float, default=300.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("mission_out"))
    args = parser.parse_args(argv)

    # 1. what the robot knows before the damage: its self-model, its gait, the monitor's healthy range
    prior = prepare_prior(args.out / "self_model", args.budget, args.seed, workers=1)
    print(f"self-model {prior.robot.label}; monitor range [{prior.calibration.lower:.3f}, "
          f"{prior.calibration.upper:.3f}] units/s")
    # 2. the mission: one episode, damage at the onset, alarm, experiments where it stands, new gait
    report = run_mission(args.damage, args.out / "mission", onset_s=args.onset_s, duration_s=args.duration_s,
                         preset=args.budget, seed=args.seed, self_model=prior.directory, workers=1)
    for key in ("onset_s", "alarm_s", "recovered_s", "target_experiments", "compute_seconds", "speed_before",
                "speed_damaged", "speed_after", "oracle_speed"):
        print(f"{key:>18}: {report[key]}")
    window = report["oracle_in_window"] or {}  # the oracle swum from the new gait's start, over the same span
    print(f"{'oracle_in_window':>18}: {window.get('best')}")
    # 3. judged against what else the robot could have done, from the onset's state to the end (units along the heading)
    print(f"{'net_displacement':>18}: {report['net_displacement']}")
    for name, alternative in (report["counterfactuals"] or {}).items():  # keep_old, oracle_at_alarm
        print(f"{name:>18}: {alternative}")
    print(f"{'recovered':>18}: {report['recovered']}")


if __name__ == "__main__":
    main()
