"""Damage monitor: false alarms on healthy swimming and alarm delays after a damage's onset.

Calibrates :class:`aquafish.monitor.DamageMonitor` for a gait on the healthy robot
(:func:`aquafish.monitor.calibrate`, seeds 0 .. ``--calibration-episodes - 1``), then

1. swims ``--healthy-episodes`` healthy episodes of ``--healthy-duration`` s from other seeds
   (10000, 10001, ...; at least an hour in all by default) and counts the episodes the monitor
   alarms in (false alarms);
2. swims each preset damage from ``--mission-seeds`` with the damage coming in force at
   ``--onset`` s (``gym.make("AquaFish-v0", damage=D, damage_onset_s=t)``) and records each
   mission's alarm delay after the onset (an alarm before it is a false alarm), and how much
   the damage slows the robot (mean speed after the onset against the healthy median).

Prints a markdown table; ``--out FILE.json`` also writes the numbers.

    python -m aquafish.benchmarks.damage_monitor --controller docs/results/damage_monitor
    aquafish bench damage_monitor --controller docs/results/damage_monitor
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from aquafish.monitor import DamageMonitor, calibrate, forward_speeds
from aquafish_gym.argtypes import path

#: The preset damages measured (every preset but ``none``).
DAMAGES = ("reversed_left_pectoral", "weak_right_pectoral", "seized_left_pectoral", "left_pectoral_missing",
           "caudal_missing", "caudal_half", "left_pectoral_half", "right_pectoral_half")
#: The first seed of the false-alarm episodes (apart from the calibration's 0, 1, ...).
HEALTHY_SEED = 10000
#: A damage "does not slow the robot" when it keeps at least this share of the healthy median speed.
NO_SLOWDOWN = 0.97


def run_monitor(monitor: DamageMonitor, speeds: np.ndarray, control_period_s: float) -> float | None:
    """Stream one episode's speeds ``(T + 1,)`` through ``monitor`` (reset first); the alarm time (s) or None."""
    monitor.reset()
    for k, speed in enumerate(speeds):
        if monitor.update_speed(speed, k * control_period_s):
            break
    return monitor.alarm_time_s


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> dict:
    """Run the measurement with the command-line arguments ``argv``; return the results."""
    from gait import load_controller

    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--controller", default="docs/results/damage_monitor",
                        help="a gait (run directory or best_controller.json; default the shipped healthy NEAT gait)")
    parser.add_argument("--window", type=float, default=6.0, help="window (s, default 6)")
    parser.add_argument("--warmup", type=float, default=6.0, help="warm-up before the first window (s, default 6)")
    parser.add_argument("--margin", type=float, default=0.25, help="margin of the healthy range (default 0.25)")
    parser.add_argument("--calibration-episodes", type=int, default=12)
    parser.add_argument("--calibration-duration", type=float, default=120.0)
    parser.add_argument("--healthy-episodes", type=int, default=30)
    parser.add_argument("--healthy-duration", type=float, default=150.0)
    parser.add_argument("--mission-seeds", default="20000,20001,20002")
    parser.add_argument("--onset", type=float, default=30.0)
    parser.add_argument("--after", type=float, default=15.0, help="seconds swum after the onset (default 15)")
    parser.add_argument("--out", type=path, default=None, help="also write the results as JSON to this file")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    controller = load_controller(args.controller)
    cal = calibrate(controller, "healthy", range(args.calibration_episodes), window_s=args.window,
                    warmup_s=args.warmup, episode_duration_s=args.calibration_duration, margin=args.margin)
    monitor = DamageMonitor(cal)
    period = cal.control_period_s
    print(f"calibration: {cal.episodes} x {cal.episode_duration_s:g} s, window {cal.window_s:g} s, warm-up "
          f"{cal.warmup_s:g} s: healthy range [{cal.lower:.4f}, {cal.upper:.4f}] units/s, median {cal.median:.4f}")

    seeds = range(HEALTHY_SEED, HEALTHY_SEED + args.healthy_episodes)
    speeds, _ = forward_speeds(controller, "healthy", seeds, args.healthy_duration)
    alarms = [run_monitor(monitor, row, period) for row in speeds]
    hours = args.healthy_episodes * args.healthy_duration / 3600.0
    false_alarms = sum(a is not None for a in alarms)
    watched_hours = args.healthy_episodes * (args.healthy_duration - cal.warmup_s - cal.window_s) / 3600.0
    print(f"healthy: {args.healthy_episodes} x {args.healthy_duration:g} s = {hours:.2f} h swum "
          f"({watched_hours:.2f} h watched after warm-up and the first window), {false_alarms} false alarm(s)")

    mission_seeds = [int(s) for s in args.mission_seeds.split(",")]
    rows = []
    for damage in DAMAGES:
        speeds, damaged = forward_speeds(controller, "healthy", mission_seeds, args.onset + args.after, damage=damage,
                                         damage_onset_s=args.onset)
        onset_index = int(round(args.onset / period))
        after = speeds[:, onset_index + cal.window:].mean()
        delays = []
        for row in speeds:
            alarm = run_monitor(monitor, row, period)
            delays.append(None if alarm is None else round(alarm - args.onset, 6))
        rows.append({"damage": damage, "delays_s": delays, "speed_after": float(after),
                     "speed_share": float(after / cal.median), "slows": bool(after / cal.median < NO_SLOWDOWN)})
    wall = time.perf_counter() - t0

    print(f"\n| damage | speed after onset (share of healthy median) | alarm delay after onset, seeds "
          f"{args.mission_seeds} (s) |\n|---|---|---|")
    for row in rows:
        cells = ", ".join("none" if d is None else ("**before onset**" if d < 0 else f"{d:.1f}") for d in row["delays_s"])
        print(f"| `{row['damage']}` | {row['speed_after']:.3f} ({row['speed_share']:.0%}) | {cells} |")
    delays = [d for row in rows for d in row["delays_s"]]
    detected = sum(d is not None and 0 <= d <= 10.0 for d in delays)
    early = sum(d is not None and d < 0 for d in delays)
    print(f"\nalarm within 10 s of the onset: {detected}/{len(delays)} missions; before the onset: {early}; "
          f"healthy: {false_alarms} false alarm(s) in {hours:.2f} h; not slowed (>= {NO_SLOWDOWN:.0%} of the "
          f"healthy speed): {[r['damage'] for r in rows if not r['slows']] or 'none'}; {wall:.0f} s wall")
    results = {"calibration": cal.to_dict(), "healthy": {"episodes": args.healthy_episodes,
               "duration_s": args.healthy_duration, "hours": hours, "false_alarms": false_alarms,
               "alarm_times_s": alarms}, "missions": rows, "onset_s": args.onset, "mission_seeds": mission_seeds,
               "detected_within_10s": detected, "missions_total": len(delays), "alarms_before_onset": early,
               "wall_s": wall}
    if args.out:
        with open(args.out, "w") as f:
            json.dump(results, f, indent=2)
            f.write("\n")
    return results


if __name__ == "__main__":
    main()
