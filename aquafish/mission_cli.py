"""``aquafish mission``: a healthy robot swims, is damaged, notices, rebuilds its self-model from
where it stands and swims on (:mod:`aquafish.mission`)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from aquafish.studies_cli import PROCEDURE_SEED_LIMIT
from aquafish_gym.argtypes import (add_alias, add_config_option, add_no_progress, add_workers, json_object,
                                   path, positive_float, seed_below)

#: The mission budgets (:data:`aquafish.mission.MISSION_PRESETS`; not imported here, to keep the
#: command line light: a test checks they agree). Each is the case-study budget of the same name
#: (:attr:`aquafish.mission.MissionPreset.case_preset`) with the monitor's and the episodes' settings.
PRESET_NAMES = ("smoke", "quick", "medium")


def _nonnegative_float(text: str) -> float:
    import math

    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds >= 0, got {text!r}") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text!r}")
    return value


def _mission(args: argparse.Namespace) -> int:
    from aquafish.mission import MISSION_FILE, run_mission

    report = run_mission(args.damage, args.out, onset_s=args.onset_s, duration_s=args.duration_s, preset=args.budget,
                         seed=args.seed, self_model=args.self_model, prior_source=args.prior, workers=args.workers,
                         warm_start=not args.cold_start, self_model_fields=args.self_model_fields,
                         video=not args.no_video,
                         oracle=not args.no_oracle, progress=not args.no_progress)
    keys = ("onset_s", "alarm_s", "recovered_s", "target_experiments", "compute_seconds", "speed_before",
            "speed_damaged", "speed_after", "oracle_speed")
    print(json.dumps({k: report[k] for k in keys} | {"oracle_in_window": (report["oracle_in_window"] or {}).get("best")},
                     indent=1))
    print(f"wrote {Path(args.out) / MISSION_FILE}, {report['files']['timeline']}, {report['files']['trajectory']}"
          + (f", {report['files']['video']}" if report["files"].get("video") else ""))
    return 0


def _mission_table(args: argparse.Namespace) -> int:
    from aquafish.mission_table import format_table, read_missions, summarise_missions
    from aquafish_gym.files import atomic_write
    from aquafish_gym.rundir import check_output_dir, run_lock

    if args.out is None:
        print(format_table(summarise_missions(read_missions(args.missions))), end="")
        return 0
    # a directory of its own, as every command's, claimed before the missions are read: another
    # command's (a recovery benchmark, whose summary files have the same names) or one inside
    # another command's run directory is refused
    with run_lock(check_output_dir(args.out), command="mission-table"):
        summary = summarise_missions(read_missions(args.missions))
        table = format_table(summary)
        atomic_write(args.out / "summary.json", (json.dumps(summary, indent=1) + "\n").encode())
        atomic_write(args.out / "summary.md", table.encode())
    print(table, end="")
    print(f"wrote {args.out / 'summary.md'} and summary.json ({summary['totals']['missions']} missions)")
    return 0


def add_commands(sub) -> None:
    m = sub.add_parser("mission", help="a mission: the robot swims, is damaged, notices it, runs target experiments "
                                       "where it stands, rebuilds its self-model (warm start) and swims on "
                                       "(aquafish.mission)")
    m.add_argument("--damage", required=True,
                   help="the damage at the onset: a preset name, a JSON fault inline or as FILE.json, sampled:SEED")
    m.add_argument("--onset-s", type=_nonnegative_float, default=30.0, metavar="SECONDS",
                   help="simulated seconds before the damage (default 30)")
    m.add_argument("--duration-s", type=positive_float, default=300.0, metavar="SECONDS",
                   help="simulated seconds of the whole mission, the one episode the robot swims; not the "
                        "length of the episodes its gaits are evolved on, which the budget sets (default 300)")
    add_alias(m, m.add_argument("--budget", default="quick", choices=PRESET_NAMES,
                                help="the mission's budget (aquafish.mission.MISSION_PRESETS): its self-model EEA and "
                                     "gait evolution get the aquafish case-study --budget of the same name; it also "
                                     "sets the gait episodes' length and the monitor's calibration (default: quick)"),
              "--preset")
    m.add_argument("--seed", type=seed_below(PROCEDURE_SEED_LIMIT), default=0,
                   help=f"seed (default 0; below {PROCEDURE_SEED_LIMIT:,}, the oracle's seeds lie above)")
    m.add_argument("--out", required=True, type=path, help="mission directory")
    m.add_argument("--self-model", type=path, default=None, metavar="DIR",
                   help="reuse the self-model, gait and monitor calibration in DIR (an earlier mission's "
                        "OUT/self_model; read as data: its JSON files, never a pickle); default: make them in "
                        "OUT/self_model")
    m.add_argument("--prior", choices=["design", "eea"], default="design",
                   help="without --self-model, the self-model before the damage: the robot's design (default) or one "
                        "the EEA builds on the healthy robot first (at quick it can get a servo sign wrong)")
    m.add_argument("--cold-start", action="store_true",
                   help="start the recovery's EEA from a random population, not at the self-model from before "
                        "the damage (the warm start's baseline)")
    m.add_argument("--self-model-fields", type=json_object, default=None, metavar="JSON",
                   help="EEA settings of the recovery's self-model search over the budget's (quick and medium: "
                        "aquafish.mission.RECOVERY_FIELDS, the ranked fault hypotheses; the rest as the case study's), as "
                        "aquafish case-study --self-model-fields (inline or FILE.json; default: none); both recorded "
                        "in mission.json")
    add_workers(m, None, "1")
    m.add_argument("--no-video", action="store_true", help="write no video")
    m.add_argument("--no-oracle", action="store_true", help="skip the oracle gaits (oracle_speed and oracle_in_window null)")
    add_no_progress(m, "generation")
    add_config_option(m)
    m.set_defaults(func=_mission)

    t = sub.add_parser("mission-table", help="many missions in one table: alarm delays, target experiments, compute, "
                                             "speeds, gains, and the totals the mission's goals are stated in "
                                             "(aquafish.mission_table)")
    t.add_argument("missions", nargs="+", type=path, metavar="DIR", help="finished missions (aquafish mission --out)")
    t.add_argument("--out", type=path, default=None,
                   help="also write OUT/summary.md and OUT/summary.json (default: print only)")
    t.set_defaults(func=_mission_table)
