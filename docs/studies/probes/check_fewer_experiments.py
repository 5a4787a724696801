"""Would the fault check keep the same self-model after fewer of a mission's experiments?

A mission's recovery runs 8 rounds (one target experiment of 1.28 s each), then checks the
search's final model against the fault hypotheses (:func:`eea.inference.selection.check_fault_hypotheses`)
on all 8 experiments; the check, not the search, makes the self-model (it replaced the search's
model on 13 of 13 missions). The search's simulations grow with the experiments recorded (round
r scores its models on r experiments: 1 + ... + 8 = 36 experiment-scorings in all) and the
check's with their number, so a recovery that stops after k rounds would spend about
``(k (k + 1) / 2) / 36`` of the estimation and ``k / 8`` of the check, and the robot would stop
for k experiments instead of 8.

The first k rounds of a mission are those a k-round mission would run (a round draws nothing
from later ones), so this probe makes the check on the first k of a mission's recorded
experiments (``recovered/experiments.npz``), from the mission's final model as row 0 (a k-round
mission would check round k's model there; no 8-round mission's check kept its row 0), with
the check's own seed and defaults, and says whether it keeps the model the check on all of the
mission's experiments kept and whether that is the truth, with the MOD_FIT of the kept model,
of row 0 (``search_model_fitness``) and of the truth's best row (``truth_fitness``; null when
no candidate is the truth): how near the truth came. It does not say how the new gait would
swim (the robot would take over elsewhere).

One JSON line per mission and k in ``--out`` (resumable)::

    python docs/studies/probes/check_fewer_experiments.py runs/missions/m_*/ --experiments 4,5,6 \\
        --out runs/check_fewer_experiments.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from aquafish_gym import Morphology
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.fault_check import FAULT_CHECK_SEED
from eea.inference.selection import check_fault_hypotheses
from mission_replay import emit_line, load_checked_mission


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    parser.add_argument("--experiments", default="4,5,6",
                        help="comma-separated k >= 1: the check on the first k experiments (a k above a "
                             "mission's experiments is skipped for it)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    counts = [int(k) for k in args.experiments.split(",")]
    if not counts or min(counts) < 1:
        parser.error(f"--experiments must be positive integers, got {args.experiments!r}")
    out = Path(args.out)
    done = ({(r["mission"], r["experiments"]) for r in map(json.loads, out.read_text().splitlines())}
            if out.is_file() else set())
    space = get_model_space("morphology+servos")
    for directory in map(str, map(Path, args.missions)):
        mission = load_checked_mission(directory, args.workers)
        if mission is None:
            continue
        report, experiments, model, kept, config = mission
        truth = np.array([report["true_model"][f] for f in space.fields])
        for k in counts:
            if (directory, k) in done or k > len(experiments):
                continue
            with Evaluator.for_config(config, workers=args.workers) as evaluator:
                started = time.perf_counter()
                check = check_fault_hypotheses(model, Morphology.healthy().to_array(), experiments[:k], evaluator,
                                               FAULT_CHECK_SEED)
                seconds, simulations = time.perf_counter() - started, int(evaluator.simulations)
            chosen = check.model
            row = {"mission": directory, "damage": report["damage"], "seed": report["seed"], "experiments": k,
                   "of": len(experiments), "same_as_all": bool(np.allclose(chosen, kept, atol=1e-4)),
                   "truth": bool(np.allclose(chosen, truth, atol=1e-4)),
                   "all_truth": bool(np.allclose(kept, truth, atol=1e-4)),
                   "model": dict(zip(space.fields, np.round(chosen, 4).tolist())),
                   "model_fitness": float(check.model_fitness[check.index]),
                   "search_model_fitness": float(check.model_fitness[0]),
                   "truth_fitness": _truth_fitness(check, truth), "simulations": simulations,
                   "mission_check_simulations": report["fault_check"]["simulations"],
                   "seconds": round(seconds, 1), "workers": args.workers}
            emit_line(row, out)


def _truth_fitness(check, truth: np.ndarray) -> float | None:
    """The best MOD_FIT among the check's candidates that are the truth (a hypothesis, or the
    search's model or a polished one landing on it); None if none is."""
    rows = [i for i, candidate in enumerate(check.models) if np.allclose(candidate, truth, atol=1e-4)]
    return max((float(check.model_fitness[i]) for i in rows), default=None)


if __name__ == "__main__":
    main()
