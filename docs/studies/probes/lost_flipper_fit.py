"""Does the true damaged robot explain a mission's experiments better than the self-model it kept?

For each finished mission, fits the initial angles of its kept self-model
(``self_model_after``) and of the truth (``true_model``) equally hard on the mission's own
target experiments (``recovered/experiments.npz``; :func:`eea.inference.selection.select_model`
with the fault check's refit settings, 10 generations and 2 scan cycles, two seeds) and prints
both MOD_FITs (eq. 3). Where the truth scores lower, no search of the model space finds it: the
experiments themselves favour the other model. Made for the missions whose pectoral flipper is
lost, where the check keeps a flipper with a weak servo instead.

    python docs/studies/probes/lost_flipper_fit.py runs/missions/rehearsal_sampled_1017_s5001 \\
        runs/missions/rehearsal_sampled_5_s1
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

import eea
from aquafish.mission import MISSION_PRESETS, _eea_config
from eea.encoding import get_model_space
from eea.evaluation import Evaluator
from eea.inference.selection import select_model


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("missions", nargs="+")
    args = parser.parse_args(argv)
    space = get_model_space("morphology+servos")
    for directory in map(Path, args.missions):
        report = json.loads((directory / "mission.json").read_text())
        experiments = eea.load_experiments(directory / "recovered" / "experiments.npz")
        kept = np.array([report["self_model_after"][f] for f in space.fields])
        truth = np.array([report["true_model"][f] for f in space.fields])
        config = _eea_config(MISSION_PRESETS[report["preset"]], report["damage"], report["seed"], 1,
                             report.get("self_model_fields") or {})
        fits = []
        with Evaluator.for_config(config, workers=1) as evaluator:
            for seed in (0, 1):
                selection = select_model(np.stack([kept, truth]), experiments, evaluator, np.random.default_rng(seed),
                                         generations=10, scan_cycles=2, model_space="morphology+servos")
                fits.append(np.round(selection.model_fitness, 5).tolist())
        print(json.dumps({"mission": directory.name, "kept_gains": kept[9:].tolist(), "true_gains": truth[9:].tolist(),
                          "mod_fit_kept_truth_per_seed": fits}), flush=True)


if __name__ == "__main__":
    main()
