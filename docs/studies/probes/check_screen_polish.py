"""Does the fault check need its screen's compass polish? Re-checks missions' self-models offline.

A mission's recovery ends with the fault check (:func:`eea.fault_check.check_final_model`): the
final model and 97 fault hypotheses about the design, each one's initial angles fitted on all
the experiments (a screen of 3 generations, a scan cycle and a compass polish), the best 8
fitted again in 2 rounds, then a gain polish. In a lean mission it is about 70 % of the
recovery's model simulations (``mission.json``'s ``simulations``), and the screen's compass
polish (60-90 simulations a candidate and experiment) is most of the screen. This probe runs
the check again on each mission's own experiments (``recovered/experiments.npz``) and final
model (``fault_check.final_model``), as the mission ran it and with ``--variant``'s change, and
reports the model each keeps, its MOD_FIT and the simulations each ran (``refit4``,
``refit_rounds1``: fewer candidates fitted again, or one round of refits instead of two; ``screen_top24``, ``screen_top16``: the screen's compass
polish only on the 24 or 16 best of the unpolished screen). A variant that keeps
the same model as the mission did gives the same mission (the same self-model, hence the same
new gait). Resumable: one JSON line per mission and variant in ``--out``.

    python docs/studies/probes/check_screen_polish.py runs/missions/window_* \\
        --variants default,no_screen_polish --out runs/check_screen_polish.jsonl
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import eea
from aquafish.mission import MISSION_PRESETS, _eea_config
from aquafish_gym import Morphology
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.fault_check import FAULT_CHECK_SEED
from eea.fitness import model_fitness_from_similarities
from eea.inference.profile import Profile
from eea.inference.selection import check_fault_hypotheses, fault_hypotheses, polish_gains, select_model

#: The screen's compass polish only on this many of the best of the unpolished screen
#: (``screen_top24``, ``screen_top16``).
SCREEN_TOP = {"screen_top24": 24, "screen_top16": 16}


def check_screen_top(model, design, experiments, evaluator, seed, top):
    """check_fault_hypotheses at its defaults, but the screen's compass polish only on the ``top``
    best of the unpolished screen (the polish takes about half of the check's simulations)."""
    candidates = np.vstack([model[None], fault_hypotheses(design)])
    screen = select_model(candidates, experiments, evaluator, np.random.default_rng(seed), generations=3,
                          scan_cycles=1, polish=False, model_space="morphology+servos")
    fitness, angles = screen.model_fitness.copy(), screen.angles.copy()
    chosen = np.argsort(-fitness, kind="stable")[:top]
    genomes = get_model_space("morphology+servos").encode(candidates[chosen])
    polished = angles[chosen].copy()
    sims = evaluator.similarities(genomes, experiments, polished)
    Profile().polish_angles(genomes, polished, sims, experiments, evaluator)
    fitness[chosen], angles[chosen] = model_fitness_from_similarities(sims), polished
    best = np.argsort(-fitness, kind="stable")[:8]
    for stage in (1, 2):
        starts = np.repeat(angles[best][:, None], len(best), axis=1)
        again = select_model(candidates[best], experiments, evaluator, np.random.default_rng(seed + stage),
                             generations=10, scan_cycles=2, start=starts, model_space="morphology+servos")
        better = again.model_fitness > fitness[best]
        fitness[best[better]], angles[best[better]] = again.model_fitness[better], again.angles[better]
    return polish_gains(candidates, fitness, angles, experiments, evaluator, seed + 3)


#: name: keyword arguments of check_fault_hypotheses over its defaults
VARIANTS = {"default": {}, "no_screen_polish": {"screen_polish": False}, "refit4": {"refit": 4},
            "refit_rounds1": {"refit_rounds": 1}, "refit4_rounds1": {"refit": 4, "refit_rounds": 1}}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    parser.add_argument("--variants", default="no_screen_polish")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    out = Path(args.out)
    done = set()
    if out.is_file():
        done = {(r["mission"], r["variant"]) for r in map(json.loads, out.read_text().splitlines())}
    space = get_model_space("morphology+servos")
    for directory in args.missions:
        report = json.loads((Path(directory) / "mission.json").read_text())
        if not report.get("fault_check"):
            continue
        experiments = eea.load_experiments(Path(directory) / "recovered" / "experiments.npz")
        model = np.array([report["fault_check"]["final_model"][f] for f in space.fields])
        config = _eea_config(MISSION_PRESETS[report["preset"]], report["damage"], report["seed"], args.workers,
                             report.get("self_model_fields") or {})
        kept = [report["self_model_after"][f] for f in space.fields]
        for name in args.variants.split(","):
            if (directory, name) in done:
                continue
            with Evaluator.for_config(config, workers=args.workers) as evaluator:
                t0 = time.perf_counter()
                design = Morphology.healthy().to_array()
                if name in SCREEN_TOP:
                    selection = check_screen_top(model, design, experiments, evaluator, FAULT_CHECK_SEED,
                                                 SCREEN_TOP[name])
                else:
                    selection = check_fault_hypotheses(model, design, experiments, evaluator, FAULT_CHECK_SEED,
                                                       **VARIANTS[name])
                chosen = selection.models[selection.index]
                row = {"mission": directory, "variant": name, "damage": report["damage"], "seed": report["seed"],
                       "simulations": int(evaluator.simulations), "wall_s": time.perf_counter() - t0,
                       "model": np.round(chosen, 4).tolist(),
                       "model_fitness": float(selection.model_fitness[selection.index]),
                       "same_as_mission": bool(np.allclose(np.round(chosen, 4), kept, atol=1e-4)),
                       "gains": np.round(chosen[9:], 4).tolist(),
                       "mission_gains": kept[9:]}
            print(json.dumps(row), flush=True)
            with out.open("a") as f:
                f.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
