"""Gait fitness cost: wall time of one 20 s AquaFish-v0 episode (the NEAT fitness).

Times, on one core, a 20 s rollout of a random NEAT controller (env creation, 200 control
steps of 10 physics steps, network activation) against the same episode driven by a
constant action (no network), and prints the median of ``--repeats`` runs and what a NEAT
run of ``--population`` x ``--generations`` costs on one core.

    python -m aquafish.benchmarks.gait_rollout [--repeats 5] [--population 50] [--generations 30]
"""

from __future__ import annotations

import argparse
import statistics
import time

import neat
import numpy as np

from gait import NEATController, load_neat_config, rollout


class ConstantController:
    """Always the same action: the env's own cost without a network."""

    def reset(self) -> None:
        pass

    def act(self, obs, time_s: float) -> np.ndarray:
        return np.array([0.5, 0.5, 1.0])


def _median_time(controller, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        rollout(controller, seed=0)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--population", type=int, default=50)
    parser.add_argument("--generations", type=int, default=30)
    args = parser.parse_args(argv)
    config = load_neat_config(population_size=2)
    population = neat.Population(config, seed=0)
    network = NEATController(population.population[min(population.population)], config)
    t_env = _median_time(ConstantController(), args.repeats)
    t_neat = _median_time(network, args.repeats)
    n = args.population * args.generations
    print(f"20 s episode, constant action : {t_env * 1e3:7.1f} ms")
    print(f"20 s episode, NEAT controller : {t_neat * 1e3:7.1f} ms  (network {100 * (t_neat - t_env) / t_neat:.0f}%)")
    print(f"NEAT {args.population} x {args.generations} = {n} episodes: {n * t_neat / 60:.1f} min on one core")


if __name__ == "__main__":
    main()
