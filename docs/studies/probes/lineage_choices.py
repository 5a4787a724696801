"""How the round's selection among estimation lineages did, against an oracle (``--lineages``, eea.search.lineages).

For every finished run with ``lineages`` >= 2 under the given directories this prints each
lineage's final OBJ_FIT (eq. 4; the truth is an oracle the run never uses), the lineage the
last round chose, and whether it was the best; then the means over runs (± std, ddof 0 as
in ``aquafish compare``): the chosen model, the best lineage (the oracle's pick) and each
lineage alone (what one of them would have ended at, on experiments chosen to split all the
lineages' models).

    python docs/studies/probes/lineage_choices.py runs/lph_lin2

Reads each run's ``lineages.csv`` (or, for runs from before it existed, its checkpoint
``state.pkl``); no simulation.
"""

from __future__ import annotations

import argparse

import numpy as np

from eea.analysis.lineage_report import lineage_objective_fitness
from eea.analysis.plot import find_runs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="study or run directories (searched recursively)")
    args = parser.parse_args(argv)
    finals, chosen = [], []
    print(f"{'run':<55} {'each lineage':<20} chosen  best?")
    for run in find_runs(args.dirs):  # raises if it finds no run
        if run.config.estimation.lineages < 2 or not run.finished:
            continue
        objective, picks = lineage_objective_fitness(run.out_dir)
        final, pick = objective[-1], int(picks[-1])
        finals.append(final)
        chosen.append(final[pick])
        print(f"{str(run.out_dir):<55} {' '.join(f'{v:.3f}' for v in final):<20} {pick} {final[pick]:.3f}  "
              f"{'yes' if final[pick] == final.max() else f'no ({final.max() - final[pick]:.3f} below)'}")
    if not finals:
        raise SystemExit("no run with lineages >= 2 found")
    finals = np.array(finals)
    alone = ", ".join(f"lineage {i} {m:.3f}" for i, m in enumerate(finals.mean(axis=0)))
    print(f"{len(finals)} runs: chosen {np.mean(chosen):.3f} ± {np.std(chosen):.3f}; "
          f"best lineage (oracle) {finals.max(axis=1).mean():.3f}; {alone}; "
          f"the best chosen in {int(np.sum(np.isclose(chosen, finals.max(axis=1))))}/{len(finals)}")


if __name__ == "__main__":
    main()
