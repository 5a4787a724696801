"""Where a case study's wall time goes, stage by stage (self-model EEA runs, gaits, PPO, transfer, video).

``python -m aquafish.benchmarks.case_study_stages --budget quick --damage reversed_left_pectoral
--seed 0 --out runs/stages`` (``aquafish bench case_study_stages ...``) runs the case study
(:func:`aquafish.case_study.run_case_study`) and prints the wall seconds of each stage from its
report's ``stage_seconds``, with each stage's share of the whole. ``--report PATH`` tabulates
a finished case study's (or recovery cell's) ``report.json`` instead, running nothing.

A stage found finished in ``--out`` costs only its loading: time a fresh directory. A
recovery cell's shared rows (healthy gait, damage-robust NEAT and PPO) are trained before the
cell, so its report times only their loading.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
from pathlib import Path

from aquafish.benchmarks import add_budget
from aquafish_gym.argtypes import path, seed_below

__all__ = ["main", "stage_table"]


def stage_table(report: dict) -> str:
    """A markdown table of ``report["stage_seconds"]``: stage, seconds, share of the case
    study's ``wall_seconds``, longest first, then the rest (report writing, figures).

    Raises:
        ValueError: the report has no ``stage_seconds`` (written before they were recorded).
    """
    stages = report.get("stage_seconds")
    if not stages:
        raise ValueError("the report has no stage_seconds (a case study run before they were recorded); "
                         "run it again in a fresh directory")
    wall = float(report["wall_seconds"])
    rows = sorted(stages.items(), key=lambda kv: -kv[1])
    rest = wall - sum(stages.values())
    lines = ["| stage | seconds | share |", "|---|---|---|"]
    lines += [f"| {name} | {seconds:.1f} | {seconds / wall:.0%} |" for name, seconds in rows]
    lines += [f"| the rest (figures, report) | {rest:.1f} | {rest / wall:.0%} |",
              f"| **case study** | **{wall:.1f}** | 100% |"]
    return "\n".join(lines)


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    from aquafish.case_study import run_case_study
    from aquafish.oracle import PROCEDURE_SEED_LIMIT

    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    add_budget(parser, "the case study's budget")
    parser.add_argument("--damage", default="reversed_left_pectoral")
    parser.add_argument("--seed", type=seed_below(PROCEDURE_SEED_LIMIT), default=0)
    parser.add_argument("--out", type=path, help="case-study directory (a fresh one times every stage)")
    parser.add_argument("--report", help="tabulate this report.json instead of running a case study")
    args = parser.parse_args(argv)
    if (args.out is None) == (args.report is None):
        parser.error("give --out (run a case study) or --report (tabulate a finished one)")
    if args.report is not None:
        report = json.loads(Path(args.report).read_text())
    else:
        report = run_case_study(args.budget, args.damage, args.seed, args.out, progress=False)
    print(f"case study {report['preset']!r}, {report['damage']}, seed {report['seed']}; "
          f"{platform.node()}, {os.cpu_count()} CPUs")
    print(stage_table(report))


if __name__ == "__main__":
    main()
