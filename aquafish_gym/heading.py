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
from aquafish_gym.env import AquaFishEnv, check_task_value

__all__ = ["HeadingEnv"]

_HEADING_BOUNDS = (-180.0, 180.0)


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

    def _reset_task(self, options):
        self._target = math.radians(self._draw_task_value(options, "target_heading_deg", self.target_heading_range,
                                                          _HEADING_BOUNDS))
        return self.params

    def _error(self) -> float:
        """Target heading minus yaw (rad), wrapped to (-pi, pi]."""
        error = self._target - math.radians(float(self.world.imu_rpy_deg()[0, 2]))
        return math.pi - (math.pi - error) % (2.0 * math.pi)

    def _task_observation(self) -> np.ndarray:
        error = self._error()
        return np.array([math.sin(error), math.cos(error)])

    def _task_info(self) -> dict[str, Any]:
        if self._world is None:
            return {}
        return {"target_heading_rad": self._target, "heading_error_rad": self._error()}

    def _get_rew(self, displacement: np.ndarray, action: np.ndarray) -> tuple[float, dict[str, float]]:
        direction = np.array([-math.sin(self._target), math.cos(self._target), 0.0])
        terms = {
            "reward_heading": self.heading_reward_weight * math.cos(self._error()),
            "reward_forward": self.forward_reward_weight * float(displacement @ direction),
            "reward_ctrl": -self.ctrl_cost_weight * float(np.sum(np.square(action))),
        }
        return sum(terms.values()), terms
