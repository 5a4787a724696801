"""Env steps per second: the single env, ``SyncVectorEnv`` over N single envs, and the batched vector env.

For each N of ``--sizes`` (default 1, 16, 64, 256), steps ``AquaFish-v0`` (default
arguments: the surface swimmer, 20 s episodes, 0.1 s control steps of 10 physics steps)

* as one single env (``gym.make``), N = 1 only: the baseline,
* as ``gym.make_vec(..., vectorization_mode="sync")``: N single envs, N worlds, Python
  between them, and
* as ``gym.make_vec(..., vectorization_mode="vector_entry_point")``: the N robots in one
  world (:mod:`aquafish_gym.vector_env`),

for about ``--env-steps`` env steps each (at least 3 vector steps) after a reset and a
warm-up step, with random actions, and prints env steps (sub-env steps) per second of this
process's CPU time (``time.process_time``: PyBullet's DIRECT client runs in-process, and
other jobs on the machine change it far less than wall time), the median of ``--repeats``
interleaved runs, and the vector env's speed-up over ``SyncVectorEnv`` at the same N.
Resets (world building) are not timed; an episode is 200 steps. The last column is the
bound PyBullet itself sets: env steps per second if a control step cost nothing but its 10
``stepSimulation`` calls on a world of the same robots (``aquafish.benchmarks.sim_throughput``'s
``time_raw_pybullet``, worlds of at most 64 robots as the vector env's).

    python -m aquafish.benchmarks.vector_env [--sizes 1,16,64,256] [--env-steps 1024] [--repeats 3]
"""

from __future__ import annotations

import argparse
import math
import platform
import time

import gymnasium as gym
import numpy as np

import aquafish_gym  # noqa: F401  (registers the envs)
from aquafish_gym import native
from aquafish_gym.env import FRAME_SKIP
from aquafish_gym.vector_env import MAX_WORLD_ROBOTS
from aquafish.benchmarks.sim_throughput import time_raw_pybullet

ENV_ID = "AquaFish-v0"


def _time_steps(env, actions: np.ndarray) -> float:
    """CPU seconds of ``len(actions)`` steps, after a reset and one warm-up step (not timed)."""
    env.reset(seed=0)
    env.step(actions[0])
    t0 = time.process_time()
    for action in actions:
        env.step(action)
    return time.process_time() - t0


def time_single(steps: int, rng: np.random.Generator) -> float:
    """CPU seconds per env step of one single env."""
    env = gym.make(ENV_ID)
    try:
        return _time_steps(env, rng.uniform(-1, 1, (steps, 3)).astype(np.float32)) / steps
    finally:
        env.close()


def time_vector(mode: str, n: int, steps: int, rng: np.random.Generator) -> float:
    """CPU seconds per env step (sub-env step) of a vector env of ``n`` sub-envs."""
    env = gym.make_vec(ENV_ID, num_envs=n, vectorization_mode=mode)
    try:
        return _time_steps(env, rng.uniform(-1, 1, (steps, n, 3)).astype(np.float32)) / (steps * n)
    finally:
        env.close()


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", default="1,16,64,256", help="numbers of sub-envs, comma-separated")
    parser.add_argument("--env-steps", type=int, default=1024, help="env steps per timed run (about)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args(argv)
    try:
        sizes = [int(s) for s in args.sizes.split(",")]
    except ValueError:
        parser.error(f"--sizes must be comma-separated integers, got {args.sizes!r}")
    if not sizes or min(sizes) < 1 or args.env_steps < 1 or args.repeats < 1:
        parser.error("--sizes, --env-steps and --repeats must be >= 1")
    rng = np.random.default_rng(0)
    print(f"machine: {platform.processor() or platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, gymnasium {gym.__version__}, compiled step: "
          f"{'yes' if native.available() else 'NO (' + str(native.unavailable_reason()) + ')'}")
    single = float(np.median([time_single(args.env_steps, rng) for _ in range(args.repeats)]))
    print(f"{ENV_ID}, env steps per CPU second (median of {args.repeats}); single env: {1 / single:,.0f}")
    print(f"{'N':>5} {'SyncVectorEnv':>14} {'vector env':>11} {'vector/sync':>12} {'vector/single':>14} "
          f"{'PyBullet bound':>15}")
    for n in sizes:
        steps = max(3, math.ceil(args.env_steps / n))
        world = min(n, MAX_WORLD_ROBOTS)
        times = np.array([(time_vector("sync", n, steps, rng), time_vector("vector_entry_point", n, steps, rng),
                           time_raw_pybullet(world, FRAME_SKIP * steps, rng) / (world * steps))
                          for _ in range(args.repeats)])
        sync, vec, raw = np.median(times, axis=0)  # interleaved, so slow spells hit all three
        print(f"{n:>5} {1 / sync:>14,.0f} {1 / vec:>11,.0f} {sync / vec:>11.1f}x {single / vec:>13.1f}x "
              f"{1 / raw:>15,.0f}", flush=True)


if __name__ == "__main__":
    main()
