"""Does the fault check need its screen's compass polish? Re-checks missions' self-models offline.

A mission's recovery ends with the fault check (:func:`eea.fault_check.check_final_model`): the
final model and 97 fault hypotheses about the design, each one's initial angles fitted on all
the experiments (a screen of 3 generations and a scan cycle, then a compass polish of its best
24), the best 8 fitted again in 2 rounds, then a gain polish. Until 2026-11-28 the screen
polished all 98 (``polish_all``), about 80 % of the check's simulations being the screen and
half of them that polish. This probe runs the check again on each mission's own experiments
(``recovered/experiments.npz``) and final model (``fault_check.final_model``) with
``--variants``' settings, and reports the model each keeps, its MOD_FIT and the simulations
each ran (``no_screen_polish``; ``screen_top24``, ``screen_top16``: the polish on the 24 or 16
best of the unpolished screen; ``refit4``, ``refit_rounds1``: fewer candidates fitted again,
or one round of refits, beside the screen polished whole). A variant that keeps the same
model as the mission did gives the same mission (the same self-model, hence the same new
gait). Each line also has ``fits``, the simulations of every angle fit in order (the screen,
the refit rounds, the gain polish's), and ``simulations_outside_fits`` (the screen's polish of
its best). Resumable: one JSON line per mission and variant in ``--out``. (``screen_top24`` first
ran at commit f296fd7 as a copy of the check inside this probe; the library's
``screen_polish_top`` is the same computation.)

    python docs/studies/probes/check_screen_polish.py runs/missions/window_* \\
        --variants polish_all,no_screen_polish --out runs/check_screen_polish.jsonl
"""

from __future__ import annotations

import argparse
import contextlib
import json
import time
from pathlib import Path

import numpy as np

from aquafish_gym import Morphology
from eea.evaluation import Evaluator
from eea.fault_check import FAULT_CHECK_SEED
import eea.inference.selection as selection_module
from eea.inference.selection import check_fault_hypotheses
from mission_replay import load_checked_mission

#: name: keyword arguments of check_fault_hypotheses over its defaults
VARIANTS = {"default": {}, "polish_all": {"screen_polish_top": 98}, "no_screen_polish": {"screen_polish_top": 0},
            "screen_top24": {"screen_polish_top": 24}, "screen_top16": {"screen_polish_top": 16},
            "refit4": {"refit": 4, "screen_polish_top": 98},
            "refit_rounds1": {"refit_rounds": 1, "screen_polish_top": 98},
            "refit4_rounds1": {"refit": 4, "refit_rounds": 1, "screen_polish_top": 98}}


@contextlib.contextmanager
def _counted_fits(evaluator):
    """Count the simulations of every select_model call the check makes: yields a list that
    gets ``[models fitted, simulations]`` per call (the screen, the refit rounds, the gain
    polish's fits, in order); what the check simulates outside them (the screen's compass
    polish of its best) is the rest of the total."""
    fits, original = [], selection_module.select_model

    def counted(models, *args, **kwargs):
        before = evaluator.simulations
        result = original(models, *args, **kwargs)
        fits.append([len(models), int(evaluator.simulations - before)])
        return result

    selection_module.select_model = counted
    try:
        yield fits
    finally:
        selection_module.select_model = original


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    parser.add_argument("--variants", default="default")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    out = Path(args.out)
    done = set()
    if out.is_file():
        done = {(r["mission"], r["variant"]) for r in map(json.loads, out.read_text().splitlines())}
    for directory in args.missions:
        mission = load_checked_mission(directory, args.workers)
        if mission is None:
            continue
        report, experiments, model, kept, config = mission
        for name in args.variants.split(","):
            if (directory, name) in done:
                continue
            with Evaluator.for_config(config, workers=args.workers) as evaluator, _counted_fits(evaluator) as fits:
                t0 = time.perf_counter()
                selection = check_fault_hypotheses(model, Morphology.healthy().to_array(), experiments, evaluator,
                                                   FAULT_CHECK_SEED, **VARIANTS[name])
                chosen = selection.models[selection.index]
                row = {"mission": directory, "variant": name, "damage": report["damage"], "seed": report["seed"],
                       "simulations": int(evaluator.simulations), "wall_s": time.perf_counter() - t0,
                       "model": np.round(chosen, 4).tolist(),
                       "model_fitness": float(selection.model_fitness[selection.index]),
                       "same_as_mission": bool(np.allclose(np.round(chosen, 4), kept, atol=1e-4)),
                       "gains": np.round(chosen[9:], 4).tolist(),
                       "mission_gains": kept[9:].tolist(),
                       "fits": fits, "simulations_outside_fits": int(evaluator.simulations) - sum(f[1] for f in fits)}
            print(json.dumps(row), flush=True)
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
