"""Wall time of one paper-setting EEA round, serial and on a process pool.

One round as in the paper (section 4): exploration (population 25, 25 generations, ACT_FIT
over up to 25 distinct models), one target experiment, estimation (population 25, 100
generations, MOD_FIT over all experiments), with 10 experiments already recorded and
1.28 s (128-step) experiments. The estimation population is random and the evaluator's
cache starts empty (a cold start: in a real run the carried-over models' results on old
experiments are mostly cached, so this is an upper bound). For each worker count, prints
wall seconds per phase, model simulations and simulations per second::

    python -m aquafish.benchmarks.eea_round [--workers 1,2] [--inference out_of_band] [--experiments 10]
"""

from __future__ import annotations

import argparse
import platform

import numpy as np

from eea.config import EEAConfig
from eea.encoding import ACTION_BITS, decode_actions
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.round import RoundParts, run_round


def recorded_experiments(parts: RoundParts, n: int, rng: np.random.Generator) -> tuple[Experiment, ...]:
    """``n`` experiments with random actions on the target, contexts locked as after their rounds."""
    experiments = []
    for i in range(n):
        experiment = parts.perform(i, decode_actions(rng.integers(0, 2, ACTION_BITS, dtype=np.uint8)))
        experiments.append(experiment.with_context(experiment.context.with_confidence(1.0)))
    return tuple(experiments)


def time_round(config: EEAConfig, n_experiments: int, seed: int = 0) -> dict:
    """Run one round (:func:`eea.round.run_round`); return wall seconds per phase and the simulation count."""
    rng = np.random.default_rng(seed)
    workers = config.runtime.workers
    with Evaluator.for_config(config) as evaluator:
        parts = RoundParts.from_config(config, rng, evaluator)
        experiments = recorded_experiments(parts, n_experiments, rng)
        evaluator.simulate(np.full((workers, 9), 0.25), np.zeros((workers, 3)),
                           np.zeros((workers, 3)))  # start the pool outside the timing
        evaluator.simulations = 0
        record = run_round(n_experiments + 1, experiments, parts, rng)
    return {"exploration_s": record.exploration_s, "target_s": record.target_s, "estimation_s": record.estimation_s,
            "wall_s": record.wall_s, "exploration_sims": record.exploration_simulations,
            "simulations": record.simulations}


def main(argv: list[str] | None = None, prog: str | None = None,
         parser_class: type[argparse.ArgumentParser] = argparse.ArgumentParser) -> None:
    """Run the benchmark with the command-line arguments ``argv`` (default: ``sys.argv[1:]``).

    ``prog`` and ``parser_class`` are the name and the parser class of its usage messages:
    ``aquafish bench`` passes its own (one-line usage errors, see :mod:`aquafish.bench_cli`).
    """
    parser = parser_class(prog=prog, description=__doc__.splitlines()[0])
    parser.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    parser.add_argument("--inference", default="out_of_band")
    parser.add_argument("--experiments", type=int, default=10, help="experiments recorded before the round")
    parser.add_argument("--duration-s", "--duration", type=float, default=1.28,
                        help="experiment length (s), as aquafish eea's --duration-s")
    args = parser.parse_args(argv)
    print(f"machine: {platform.processor() or platform.machine()}, {platform.python_implementation()} "
          f"{platform.python_version()}; one round, {args.experiments} experiments recorded, "
          f"{args.duration_s} s, inference {args.inference}, paper settings (25 x 25 exploration, 25 x 100 estimation)")
    print(f"{'workers':>7} {'wall s':>8} {'explore s':>9} {'estimate s':>10} {'simulations':>11} {'sims/s':>8} "
          f"{'robot-steps/s':>13}")
    for workers in (int(w) for w in args.workers.split(",")):
        config = EEAConfig.from_flat({"inference": args.inference, "duration_s": args.duration_s, "workers": workers})
        r = time_round(config, args.experiments)
        rate = r["simulations"] / r["wall_s"]
        print(f"{workers:>7} {r['wall_s']:>8.1f} {r['exploration_s']:>9.1f} {r['estimation_s']:>10.1f} "
              f"{r['simulations']:>11} {rate:>8.0f} {rate * config.steps:>13.0f}", flush=True)


if __name__ == "__main__":
    main()
