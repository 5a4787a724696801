"""``aquafish swim`` and ``aquafish envs``, the simulator package's sub-commands (``aquafish bench`` is in :mod:`aquafish.bench_cli`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from aquafish_gym.argtypes import add_alias, add_episode_duration, csv_list, damage_list, path


def _swim(args: argparse.Namespace) -> int:
    from aquafish_gym.damage import get_damage
    from aquafish_gym.rundir import check_memory, check_output_dir
    from aquafish_gym.swim import plot_trajectories, swim_trajectories

    damages = [get_damage(name).name for name in args.damages]  # an unknown name: the message lists the valid ones
    action = list(args.action)
    if len(action) != 3:
        raise ValueError(f"--action needs 3 comma-separated numbers (left rev/s, right rev/s, caudal Hz), got {len(action)}")
    # the trajectory: one (robots, 2) sample of ~150 bytes per 0.1 s, plus 16 bytes per robot
    check_memory(f"--episode-duration-s {args.episode_duration_s:g}",
                 args.episode_duration_s / 0.1 * (150 + 16 * len(damages)), "give a shorter --episode-duration-s")
    check_output_dir(args.out)
    traj = swim_trajectories(damages, action, args.episode_duration_s)
    labels = ["healthy" if d == "none" else d for d in damages]
    path = plot_trajectories(traj, labels, Path(args.out) / "trajectories.png",
                             title=f"fixed gait {tuple(action)} (rev/s, rev/s, Hz), {args.episode_duration_s:g} s")
    for label, t in zip(labels, traj):
        print(f"{label:>24}: end at x={t[-1, 0]:+.2f}, y={t[-1, 1]:+.2f} units")
    print(f"wrote {path}")
    return 0


def env_lines() -> list[str]:
    """One line per registered task: id, observation and action sizes, the class's summary."""
    import gymnasium as gym

    from aquafish_gym import ENV_IDS

    lines = []
    for env_id in ENV_IDS:
        env = gym.make(env_id)
        summary = (type(env.unwrapped).__doc__ or "").strip().splitlines()[0]
        lines.append(f"{env_id:<27} obs {env.observation_space.shape[0]:>2}  act {env.action_space.shape[0]}  {summary}")
        env.close()
    return lines


def _envs(args: argparse.Namespace) -> int:
    print("\n".join(env_lines()))
    return 0


def add_commands(sub) -> None:
    """Add the ``swim`` and ``envs`` sub-commands to an argparse ``subparsers`` object."""
    p = sub.add_parser("swim", help="swim the healthy and damaged robots with a fixed gait; plot trajectories")
    p.add_argument("--damages", type=damage_list,
                   default=("none", "left_pectoral_half", "reversed_left_pectoral", "caudal_missing"),
                   help="comma-separated damages: preset names, JSON faults inline or as FILE.json, sampled:SEED "
                        "(default none,left_pectoral_half,reversed_left_pectoral,caudal_missing)")
    p.add_argument("--action", type=csv_list(float), default=(-0.5, -0.5, 1.0),
                   help="servo command: left rev/s, right rev/s, caudal Hz (default -0.5,-0.5,1.0: both paddles "
                        "pushing backwards under water, the tail at 1 Hz)")
    add_alias(p, add_episode_duration(p, 20.0, "20", note="the one swim of each robot"), "--duration")
    p.add_argument("--out", type=path, default="demo_out", help="output directory (default demo_out)")
    p.set_defaults(func=_swim)

    e = sub.add_parser("envs", help="list the registered Gymnasium tasks (gym.make ids), one line each")
    e.set_defaults(func=_envs)
