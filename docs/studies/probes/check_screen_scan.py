"""How many of the fault check's 98 candidates does its screen need to scan? Measured offline on missions.

The fault check's screen (:func:`eea.inference.selection.check_fault_hypotheses`) fits every
candidate's initial angles (3 generations from 8 random starts: about 15 simulations a candidate
and experiment) and then scans each flipper's angle over a grid (57 more), 80 % of the screen's
simulations; the screen's best 24 are then given a compass polish, and the best 8 of that are
fitted again. A first cut would scan only the ``K`` best of the fit before the scan. The scan
can only raise a candidate's MOD_FIT, so the cut keeps the check exactly as it is whenever the
``K`` best before the scan hold every one of the 24 best after it: the polish, the refits and
the gain polish then see the same candidates with the same angles.

This probe runs the screen on a mission's own experiments (``recovered/experiments.npz``) and
final model (``fault_check.final_model``) once, records every candidate's MOD_FIT before and
after the scan, polishes the 24 best as the check does, and reports:

* ``k_exact``: the smallest ``K`` at which the cut changes nothing (the largest rank before the
  scan among the 24 best after it);
* ``k_refit``: the largest rank before the scan among the 8 candidates the refit rounds take
  (after the polish): a cut below it drops one of them;
* ``kept_rank_before_scan``: the rank before the scan of the candidate the mission kept (its
  self-model, or where its gain polish started; ``null`` if that is not a candidate);
* the simulations of each part.

Beside each line, ``OUT_STEM_<mission>.npz`` keeps every candidate's similarity per experiment
(eq. 2) before and after the scan, their MOD_FIT after the polish, the polished 24 and the
refitted 8, to try other rankings before the scan offline.

Outcome (2026-11-29, docs/main_job.md, "Where the check's and the search's simulations go"): on
four missions ``k_exact`` was 34-51 and the kept candidate ranked as low as 44th before the scan
(``sampled:13`` seed 2), so no cut much below all 98 is safe; not adopted, the library's check
scans all 98. One JSON line per mission in ``--out`` (resumable)::

    python docs/studies/probes/check_screen_scan.py runs/missions/*/ --out runs/check_screen_scan.jsonl
"""

from __future__ import annotations

import argparse
import inspect
import json
from pathlib import Path

import numpy as np

from aquafish_gym import Morphology
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.fault_check import FAULT_CHECK_SEED
from eea.inference.profile import Profile
from eea.inference.selection import (check_fault_hypotheses, fault_hypotheses, model_fitness_from_similarities,
                                     select_model)
from mission_replay import emit_line, load_checked_mission

#: the check's screen and refit as the library runs them (its defaults)
CHECK = {name: p.default for name, p in inspect.signature(check_fault_hypotheses).parameters.items()
         if p.default is not inspect.Parameter.empty}


def _ranks(fitness: np.ndarray) -> np.ndarray:
    """1-based rank of each entry (1: highest), ties in row order, as the check's stable sort."""
    order = np.argsort(-fitness, kind="stable")
    ranks = np.empty(len(fitness), dtype=int)
    ranks[order] = np.arange(1, len(fitness) + 1)
    return ranks


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    out = Path(args.out)
    done = {r["mission"] for r in map(json.loads, out.read_text().splitlines())} if out.is_file() else set()
    space = get_model_space("morphology+servos")
    for directory in args.missions:
        directory = str(Path(directory))
        if directory in done:
            continue
        mission = load_checked_mission(directory, args.workers)
        if mission is None:
            continue
        report, experiments, model, kept, config = mission
        candidates = np.vstack([model[None], fault_hypotheses(Morphology.healthy().to_array())])
        genomes = space.encode(candidates)
        with Evaluator.for_config(config, workers=args.workers) as evaluator:
            fit = select_model(candidates, experiments, evaluator, np.random.default_rng(FAULT_CHECK_SEED),
                               generations=CHECK["screen_generations"], scan_cycles=0, polish=False,
                               model_space="morphology+servos")
            fit_sims = int(evaluator.simulations)
            angles = fit.angles.copy()
            sims = evaluator.similarities(genomes, experiments, angles)
            fit_similarities = sims.copy()
            Profile().scan_angles(genomes, angles, sims, experiments, evaluator, CHECK["screen_scan_cycles"])
            scanned = model_fitness_from_similarities(sims)
            scan_sims = int(evaluator.simulations) - fit_sims
            top = np.argsort(-scanned, kind="stable")[:CHECK["screen_polish_top"]]
            polished, polished_sims = angles[top].copy(), sims[top].copy()
            Profile().polish_angles(genomes[top], polished, polished_sims, experiments, evaluator)
            after_polish = scanned.copy()
            after_polish[top] = model_fitness_from_similarities(polished_sims)
            polish_sims = int(evaluator.simulations) - fit_sims - scan_sims
        before = _ranks(fit.model_fitness)
        refit = np.argsort(-after_polish, kind="stable")[:CHECK["refit"]]
        # the candidate the mission kept, or the one its gain polish started from (same dimensions, nearest gains)
        same_shape = np.flatnonzero(np.all(np.isclose(candidates[:, :9], kept[:9], atol=1e-4), axis=1))
        kept_row = None
        if len(same_shape):
            kept_row = int(same_shape[np.argmin(np.abs(candidates[same_shape, 9:] - kept[9:]).sum(axis=1))])
        row = {"mission": directory, "damage": report["damage"], "seed": report["seed"],
               "k_exact": int(before[top].max()), "k_refit": int(before[refit].max()),
               "kept_row": kept_row, "kept_exact": bool(kept_row is not None
                                                        and np.allclose(candidates[kept_row], kept, atol=1e-4)),
               "kept_rank_before_scan": None if kept_row is None else int(before[kept_row]),
               "kept_rank_after_scan": None if kept_row is None else int(_ranks(scanned)[kept_row]),
               "refit_rows": refit.tolist(), "refit_ranks_before_scan": before[refit].tolist(),
               "top24_ranks_before_scan": before[top].tolist(),
               "simulations": {"fit": fit_sims, "scan": scan_sims, "polish_24": polish_sims},
               "mission_check_simulations": report["fault_check"]["simulations"]}
        out.parent.mkdir(parents=True, exist_ok=True)
        np.savez(out.with_name(f"{out.stem}_{Path(directory).name}.npz"), fit_similarities=fit_similarities,
                 scanned_similarities=sims, after_polish=after_polish, top24=top, refit=refit,
                 kept_row=-1 if kept_row is None else kept_row)
        emit_line(row, out)  # after the arrays: a mission with its line has them


if __name__ == "__main__":
    main()
