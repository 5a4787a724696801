"""Env steps per second of PPO training: SB3's DummyVecEnv over single envs vs. the batched vector env.

Trains PPO with ``gait/rl_hyperparams.yml``'s ``ppo -> AquaFish-v0`` settings (``--n-envs``
and ``--n-steps`` override two of them) on the healthy robot for ``--timesteps`` env steps,
once on each env stack, interleaved over ``--repeats``:

* ``dummy``: ``make_vec_env`` (a ``DummyVecEnv``) over ``n_envs`` single envs of
  :func:`gait.rl.make_rl_env`, what :func:`gait.rl.train_rl` used before, and
* ``vector``: :func:`gait.sb3_vec_env.make_clock_vec_env`, the ``n_envs`` robots in one
  PyBullet world, what :func:`gait.rl.train_rl` uses,

and prints, per stack, the median env steps per second of ``model.learn`` (wall and this
process's CPU time: PyBullet runs in-process), the share of the wall time spent in the env
(``reset``, ``step_wait``), the speed-up over ``dummy``, and the mean return of the last
100 training episodes of the first repeat (same seed on both stacks: equal, up to the
episode log's float32 sums, while no float32 reward differs between the stacks; once one
rounds differently, PPO's sampling diverges as with another seed).

    python -m aquafish.benchmarks.ppo_vec_env (or aquafish bench ppo_vec_env) [--timesteps 8192] [--num-threads 1] [--repeats 1] [--n-envs N --n-steps S]
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np

from aquafish_gym.argtypes import seed_below


def _timed(venv):
    """``venv`` in a ``VecEnvWrapper`` that adds the wall seconds of ``reset``/``step_wait`` to ``.env_s``."""
    from stable_baselines3.common.vec_env import VecEnvWrapper

    class Timed(VecEnvWrapper):
        env_s = 0.0

        def reset(self):
            t0 = time.perf_counter()
            obs = self.venv.reset()
            self.env_s += time.perf_counter() - t0
            return obs

        def step_wait(self):
            t0 = time.perf_counter()
            out = self.venv.step_wait()
            self.env_s += time.perf_counter() - t0
            return out

    return Timed(venv)


def train_once(stack: str, timesteps: int, seed: int, n_envs: int | None, n_steps: int | None) -> dict[str, float]:
    """Train PPO once on ``stack`` ("dummy" or "vector"); wall/CPU seconds, env seconds, steps, final mean return.

    Raises:
        ValueError: an unknown stack.
    """
    from stable_baselines3 import PPO
    from stable_baselines3.common.env_util import make_vec_env

    from gait.rl import load_hyperparams, make_rl_env, quiet_logger
    from gait.robots import as_robot
    from gait.sb3_vec_env import make_clock_vec_env

    hp = load_hyperparams("ppo")
    hp.pop("n_timesteps")
    policy, envs = hp.pop("policy"), hp.pop("n_envs")
    envs = n_envs or envs
    if n_steps:
        hp["n_steps"] = n_steps
    robot = as_robot("healthy")
    if stack == "dummy":
        venv = make_vec_env(lambda: make_rl_env(robot), n_envs=envs, seed=seed)
    elif stack == "vector":
        venv = make_clock_vec_env(robot, envs, seed=seed)
    else:
        raise ValueError(f"unknown stack {stack!r}")
    venv = _timed(venv)
    model = PPO(policy, venv, seed=seed, device="cpu", **hp)
    model.set_logger(quiet_logger())  # no empty SB3-<date> directory in the temporary folder
    wall, cpu = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=timesteps)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    venv.close()
    returns = [e["r"] for e in model.ep_info_buffer]
    return {"wall_s": wall, "cpu_s": cpu, "env_s": venv.env_s, "steps": model.num_timesteps,
            "episodes": len(returns), "mean_return": float(np.mean(returns)) if returns else float("nan")}


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages
    (``aquafish bench ppo_vec_env`` passes its own). Needs the ``[rl]`` extra.
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--timesteps", type=int, default=8192, help="env steps of PPO per run")
    parser.add_argument("--num-threads", type=int, default=1, help="torch CPU threads")
    parser.add_argument("--repeats", type=int, default=1, help="interleaved runs per stack (the median is shown)")
    parser.add_argument("--seed", type=seed_below(), default=0, help="SB3's seed (both stacks)")
    parser.add_argument("--n-envs", type=int, default=None, help="override the YAML's n_envs")
    parser.add_argument("--n-steps", type=int, default=None, help="override the YAML's n_steps (per env)")
    args = parser.parse_args(argv)
    import torch

    torch.set_num_threads(args.num_threads)
    runs: dict[str, list[dict[str, float]]] = {"dummy": [], "vector": []}
    for _ in range(args.repeats):
        for stack in runs:
            runs[stack].append(train_once(stack, args.timesteps, args.seed, args.n_envs, args.n_steps))
    print(f"PPO, AquaFish-v0, {args.timesteps} steps, n_envs={args.n_envs or 'YAML'}, n_steps={args.n_steps or 'YAML'}, "
          f"torch threads {args.num_threads}, {args.repeats} repeat(s), {platform.node()} ({platform.processor()})")
    base = statistics.median(r["steps"] / r["wall_s"] for r in runs["dummy"])
    for stack, rs in runs.items():
        wall = statistics.median(r["steps"] / r["wall_s"] for r in rs)
        cpu = statistics.median(r["steps"] / r["cpu_s"] for r in rs)
        env = statistics.median(r["env_s"] / r["wall_s"] for r in rs)
        print(f"{stack:7s} {wall:8,.0f} steps/s wall  {cpu:8,.0f} steps/s CPU  env {env:4.0%} of wall  "
              f"x{wall / base:.2f}  final mean return {rs[0]['mean_return']:.4f} ({rs[0]['episodes']} episodes)")


if __name__ == "__main__":
    main()
