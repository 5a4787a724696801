"""``aquafish gait``, ``aquafish transfer`` and ``aquafish rl`` sub-commands."""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path

import numpy as np

from aquafish_gym.argtypes import (add_alias, add_config_option, add_episode_duration, add_no_progress, add_workers,
                                   int_at_least, path, seed_below)
from aquafish_gym.rundir import check_output_dir

#: gait.controller.SB3_ALGOS, spelled out: importing gait here would cost every command 0.6 s
#: (tests/gait/test_gait_rl.py checks the two agree).
RL_ALGOS = ("ppo", "sac", "recurrent_ppo")

ROBOT_HELP = ("'healthy', a damage name, inline JSON fault or sampled:SEED (the healthy robot with that damage), "
              "9 comma-separated numbers, or a JSON/text file")
DAMAGE_HELP = ("damage applied to --morphology: a preset name, a JSON fault inline or as FILE.json (keys scale, seized, "
               "gains) or sampled:SEED (default none)")


def add_commands(subparsers) -> None:
    """Register the gait sub-commands on the ``aquafish`` parser's ``subparsers``."""
    p = subparsers.add_parser("gait", help="evolve a swimming controller with NEAT (paper section 5)",
                              description="Evolve a NEAT controller that swims forward as far as possible in 20 s "
                                          "(or maximises the return of another AquaFish task, --env).")
    p.add_argument("--env", default="AquaFish-v0", help="task (`aquafish envs` lists them; default AquaFish-v0)")
    p.add_argument("--morphology", default="healthy", help=f"robot to evolve for: {ROBOT_HELP} (default healthy)")
    p.add_argument("--damage", default="none", help=DAMAGE_HELP)
    p.add_argument("--generations", type=int_at_least(1), default=30, help="total generations (default 30)")
    p.add_argument("--population-size", type=int_at_least(2), default=None, help="genomes per generation (default: the config's, 50)")
    p.add_argument("--seed", type=seed_below(), default=0, help="seeds NEAT and the fitness episode's initial flipper angles (default 0)")
    p.add_argument("--out", type=path, default=Path("runs/gait"), help="output directory (default runs/gait)")
    add_workers(p, os.cpu_count(), "all cores")
    p.add_argument("--neat-config", type=path, default=None,
                   help="NEAT INI file (default gait/neat_config.ini; a run's own copy is its neat_config.ini)")
    p.add_argument("--resume", default=None, help="checkpoint file (in checkpoints/ of a run directory with its fitness_settings.json) to "
                        "continue from, or 'latest' (in --out). A run directory is trusted like code: its "
                        "checkpoints are pickles, so resume only runs you made or trust")
    add_episode_duration(p, 20.0, "20", note="each genome's evaluation")
    p.add_argument("--episodes-per-genome", type=int_at_least(1), default=1,
                   help="episodes per evaluation from different initial angles (seeds seed, seed+1, ...); fitness is their mean (default 1)")
    p.add_argument("--spread-headings", action="store_true",
                   help="start episode k of the K turned by -180 + 360 (k + 1/2) / K degrees and score it along its "
                        "own start heading, so the gait swims alike whichever way it points (AquaFish-v0; with "
                        "--episodes-per-genome 2: -90 and +90 degrees)")
    p.add_argument("--checkpoint-every", type=int_at_least(1), default=5, help="generations between checkpoints (default 5)")
    p.add_argument("--verbose", action="store_true", help="NEAT's per-generation report (species, fitness statistics)")
    add_alias(p, add_no_progress(p, "generation"), "--quiet")
    add_config_option(p)
    p.set_defaults(func=run_gait)

    p = subparsers.add_parser("transfer", help="score controllers on their native robot and on a target (Figure 12)",
                              description="Run each controller on its native robot and on the target from the same "
                                          "initial flipper angles; write distances, trajectories and a Figure-12 plot.")
    p.add_argument("--controller", nargs="+", required=True, type=path,
                   help="controller files (best_controller.json NEAT, model.zip SB3) or run directories, one panel "
                        "each; no controller file runs code when loaded (pickles are refused)")
    p.add_argument("--native", nargs="+", default=["healthy"], help=f"each controller's own robot: {ROBOT_HELP}; one, or one per controller")
    p.add_argument("--target", required=True, help=f"robot to transfer to: {ROBOT_HELP}")
    p.add_argument("--seed", type=seed_below(), default=0, help="seed of the first episode: draws the initial angles (default 0, as `aquafish gait`)")
    p.add_argument("--episodes", type=int_at_least(1), default=1,
                   help="paired episodes per robot (seeds seed, seed+1, ...); distances are their means (default 1)")
    p.add_argument("--initial-angles", default=None, help="3 comma-separated angles (rad): left, right pectoral, caudal")
    p.add_argument("--title", nargs="+", default=None, help="one title per controller")
    p.add_argument("--out", type=path, default=Path("runs/transfer"), help="writes transfer.json and transfer.png (default runs/transfer)")
    p.set_defaults(func=run_transfer)

    p = subparsers.add_parser("rl", help="train a stable-baselines3 PPO/SAC/RecurrentPPO baseline (needs the [rl] extra)",
                              description="Train PPO, SAC or sb3-contrib's RecurrentPPO (an LSTM policy) on AquaFish-v0 "
                                          "(clock appended to the observation).")
    p.add_argument("--algo", choices=RL_ALGOS, default="ppo", help="algorithm (default ppo)")
    p.add_argument("--env", default="AquaFish-v0", help="task (`aquafish envs` lists them; default AquaFish-v0)")
    p.add_argument("--morphology", default="healthy", help=f"robot: {ROBOT_HELP} (default healthy)")
    p.add_argument("--damage", default="none", help=DAMAGE_HELP)
    p.add_argument("--timesteps", type=int_at_least(1), default=None, help="env steps of 0.1 s (default: the YAML's n_timesteps)")
    p.add_argument("--seed", type=seed_below(), default=0, help="training seed (default 0)")
    p.add_argument("--out", type=path, default=Path("runs/rl"), help="output directory (default runs/rl)")
    p.add_argument("--hyperparams", type=path, default=None, help="RL-Zoo-style YAML (default gait/rl_hyperparams.yml)")
    add_episode_duration(p, 20.0, "20", note="each training episode")
    p.add_argument("--num-threads", type=int_at_least(1), default=1, help="torch CPU threads (default 1)")
    p.add_argument("--verbose", type=int, default=0, choices=(0, 1, 2), help="SB3 verbosity (default 0)")
    add_no_progress(p, "rollout")
    add_config_option(p)
    p.set_defaults(func=run_rl)


