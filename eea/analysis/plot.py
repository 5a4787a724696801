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
import os
import re
from collections import defaultdict
from pathlib import Path

import numpy as np

from aquafish_gym.files import save_figure
from eea.inference import INFERENCE_NAMES
from eea.record import CONFIG_FILE, RunResult, load_result

__all__ = ["GroupSummary", "final_round_table", "find_runs", "plot_runs", "plot_study", "summarise_runs",
           "welch_p_value"]


@dataclasses.dataclass(frozen=True)
class GroupSummary:
    """Objective fitness of the replicate runs of one (inference, duration) group.

    Attributes:
        runs: number of replicate runs.
        mean: ``(R,)`` mean OBJ_FIT per round over the runs, R = the number of rounds
            every run of the group has finished (longer runs are truncated to it).
        std: ``(R,)`` population standard deviation (ddof = 0) per round.
        final: ``(runs,)`` each run's OBJ_FIT at round R.
        median_error_deg: ``(3,)`` median inference error (degrees; left, right pectoral,
            caudal) over rounds 1..R of every run
            (:attr:`~eea.record.RunResult.inference_error_deg`).
    """

    runs: int
    mean: np.ndarray
    std: np.ndarray
    final: np.ndarray
    median_error_deg: np.ndarray


def find_runs(paths) -> list[RunResult]:
    """Every run under ``paths`` (run directories, or directories searched recursively).

    Runs without a finished round are left out. Directories found by the search come in
    natural order (``seed2`` before ``seed10``), so tables list seeds as numbers.

    Raises:
        ValueError: if a path does not exist or no run is found.
    """
    dirs = []
    for path in map(Path, paths):
        if not path.exists():
            raise ValueError(f"{path} does not exist")
        if (path / CONFIG_FILE).exists():
            dirs.append(path)
        else:
            dirs += sorted((p.parent for p in path.rglob(CONFIG_FILE)), key=_natural_key)
    results = [r for r in (load_result(d) for d in dict.fromkeys(dirs)) if r.rounds]
    if not results:
        raise ValueError(f"no EEA run with a finished round under {', '.join(map(str, paths))}")
    return results


def _natural_key(path: Path) -> list:
    """Sort key that compares the digit runs of ``path`` as integers: ``seed2`` < ``seed10``."""
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", str(path))]


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
    groups: dict[tuple[str, float], list[RunResult]] = defaultdict(list)
    for r in results:
        groups[(r.config.inference.name, r.config.duration_s)].append(r)
    summary = {}
    for key in sorted(groups, key=_order):
        runs = groups[key]
        rounds = min(len(r.rounds) for r in runs)
        values = np.array([r.objective_fitness[:rounds] for r in runs])  # (runs, R)
        errors = np.concatenate([r.inference_error_deg[:rounds] for r in runs])  # (runs * R, 3)
        summary[key] = GroupSummary(len(runs), values.mean(axis=0), values.std(axis=0), values[:, -1],
                                    np.median(errors, axis=0))
    return summary


def welch_p_value(a, b) -> float:
    """Two-sided p-value of Welch's t-test that samples ``a`` and ``b`` have equal means.

    Args:
        a: ``(n,)`` samples (e.g. final-round OBJ_FIT of replicate runs).
        b: ``(m,)`` samples, likewise.

    Returns:
        The p-value in [0, 1]; NaN if either sample has fewer than 2 values or both have
        zero variance (the test is undefined).
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    if len(a) < 2 or len(b) < 2 or (np.ptp(a) == 0 and np.ptp(b) == 0):
        return float("nan")
    from scipy.stats import ttest_ind

    return float(ttest_ind(a, b, equal_var=False).pvalue)


def final_round_table(summary: dict[tuple[str, float], GroupSummary]) -> str:
    """Plain-text table of the last round, one line per group.

    Columns: inference, duration_s, runs, rounds, mean and std (ddof 0) OBJ_FIT;
    ``p_vs_none``, Welch's two-sided p-value (:func:`welch_p_value`) of the final OBJ_FIT
    against the ``none`` group of the same duration ("-" for ``none`` itself, when there
    is no such group, or when the test is undefined); and the median inference error in
    degrees per flipper (``err_left``, ``err_right``, ``err_caudal``).
    """
    lines = [f"{'inference':<12} {'duration_s':>10} {'runs':>5} {'rounds':>6} {'mean':>7} {'std':>7} "
             f"{'p_vs_none':>9} {'err_left':>8} {'err_right':>9} {'err_caudal':>10}"]
    for (inference, duration), s in summary.items():
        baseline = summary.get(("none", duration))
        p = welch_p_value(s.final, baseline.final) if baseline is not None and inference != "none" else np.nan
        p_text = "-" if np.isnan(p) else f"{p:.3f}"
        left, right, caudal = s.median_error_deg
        lines.append(f"{inference:<12} {duration:>10g} {s.runs:>5} {len(s.mean):>6} "
                     f"{s.mean[-1]:>7.4f} {s.std[-1]:>7.4f} {p_text:>9} {left:>8.1f} {right:>9.1f} {caudal:>10.1f}")
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
    try:
        return save_figure(fig, out_png, format="png", dpi=120)
    finally:
        plt.close(fig)


def plot_runs(paths, out_png: str | os.PathLike) -> str:
    """Find the runs under ``paths``, draw :func:`plot_study` to ``out_png``, return the table.

    Raises:
        ValueError: as :func:`find_runs`.
    """
    summary = summarise_runs(find_runs(paths))
    plot_study(summary, out_png)
    return final_round_table(summary)
