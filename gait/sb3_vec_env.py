"""A stable-baselines3 ``VecEnv`` over the batched vector env of an AquaFish task.

:class:`ClockVecEnv` gives SB3 (PPO, SAC, RecurrentPPO) the N sub-envs of
``gym.make_vec(env_id, num_envs=N, vectorization_mode="vector_entry_point", ...)``
(:mod:`aquafish_gym.vector_env`: N robots in one PyBullet world, stepped by the compiled
step) with the clock appended to every sub-env's observation, the numbers
:class:`gait.clock.ClockObservation` appends (:func:`gait.clock.clock_features` of the
sub-env's ``info["time_s"]``, bit for bit). It replaces SB3's ``DummyVecEnv`` over N
``ClockObservation`` envs (``make_vec_env``) and gives what that stack gives for the same
seeds and actions: observations bit-equal, rewards, ``info["distance"]`` and the other
position terms to the vector env's round-off (sub-env 0 exact).

Conventions converted: Gymnasium's vector env resets on the step *after* an episode ends
(``AutoresetMode.NEXT_STEP``); SB3 resets in the same step. At the step that ends the
episodes (every sub-env's episode has the same length, so they end together) this adapter
puts the last observation (with its clock) in ``infos[i]["terminal_observation"]`` and
``truncated and not terminated`` in ``infos[i]["TimeLimit.truncated"]``, resets the vector
env at once (the sub-envs' generators continue, as ``DummyVecEnv``'s ``env.reset()``)
and returns the first observations of the new episodes, as ``DummyVecEnv`` does. Episode
statistics (``infos[i]["episode"]``) come from SB3's ``VecMonitor`` around the adapter
(:func:`make_clock_vec_env`), in place of one ``Monitor`` per env.
"""

from __future__ import annotations

import os
from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv, VecMonitor

import aquafish_gym  # registers the AquaFish tasks  # noqa: F401
from aquafish_gym.checks import check_int
from gait.clock import CLOCK_DIM, CLOCK_PERIOD_S, check_clock_period, clock_features
from gait.robots import Robot, as_robot
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, check_env_id

__all__ = ["ClockVecEnv", "MONITOR_FILE", "make_clock_vec_env"]

#: The episode log :func:`make_clock_vec_env` writes in its ``monitor_dir``.
MONITOR_FILE = "monitor.csv"


