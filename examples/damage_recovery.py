"""Damage recovery through the Python API (paper section 5): self-model, evolve gaits, transfer.

    python examples/damage_recovery.py [--preset quick|medium|paper|smoke] [--damage caudal_half] [--out DIR]

The steps of ``aquafish case-study`` (``aquafish/case_study.py``, which also writes the
report and figures), with a preset's settings. Finished steps in ``--out`` are reused.
"""

import argparse
from pathlib import Path

import eea
import gait
from aquafish.case_study import PRESETS, verdict
from aquafish_gym import Morphology
from eea.config import EEAConfig

def main() -> None:  # a function under the __main__ guard: worker processes are spawned
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="quick", choices=sorted(PRESETS))
    parser.add_argument("--damage", default="left_pectoral_half")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=Path("recovery_out"))
    args = parser.parse_args()
    settings = PRESETS[args.preset]

    # 1. the damaged robot (the target) self-models with the EEA: plain, and with out-of-band inference
    models = {}
    for key, inference in (("plain_eea", "none"), ("self_model", "out_of_band")):
        config = EEAConfig(inference=inference, damage=args.damage, seed=args.seed, **settings.eea)
        result = eea.run(config, args.out / f"eea_{inference}")
        models[key] = result.best_morphology
        print(f"{key}: objective fitness {result.rounds[-1]['objective_fitness']:.3f} (eq. 4)")

    # 2. a NEAT gait for every robot: healthy, the two self-models, the true damaged robot (oracle)
    target = gait.as_robot(args.damage)
    natives = {"healthy": Morphology.healthy(), **models, "true_damaged": target}
    distances = {}
    for key, native in natives.items():
        controller = gait.evolve_or_load_gait(
            native, args.out / f"gait_{key}", generations=settings.gait_generations,
            population_size=settings.gait_population, seed=args.seed, episodes_per_genome=settings.gait_episodes)
        # 3. each gait swims on its own robot and on the damaged one, from the same starts
        t = gait.score_transfer(controller, native, target, seed=args.seed, episodes=settings.transfer_episodes)
        distances[key] = {"target_distance": t.target_distance}
        print(f"{key:>12}: {t.native_distance:6.2f} units on its robot, {t.target_distance:6.2f} on the damaged robot")

    print(verdict(distances)["line"])


if __name__ == "__main__":
    main()
