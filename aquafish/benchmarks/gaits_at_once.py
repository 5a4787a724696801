"""Several NEAT gaits one after the other, or at once on one shared process pool.

Evolves the gaits of a case study's rows at a budget's NEAT settings (``--budget``, default
``quick``: its ``gait_population`` genomes x ``gait_episodes`` starts, ``gait_generations``
generations or ``--generations``, 20 s episodes, seed 0) on six robots: the healthy robot, the
damage-robust one (a damage drawn per episode) and four damaged robots standing in for the
models and the oracle (``reversed_left_pectoral``, ``left_pectoral_half``, ``caudal_half``,
``right_pectoral_half``). Each run evolves all six with ``--workers`` W processes, either one
after the other (:func:`gait.evolve_gait`, each its own evaluator; a ``quick`` generation is
one world, in-process) or at once (:meth:`gait.shared_pool.SharedPool.run_each` on one pool of
W). Runs are interleaved, ``--repeats`` times. It prints the median wall seconds of each way,
their ratio, and whether every gait's best fitness is the same both ways (it must be: exactly).

    python -m aquafish.benchmarks.gaits_at_once [--budget quick] [--workers 2] [--repeats 1] [--generations N]
"""

from __future__ import annotations

import argparse
import functools
import statistics
import time

import gait
from aquafish.benchmarks import add_budget
from aquafish.case_study import PRESETS
from aquafish_gym.argtypes import add_workers
from gait.robots import RANDOM_DAMAGE, as_robot
from gait.shared_pool import SharedPool

SEED = 0
#: The robots whose gaits are evolved: name -> robot string and damage.
ROBOTS = {"healthy": ("healthy", "none"), "robust": ("healthy", RANDOM_DAMAGE),
          "reversed_left_pectoral": ("reversed_left_pectoral", "none"),
          "left_pectoral_half": ("left_pectoral_half", "none"), "caudal_half": ("caudal_half", "none"),
          "right_pectoral_half": ("right_pectoral_half", "none")}


def _evolve_all(settings, generations: int, workers: int, at_once: bool) -> tuple[float, dict[str, float]]:
    """Wall seconds and every gait's best fitness."""
    kwargs = dict(generations=generations, population_size=settings.gait_population, seed=SEED, workers=workers,
                  episodes_per_genome=settings.gait_episodes, episode_duration_s=settings.episode_duration_s,
                  progress=False)
    robots = {name: as_robot(robot, damage=damage) for name, (robot, damage) in ROBOTS.items()}
    started = time.perf_counter()
    if at_once:
        with SharedPool(workers) as pool:
            results = pool.run_each([functools.partial(gait.evolve_gait, robot, shared=pool, **kwargs)
                                     for robot in robots.values()])
    else:
        results = [gait.evolve_gait(robot, **kwargs) for robot in robots.values()]
    return time.perf_counter() - started, {name: r.best_fitness for name, r in zip(robots, results)}


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    add_budget(parser, "the case-study budget whose NEAT settings are used")
    parser.add_argument("--generations", type=int, default=None, help="per gait (>= 1; default: the budget's)")
    add_workers(parser, 2, note="at least 2: one worker has nothing to share")
    parser.add_argument("--repeats", type=int, default=1, help="runs of each way, interleaved (>= 1)")
    args = parser.parse_args(argv)
    settings = PRESETS[args.budget]
    generations = args.generations if args.generations is not None else settings.gait_generations
    if generations < 1 or args.workers < 2 or args.repeats < 1:
        parser.error("--generations must be >= 1, --workers >= 2 and --repeats >= 1")
    walls: dict[bool, list[float]] = {False: [], True: []}
    best: dict[bool, dict[str, float]] = {}
    for _ in range(args.repeats):
        for at_once in (False, True):
            wall, best[at_once] = _evolve_all(settings, generations, args.workers, at_once)
            walls[at_once].append(wall)
    before, after = statistics.median(walls[False]), statistics.median(walls[True])
    print(f"{len(ROBOTS)} NEAT gaits at budget {args.budget!r}: {settings.gait_population} genomes x "
          f"{settings.gait_episodes} starts, {generations} generations, {args.workers} workers, median of "
          f"{args.repeats}")
    print(f"one after the other: {before:.1f} s; at once: {after:.1f} s; ratio {after / before:.2f}x; "
          f"the same best fitness: {best[False] == best[True]}")


if __name__ == "__main__":
    main()
