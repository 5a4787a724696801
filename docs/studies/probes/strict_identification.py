"""Strict identification of finished EEA runs' self-models (eea.identification.identification).

For every ``morphology+servos`` run below each directory given (a ``rounds.csv`` with its
``config.json``), the self-model the run kept (its check's, :attr:`eea.RunResult.self_model`) is
judged against the run's damage: strictly (every part's servo and flipper kind the truth's, so a
healthy part held faulty is a miss; a lost flipper's servo not judged) and leniently (every
faulty servo named with the sign of its gain, :func:`eea.identification.servo_faults_named`).

    python docs/studies/probes/strict_identification.py docs/results/heldout_sampled_hyp docs/results/heldout_rlp_hyp
"""

import argparse
import json
from pathlib import Path

import numpy as np

import eea
from eea.encoding import get_model_space
from eea.identification import identification, servo_faults_named


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directories", nargs="+", type=Path, help="directories holding finished EEA runs")
    args = parser.parse_args()
    space = get_model_space("morphology+servos")
    for root in args.directories:
        runs = sorted(p.parent for p in root.rglob("rounds.csv"))
        strict, named, judged = 0, 0, 0
        for run in runs:
            damage = json.loads((run / "config.json").read_text())["damage"]
            model, truth = np.asarray(eea.load_result(run).self_model, dtype=float), space.truth(damage)
            strict += identification(model, truth)["strict"]
            verdict = servo_faults_named(model, truth)
            judged += verdict is not None
            named += bool(verdict)
        print(f"{root}: {len(runs)} runs; identified strictly {strict} of {len(runs)}; "
              f"every faulty servo named with its sign (lenient) {named} of {judged}")


if __name__ == "__main__":
    main()
