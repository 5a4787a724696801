"""Swim robots with a fixed servo command and record their trajectories (the quick-start demo)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aquafish_gym.damage import get_damage
from aquafish_gym.files import save_figure
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.simulator import BatchWorld

#: The demo's fixed gait: both pectorals at 0.25 rev/s, caudal fin at 1 Hz. From flippers at 0,
#: the healthy robot swims 5.8 units straight ahead in 20 s, the one with a half-length left
#: pectoral veers to the right (2.8 units sideways), half a tail swims 2.3 units, no tail none.
FIXED_GAIT = (0.25, 0.25, 1.0)


def swim_trajectories(damages, action=FIXED_GAIT, duration_s: float = 20.0, initial_angles=(0.0, 0.0, 0.0),
                      params: SimParams | None = None, sample_every_s: float = 0.1) -> np.ndarray:
    """Swim the healthy robot with each named damage, all in one batch.

    Args:
        damages: damage names (``"none"`` for the healthy robot), length N.
        action: ``(3,)`` servo command (rev/s, rev/s, Hz), held for the whole swim.
        duration_s: simulated seconds.
        initial_angles: ``(3,)`` initial flipper angles (rad).
        params: simulator parameters.
        sample_every_s: trajectory sampling period (s).

    Returns:
        ``(N, T + 1, 2)`` x, y of each body's centre of mass relative to its start
        (units, 1 unit = 8 cm), T = duration / sample period.

    Raises:
        ValueError: unknown damage name or bad command.
    """
    damage_list = [get_damage(d) for d in damages]
    morph = np.stack([d.apply().to_array() for d in damage_list])
    n = len(damage_list)
    every = max(1, int(round(sample_every_s / DT_S)))
    samples = int(round(duration_s / DT_S)) // every
    with BatchWorld(morph, params, [d.faults for d in damage_list]) as world:
        world.reset(np.tile(initial_angles, (n, 1)), np.tile(action, (n, 1)))
        out = [world.position[:, 0, :2] - world.home[:, :2]]
        for _ in range(samples):
            for _ in range(every):
                world.step()
            out.append(world.position[:, 0, :2] - world.home[:, :2])
    return np.stack(out, axis=1)


def plot_trajectories(trajectories: np.ndarray, labels, path: Path, title: str = "") -> Path:
    """Plot ``(N, T, 2)`` trajectories on one axes with the start marked; write a PNG atomically.

    Raises:
        OSError: as :func:`aquafish_gym.files.save_figure`.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    for traj, label in zip(trajectories, labels):
        ax.plot(traj[:, 0], traj[:, 1], label=label)
    ax.plot([0], [0], "ko", label="start")
    ax.set_xlabel("x (units, 1 unit = 8 cm)")
    ax.set_ylabel("y (units, forward)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title)
    try:
        return save_figure(fig, path, dpi=120, bbox_inches="tight")
    finally:
        plt.close(fig)
