"""Transfer scoring (paper section 5, Figure 12): a controller on its native robot and on a target.

The controller evolved (or trained) for one morphology, its *native* robot, is run for one
20 s episode on that robot and on a *target* (the damaged robot in the paper), both from the
same initial flipper angles. The forward distances and the ``(T + 1, 2)`` x, y trajectories
(every 0.1 s) show how well the gait survives the change of body.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from gait.controller import Controller
from gait.plots import plot_transfer
from gait.robots import Robot, as_robot
from gait.rollout import EPISODE_DURATION_S, Rollout, rollout


@dataclasses.dataclass(frozen=True)
class TransferResult:
    """One controller scored on its native robot and on a target.

    Attributes:
        native: the robot the controller was made for.
        target: the robot it is transferred to.
        native_rollout, target_rollout: the two episodes.
    """

    native: Robot
    target: Robot
    native_rollout: Rollout
    target_rollout: Rollout

    @property
    def native_distance(self) -> float:
        """Forward distance on the native robot (units)."""
        return self.native_rollout.distance

    @property
    def target_distance(self) -> float:
        """Forward distance on the target (units)."""
        return self.target_rollout.distance

    @property
    def native_trajectory(self) -> np.ndarray:
        """``(T + 1, 2)`` x, y on the native robot (units)."""
        return self.native_rollout.trajectory

    @property
    def target_trajectory(self) -> np.ndarray:
        """``(T + 1, 2)`` x, y on the target (units)."""
        return self.target_rollout.trajectory

    @property
    def transfer_ratio(self) -> float:
        """``target_distance / native_distance`` (nan if the native distance is 0)."""
        return self.target_distance / self.native_distance if self.native_distance else float("nan")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary with both trajectories (x, y lists)."""
        return {
            "native": self.native.to_dict(),
            "target": self.target.to_dict(),
            "native_distance": self.native_distance,
            "target_distance": self.target_distance,
            "initial_angles_rad": self.native_rollout.initial_angles.tolist(),
            "times_s": self.native_rollout.times_s.tolist(),
            "native_trajectory": self.native_trajectory.tolist(),
            "target_trajectory": self.target_trajectory.tolist(),
        }


def score_transfer(controller: Controller, native, target, *, seed: int = 0, initial_angles=None,
                   episode_duration_s: float = EPISODE_DURATION_S, **env_kwargs: Any) -> TransferResult:
    """Run ``controller`` on its native robot and on the target, from the same initial angles.

    Args:
        controller: a NEAT or SB3 controller.
        native: the controller's own robot: a ``Robot``, ``Morphology``, 9 numbers or a robot
            string (``"healthy"``, a damage name, a file, 9 comma-separated numbers).
        target: the robot to transfer to, in the same forms; a damage name means the healthy
            robot with that damage (the paper's damaged target), e.g. ``"left_pectoral_half"``.
        seed: episode seed; draws the initial angles unless ``initial_angles`` (the same
            seed draws the same angles on both robots). Use the evolution run's seed to
            reproduce its fitness on the native robot.
        initial_angles: ``(3,)`` rad for both episodes, or None.
        episode_duration_s: simulated seconds (20 s in the paper).
        **env_kwargs: further AquaFish-v0 arguments for both episodes.

    Returns:
        :class:`TransferResult`.

    Raises:
        ValueError: an invalid robot, angles or env argument.
    """
    native, target = as_robot(native), as_robot(target)
    kw = dict(seed=seed, initial_angles=initial_angles, episode_duration_s=episode_duration_s, **env_kwargs)
    return TransferResult(native, target, rollout(controller, native, **kw), rollout(controller, target, **kw))


def save_transfer(results: Sequence[TransferResult], path) -> Path:
    """Write the results (distances and trajectories) as a JSON list; return the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps([r.to_dict() for r in results], indent=1))
    return path


__all__ = ["TransferResult", "plot_transfer", "save_transfer", "score_transfer"]
