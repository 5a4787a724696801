"""Did each finished self-model run name its target's servo faults? (no simulation)

For every finished ``morphology+servos`` run under the given directories this prints one JSON
line: the damage (and a sampled fault's description), the true gains, the search's final
model's gains and the self-model's (what the run's check against fault hypotheses kept,
``fault_check.json``), and for both whether they name every faulty servo with the sign of its
gain (``eea.identification.servo_faults_named``: None when the target has no servo
fault on a flipper it still has) and, looser, on the right part by its gain or its flipper
(``fault_parts_named``), whether both pectoral signs are right (as the recovery
benchmark judges them) and how many healthy servos they hold at another gain. A last line
counts the runs judged and named.

    python docs/studies/probes/identification.py runs/heldout_sampled
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from aquafish_gym import get_damage
from eea.identification import fault_parts_named, healthy_servos_named_faulty, pectoral_signs_right, servo_faults_named
from eea.analysis.plot import find_runs


def judge(result) -> dict:
    """The JSON line of one finished run (see the module docstring)."""
    truth, final = result.true_model, np.asarray(result.best_model, dtype=float)
    checked = result.fault_check is not None
    model = np.asarray(result.self_model, dtype=float) if checked else final
    line = {"run": str(result.out_dir), "damage": result.config.damage, "seed": result.config.seed,
            "fault": get_damage(result.config.damage).description, "rounds": len(result.rounds),
            "true_gains": truth[9:].tolist(), "checked": checked}
    for name, m in (("final", final), ("self_model", model)):
        line |= {f"{name}_gains": m[9:].tolist(), f"{name}_named": servo_faults_named(m, truth),
                 f"{name}_parts_named": fault_parts_named(m, truth), f"{name}_signs": pectoral_signs_right(m, truth),
                 f"{name}_false_faults": healthy_servos_named_faulty(m, truth)}
    return line


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dirs", nargs="+", help="directories searched for finished morphology+servos runs")
    args = parser.parse_args(argv)
    lines = [judge(r) for r in find_runs(args.dirs) if r.config.model_space == "morphology+servos" and r.finished]
    for line in lines:
        print(json.dumps(line), flush=True)
    counts = {}
    for name in ("final", "self_model"):
        judged = [line[f"{name}_named"] for line in lines if line[f"{name}_named"] is not None]
        parts = [line[f"{name}_parts_named"] for line in lines if line[f"{name}_parts_named"] is not None]
        counts[name] = {"judged": len(judged), "named": sum(judged), "parts_named": sum(parts)}
    print(json.dumps({"runs": len(lines), "checked": sum(line["checked"] for line in lines), **counts}))


if __name__ == "__main__":
    main()
