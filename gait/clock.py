"""The oscillator clock a gait controller sees besides the IMU.

The fluid model rewards strokes whose speed follows the phase of the stroke (fast power
stroke, slow recovery); a controller with only the IMU cannot time that. Every controller
(NEAT network or RL policy) therefore receives the observation followed by
``sin(2 pi t / period)`` and ``cos(2 pi t / period)``, where ``t`` is the simulated time
of the observation (s). :class:`ClockObservation` does the same for a Gymnasium env, so an
RL policy trained on the wrapped env and a NEAT network see identical inputs.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from aquafish_gym.checks import check_seconds

#: Default clock period (s): one caudal stroke at the fin's 1 Hz maximum.
CLOCK_PERIOD_S = 1.0
#: Number of entries the clock adds to the observation.
CLOCK_DIM = 2
#: Size of the AquaFish-v0 observation (IMU) without the clock (other tasks append entries).
OBS_DIM = 12


def check_clock_period(period_s: float) -> float:
    """Return ``period_s`` as a float.

    Raises:
        ValueError: not a finite number > 0.
    """
    return check_seconds("clock_period_s", period_s)


def clock_features(time_s: float, period_s: float = CLOCK_PERIOD_S) -> np.ndarray:
    """Return ``(2,)`` float64 ``[sin(2 pi t / period), cos(2 pi t / period)]``."""
    phase = 2.0 * math.pi * float(time_s) / period_s
    return np.array([math.sin(phase), math.cos(phase)])


def with_clock(obs, time_s: float, period_s: float = CLOCK_PERIOD_S) -> np.ndarray:
    """Append the clock to an observation.

    Args:
        obs: ``(n,)`` observation of an AquaFish task (n = 12 for AquaFish-v0).
        time_s: simulated time of the observation (s), ``info["time_s"]``.
        period_s: clock period (s).

    Returns:
        ``(n + 2,)`` float64: the observation, then sin and cos of the clock phase.

    Raises:
        ValueError: ``obs`` is not a non-empty 1-D array.
    """
    obs = np.asarray(obs, dtype=np.float64)
    if obs.ndim != 1 or not obs.size:
        raise ValueError(f"observation must be a non-empty 1-D array, got shape {obs.shape}")
    return np.concatenate([obs, clock_features(time_s, period_s)])


class ClockObservation(gym.ObservationWrapper):
    """Append ``sin`` and ``cos`` of the clock phase to an AquaFish task's observation.

    The observation space becomes ``Box((n + 2,), float64)``: the env's n entries (12 for
    AquaFish-v0), then the clock in [-1, 1]. The time is the env's ``info["time_s"]``.

    Args:
        env: an env of the AquaFish family (possibly wrapped) whose ``info`` carries ``time_s``.
        period_s: clock period (s).

    Raises:
        ValueError: a non-positive period or an observation space that is not a 1-D Box.
    """

    def __init__(self, env: gym.Env, period_s: float = CLOCK_PERIOD_S):
        super().__init__(env)
        self.period_s = check_clock_period(period_s)
        space = env.observation_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ValueError(f"ClockObservation needs a 1-D Box observation space, got {space}")
        low = np.concatenate([space.low, -np.ones(CLOCK_DIM)])
        high = np.concatenate([space.high, np.ones(CLOCK_DIM)])
        self.observation_space = spaces.Box(low, high, dtype=np.float64)
        self._time_s = 0.0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        self._time_s = float(info["time_s"])
        return self.observation(obs), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._time_s = float(info["time_s"])
        return self.observation(obs), reward, terminated, truncated, info

    def observation(self, observation) -> np.ndarray:
        return with_clock(observation, self._time_s, self.period_s)