def run_gait(args: argparse.Namespace) -> int:
    from gait.neat_evolution import latest_checkpoint, evolve_gait

    check_output_dir(args.out)
    resume = latest_checkpoint(args.out) if args.resume == "latest" else args.resume
    result = evolve_gait(args.morphology, damage=args.damage, generations=args.generations,
                         population_size=args.population_size, seed=args.seed, out_dir=args.out, workers=args.workers,
                         config_path=args.neat_config, resume=resume, episode_duration_s=args.episode_duration_s,
                         episodes_per_genome=args.episodes_per_genome, checkpoint_every=args.checkpoint_every, verbose=args.verbose,
                         progress=not args.no_progress, env_id=args.env, spread_headings=args.spread_headings)
    score = (f"forward distance {result.best_fitness:.3f} units ({result.best_fitness * 8:.1f} cm)" if args.env == "AquaFish-v0"
             else f"{args.env} return {result.best_fitness:.3f}")
    print(f"best {score} in {args.episode_duration_s:g} s on {result.robot.label}; {result.generations} generations, "
          f"{result.wall_time_s:.0f} s wall; wrote {args.out}")
    return 0


def _how_to_continue_gait(args: argparse.Namespace) -> str:
    """How an interrupted ``aquafish gait`` continues: a run with a checkpoint only with ``--resume
    latest`` (the same command without it is refused, so as not to overwrite the run)."""
    from gait.neat_evolution import CHECKPOINT_DIR, CHECKPOINT_PREFIX

    if args.resume != "latest" and any((Path(args.out) / CHECKPOINT_DIR).glob(CHECKPOINT_PREFIX + "*")):
        return "run the same command with --resume latest to continue"
    return "run the same command to continue"


run_gait.how_to_continue = _how_to_continue_gait


def _angles(text: str | None):
    if text is None:
        return None
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3:
        raise ValueError(f"--initial-angles needs 3 comma-separated numbers (rad), got {text!r}")
    return np.array(values)


def run_transfer(args: argparse.Namespace) -> int:
    from gait.controller import load_controller
    from gait.plots import plot_transfer
    from gait.transfer import save_transfer, score_transfer

    natives = args.native * len(args.controller) if len(args.native) == 1 else args.native
    if len(natives) != len(args.controller):
        raise ValueError(f"give one --native or one per --controller ({len(args.controller)}), got {len(args.native)}")
    if args.title is not None and len(args.title) != len(args.controller):
        raise ValueError(f"give one --title per --controller ({len(args.controller)}), got {len(args.title)}")
    angles = _angles(args.initial_angles)
    check_output_dir(args.out)
    controllers = [load_controller(path) for path in args.controller]  # every file refused before any episode
    results = []
    for path, controller, native in zip(args.controller, controllers, natives):
        result = score_transfer(controller, native, args.target, seed=args.seed, episodes=args.episodes,
                                initial_angles=angles)
        results.append(result)
        print(f"{path}: native {result.native.label} {result.native_distance:.3f} units, "
              f"target {result.target.label} {result.target_distance:.3f} units (mean of {result.episodes})")
    save_transfer(results, args.out / "transfer.json")
    plot_transfer(results, args.out / "transfer.png", titles=args.title)
    print(f"wrote {args.out / 'transfer.json'} and {args.out / 'transfer.png'}")
    return 0


def run_rl(args: argparse.Namespace) -> int:
    from gait.controller import require_rl
    from gait.rl import train_rl

    require_rl(f"--algo {args.algo}", args.algo, training=True)

    path = train_rl(args.algo, args.morphology, args.timesteps, args.seed, args.out, damage=args.damage,
                    hyperparams_path=args.hyperparams, episode_duration_s=args.episode_duration_s,
                    num_threads=args.num_threads, verbose=args.verbose, env_id=args.env,
                    progress=not args.no_progress)
    meta = json.loads(path.with_suffix(".json").read_text())
    asked = meta.get("timesteps_requested", meta["timesteps"])
    if asked != meta["timesteps"]:
        print(f"note: --timesteps {asked} was rounded up to {meta['timesteps']} steps ({args.algo.upper()} trains whole "
              "rollouts of n_steps x n_envs steps; see the hyperparameter file)")
    print(f"{args.algo.upper()} on {args.env}: {meta['timesteps']} steps in {meta['wall_time_s']:.0f} s; forward distance "
          f"{meta['eval_distance']:.3f} units, return {meta['eval_return']:.3f} in 20 s (seed {meta['eval_seed']}); "
          f"wrote {path}")
    return 0
