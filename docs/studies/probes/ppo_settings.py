"""PPO settings compared on the case study's two PPO rows (docs/gaits.md, "Cheaper PPO updates").

For each training seed, trains PPO with a hyperparameter file (``gait/rl_hyperparams.yml``'s
layout) for the ``quick`` case study's budget (144,000 env steps, one torch thread) on

* ``damaged``: the damaged robot itself (``--damage``; the case study's ``ppo`` row, whose
  self-model is the truth on its development seeds), and
* ``robust``: the healthy robot with a damage preset drawn each episode (``robust_ppo``),

then scores the policy as the case study does: ``gait.score_transfer`` on the damaged robot,
seed = the training seed, 5 paired starts. Writes one JSON file a run to ``--out``
(``<label>_<row>_s<seed>.json``: distances in units over 20 s, wall and process CPU seconds of
the training) and skips runs already there, so an interrupted probe resumes; ``--summary``
prints the mean, standard deviation, median and per-seed distances of every label found, with
Welch's and Mann-Whitney's p against ``--baseline``.

    python docs/studies/probes/ppo_settings.py --hyperparams old.yml --label before --seeds 0-9 --out runs/ppo_settings
    python docs/studies/probes/ppo_settings.py --hyperparams gait/rl_hyperparams.yml --label now --seeds 0-9 --out runs/ppo_settings
    python docs/studies/probes/ppo_settings.py --summary --baseline before --out runs/ppo_settings
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import gait
from aquafish.case_study import PRESETS, RANDOM_DAMAGE
from aquafish_gym import Morphology
from aquafish_gym.files import atomic_write
from gait.robots import Robot

ROWS = ("damaged", "robust")


def seeds_arg(text: str) -> list[int]:
    """``"0-9"`` or ``"0,3,5"`` as a list of seeds."""
    if "-" in text:
        lo, hi = (int(v) for v in text.split("-", 1))
        return list(range(lo, hi + 1))
    return [int(v) for v in text.split(",")]


def run(hyperparams: str, label: str, seeds: list[int], rows: list[str], damage: str, out: Path) -> None:
    """Train and score every ``row x seed`` not yet in ``out`` (module docstring)."""
    target = gait.as_robot(damage)
    natives = {"damaged": target, "robust": Robot(Morphology.healthy(), RANDOM_DAMAGE, "random damage")}
    steps = PRESETS["quick"].rl_timesteps
    for seed in seeds:
        for row in rows:
            result = out / f"{label}_{row}_s{seed}.json"
            if result.exists():
                continue
            t0, c0 = time.perf_counter(), time.process_time()
            path = gait.train_or_load_rl("ppo", natives[row], steps, seed, out / f"{label}_{row}_s{seed}",
                                         hyperparams_path=hyperparams, num_threads=1, progress=False)
            wall, cpu = time.perf_counter() - t0, time.process_time() - c0
            scored = gait.score_transfer(gait.load_controller(path), natives[row], target, seed=seed, episodes=5)
            line = {"label": label, "row": row, "seed": seed, "hyperparams": hyperparams, "damage": damage,
                    "wall_s": wall, "cpu_s": cpu, "target_distance": scored.target_distance,
                    "native_distance": scored.native_distance}
            atomic_write(result, json.dumps(line).encode())
            print(json.dumps(line), flush=True)


def summary(out: Path, baseline: str) -> None:
    """Print each label's distances per row against ``baseline``'s on the seeds both have."""
    from scipy.stats import mannwhitneyu, ttest_ind

    runs = [json.loads(p.read_text()) for p in sorted(out.glob("*.json"))]
    by = {(r["label"], r["row"], r["seed"]): r for r in runs}
    for row in ROWS:
        for label in sorted({r["label"] for r in runs}):
            seeds = sorted(s for (lab, rw, s) in by if lab == label and rw == row and (baseline, row, s) in by)
            if not seeds:
                continue
            mine = [by[(label, row, s)]["target_distance"] for s in seeds]
            base = [by[(baseline, row, s)]["target_distance"] for s in seeds]
            cpu = statistics.mean(by[(label, row, s)]["cpu_s"] for s in seeds)
            text = (f"{row} {label} seeds {seeds[0]}-{seeds[-1]} ({len(seeds)}): {statistics.mean(mine):.3f} "
                    f"± {statistics.stdev(mine):.3f}, median {statistics.median(mine):.2f}, CPU {cpu:.1f} s")
            if label != baseline and len(seeds) > 1:
                text += (f"; against {baseline}: Welch p {ttest_ind(mine, base, equal_var=False).pvalue:.3f}, "
                         f"Mann-Whitney p {mannwhitneyu(mine, base).pvalue:.3f}")
            print(text)
            print("   " + " ".join(f"{v:.2f}" for v in mine))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--hyperparams", help="RL-Zoo-style YAML (gait/rl_hyperparams.yml's layout)")
    parser.add_argument("--label", help="name of these settings in the file names")
    parser.add_argument("--seeds", type=seeds_arg, default=list(range(10)), help="training seeds: 0-9 or 0,3,5")
    parser.add_argument("--rows", default=",".join(ROWS), help=f"comma-separated, of {', '.join(ROWS)}")
    parser.add_argument("--damage", default="reversed_left_pectoral", help="the damaged robot")
    parser.add_argument("--out", type=Path, required=True, help="directory of the runs and their JSON lines")
    parser.add_argument("--summary", action="store_true", help="print the comparison of what --out holds")
    parser.add_argument("--baseline", default="before", help="the label the others are compared with")
    args = parser.parse_args()
    if args.summary:
        summary(args.out, args.baseline)
        return
    rows = args.rows.split(",")
    if not args.hyperparams or not args.label or not set(rows) <= set(ROWS):
        parser.error(f"--hyperparams and --label are needed, and --rows of {', '.join(ROWS)}")
    args.out.mkdir(parents=True, exist_ok=True)
    run(args.hyperparams, args.label, args.seeds, rows, args.damage, args.out)


if __name__ == "__main__":
    main()
