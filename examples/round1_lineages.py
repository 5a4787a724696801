"""Where the two lineages of a run stand after round 1 (docs/studies/unknown_angles.md).

With ``--cma-global-first-round 1`` the estimation's local and global CMA-ES start
together in round 1, from two random points, so that round 1 (one experiment, where a
run's wrong basin is mostly decided) ends with two independently found models. For each
seed this runs round 1 of the library preset with two lineages (a resumable run directory
per seed under ``--out``) and prints each lineage's own best model of the last generation:
its dimensions, its OBJ_FIT (eq. 4) against the target, the flipper fields that are 0 where
the target's flipper has all three dimensions (a massless flipper, ``wrong_basins.py``),
and the distance between the two lineages (1 - OBJ_FIT of one against the other).

    python examples/round1_lineages.py --seeds 11,12,18,19 --out runs/round1_lineages

Costs one round per seed (about 45 s on one core for the reduced setting).
"""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

import numpy as np

from aquafish_gym import MORPHOLOGY_FIELDS, get_damage
from eea.checkpoint import load_state
from eea.config import EEAConfig
from eea.diversity import model_distance
from eea.encoding import decode_models
from eea.fitness import objective_fitness
from eea.run import run

from wrong_basins import massless


def lineages(config: EEAConfig, out_dir: Path) -> dict[str, np.ndarray]:
    """Run (or resume) round 1 of ``config`` in ``out_dir``; each lineage's best ``(45,)`` genome."""
    run(config.replace(rounds=1), out_dir, progress=False)
    search = pickle.loads(load_state(out_dir).estimation["search"]["pickle"])
    return search.lineage_best_genomes


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="0", help="comma-separated seeds")
    parser.add_argument("--damage", default="left_pectoral_half")
    parser.add_argument("--preset", action="append", default=None,
                        help="presets (default: reduced and library), given again for more")
    parser.add_argument("--global-keep", type=int, default=10, help="--cma-global-keep of the runs")
    parser.add_argument("--out", required=True, help="directory of the round-1 runs (seed<k> below it)")
    args = parser.parse_args(argv)
    truth = get_damage(args.damage).apply().to_array()
    truth_fields = dict(zip(MORPHOLOGY_FIELDS, truth))
    for seed in (int(s) for s in args.seeds.split(",")):
        config = EEAConfig.from_presets(*(args.preset or ("reduced", "library")), damage=args.damage, seed=seed,
                                        cma_global_first_round=1, cma_global_keep=args.global_keep, workers=1)
        bests = lineages(config, Path(args.out) / f"seed{seed}")
        if not bests:
            raise SystemExit(f"{Path(args.out) / f'seed{seed}'}: its checkpoint records no lineage bests "
                             "(written before CMAModelSearch.lineage_best_genomes); delete it and run again")
        for name, genome in bests.items():
            dims = decode_models(genome[None])[0]
            zero = massless(dict(zip(MORPHOLOGY_FIELDS, dims)), truth_fields)
            print(f"seed {seed:<3} {name:<6} {np.array2string(dims, precision=3, max_line_width=200)} "
                  f"OBJ_FIT {float(objective_fitness(dims, truth)):.3f} massless {', '.join(zero) or '-'}")
        apart = float(model_distance(bests["local"][None], bests["global"])[0])
        print(f"seed {seed:<3} lineages apart: {apart:.3f} (1 - OBJ_FIT)")


if __name__ == "__main__":
    main()
