"""Study results: mean objective fitness against EEA round (paper Figures 5-10).

Runs are found on disk (:func:`find_runs`), grouped by (inference strategy, experiment
duration) and summarised round by round (:func:`summarise_runs`); :func:`plot_study` draws
the paper's figure layout - one panel per strategy, one colour per duration, mean OBJ_FIT
(eq. 4) over replicates as a solid line and its standard deviation as a dashed line - and
:func:`final_round_table` prints the final-round numbers::

    print(plot_runs(["runs/study"], "runs/study/objective_fitness.png"))
"""

from __future__ import annotations

import dataclasses
import io
import os
from collections import defaultdict
from pathlib import Path

import numpy as np

from eea.checkpoint import atomic_write
from eea.inference import INFERENCE_NAMES
from eea.record import CONFIG_FILE, RunResult, load_result

__all__ = ["GroupSummary", "final_round_table", "find_runs", "plot_runs", "plot_study", "summarise_runs"]


@dataclasses.dataclass(frozen=True)
class GroupSummary:
    """Objective fitness of the replicate runs of one (inference, duration) group.

    Attributes:
        runs: number of replicate runs.
        mean: ``(R,)`` mean OBJ_FIT per round over the runs, R = the number of rounds
            every run of the group has finished (longer runs are truncated to it).
        std: ``(R,)`` population standard deviation (ddof = 0) per round.
    """

    runs: int
    mean: np.ndarray
    std: np.ndarray


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


def _order(key: tuple[str, float]) -> tuple[int, str, float]:
    """Sort key: strategies in registry (paper) order, then by name, then by duration."""
    inference, duration = key
    rank = INFERENCE_NAMES.index(inference) if inference in INFERENCE_NAMES else len(INFERENCE_NAMES)
    return rank, inference, duration


def summarise_runs(results: list[RunResult]) -> dict[tuple[str, float], GroupSummary]:
    """Per ``(inference, duration_s)``: mean and std of OBJ_FIT by round over its runs.

    Returns:
        ``{(inference, duration_s): GroupSummary}`` in the paper's strategy order, then by
        duration.
    """
    groups: dict[tuple[str, float], list[list[float]]] = defaultdict(list)
    for r in results:
        groups[(r.config.inference, r.config.duration_s)].append(r.objective_fitness)
    summary = {}
    for key in sorted(groups, key=_order):
        curves = groups[key]
        rounds = min(map(len, curves))
        values = np.array([c[:rounds] for c in curves])  # (runs, R)
        summary[key] = GroupSummary(len(curves), values.mean(axis=0), values.std(axis=0))
    return summary


def final_round_table(summary: dict[tuple[str, float], GroupSummary]) -> str:
    """Plain-text table: per group, runs, rounds, and mean and std OBJ_FIT at the last round."""
    lines = [f"{'inference':<12} {'duration_s':>10} {'runs':>5} {'rounds':>6} {'mean':>7} {'std':>7}"]
    for (inference, duration), s in summary.items():
        lines.append(f"{inference:<12} {duration:>10g} {s.runs:>5} {len(s.mean):>6} "
                     f"{s.mean[-1]:>7.4f} {s.std[-1]:>7.4f}")
    return "\n".join(lines)


def plot_study(summary: dict[tuple[str, float], GroupSummary], out_png: str | os.PathLike) -> Path:
    """Draw Figures 5-10: a panel per strategy, mean (solid) and std (dashed) vs round.

    Args:
        summary: from :func:`summarise_runs`.
        out_png: output image path (parent directories are created; written atomically).

    Returns:
        The PNG's path.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    strategies = list(dict.fromkeys(inference for inference, _ in summary))
    fig, axes = plt.subplots(1, len(strategies), figsize=(4.2 * len(strategies), 3.8), squeeze=False, sharey=True)
    for ax, strategy in zip(axes[0], strategies):
        for i, ((inference, duration), s) in enumerate(kv for kv in summary.items() if kv[0][0] == strategy):
            rounds = np.arange(1, len(s.mean) + 1)
            ax.plot(rounds, s.mean, "-", color=f"C{i}", label=f"{duration:g} s (n={s.runs})")
            ax.plot(rounds, s.std, "--", color=f"C{i}")
        ax.set_title(strategy)
        ax.set_xlabel("EEA round")
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(loc="center right", fontsize=8)
    axes[0, 0].set_ylabel("objective fitness (solid: mean, dashed: std)")
    fig.tight_layout()
    png = io.BytesIO()
    fig.savefig(png, format="png", dpi=120)
    plt.close(fig)
    path = Path(out_png)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, png.getvalue())
    return path


def plot_runs(paths, out_png: str | os.PathLike) -> str:
    """Find the runs under ``paths``, draw :func:`plot_study` to ``out_png``, return the table.

    Raises:
        ValueError: as :func:`find_runs`.
    """
    summary = summarise_runs(find_runs(paths))
    plot_study(summary, out_png)
    return final_round_table(summary)
