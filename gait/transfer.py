"""Transfer scoring (paper section 5, Figure 12): a controller on its native robot and on a target.

The controller evolved (or trained) for one morphology, its *native* robot, is run for 20 s
episodes on that robot and on a *target* (the damaged robot in the paper), episode k of both
from the same initial flipper angles (seed ``seed + k``); the K episodes on each robot run at
once on one vector env (:func:`gait.rollout.batch_rollouts`: the single env's episodes, positions
to round-off). The mean forward distances and the
first episode's ``(T + 1, 2)`` x, y trajectories (every 0.1 s) show how well the gait
survives the change of body. A gait's distance depends strongly on where its flippers start
(an evolved gait can swim 5 units from one start and drift backwards from another), so
score several episodes when comparing controllers; the paper's Figure 12 shows one.
:func:`gait.plots.plot_transfer` draws the figure (also exported as ``gait.plot_transfer``).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from aquafish_gym.files import atomic_write
from gait.controller import Controller
from gait.robots import Robot, as_robot
from gait.envs import EPISODE_DURATION_S, check_episodes
from gait.rollout import Rollout, batch_rollouts


@dataclasses.dataclass(frozen=True)
class TransferResult:
    """One controller scored on its native robot and on a target over K paired episodes.

    Attributes:
        native: the robot the controller was made for.
        target: the robot it is transferred to.
        native_rollouts, target_rollouts: the K >= 1 episodes on each robot; episode k of
            both starts from the same initial angles.

    Raises:
        ValueError: if the two tuples are empty or of different lengths.
    """

    native: Robot
    target: Robot
    native_rollouts: tuple[Rollout, ...]
    target_rollouts: tuple[Rollout, ...]

    def __post_init__(self) -> None:
        if not self.native_rollouts or len(self.native_rollouts) != len(self.target_rollouts):
            raise ValueError(f"need K >= 1 paired episodes, got {len(self.native_rollouts)} native and "
                             f"{len(self.target_rollouts)} target rollouts")

    @property
    def episodes(self) -> int:
        """K, the number of paired episodes."""
        return len(self.native_rollouts)

    @property
    def native_rollout(self) -> Rollout:
        """The first episode on the native robot (the one drawn in Figure 12)."""
        return self.native_rollouts[0]

    @property
    def target_rollout(self) -> Rollout:
        """The first episode on the target."""
        return self.target_rollouts[0]

    @property
    def native_distances(self) -> np.ndarray:
        """``(K,)`` forward distance of each episode on the native robot (units)."""
        return np.array([r.distance for r in self.native_rollouts])

    @property
    def target_distances(self) -> np.ndarray:
        """``(K,)`` forward distance of each episode on the target (units)."""
        return np.array([r.distance for r in self.target_rollouts])

    @property
    def native_distance(self) -> float:
        """Mean forward distance on the native robot over the K episodes (units)."""
        return float(self.native_distances.mean())

    @property
    def target_distance(self) -> float:
        """Mean forward distance on the target over the K episodes (units)."""
        return float(self.target_distances.mean())

    @property
    def native_trajectory(self) -> np.ndarray:
        """``(T + 1, 2)`` x, y of the first episode on the native robot (units)."""
        return self.native_rollout.trajectory

    @property
    def target_trajectory(self) -> np.ndarray:
        """``(T + 1, 2)`` x, y of the first episode on the target (units)."""
        return self.target_rollout.trajectory

    @property
    def transfer_ratio(self) -> float:
        """``target_distance / native_distance`` of the means (nan if the native mean is 0)."""
        return self.target_distance / self.native_distance if self.native_distance else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary: mean and per-episode distances, the first episode's trajectories."""
        return {
            "native": self.native.to_dict(),
            "target": self.target.to_dict(),
            "episodes": self.episodes,
            "native_distance": self.native_distance,
            "target_distance": self.target_distance,
            "native_distances": self.native_distances.tolist(),
            "target_distances": self.target_distances.tolist(),
            "initial_angles_rad": self.native_rollout.initial_angles.tolist(),
            "times_s": self.native_rollout.times_s.tolist(),
            "native_trajectory": self.native_trajectory.tolist(),
            "target_trajectory": self.target_trajectory.tolist(),
        }


def score_transfer(controller: Controller, native, target, *, seed: int = 0, episodes: int = 1, initial_angles=None,
                   episode_duration_s: float = EPISODE_DURATION_S, **env_kwargs: Any) -> TransferResult:
    """Run ``controller`` on its native robot and on the target, from the same initial angles.

    Args:
        controller: a NEAT or SB3 controller.
        native: the controller's own robot: a ``Robot``, ``Morphology``, 9 numbers or a robot
            string (``"healthy"``, a damage name, a file, 9 comma-separated numbers).
        target: the robot to transfer to, in the same forms; a damage name means the healthy
            robot with that damage (the paper's damaged target), e.g. ``"left_pectoral_half"``.
        seed: seed of the first episode; episode k uses ``seed + k``, which draws its
            initial angles unless ``initial_angles`` (the same seed draws the same angles
            on both robots). Use the evolution run's seed and ``episodes_per_genome`` to
            reproduce its fitness on the native robot.
        episodes: K >= 1 paired episodes; distances are their means.
        initial_angles: ``(3,)`` rad for every episode (then ``episodes`` must be 1), or None.
        episode_duration_s: simulated seconds (20 s in the paper).
        **env_kwargs: further AquaFish-v0 arguments for both episodes.

    Returns:
        :class:`TransferResult`.

    Raises:
        ValueError: an invalid robot, angles or env argument; ``episodes`` < 1, or > 1 with
            fixed ``initial_angles`` (the episodes would be identical).
    """
    episodes = check_episodes(episodes, initial_angles)
    native, target = as_robot(native), as_robot(target)
    kw = dict(initial_angles=initial_angles, episode_duration_s=episode_duration_s, **env_kwargs)
    seeds = [seed + k for k in range(episodes)]
    return TransferResult(native, target, tuple(batch_rollouts(controller, native, seeds, **kw)),
                          tuple(batch_rollouts(controller, target, seeds, **kw)))


def save_transfer(results: Sequence[TransferResult], path) -> Path:
    """Write the results (distances and trajectories) as a JSON list atomically; return the path.

    Raises:
        OSError: as :func:`aquafish_gym.files.atomic_write`.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, json.dumps([r.to_dict() for r in results], indent=1).encode())
    return path


__all__ = ["TransferResult", "save_transfer", "score_transfer"]
