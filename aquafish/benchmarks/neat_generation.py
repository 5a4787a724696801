"""NEAT generations per second: a generation on single envs genome by genome vs at once on the vector env.

Runs NEAT (``neat.Population`` on ``gait/neat_config.ini``, as :func:`gait.evolve_gait` does,
without its files and reporters) at a case-study preset's NEAT settings (``--budget``,
default ``quick``: its ``gait_population`` genomes x ``gait_episodes`` starts, 20 s
episodes, healthy robot, seed 0) for ``--generations`` generations with each evaluator:

* ``single``: :func:`gait.fitness_task.evaluate_genome` genome by genome, one single env
  per episode (the code before the vector env, ``evolve_gait(batched=False)``), in-process
  and, for each ``W`` > 1 of ``--workers``, on ``W`` processes
  (:class:`gait.neat_progress.PoolEvaluator`);
* ``batched``: :class:`gait.batch_fitness.BatchEvaluator` (the default of ``evolve_gait``;
  worlds of at most :data:`gait.batch_fitness.GENERATION_WORLD_ROBOTS` robots) in-process:
  ``all genomes`` scores NEAT's elites again, as ``single`` does (the batching's share alone),
  the default keeps their fitness; and, for each ``W`` > 1 of ``--workers``, on ``W``
  processes (the generation's worlds dealt to them; the same fitnesses, bit for bit).

Runs are interleaved, ``--repeats`` times. It prints, per evaluator, the median over runs of
the generations per wall second and the CPU seconds per generation of this process (the
pool's processes are not counted: "-"), both over the generations after the first (so a
pool's start-up is left out); the ratio of generations per second to in-process ``single``;
and the largest difference of any genome's fitness from ``single``'s (the same genomes
evolve; round-off only).

    python -m aquafish.benchmarks.neat_generation [--budget quick] [--generations 3] [--repeats 3] [--workers 1,2]
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import os
import random
import statistics
import time

import neat
import numpy as np

from aquafish.benchmarks import add_budget
from aquafish.case_study import PRESETS
from gait.batch_fitness import BatchEvaluator
from gait.fitness_task import FitnessTask, evaluate_genome
from gait.neat_evolution import load_neat_config, set_num_inputs
from gait.neat_progress import PoolEvaluator
from gait.robots import as_robot

SEED = 0


def _workers(text: str) -> list[int]:
    try:
        values = [int(w) for w in text.split(",")]
    except ValueError:
        values = []
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"--workers must be comma-separated integers >= 1, got {text!r}")
    return values


class _Clock(neat.reporting.BaseReporter):
    """Wall and CPU time after each generation's evaluation, and every genome's fitness."""

    def __init__(self):
        self.wall, self.cpu, self.fitness = [], [], []

    def post_evaluate(self, config, population, species, best_genome) -> None:
        self.wall.append(time.perf_counter())
        self.cpu.append(time.process_time())
        self.fitness.append([g.fitness for _, g in sorted(population.items())])


def _serial(task: FitnessTask):
    def evaluate(genomes, config):
        for _, genome in genomes:
            genome.fitness = evaluate_genome(genome, config, task=task)
    return contextlib.nullcontext(evaluate)


def _run(task: FitnessTask, population_size: int, generations: int, evaluator) -> tuple[float, float, np.ndarray]:
    """Generations per wall second, CPU seconds per generation (after the first), every fitness."""
    random.seed(SEED)
    np.random.seed(SEED)
    config = load_neat_config(population_size=population_size)
    set_num_inputs(config, 14)
    population = neat.Population(config, seed=SEED)
    clock = _Clock()
    population.add_reporter(clock)
    with evaluator as evaluate:
        population.run(evaluate, generations)
    timed = generations - 1
    return (timed / (clock.wall[-1] - clock.wall[0]), (clock.cpu[-1] - clock.cpu[0]) / timed,
            np.array(clock.fitness, dtype=np.float64))


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    add_budget(parser, "the case-study budget whose NEAT settings are timed")
    parser.add_argument("--generations", type=int, default=3, help="per run (>= 2; the first is not timed)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--workers", type=_workers, default=[1, 2], help="comma-separated process counts")
    args = parser.parse_args(argv)
    if args.generations < 2 or args.repeats < 1:
        parser.error("--generations must be >= 2 and --repeats >= 1")
    preset = PRESETS[args.budget]
    task = FitnessTask(as_robot("healthy"), SEED, episodes=preset.gait_episodes)
    evaluate = functools.partial(evaluate_genome, task=task)
    modes = {"single, in-process": lambda: _serial(task)}
    for w in sorted(set(args.workers) - {1}):
        modes[f"single, {w} processes"] = lambda w=w: PoolEvaluator(w, evaluate)
    modes["batched, all genomes"] = lambda: BatchEvaluator(task, keep_fitness=False)
    modes["batched (elites kept)"] = lambda: BatchEvaluator(task)
    for w in sorted(set(args.workers) - {1}):
        modes[f"batched, {w} processes"] = lambda w=w: BatchEvaluator(task, w)
    runs: dict[str, list[tuple[float, float]]] = {name: [] for name in modes}
    fitness: dict[str, np.ndarray] = {}
    for _ in range(args.repeats):
        for name, make in modes.items():
            rate, cpu, fitness[name] = _run(task, preset.gait_population, args.generations, make())
            runs[name].append((rate, cpu))
    reference = "single, in-process"
    base = statistics.median(r for r, _ in runs[reference])
    print(f"NEAT at budget {args.budget!r}: {preset.gait_population} genomes x {preset.gait_episodes} starts, "
          f"20 s episodes, {args.generations} generations ({args.generations - 1} timed), median of "
          f"{args.repeats}, {os.cpu_count()} CPUs")
    print(f"{'evaluator':<24} {'generations/s':>14} {'s/generation':>13} {'CPU s/generation':>17} {'ratio':>7} "
          f"{'max |fitness diff|':>19}  generations/s of each run")
    for name, values in runs.items():
        rate = statistics.median(r for r, _ in values)
        cpu = f"{statistics.median(c for _, c in values):17.2f}" if "processes" not in name else f"{'-':>17}"
        diff = float(np.abs(fitness[name] - fitness[reference]).max())
        print(f"{name:<24} {rate:14.3f} {1 / rate:13.2f} {cpu} {rate / base:6.1f}x {diff:19.1e}  "
              f"{', '.join(f'{r:.3f}' for r, _ in values)}")


if __name__ == "__main__":
    main()
