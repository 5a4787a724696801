"""Reduced study of the four inference strategies (issue #3 evidence; paper section 4).

Population 25, 30 estimation and 10 exploration generations per round, 10 rounds,
1.28 s experiments, seeds 0-4, for ``known``, ``none``, ``in_band`` and ``out_of_band``.
Out-of-band inference runs every 10 estimation generations (0, 10, 20): the paper's
period 35 of 100 generations (0, 35, 70), scaled to 30 generations. Runs go one at a time
into ``OUT/<inference>/seed<k>`` (finished runs are skipped, interrupted ones resume), then
the mean final objective fitness per strategy is printed and ``OUT/objective_fitness.png``
drawn::

    nohup python -m eea.scripts.reduced_study --out runs/reduced --workers 2 > runs/reduced.log 2>&1 &

Target (issue #3): ``known`` >= 0.9 and ``out_of_band`` > ``none``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from eea.config import EEAConfig
from eea.plot import plot_runs
from eea.run import run

STRATEGIES = ("known", "none", "in_band", "out_of_band")
SETTINGS = dict(estimation_population=25, estimation_generations=30, exploration_population=25,
                exploration_generations=10, rounds=10, duration_s=1.28, oob_period=10)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="runs/reduced", help="study directory")
    parser.add_argument("--seeds", type=int, default=5, help="replicates (seeds 0 .. n-1)")
    parser.add_argument("--workers", type=int, default=2, help="worker processes per run")
    parser.add_argument("--strategies", default=",".join(STRATEGIES), help="comma-separated inference names")
    parser.add_argument("--no-progress", action="store_true", help="hide the per-run progress bars")
    args = parser.parse_args(argv)
    out = Path(args.out)
    for seed in range(args.seeds):  # seed-major: every strategy gets a replicate early
        for inference in args.strategies.split(","):
            config = EEAConfig(inference=inference, seed=seed, workers=args.workers, **SETTINGS)
            result = run(config, out / inference / f"seed{seed}", progress=not args.no_progress)
            print(f"{inference:>12} seed {seed}: final objective fitness {result.rounds[-1]['objective_fitness']:.4f} "
                  f"({result.rounds[-1]['simulations']} simulations, {result.rounds[-1]['wall_seconds']:.0f} s)",
                  flush=True)
    print(plot_runs([out], out / "objective_fitness.png"))


if __name__ == "__main__":
    main()
