"""Simulator throughput: microseconds per robot-step of ``simulate_batch`` versus raw PyBullet.

For batches of 1, 25 and 100 robots of 128 steps, measures in the same run

* ``simulate_batch`` (world creation, fluid model, servos, IMU log) with the compiled step
  (:mod:`aquafish_gym.native`, the default when it is built),
* the same with the NumPy path (``native=False``; the same results bit for bit),
* PyBullet stepping the same bodies with no fluid model and no per-step Python work
  (``stepSimulation`` only, after the same world is built), and
* ``simulate_batch`` in deep water (``waterline=None``, the model before the surface
  swimmer, compiled),

all at the default physics (the surface swimmer) unless named, and prints microseconds per
robot-step, the ratio of each path to raw PyBullet, and what the surface model (hydrostatics
and wetted blade-element strips) costs over deep water (median of ``--repeats`` interleaved
runs). Times are this
process's CPU time (``time.process_time``): PyBullet's DIRECT client runs in-process, so
that is the simulator's whole cost, and other jobs on the machine change it far less than
wall time.

    python -m aquafish.benchmarks.sim_throughput [--steps 128] [--repeats 5] [--sizes 1,25,100]
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from aquafish_gym import BatchWorld, Morphology, SimParams, native, simulate_batch
from aquafish_gym.bullet import p
from aquafish_gym.morphology import MORPHOLOGY_BOUNDS


def _inputs(n: int, rng: np.random.Generator):
    lo, hi = MORPHOLOGY_BOUNDS[:, 0], MORPHOLOGY_BOUNDS[:, 1]
    morph = rng.uniform(lo, hi, size=(n, 9))
    morph[0] = Morphology.healthy().to_array()
    actions = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(0, 1, n)])
    angles = np.column_stack([rng.uniform(0, 2 * np.pi, n), rng.uniform(0, 2 * np.pi, n), rng.uniform(-0.5, 0.5, n)])
    return morph, actions, angles


def time_simulate_batch(n: int, steps: int, rng, params: SimParams | None = None, native: bool | None = None) -> float:
    morph, actions, angles = _inputs(n, rng)
    t0 = time.process_time()
    simulate_batch(morph, actions, angles, steps, params=params, native=native)
    return time.process_time() - t0


def time_raw_pybullet(n: int, steps: int, rng) -> float:
    """The same robots, motors set once, then ``stepSimulation`` only."""
    morph, actions, angles = _inputs(n, rng)
    client = p.connect(p.DIRECT)
    try:
        world = BatchWorld(morph, client=client, native=False)
        world.reset(angles, actions)
        t0 = time.process_time()
        for _ in range(steps):
            p.stepSimulation(physicsClientId=client)
        return time.process_time() - t0
    finally:
        p.disconnect(client)


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=128)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--sizes", default="1,25,100")
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    sizes = [int(s) for s in args.sizes.split(",")]
    print(f"machine: {platform.processor() or platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}, pybullet API {p.getAPIVersion()}, compiled step: "
          f"{'yes' if native.available() else 'NO (' + str(native.unavailable_reason()) + ')'}")
    compiled = native.available() or None
    deep = SimParams(waterline=None)
    print(f"{'robots':>6} {'steps':>5} {'sim us/robot-step':>18} {'numpy-path us':>13} {'raw us/robot-step':>18} "
          f"{'ratio':>6} {'numpy ratio':>11} {'deep us':>8} {'deep ratio':>10} {'surface cost':>12}")
    for n in sizes:
        time_simulate_batch(n, 8, rng)  # warm-up
        times = np.array([(time_simulate_batch(n, args.steps, rng, native=compiled),
                           time_simulate_batch(n, args.steps, rng, native=False),
                           time_raw_pybullet(n, args.steps, rng),
                           time_simulate_batch(n, args.steps, rng, deep, native=compiled))
                          for _ in range(args.repeats)])
        sim, numpy_path, raw, deep_t = np.median(times, axis=0)  # interleaved, so slow spells hit all four
        us = 1e6 / (n * args.steps)
        print(f"{n:>6} {args.steps:>5} {sim * us:>18.1f} {numpy_path * us:>13.1f} {raw * us:>18.1f} {sim / raw:>6.2f} "
              f"{numpy_path / raw:>11.2f} {deep_t * us:>8.1f} {deep_t / raw:>10.2f} "
              f"{np.median(times[:, 0] / times[:, 3]) - 1:>11.1%}", flush=True)


if __name__ == "__main__":
    main()
