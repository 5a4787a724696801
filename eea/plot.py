"""Study plots: mean objective fitness against EEA round (paper Figures 5-10).

Runs are grouped by inference strategy (and by experiment duration when several occur);
each group gets one colour: its mean OBJ_FIT (eq. 4) over replicates as a solid line and
its standard deviation as a dashed line, as in the paper's figures.
"""

from __future__ import annotations

import os
from collections import defaultdict
from pathlib import Path

import numpy as np

from eea.record import CONFIG_FILE, RunResult, load_result

__all__ = ["find_runs", "plot_runs", "summarise_runs"]


def find_runs(paths) -> list[RunResult]:
    """Every run under ``paths`` (run directories, or directories searched recursively).

    Runs without a finished round are left out.

    Raises:
        ValueError: if a path does not exist or no run is found.
    """
    dirs = []
    for path in map(Path, paths):
        if not path.exists():
            raise ValueError(f"{path} does not exist")
        dirs += [path] if (path / CONFIG_FILE).exists() else sorted(p.parent for p in path.rglob(CONFIG_FILE))
    results = [r for r in (load_result(d) for d in dict.fromkeys(dirs)) if r.rounds]
    if not results:
        raise ValueError(f"no EEA run with a finished round under {', '.join(map(str, paths))}")
    return results


def summarise_runs(results: list[RunResult]) -> dict[str, dict]:
    """Per group label: ``{"runs": n, "mean": (R,), "std": (R,)}`` of OBJ_FIT by round.

    Round r's statistics use the runs that reached it; R is the longest run's length.
    Labels are the inference names, with the duration appended if durations differ.
    """
    durations = {r.config.duration_s for r in results}
    groups: dict[str, list[list[float]]] = defaultdict(list)
    for r in sorted(results, key=lambda r: (r.config.inference, r.config.duration_s)):
        label = r.config.inference if len(durations) == 1 else f"{r.config.inference} {r.config.duration_s:g} s"
        groups[label].append(r.objective_fitness)
    summary = {}
    for label, curves in groups.items():
        length = max(map(len, curves))
        by_round = [[c[i] for c in curves if len(c) > i] for i in range(length)]
        summary[label] = {"runs": len(curves), "complete": min(map(len, curves)),
                          "mean": np.array([np.mean(v) for v in by_round]),
                          "std": np.array([np.std(v) for v in by_round])}
    return summary


def plot_runs(paths, out_png: str | os.PathLike) -> str:
    """Draw mean (solid) and std (dashed) OBJ_FIT against round; save a PNG.

    Args:
        paths: run directories or directories containing runs.
        out_png: output image path (parent directories are created).

    Returns:
        A text table: per group, the number of runs and the mean and std of OBJ_FIT at
        the last round all its runs reached.

    Raises:
        ValueError: as :func:`find_runs`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    summary = summarise_runs(find_runs(paths))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    lines = [f"{'condition':<24} {'runs':>4} {'round':>5} {'mean OBJ_FIT':>12} {'std':>7}"]
    for label, s in summary.items():
        rounds = np.arange(1, len(s["mean"]) + 1)
        (line,) = ax.plot(rounds, s["mean"], "-", label=f"{label} (n={s['runs']})")
        ax.plot(rounds, s["std"], "--", color=line.get_color())
        last = s["complete"] - 1
        lines.append(f"{label:<24} {s['runs']:>4} {last + 1:>5} {s['mean'][last]:>12.4f} {s['std'][last]:>7.4f}")
    ax.set_xlabel("EEA round")
    ax.set_ylabel("objective fitness (solid: mean, dashed: std)")
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(loc="center right", fontsize=8)
    fig.tight_layout()
    Path(out_png).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out_png, dpi=120)
    plt.close(fig)
    return "\n".join(lines)
