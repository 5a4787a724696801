"""NEAT generations per second: a generation on single envs genome by genome vs at once on the vector env.

Runs :func:`gait.evolve_gait` (no files, no progress) at a case-study preset's NEAT settings
(``--preset``, default ``quick``: its ``gait_population`` genomes x ``gait_episodes`` starts,
20 s episodes, healthy robot, seed 0) for ``--generations`` generations in each mode:

* ``single``: ``batched=False``, genome by genome on single envs (``evaluate_genome``: the
  code of the release before the vector env), on ``W`` processes for each ``W`` of
  ``--workers`` (1: in-process, no pool);
* ``batched``: ``batched=True`` (the default), the generation at once on the vector env
  (:mod:`gait.batch_fitness`), with ``workers`` = the largest of ``--workers`` (a generation
  of at most 64 robots is one world, evaluated in-process whatever ``workers``); NEAT's
  elites keep their fitness (``BatchEvaluator(keep_fitness=True)``), and ``batched, all
  genomes`` scores them again, as ``single`` does, to show the batching's share alone.

Modes run interleaved, ``--repeats`` times; it prints the median generations per second of
each (steady state: generations after the first, so a pool's start-up is left out), its
ratio to ``single`` on one process, and the largest difference of the best and mean fitness
per generation from ``single`` on one process (the same genomes evolve; round-off only).

    python -m benchmarks.neat_generation [--preset quick] [--generations 3] [--repeats 1] [--workers 1,2]
"""

from __future__ import annotations

import argparse
import functools
import os
import statistics

import numpy as np

from aquafish.case_study import PRESETS
from gait import evolve_gait, neat_evolution


def _workers(text: str) -> list[int]:
    try:
        values = [int(w) for w in text.split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"--workers must be comma-separated integers >= 1, got {text!r}") from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"--workers must be comma-separated integers >= 1, got {text!r}")
    return values


def _run(preset, generations: int, workers: int, batched: bool, keep_fitness: bool) -> tuple[float, np.ndarray]:
    """Steady-state generations per second and ``(generations, 2)`` best and mean fitness of one run."""
    evaluator = neat_evolution.BatchEvaluator
    neat_evolution.BatchEvaluator = functools.partial(evaluator, keep_fitness=keep_fitness)
    try:
        result = evolve_gait(None, generations=generations, population_size=preset.gait_population, seed=0,
                             workers=workers, episodes_per_genome=preset.gait_episodes, progress=False,
                             batched=batched)
    finally:
        neat_evolution.BatchEvaluator = evaluator
    wall = [h["wall_time_s"] for h in result.history]
    fitness = np.array([(h["best_fitness"], h["mean_fitness"]) for h in result.history])
    return (generations - 1) / (wall[-1] - wall[0]), fitness


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=sorted(PRESETS), default="quick")
    parser.add_argument("--generations", type=int, default=3, help="per run (>= 2; the first is not timed)")
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--workers", type=_workers, default=[1, 2], help="comma-separated process counts")
    args = parser.parse_args(argv)
    if args.generations < 2 or args.repeats < 1:
        parser.error("--generations must be >= 2 and --repeats >= 1")
    preset = PRESETS[args.preset]
    workers = max(args.workers)
    modes = [(f"single, {w} process{'es' if w > 1 else ''}", w, False, False) for w in args.workers]
    modes += [(f"batched, all genomes (w={workers})", workers, True, False), (f"batched (w={workers})", workers, True, True)]
    rates: dict[str, list[float]] = {mode[0]: [] for mode in modes}
    fitness: dict[str, np.ndarray] = {}
    for _ in range(args.repeats):
        for name, w, batched, keep in modes:
            rate, fitness[name] = _run(preset, args.generations, w, batched, keep)
            rates[name].append(rate)
    reference = modes[0][0]
    base = statistics.median(rates[reference])
    print(f"NEAT at preset {args.preset!r}: {preset.gait_population} genomes x {preset.gait_episodes} starts, "
          f"20 s episodes, {args.generations} generations, median of {args.repeats}, {os.cpu_count()} CPUs")
    print(f"{'mode':<30} {'generations/s':>14} {'s/generation':>13} {'ratio':>7} {'max |fitness diff|':>19}")
    for name, *_ in modes:
        rate = statistics.median(rates[name])
        diff = float(np.abs(fitness[name] - fitness[reference]).max())
        print(f"{name:<30} {rate:14.3f} {1 / rate:13.2f} {rate / base:6.1f}x {diff:19.1e}")


if __name__ == "__main__":
    main()
