"""The Gymnasium env ``AquaFishHeading-v0``: turn to a target heading and hold it.

Same robot, morphology, damage and simulator parameters as ``AquaFish-v0``
(:class:`~aquafish_gym.env.AquaFishEnv`); turning is what the pectoral flippers are for, so
a pectoral damage matters here more than in forward swimming.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium.utils import EzPickle

from aquafish_gym.checks import check_weight
from aquafish_gym.env import AquaFishEnv, BodyState, Episodes, check_task_value

__all__ = ["HeadingEnv", "along_heading"]

_HEADING_BOUNDS = (-180.0, 180.0)


def along_heading(displacement, heading_rad) -> np.ndarray:
    """Horizontal displacement along a heading: its component on the unit vector ``(-sin, cos)``.

    Args:
        displacement: ``(..., 2)`` (or wider: the first two entries are used) x, y displacement
            (units, world frame).
        heading_rad: heading(s) broadcasting with ``displacement[..., 0]``, radians
            counter-clockwise from +y (the initial forward direction; the env's yaw convention).

    Returns:
        ``(...)`` units; at 0 rad the y displacement.
    """
    d = np.asarray(displacement, dtype=np.float64)
    heading = np.asarray(heading_rad, dtype=np.float64)
    return d[..., 0] * -np.sin(heading) + d[..., 1] * np.cos(heading)


class HeadingEnv(AquaFishEnv):
    """Turn to a target heading drawn per episode, and hold it (optionally swimming along it).

    ## Description
    The robot of ``AquaFish-v0`` must bring its yaw (counter-clockwise from the initial
    heading, seen from above) to a target heading and keep it there. The target is given in
    the observation as the sine and cosine of the heading error.

    ## Action Space
    As ``AquaFish-v0``: ``Box(-1, 1, (3,), float32)`` mapped onto left and right pectoral
    speed (rev/s, [-0.5, 0.5]) and caudal frequency (Hz, [0, 1]).

    ## Observation Space
    ``Box(14,), float64``: the 12 IMU entries of ``AquaFish-v0``, then

    | Num | Observation                                    | Min | Max | Unit |
    |-----|------------------------------------------------|-----|-----|------|
    | 12  | sin(target heading - yaw)                      | -1  | 1   | -    |
    | 13  | cos(target heading - yaw)                      | -1  | 1   | -    |

    ## Rewards
    ``reward = reward_heading + reward_forward + reward_ctrl`` per 0.1 s control step, each
    term in ``info``:

    | term             | value                                                      | unit  |
    |------------------|------------------------------------------------------------|-------|
    | `reward_heading` | `heading_reward_weight * cos(target heading - yaw)`        | -     |
    | `reward_forward` | `forward_reward_weight *` displacement of the body along the target heading during the step | units |
    | `reward_ctrl`    | `-ctrl_cost_weight * sum(action**2)`                       | -     |

    ## Starting State
    As ``AquaFish-v0``. The target heading is drawn at reset;
    ``options={"target_heading_deg": ...}`` fixes it for one episode.

    ## Episode End
    Never terminated; truncated after ``episode_duration_s``.

    ## Arguments
    Every ``AquaFish-v0`` argument (morphology, damage incl. ``"random"``, faults, frame
    skip, episode length, control cost, rendering, every ``SimParams`` field), and:

    | Parameter               | Default       | Description                                   |
    |-------------------------|---------------|-----------------------------------------------|
    | `target_heading_deg`    | (-180, 180)   | degrees counter-clockwise from the initial heading: a number, or a `(lo, hi)` range drawn per episode; within [-180, 180] |
    | `heading_reward_weight` | 1.0           | weight of the heading term (>= 0)             |
    | `forward_reward_weight` | 0.0           | weight of the forward-swim term (>= 0)        |

    ``info`` adds ``target_heading_rad`` and ``heading_error_rad`` (target minus yaw,
    wrapped to (-pi, pi]).

    ``reset``'s ``options`` takes ``AquaFish-v0``'s keys (``"damage"``, ``"initial_angles"``)
    and ``"target_heading_deg"``; any other is refused.

    ## Copying and pickling
    As ``AquaFish-v0``: ``copy.deepcopy`` and ``pickle`` give a fresh env with the same
    constructor arguments, which must be ``reset`` before ``step``.

    Raises:
        ValueError: an unknown keyword or a value out of range (named in the message).
    """

    env_id = "AquaFishHeading-v0"
    reset_options = AquaFishEnv.reset_options + ("target_heading_deg",)

    def __init__(self, target_heading_deg=(-180.0, 180.0), heading_reward_weight: float = 1.0,
                 forward_reward_weight: float = 0.0, **kwargs: Any):
        self.target_heading_range = check_task_value("target_heading_deg", target_heading_deg, *_HEADING_BOUNDS)
        self.heading_reward_weight = check_weight("heading_reward_weight", heading_reward_weight)
        self.forward_reward_weight = check_weight("forward_reward_weight", forward_reward_weight)
        self._target = 0.0
        super().__init__(**kwargs)
        EzPickle.__init__(self, target_heading_deg=target_heading_deg, heading_reward_weight=heading_reward_weight,
                          forward_reward_weight=forward_reward_weight, **kwargs)

    def _task_observation_high(self) -> np.ndarray:
        return np.ones(2)

    def _reset_task(self, options) -> None:
        self._target = math.radians(self._draw_task_value(options, "target_heading_deg", self.target_heading_range,
                                                          _HEADING_BOUNDS))

    def _task_variables(self) -> dict[str, np.ndarray]:
        return {"target_heading_rad": np.float64(self._target)}

    @staticmethod
    def _errors(state: BodyState, episodes: Episodes) -> np.ndarray:
        """``(N,)`` target heading minus yaw (rad), wrapped to (-pi, pi]."""
        error = episodes.task["target_heading_rad"] - state.rpy_rad()[:, 2]
        return math.pi - np.remainder(math.pi - error, 2.0 * math.pi)

    def _task_observations(self, state: BodyState, episodes: Episodes) -> np.ndarray:
        error = self._errors(state, episodes)
        return np.stack([np.sin(error), np.cos(error)], axis=1)

    def _task_infos(self, state: BodyState, episodes: Episodes) -> dict[str, np.ndarray]:
        return {"target_heading_rad": episodes.task["target_heading_rad"].copy(),
                "heading_error_rad": self._errors(state, episodes)}

    def _rewards(self, state: BodyState, episodes: Episodes, displacement: np.ndarray,
                 actions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        target = episodes.task["target_heading_rad"]
        along = along_heading(displacement, target)
        terms = {
            "reward_heading": self.heading_reward_weight * np.cos(self._errors(state, episodes)),
            "reward_forward": self.forward_reward_weight * along,
            "reward_ctrl": -self.ctrl_cost_weight * np.sum(np.square(actions), axis=1),
        }
        return terms["reward_heading"] + terms["reward_forward"] + terms["reward_ctrl"], terms
