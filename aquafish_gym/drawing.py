"""Schematic drawings of a morphology (the paper's Figure 11), with matplotlib."""

from __future__ import annotations

from pathlib import Path

from aquafish_gym.files import save_figure
from aquafish_gym.morphology import Morphology
from aquafish_gym.robot import BODY_LENGTH, BODY_RADIUS, CAUDAL_HINGE_Y, PECTORAL_HINGE_Y

FLIPPER_COLOR = "#d62728"  # flippers in red, as in the paper's Figure 11
BODY_COLOR = "#c7c7d6"


def draw_morphology(ax_top, ax_side, morphology: Morphology, title: str = "") -> None:
    """Draw the robot from above (x-y) on ``ax_top`` and from the side (y-z) on ``ax_side``.

    Flippers at angle 0 ("arms back"; caudal straight back). Units: simulator units.
    """
    from matplotlib.patches import FancyBboxPatch, Rectangle

    m = morphology.to_array().reshape(3, 3)
    (lx, ly, lz), (rx, ry, rz), (cx, cy, cz) = m
    half_len = BODY_LENGTH / 2
    for ax, (w, h) in ((ax_top, (2 * BODY_RADIUS, BODY_LENGTH)), (ax_side, (BODY_LENGTH, 2 * BODY_RADIUS))):
        if ax is ax_top:
            ax.add_patch(FancyBboxPatch((-BODY_RADIUS + 0.5 * 0.999, -half_len + 0.5), 1e-3, BODY_LENGTH - 1.0,
                                        boxstyle=f"round,pad={BODY_RADIUS}", fc=BODY_COLOR, ec="k", lw=0.8))
        else:
            ax.add_patch(FancyBboxPatch((-half_len + 0.5, -1e-3 / 2), BODY_LENGTH - 1.0, 1e-3,
                                        boxstyle=f"round,pad={BODY_RADIUS}", fc=BODY_COLOR, ec="k", lw=0.8))
    # top view: x lateral (right = +x), y forward
    ax_top.add_patch(Rectangle((-BODY_RADIUS - lx, PECTORAL_HINGE_Y - ly), lx, ly, fc=FLIPPER_COLOR, ec="k", lw=0.6, zorder=3))
    ax_top.add_patch(Rectangle((BODY_RADIUS, PECTORAL_HINGE_Y - ry), rx, ry, fc=FLIPPER_COLOR, ec="k", lw=0.6, zorder=3))
    ax_top.add_patch(Rectangle((-cx / 2, CAUDAL_HINGE_Y - cy), cx, cy, fc=FLIPPER_COLOR, ec="k", lw=0.6, zorder=3))
    # side view: y forward (to the right), z up; the left pectoral is the near one
    ax_side.add_patch(Rectangle((PECTORAL_HINGE_Y - ly, -lz / 2), ly, lz, fc=FLIPPER_COLOR, ec="k", lw=0.6, zorder=3))
    ax_side.add_patch(Rectangle((CAUDAL_HINGE_Y - cy, -cz / 2), cy, cz, fc=FLIPPER_COLOR, ec="k", lw=0.6, zorder=3))
    ax_top.set_xlim(-2.0, 2.0)
    ax_top.set_ylim(-3.0, 1.0)
    ax_side.set_xlim(-3.0, 1.0)
    ax_side.set_ylim(-1.0, 1.0)
    for ax in (ax_top, ax_side):
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
    ax_top.set_title(title, fontsize=9)
    ax_top.set_xlabel("x (lateral)", fontsize=7)
    ax_top.set_ylabel("y (forward)", fontsize=7)
    ax_side.set_xlabel("y (forward)", fontsize=7)
    ax_side.set_ylabel("z (up)", fontsize=7)


def plot_morphologies(morphologies: list[Morphology], titles: list[str], path) -> Path:
    """Draw morphologies side by side (top view above, side view below); write a PNG atomically.

    Raises:
        OSError: as :func:`aquafish_gym.files.save_figure`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(morphologies)
    fig, axes = plt.subplots(2, n, figsize=(3.2 * n, 5.4), gridspec_kw={"height_ratios": [2, 1]}, squeeze=False)
    for k, (m, t) in enumerate(zip(morphologies, titles)):
        draw_morphology(axes[0, k], axes[1, k], m, t)
    fig.tight_layout()
    try:
        return save_figure(fig, path, dpi=120)
    finally:
        plt.close(fig)
