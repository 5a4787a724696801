"""Figures of the gait study: fitness per generation, and transfer trajectories (Figure 12).

Matplotlib's object-oriented API (a bare ``Figure``, rendered in memory by
:func:`aquafish_gym.files.save_figure` and written atomically): no pyplot, no global backend
change, works headless.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from aquafish_gym.files import save_figure
from gait.transfer import TransferResult

#: Centimetres per simulator unit (the body diameter is 1 unit = 8 cm).
CM_PER_UNIT = 8.0


def plot_fitness_history(history: Sequence[dict], path, title: str | None = None) -> Path:
    """Plot the best and mean (+- std) fitness per generation of a NEAT run.

    Args:
        history: per-generation dicts with ``generation``, ``best_fitness``,
            ``mean_fitness``, ``std_fitness`` and ``best_so_far`` (units), as in
            ``GaitResult.history``.
        path: image file to write (format from its suffix, e.g. ``.png``).
        title: axes title.

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: an empty history.
    """
    if not history:
        raise ValueError("history is empty: nothing to plot")
    gen = np.array([h["generation"] for h in history])
    best = np.array([h["best_fitness"] for h in history])
    mean = np.array([h["mean_fitness"] for h in history])
    std = np.array([h["std_fitness"] for h in history])
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    ax.plot(gen, [h["best_so_far"] for h in history], "k-", label="best so far")
    ax.plot(gen, best, "o", ms=3, color="tab:blue", label="best of generation")
    ax.plot(gen, mean, "-", color="tab:orange", label="mean")
    ax.fill_between(gen, mean - std, mean + std, color="tab:orange", alpha=0.2, label="mean +- std")
    ax.set_xlabel("generation")
    ax.set_ylabel("forward distance in 20 s (units, 1 unit = 8 cm)")
    ax.set_title(title or "NEAT gait evolution")
    ax.grid(alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path, dpi=120)


#: Panels per row of :func:`plot_transfer` (more results wrap to further rows).
MAX_PANELS_PER_ROW = 4


def plot_transfer(results: Sequence[TransferResult], path, titles: Sequence[str] | None = None) -> Path:
    """Plot native and target trajectories of each transfer, one axes per result (Figure 12),
    :data:`MAX_PANELS_PER_ROW` to a row.

    Each axes shows the controller on its native morphology (solid) and on the target
    (dashed), x and y in units (1 unit = 8 cm; heading +y at the start), the common start
    marked with a black circle and each end with a cross. The trajectories are the first
    episode's; the legend gives its distance and, for K > 1 episodes, the mean over all K.

    Args:
        results: one :class:`~gait.transfer.TransferResult` per panel.
        path: image file to write.
        titles: one title per panel (default: "native -> target").

    Returns:
        ``path`` as a ``Path``.

    Raises:
        ValueError: no results, or ``titles`` of the wrong length.
    """
    results = list(results)
    if not results:
        raise ValueError("no transfer results to plot")
    if titles is not None and len(titles) != len(results):
        raise ValueError(f"titles must have one entry per result ({len(results)}), got {len(titles)}")
    ncols = min(len(results), MAX_PANELS_PER_ROW)
    nrows = -(-len(results) // ncols)
    fig = Figure(figsize=(4.2 * ncols, 4.4 * nrows))
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[len(results):]:
        ax.set_visible(False)
    for i, (ax, r) in enumerate(zip(axes, results)):
        runs = ((r.native_trajectory, r.native_distances, f"native ({r.native.label})", "tab:blue", "-"),
                (r.target_trajectory, r.target_distances, f"target ({r.target.label})", "tab:red", "--"))
        for traj, dists, name, color, style in runs:
            label = f"{name}: {dists[0]:.2f} units"
            if len(dists) > 1:
                label += f" (mean of {len(dists)}: {dists.mean():.2f})"
            ax.plot(traj[:, 0], traj[:, 1], style, color=color, lw=1.5, label=label)
            ax.plot(traj[-1, 0], traj[-1, 1], "x", color=color, ms=8)
        ax.plot(*r.native_trajectory[0], "ko", ms=7, label="start")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("x (units)")
        ax.set_ylabel("y, initial heading (units)")
        ax.set_title(titles[i] if titles else f"{r.native.label} -> {r.target.label}", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(loc="best", fontsize=7)
    fig.tight_layout()
    return save_figure(fig, path, dpi=120)


def plot_learning_curve(episodes: np.ndarray, path, title: str = "") -> Path:
    """Plot RL episode return (forward distance, units) against env steps.

    Args:
        episodes: ``(E, 3)`` return, length (steps), wall time per episode, in order
            (columns ``r``, ``l``, ``t`` of SB3's
            ``stable_baselines3.common.monitor.load_results``, as :func:`gait.rl.train_rl` reads them).
        path: image file to write.
        title: axes title.

    Raises:
        ValueError: no episodes.
    """
    if len(episodes) == 0:
        raise ValueError("no episodes to plot")
    steps = np.cumsum(episodes[:, 1])
    fig = Figure(figsize=(6, 4))
    ax = fig.add_subplot()
    ax.plot(steps, episodes[:, 0], ".", ms=2, alpha=0.4, label="episode")
    k = max(1, len(episodes) // 20)
    ax.plot(steps[k - 1:], np.convolve(episodes[:, 0], np.ones(k) / k, mode="valid"), "k-", label=f"mean of {k}")
    ax.set_xlabel("env steps (0.1 s each)")
    ax.set_ylabel("forward distance per episode (units)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return save_figure(fig, path, dpi=120)
