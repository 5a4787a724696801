"""The AquaFish task a gait runs in: its id, the paper's episode length, and the env for a robot.

Below every other module of :mod:`gait` that builds an env (rollouts, the fitness task, RL,
the SB3 loader of :mod:`gait.controller`, videos), so none of them imports another for it.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

import aquafish_gym  # registers the AquaFish tasks
from aquafish_gym.checks import check_int
from gait.robots import as_robot

__all__ = ["DEFAULT_ENV_ID", "EPISODE_DURATION_S", "check_env_id", "check_episodes", "make_env"]

#: The paper's gait episode: 20 s of simulated swimming.
EPISODE_DURATION_S = 20.0
#: The paper's task (swim forward); ``env_id`` arguments take any id of ``aquafish_gym.ENV_IDS``.
DEFAULT_ENV_ID = "AquaFish-v0"


def check_env_id(env_id: str) -> str:
    """Return ``env_id`` if it names a registered AquaFish task.

    Raises:
        ValueError: another id; the message lists the registered tasks.
    """
    if env_id not in aquafish_gym.ENV_IDS:
        raise ValueError(f"unknown env id {env_id!r}; the AquaFish tasks are {list(aquafish_gym.ENV_IDS)}")
    return env_id


def make_env(robot=None, *, damage: str = "none", initial_angles=None,
             episode_duration_s: float = EPISODE_DURATION_S, env_id: str = DEFAULT_ENV_ID, **env_kwargs: Any) -> gym.Env:
    """``gym.make(env_id)`` (default ``"AquaFish-v0"``) for a robot (anything :func:`gait.robots.as_robot` takes).

    Raises:
        ValueError: an invalid robot, damage, angles, env id or env argument.
    """
    robot = as_robot(robot if robot is not None else "healthy", damage=damage)
    return gym.make(check_env_id(env_id), **robot.env_kwargs(), initial_angles=initial_angles,
                    episode_duration_s=episode_duration_s, **env_kwargs)


def check_episodes(episodes, initial_angles=None) -> int:
    """Validate a number of episodes drawn from seeds ``seed, seed + 1, ...``; return it as an int.

    Raises:
        ValueError: if ``episodes`` is not an integer >= 1, or is > 1 while ``initial_angles``
            are fixed (every episode would be the same).
    """
    check_int("episodes", episodes, 1)
    if episodes > 1 and initial_angles is not None:
        raise ValueError(f"episodes must be 1 when initial_angles are fixed (they would be identical), got {episodes}")
    return int(episodes)
