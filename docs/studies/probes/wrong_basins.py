"""Which runs end in a massless-flipper basin, and how many experiments left the tail still (docs/studies/unknown_angles.md).

A flipper with one dimension 0 (level 0 of its field) has no mass and keeps only the faces
the other two dimensions span (zero thickness: the paddle face alone): a qualitatively
different flipper from any with all three dimensions >= one level. On ``left_pectoral_half``
a third of the runs (6 of the 20 kept library runs) settle in round 1 on a model with a
pectoral of zero thickness, about twice as long as the truth's, and stay there to round 10;
they end at OBJ_FIT 0.83-0.90 while the others end at 0.96 on average. For every finished
run under the given directories this prints the final OBJ_FIT (eq. 4) and MOD_FIT (eq. 3),
the flipper fields that are 0 in the final model where the target's flipper has all three
dimensions (with the round the run's model first had such a flipper and how many rounds
it had one), and how many of the run's experiments left the tail still (caudal command
below 0.05 Hz), then the mean OBJ_FIT of the runs with and without a massless flipper.

    python docs/studies/probes/wrong_basins.py docs/results/lph_cs8_lib8

Works from ``rounds.csv`` alone; no simulation.
"""

from __future__ import annotations

import argparse

import numpy as np

from aquafish_gym import MORPHOLOGY_FIELDS
from eea.analysis.plot import find_runs

#: A caudal command below this (Hz) leaves the tail still for a 1.28 s experiment.
STILL_TAIL_HZ = 0.05
#: The three fields of each flipper, in ``rounds.csv``'s ``model_<field>`` columns.
FLIPPERS = tuple(MORPHOLOGY_FIELDS[i : i + 3] for i in range(0, len(MORPHOLOGY_FIELDS), 3))


def massless(dims: dict, truth: dict) -> list[str]:
    """The fields that are 0 in ``dims`` of every flipper whose three dimensions in
    ``truth`` are all > 0 (both ``{field: value}`` over :data:`aquafish_gym.MORPHOLOGY_FIELDS`)."""
    return [f for fields in FLIPPERS if all(truth[f] > 0.0 for f in fields) for f in fields if dims[f] == 0.0]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="study or run directories (searched recursively)")
    args = parser.parse_args(argv)
    print(f"{'run':<55} {'OBJ_FIT':>7} {'MOD_FIT':>8}  {'massless flipper (first round, rounds)':<38} still tail")
    trapped, free = [], []
    for run in find_runs(args.dirs):  # raises if it finds no run
        truth = dict(zip(MORPHOLOGY_FIELDS, run.target_morphology.to_array()))
        rounds = [{f: float(row[f"model_{f}"]) for f in MORPHOLOGY_FIELDS} for row in run.rounds]
        flagged = [int(row["round"]) for row, dims in zip(run.rounds, rounds) if massless(dims, truth)]
        final = massless(rounds[-1], truth)
        still = sum(float(row["action_caudal_hz"]) < STILL_TAIL_HZ for row in run.rounds)
        obj = float(run.rounds[-1]["objective_fitness"])
        (trapped if final else free).append(obj)
        where = f"{', '.join(final)} ({flagged[0]}, {len(flagged)})" if final else "-"
        print(f"{str(run.out_dir):<55} {obj:>7.3f} {float(run.rounds[-1]['model_fitness']):>8.5f}  {where:<38} "
              f"{still}/{len(run.rounds)}")
    summary = [f"{len(trapped)} of {len(trapped) + len(free)} runs end with a massless flipper"]
    summary += [f"mean OBJ_FIT {label} {np.mean(v):.3f}" for label, v in (("with", trapped), ("without", free)) if v]
    print("; ".join(summary))


if __name__ == "__main__":
    main()
