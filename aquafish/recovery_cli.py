"""``aquafish recovery``: the recovery benchmark, the damage-recovery case study over many
damages and seeds (:mod:`aquafish.recovery`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from aquafish.studies_cli import CASE_STUDY_BUDGETS, PROCEDURE_SEED_LIMIT
from aquafish_gym.argtypes import (add_alias, add_config_option, add_episode_duration, add_no_progress, add_processes,
                                   add_workers, csv_list, damage_list, json_object, path, seed_below)


def _recovery(args: argparse.Namespace) -> int:
    from aquafish.recovery import SUMMARY_MD, render_summary, run_recovery, summary_so_far

    if args.summary_only:
        summary = summary_so_far(args.out)
        print(render_summary(summary))
        missing = {(m["damage"], m["seed"]) for m in summary["missing"]}
        triaged = missing & {(c["damage"], c["seed"]) for c in summary["cells"]}  # broken, rows still to run
        print(f"{summary['totals']['cells'] - len(triaged)} cells finished, {len(missing)} to run"
              + (f" ({len(triaged)} of them triaged, their other rows to run)" if triaged else "")
              + " (nothing written)")
        return 0
    summary = run_recovery(args.out, preset=args.budget, damages=args.damages, seeds=args.seeds,
                           episode_duration_s=args.episode_duration_s, processes=args.processes, workers=args.workers,
                           backend=args.backend, address=args.address, progress=not args.no_progress,
                           all_rows=args.all_rows, self_model_fields=args.self_model_fields)
    print((Path(args.out) / SUMMARY_MD).read_text())
    print(f"wrote {Path(args.out) / SUMMARY_MD} and summary.json ({summary['totals']['cells']} cells)")
    return 0


def add_commands(sub) -> None:
    r = sub.add_parser("recovery", help="recovery benchmark: the damage-recovery case study per damage and seed, "
                                        "the damage-independent rows trained once per seed, and a summary "
                                        "(aquafish.recovery)")
    r.add_argument("--damages", type=damage_list, default=None,
                   help="comma-separated damages (default: every preset but none): preset names, JSON faults "
                        "inline or as FILE.json (keys scale, seized, gains), sampled:SEED")
    r.add_argument("--seeds", type=csv_list(seed_below(PROCEDURE_SEED_LIMIT)), default=(0,),
                   help=f"comma-separated case-study seeds (default 0; each below {PROCEDURE_SEED_LIMIT:,})")
    add_alias(r, r.add_argument("--budget", default="quick", choices=CASE_STUDY_BUDGETS,
                                help="the budget of every cell's case study, as aquafish case-study --budget: "
                                     "smoke, quick, medium or paper (default: quick)"),
              "--preset")
    add_alias(r, add_episode_duration(r, None, "the budget's, 20 s", note="every cell's gait evolution and transfer"),
              "--episode-duration")
    r.add_argument("--out", required=True, type=path,
                   help="benchmark directory (finished cells and shared rows are reused)")
    add_processes(r, 1, note="case-study cells on the local backend; above 1 each cell evaluates serially")
    add_workers(r, None, "all cores", note="a cell's; 1 when cells run at once")
    r.add_argument("--all-rows", action="store_true",
                   help="run every row on every cell (default: the self-models, their gaits and PPO only where the "
                        "damage breaks the healthy gait; the recovery rates count those cells only)")
    r.add_argument("--self-model-fields", type=json_object, default=None, metavar="JSON",
                   help="every cell's self-model EEA settings, as aquafish case-study --self-model-fields (default: "
                        "none); a benchmark directory keeps one value")
    r.add_argument("--summary-only", action="store_true",
                   help="print the summary of the cells OUT holds so far and run nothing (reads only: works while "
                        "another process runs the benchmark)")
    r.add_argument("--backend", choices=["local", "ray"], default="local", help="local processes or Ray tasks")
    r.add_argument("--address", default=None,
                   help="Ray cluster address (as for aquafish study --address; default: start a local Ray)")
    add_no_progress(r, "cell")
    add_config_option(r)
    r.set_defaults(func=_recovery)
