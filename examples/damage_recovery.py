"""Damage recovery through the Python API (paper section 5): self-model, evolve gaits, transfer, video.

    python examples/damage_recovery.py [--budget quick] [--damage NAME] [--episode-duration-s 60] [--out DIR]

The steps of ``aquafish case-study`` (which also writes the report, figures and PPO rows) with a preset's budget. The
self-model holds a gain per servo (its gait's robot has them as ``ServoFaults``); ``robust``: random damages.
"""

import argparse
from pathlib import Path

import eea
import gait
from aquafish.case_study import PRESETS, model_fields, own_self_model_fields, verdict
from aquafish.oracle import evolve_oracle
from aquafish_gym import Morphology, ServoFaults
from gait.video import record_video


def main(argv=None) -> None:  # a function under the __main__ guard: worker processes are spawned
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", "--preset", default="quick", choices=sorted(PRESETS))  # --preset: the old name
    parser.add_argument("--damage", default="reversed_left_pectoral")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--episode-duration-s", "--episode-duration", type=float, default=20.0, help="seconds per episode")
    parser.add_argument("--out", type=Path, default=Path("recovery_out"))
    parser.add_argument("--workers", type=int, default=None)  # processes (default: all cores)
    args = parser.parse_args(argv)
    s, seconds, seed, workers = PRESETS[args.budget], args.episode_duration_s, args.seed, args.workers

    # 1. the damaged robot self-models: plain EEA (the paper's 9 dimensions) and the case study's self-model
    robots = {"healthy": gait.Robot(Morphology.healthy()), "robust": gait.Robot(Morphology.healthy(), "random")}
    self_model_fields = model_fields(own=own_self_model_fields(s, None))  # quick: the ranked fault hypotheses
    for key, method, fields in (("plain_eea", "none", {}), ("self_model", "profile_lineages", self_model_fields)):
        eea.run(eea.EEAConfig.from_method(method, s.budget, damage=args.damage, seed=seed, **fields,
                                          **({"workers": workers} if workers else {})), args.out / f"eea_{key}")
        result = eea.load_result(args.out / f"eea_{key}")  # self_model: what the check against fault hypotheses kept
        gains = tuple(result.self_model[9:])  # the 3 servo gains after the 9 dimensions (none in "morphology")
        robots[key] = gait.Robot(result.self_model_morphology, faults=ServoFaults(speed_scale=gains) if gains else None)
    target = gait.as_robot(args.damage)  # the damaged robot: the oracle gait's robot too
    # 2. a NEAT gait per robot, one budget; the oracle: the best of 3 runs on the damaged robot, 3x the generations
    kw = dict(population_size=s.gait_population, episodes_per_genome=s.gait_episodes, episode_duration_s=seconds,
              generations=s.gait_generations, workers=workers)
    controllers = {key: gait.evolve_or_load_gait(robot, args.out / f"gait_{key}_{seconds:g}s", seed=seed, **kw)
                   for key, robot in robots.items()}
    controllers["true_damaged"] = evolve_oracle(target, args.out / f"oracle_{seconds:g}s", **kw).controller
    robots["true_damaged"] = target  # 3. each swims on its robot and on the damaged one, from the same starts
    transfers = {key: gait.score_transfer(controllers[key], robot, target, seed=seed, episodes=s.transfer_episodes,
                                          episode_duration_s=seconds) for key, robot in robots.items()}
    for key, t in transfers.items():
        print(f"{key:>12}: {t.native_distance:6.2f} units on its robot, {t.target_distance:6.2f} on the damaged robot")
    print(verdict({key: {"target_distance": t.target_distance} for key, t in transfers.items()})["line"])
    # 4. the damaged robot from above under three of the gaits (mp4, or a GIF without imageio-ffmpeg)
    video = record_video({k: controllers[k] for k in ("healthy", "self_model", "true_damaged")}, target,
                         args.out / "recovery", seed=seed, episode_duration_s=seconds)
    print(f"wrote {video}")


if __name__ == "__main__":
    main()
