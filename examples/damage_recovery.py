"""Damage recovery (paper section 5): self-model a damaged robot, evolve gaits, transfer them.

    python examples/damage_recovery.py [--preset quick|paper|smoke] [--damage left_pectoral_half] [--out DIR]

The same as ``aquafish case-study``; see ``aquafish/case_study.py``.
"""

import argparse

from aquafish.case_study import PRESETS, run_case_study

if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="quick", choices=sorted(PRESETS))
    parser.add_argument("--damage", default="left_pectoral_half")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="case_study_out")
    args = parser.parse_args()
    report = run_case_study(args.preset, args.damage, args.seed, args.out)
    for label, c in report["controllers"].items():
        print(f"{label:>28}: native {c['native_distance']:6.2f}  on target {c['target_distance']:6.2f} units")
