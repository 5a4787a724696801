"""Would a margin in the fault check keep models nearer the truth?

The fault check (:mod:`eea.fault_check`) keeps the candidate with the highest MOD_FIT among the
search's final model (row 0), the 97 fault hypotheses about the design (rows 1-97) and up to two
gain-polished hypotheses (rows 98-99). With few experiments, the search's inexact model or a
polished row can beat the true hypothesis by a hair (six-round missions: 0.0025 and 0.0003 of
MOD_FIT). A margin rule keeps a row that is not a hypothesis only when it beats the best
hypothesis by more than ``m``; otherwise the best hypothesis (or, under ``--rows search``, the
best of the hypotheses and polished rows) is kept.

This probe applies the rule, offline, to finished checks' records (``fault_check.json`` beside
its run's ``config.json``, found under the given directories), which hold every candidate's
MOD_FIT, so no simulation is run. For each record and margin it prints whether the kept row
changes and each model's error against the truth (the run's damage in ``morphology+servos``):
the sum of the three servo gains' absolute errors and the largest absolute error of the nine
dimensions (simulator units). One JSON line per record and margin, then a summary per margin::

    python docs/studies/probes/check_margin.py docs/results --margins 0.001,0.002,0.003,0.005 \\
        --out runs/check_margin.jsonl
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from aquafish_gym import Morphology
from eea.encoding import get_model_space
from eea.fault_check import read_fault_check
from eea.inference.selection import fault_hypotheses


def kept_with_margin(fitness: np.ndarray, hypotheses: int, margin: float, rows: str) -> int:
    """The row the check keeps under the margin rule.

    Args:
        fitness: ``(98 + P,)`` every candidate's MOD_FIT: row 0 the search's model, rows
            ``1..hypotheses`` the hypotheses, then the polished rows.
        hypotheses: how many hypothesis rows there are.
        margin: MOD_FIT a row that is not a hypothesis must beat the best hypothesis by (>= 0).
        rows: ``"all"`` (the search's model and polished rows need the margin) or ``"search"``
            (only the search's model does).

    Raises:
        ValueError: a negative margin or an unknown ``rows``.
    """
    if margin < 0 or rows not in ("all", "search"):
        raise ValueError(f"margin must be >= 0 and rows 'all' or 'search', got {margin} and {rows!r}")
    hyp = np.arange(1, 1 + hypotheses)
    best_hypothesis = int(hyp[np.argmax(fitness[hyp])])
    needs_margin = [0] + (list(range(1 + hypotheses, len(fitness))) if rows == "all" else [])
    allowed = [i for i in range(len(fitness))
               if i not in needs_margin or fitness[i] > fitness[best_hypothesis] + margin]
    return int(allowed[int(np.argmax(fitness[allowed]))])


def errors(model: np.ndarray, truth: np.ndarray) -> tuple[float, float]:
    """``(gain error, dimension error)``: the summed absolute error of the 3 servo gains and the
    largest absolute error of the 9 dimensions (simulator units)."""
    return float(np.abs(model[9:] - truth[9:]).sum()), float(np.abs(model[:9] - truth[:9]).max())


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("roots", nargs="+", help="directories searched for fault_check.json")
    parser.add_argument("--margins", default="0.001,0.002,0.003,0.005")
    parser.add_argument("--rows", choices=("all", "search"), default="all")
    parser.add_argument("--out", help="also write the JSON lines here (overwritten)")
    args = parser.parse_args(argv)
    margins = [float(m) for m in args.margins.split(",")]
    space = get_model_space("morphology+servos")
    hypotheses = len(fault_hypotheses(Morphology.healthy().to_array()))
    lines = []
    for path in sorted(p for root in args.roots for p in Path(root).rglob("fault_check.json")):
        config = json.loads((path.parent / "config.json").read_text())
        check = read_fault_check(path.parent)
        truth = space.truth(config["damage"])
        kept_error = errors(check.model, truth)
        for margin in margins:
            index = kept_with_margin(check.model_fitness, hypotheses, margin, args.rows)
            lines.append({"record": str(path.parent), "damage": config["damage"], "margin": margin,
                          "rows": args.rows, "kept": check.index, "kept_with_margin": index,
                          "changed": index != check.index,
                          "fitness_gap": float(check.model_fitness[check.index] - check.model_fitness[index]),
                          "gain_error": kept_error[0], "dimension_error": kept_error[1],
                          "gain_error_with_margin": errors(check.models[index], truth)[0],
                          "dimension_error_with_margin": errors(check.models[index], truth)[1]})
    text = "".join(json.dumps(line) + "\n" for line in lines)
    print(text, end="")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text)
    for margin in margins:
        rows = [r for r in lines if r["margin"] == margin]
        changed = [r for r in rows if r["changed"]]
        nearer = sum(r["gain_error_with_margin"] < r["gain_error"] - 1e-9 for r in changed)
        further = sum(r["gain_error_with_margin"] > r["gain_error"] + 1e-9 for r in changed)
        print(f"margin {margin}: {len(changed)} of {len(rows)} checks change; gains nearer the truth on "
              f"{nearer}, further on {further}; summed gain error {sum(r['gain_error'] for r in rows):.3f} -> "
              f"{sum(r['gain_error_with_margin'] for r in rows):.3f}")


if __name__ == "__main__":
    main()