class ClockVecEnv(VecEnv):
    """SB3 ``VecEnv`` of N sub-envs of an AquaFish task in one vector env, clock appended.

    Args:
        robot: the robot of every sub-env (anything :func:`gait.robots.as_robot` takes).
        num_envs: N, number of sub-envs (>= 1).
        episode_duration_s: simulated seconds per episode.
        clock_period_s: period of the clock input (s).
        env_id: the task (``aquafish_gym.ENV_IDS``).
        max_world_robots: most robots of one PyBullet world (None: the vector env's default).

    Spaces: ``observation_space`` is ``Box((n + 2,), float64)``, as
    ``ClockObservation``'s (n = 12 for AquaFish-v0); ``action_space`` the task's
    ``Box(-1, 1, (3,), float32)``. Shapes: ``reset() -> obs (N, n + 2)``;
    ``step(actions (N, 3)) -> obs (N, n + 2) float64, rewards (N,) float32 (as
    DummyVecEnv), dones (N,) bool, infos`` (a list of N dicts: the single env's info
    entries of that sub-env, plus SB3's keys).

    Seeding: ``seed(s)`` (SB3 calls it with the model's seed) makes the next ``reset()``
    seed sub-env i with ``s + i``, as ``DummyVecEnv``; later resets continue each sub-env's
    generator.

    Raises:
        ValueError: a bad robot, ``num_envs``, period, env id or env argument; in ``step``:
            actions the vector env refuses (shape ``(N, 3)``, finite, in [-1, 1]).
    """

    def __init__(self, robot: Robot | Any = None, num_envs: int = 1, *,
                 episode_duration_s: float = EPISODE_DURATION_S, clock_period_s: float = CLOCK_PERIOD_S,
                 env_id: str = DEFAULT_ENV_ID, max_world_robots: int | None = None):
        check_int("num_envs", num_envs, 1)
        robot = as_robot(robot if robot is not None else "healthy")
        self.period_s = check_clock_period(clock_period_s)
        self.env_id = check_env_id(env_id)
        kwargs = {} if max_world_robots is None else {"max_world_robots": max_world_robots}
        self.vector_env = gym.make_vec(self.env_id, num_envs=int(num_envs), vectorization_mode="vector_entry_point",
                                       **robot.env_kwargs(), episode_duration_s=episode_duration_s, **kwargs)
        space = self.vector_env.single_observation_space
        if not isinstance(space, spaces.Box) or len(space.shape) != 1:
            raise ValueError(f"ClockVecEnv needs a 1-D Box observation space, got {space}")
        observation_space = spaces.Box(np.concatenate([space.low, -np.ones(CLOCK_DIM)]),
                                       np.concatenate([space.high, np.ones(CLOCK_DIM)]), dtype=np.float64)
        self._actions: np.ndarray | None = None
        super().__init__(int(num_envs), observation_space, self.vector_env.single_action_space)

    @property
    def sub_envs(self) -> list[gym.Env]:
        """The vector env's per-sub-env task objects (they draw each sub-env's episodes; they never step)."""
        return list(self.vector_env.unwrapped.envs)

    def _with_clock(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        """``(N, n)`` observations -> ``(N, n + 2)``: each row followed by its clock (``with_clock``'s numbers)."""
        clock = np.array([clock_features(t, self.period_s) for t in info["time_s"]])
        return np.concatenate([np.asarray(obs, dtype=np.float64), clock], axis=1)

    def _infos(self, info: dict[str, Any]) -> list[dict[str, Any]]:
        """Gymnasium's vector info (``(N, ...)`` arrays and ``"_key"`` masks) -> N dicts."""
        keys = [k for k in info if not k.startswith("_")]
        return [{k: info[k][i] for k in keys if info[f"_{k}"][i]} for i in range(self.num_envs)]

    def reset(self) -> np.ndarray:
        """Start an episode in every sub-env (seeds and options set by ``seed``/``set_options``, used once).

        Returns:
            ``(N, n + 2)`` float64 observations.

        Raises:
            ValueError: options that differ between sub-envs (the vector env applies one
                ``options`` dict to all), or that the task refuses.
        """
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        options = [dict(o) for o in self._options]
        if any(o != options[0] for o in options):
            raise ValueError("ClockVecEnv resets every sub-env with the same options; got different options per "
                             f"sub-env: {options}")
        obs, info = self.vector_env.reset(seed=seeds, options=options[0] or None)
        self.reset_infos = self._infos(info)
        self._reset_seeds()
        self._reset_options()
        return self._with_clock(obs, info)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        """Step every sub-env with the actions given to ``step_async``; reset them when their episodes end.

        Returns:
            ``obs (N, n + 2)``, ``rewards (N,)`` float32, ``dones (N,)`` bool, ``infos`` (N dicts;
            at an episode's end with ``"terminal_observation"`` ``(n + 2,)`` and ``"TimeLimit.truncated"``).

        Raises:
            ValueError: actions the vector env refuses.
            RuntimeError: without a pending ``step_async``, or if some sub-envs' episodes
                ended and others not (the vector env never does that).
        """
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        actions, self._actions = self._actions, None
        obs, rewards, terminated, truncated, info = self.vector_env.step(np.asarray(actions))
        obs = self._with_clock(obs, info)
        infos = self._infos(info)
        dones = np.logical_or(terminated, truncated)
        for i in range(self.num_envs):
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        if dones.any():
            if not dones.all():
                raise RuntimeError("the vector env ended some episodes and not others")
            for i in range(self.num_envs):
                infos[i]["terminal_observation"] = obs[i]
            # SB3 resets in the step that ends the episode; this is the vector env's next-step
            # autoreset done now (no seeds: each sub-env's generator continues)
            first, reset_info = self.vector_env.reset()
            obs = self._with_clock(first, reset_info)
            self.reset_infos = self._infos(reset_info)
        return obs, np.asarray(rewards, dtype=np.float32), dones, infos

    def close(self) -> None:
        self.vector_env.close()

    def _indices(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, (int, np.integer)):
            return [int(indices)]
        return [int(i) for i in indices]

    def get_attr(self, attr_name: str, indices: None | int | Sequence[int] = None) -> list[Any]:
        """Attribute ``attr_name`` of each sub-env's task object (:attr:`sub_envs`; ``render_mode`` is None).

        Raises:
            AttributeError: no such attribute.
        """
        if attr_name == "render_mode":
            return [None for _ in self._indices(indices)]
        return [getattr(self.sub_envs[i], attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: None | int | Sequence[int] = None) -> None:
        """Set ``attr_name`` on each sub-env's task object (:attr:`sub_envs`)."""
        for i in self._indices(indices):
            setattr(self.sub_envs[i], attr_name, value)

    def env_method(self, method_name: str, *method_args, indices: None | int | Sequence[int] = None,
                   **method_kwargs) -> list[Any]:
        """Call ``method_name`` of each sub-env's task object (:attr:`sub_envs`).

        These objects draw the episodes and compute nothing of the running world: a method
        that steps or resets them does not reach the vector env.
        """
        return [getattr(self.sub_envs[i], method_name)(*method_args, **method_kwargs) for i in self._indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices: None | int | Sequence[int] = None) -> list[bool]:
        """False for each sub-env: the sub-envs are not Gymnasium envs wrapped in ``wrapper_class``."""
        return [False for _ in self._indices(indices)]


def make_clock_vec_env(robot: Robot | Any = None, num_envs: int = 1, *, seed: int | None = None,
                       monitor_dir: str | None = None, **kwargs: Any) -> VecMonitor:
    """A :class:`ClockVecEnv` in SB3's ``VecMonitor``: what ``make_vec_env(make_rl_env, n_envs,
    seed=seed, monitor_dir=...)`` gives, on one vector env.

    Args:
        robot: as :class:`ClockVecEnv`.
        num_envs: as :class:`ClockVecEnv`.
        seed: the first reset seeds sub-env i with ``seed + i`` (None: fresh entropy).
        monitor_dir: directory of the episode log ``monitor.csv`` (return ``r``, length
            ``l``, wall time ``t`` in s; :func:`stable_baselines3.common.monitor.load_results`
            reads it), or None for none. ``VecMonitor`` sums returns in float32 (``Monitor``
            sums in float64 and rounds to 6 decimals).
        **kwargs: as :class:`ClockVecEnv`.

    Raises:
        ValueError: as :class:`ClockVecEnv`.
    """
    venv = ClockVecEnv(robot, num_envs, **kwargs)
    if seed is not None:
        venv.seed(seed)
    return VecMonitor(venv, filename=None if monitor_dir is None else os.path.join(str(monitor_dir), MONITOR_FILE))
