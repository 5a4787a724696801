"""The Gymnasium env ``AquaFishStationKeeping-v0``: hold position and heading in a current.

The task of the paper's lab (Moore, Clark & McKinley, GECCO 2013, "Evolution of station
keeping as a response to flows in an aquatic robot") on the same robot, morphology, damage
and simulator parameters as ``AquaFish-v0`` (:class:`~aquafish_gym.env.AquaFishEnv`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium.utils import EzPickle

from aquafish_gym.checks import check_weight
from aquafish_gym.env import AquaFishEnv, BodyState, Episodes, check_task_value

__all__ = ["StationKeepingEnv"]

_SPEED_NAME, _SPEED_BOUNDS = "current_speed (units/s)", (0.0, 5.0)
_DIRECTION_BOUNDS = (-360.0, 360.0)


class StationKeepingEnv(AquaFishEnv):
    """Stay at the start position and heading while a uniform water current pushes the robot.

    ## Description
    The robot of ``AquaFish-v0`` in a uniform, horizontal water current (the fluid model's
    ``water_current``, docs/physics.md). Speed and direction are fixed or drawn per
    episode. Like the real robot, the controller senses only its IMU: the observation does
    not contain the current, which it must infer from how the water moves the body.

    ## Action Space
    As ``AquaFish-v0``: ``Box(-1, 1, (3,), float32)`` mapped onto left and right pectoral
    speed (rev/s, [-0.5, 0.5]) and caudal frequency (Hz, [0, 1]).

    ## Observation Space
    As ``AquaFish-v0``: ``Box(12,), float64``, the IMU (sin and cos of roll, pitch, yaw;
    body-frame angular velocity in rad/s; body-frame linear velocity over ground in units/s).

    ## Rewards
    ``reward = reward_position + reward_heading + reward_ctrl`` per 0.1 s control step, each
    term in ``info``:

    | term              | value                                              | unit     |
    |-------------------|----------------------------------------------------|----------|
    | `reward_position` | `-position_cost_weight * d`, d = horizontal distance of the body from its start | units |
    | `reward_heading`  | `-heading_cost_weight * (1 - cos(yaw))`, yaw from the start heading | - |
    | `reward_ctrl`     | `-ctrl_cost_weight * sum(action**2)`               | -        |

    A robot that holds perfectly scores 0; one carried off at the current's speed ``u``
    for an episode of ``T`` seconds scores about ``-position_cost_weight * u T^2 / 0.2``.

    ## Starting State
    As ``AquaFish-v0`` (origin, level, heading +y, at rest; random initial flipper
    angles). The current is drawn at reset: ``options={"current_speed": ...,
    "current_direction_deg": ...}`` fixes it for one episode.

    ## Episode End
    Never terminated; truncated after ``episode_duration_s``.

    ## Arguments
    Every ``AquaFish-v0`` argument (morphology, damage incl. ``"random"``, faults, frame
    skip, episode length, control cost, rendering, every ``SimParams`` field except
    ``water_current``), and:

    | Parameter               | Default | Description                                            |
    |-------------------------|---------|--------------------------------------------------------|
    | `current_speed`         | 0.2     | units/s (1 unit = 8 cm), or a `(lo, hi)` range drawn per episode; in [0, 5] |
    | `current_direction_deg` | 180.0   | where the water flows, counter-clockwise from the initial heading seen from above (0: from behind, 180: head-on, 90: towards the robot's left); a `(lo, hi)` range or `None` (uniform on [0, 360)) draws it per episode |
    | `position_cost_weight`  | 1.0     | weight of the distance term (>= 0)                     |
    | `heading_cost_weight`   | 1.0     | weight of the heading term (>= 0)                      |

    ``info`` adds ``current`` (the episode's ``(3,)`` world-frame water velocity, units/s;
    for analysis, not for the controller), ``distance_from_start`` (units) and
    ``heading_error_rad``.

    ``reset``'s ``options`` takes ``AquaFish-v0``'s keys (``"damage"``, ``"initial_angles"``)
    and ``"current_speed"`` and ``"current_direction_deg"``; any other is refused.

    ## Copying and pickling
    As ``AquaFish-v0``: ``copy.deepcopy`` and ``pickle`` give a fresh env with the same
    constructor arguments, which must be ``reset`` before ``step``.

    Raises:
        ValueError: an unknown keyword, ``water_current`` (set the current with the
            arguments above), or a value out of range (named in the message).
    """

    env_id = "AquaFishStationKeeping-v0"
    reset_options = AquaFishEnv.reset_options + ("current_speed", "current_direction_deg")
    _task_sim_params = ("water_current",)

    def __init__(self, current_speed=0.2, current_direction_deg=180.0, position_cost_weight: float = 1.0,
                 heading_cost_weight: float = 1.0, **kwargs: Any):
        if "water_current" in kwargs:
            raise ValueError("AquaFishStationKeeping-v0 sets the water current itself; "
                             "use current_speed and current_direction_deg instead of water_current")
        self.current_speed_range = check_task_value(_SPEED_NAME, current_speed, *_SPEED_BOUNDS)
        self.current_direction_range = (0.0, 360.0) if current_direction_deg is None else check_task_value(
            "current_direction_deg", current_direction_deg, *_DIRECTION_BOUNDS)
        self.position_cost_weight = check_weight("position_cost_weight", position_cost_weight)
        self.heading_cost_weight = check_weight("heading_cost_weight", heading_cost_weight)
        self._current = np.zeros(3)
        super().__init__(**kwargs)
        EzPickle.__init__(self, current_speed=current_speed, current_direction_deg=current_direction_deg,
                          position_cost_weight=position_cost_weight, heading_cost_weight=heading_cost_weight, **kwargs)

    def _reset_task(self, options: dict | None) -> None:
        speed = self._draw_task_value(options, "current_speed", self.current_speed_range, _SPEED_BOUNDS, _SPEED_NAME)
        direction = math.radians(self._draw_task_value(options, "current_direction_deg", self.current_direction_range,
                                                       _DIRECTION_BOUNDS))
        self._current = np.array([-math.sin(direction), math.cos(direction), 0.0]) * speed

    def _task_variables(self) -> dict[str, np.ndarray]:
        return {"current": self._current.copy()}

    def _water_current(self) -> np.ndarray:
        return self._current

    def _offsets(self, state: BodyState, episodes: Episodes) -> np.ndarray:
        """``(N,)`` horizontal distance of each body from its start (units)."""
        offset = state.position - episodes.start
        return np.hypot(offset[:, 0], offset[:, 1])

    def _task_infos(self, state: BodyState, episodes: Episodes) -> dict[str, np.ndarray]:
        return {"current": episodes.task["current"].copy(), "distance_from_start": self._offsets(state, episodes),
                "heading_error_rad": state.rpy_rad()[:, 2]}

    def _rewards(self, state: BodyState, episodes: Episodes, displacement: np.ndarray,
                 actions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        terms = {
            "reward_position": -self.position_cost_weight * self._offsets(state, episodes),
            "reward_heading": -self.heading_cost_weight * (1.0 - np.cos(state.rpy_rad()[:, 2])),
            "reward_ctrl": -self.ctrl_cost_weight * np.sum(np.square(actions), axis=1),
        }
        return terms["reward_position"] + terms["reward_heading"] + terms["reward_ctrl"], terms
