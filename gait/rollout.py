"""Run a controller for one episode of an AquaFish task: forward distance, return and trajectory.

This is the gait fitness of paper section 5 ("swimming as far forward as possible in
20 seconds of simulation time"): the env's summed ``reward_forward``, i.e. the body's
displacement along its initial heading (units; 1 unit = 8 cm). Because it goes through
``gym.make("AquaFish-v0")``, the NEAT fitness, the RL return (with ``ctrl_cost_weight = 0``)
and the transfer score are the same number.

Determinism: the env rebuilds its PyBullet world on every reset, so an episode depends only
on the controller, the robot, and the initial flipper angles, which are either given or
drawn by ``reset(seed=seed)``. The same ``seed`` gives the same angles on every robot.

:func:`batch_rollouts` runs several episodes of one controller on one robot at once, as the
sub-envs of one batched vector env (``gym.make_vec``, :mod:`aquafish_gym.vector_env`): the
same observations and actions as :func:`rollout` to the last bit, positions (trajectory,
distance) to the vector env's round-off (at most 6e-13 units over 20 s; the first episode,
at the world's origin, exact).
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any, Sequence

import gymnasium as gym
import numpy as np

from aquafish_gym.checks import check_int
from gait.controller import Controller
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, check_env_id, make_env
from gait.robots import Robot, as_robot


@dataclasses.dataclass(frozen=True)
class Rollout:
    """One episode of a controller on a robot.

    Attributes:
        distance: forward distance along the initial heading (units), the gait fitness.
        episode_return: the env's summed reward (equals ``distance`` when the env's
            ``ctrl_cost_weight`` is 0, the default).
        trajectory: ``(T + 1, 2)`` body x, y (units) at the start and after each control
            step (every 0.1 s by default), ``T = episode_duration_s / control step``.
        times_s: ``(T + 1,)`` simulated time of each trajectory row (s).
        initial_angles: ``(3,)`` initial left pectoral, right pectoral, caudal angles (rad).
        robot: the robot that swam.
    """

    distance: float
    episode_return: float
    trajectory: np.ndarray
    times_s: np.ndarray
    initial_angles: np.ndarray
    robot: Robot


def rollout(controller: Controller, robot=None, *, damage: str = "none", seed: int = 0, initial_angles=None,
            episode_duration_s: float = EPISODE_DURATION_S, env_id: str = DEFAULT_ENV_ID,
            initial_yaw_deg: float | None = None, **env_kwargs: Any) -> Rollout:
    """Run ``controller`` for one episode and record its distance and trajectory.

    Args:
        controller: any :class:`~gait.controller.Controller`.
        robot: a :class:`~gait.robots.Robot`, ``Morphology``, 9 numbers or a robot string
            (default: the healthy robot).
        damage: damage applied to a robot given as a morphology.
        seed: ``reset(seed=)``; draws the initial flipper angles unless ``initial_angles``.
        initial_angles: ``(3,)`` left, right pectoral, caudal angles (rad), or None.
        episode_duration_s: simulated seconds (20 s is the paper's gait fitness).
        env_id: the task (``aquafish_gym.ENV_IDS``; default the paper's ``"AquaFish-v0"``).
        initial_yaw_deg: start turned by this many degrees counter-clockwise from +y (the env's
            reset option; None: headed +y). The env's distance stays measured along +y.
        **env_kwargs: further env arguments (e.g. ``frame_skip``, fluid parameters).

    Returns:
        The :class:`Rollout`.

    Raises:
        ValueError: invalid robot or env arguments, or a controller action outside [-1, 1]^3.
    """
    check_int("seed", seed)
    robot = as_robot(robot if robot is not None else "healthy", damage=damage)
    env = make_env(robot, initial_angles=initial_angles, episode_duration_s=episode_duration_s, env_id=env_id, **env_kwargs)
    try:
        controller.reset()
        options = None if initial_yaw_deg is None else {"initial_yaw_deg": initial_yaw_deg}
        obs, info = env.reset(seed=int(seed), options=options)
        xy = [(info["x_position"], info["y_position"])]
        times = [info["time_s"]]
        angles = np.asarray(info["initial_angles"], dtype=np.float64).copy()
        total = 0.0
        done = False
        while not done:
            obs, reward, terminated, truncated, info = env.step(controller.act(obs, info["time_s"]))
            total += reward
            xy.append((info["x_position"], info["y_position"]))
            times.append(info["time_s"])
            done = terminated or truncated
    finally:
        env.close()
    return Rollout(distance=float(info["distance"]), episode_return=float(total), trajectory=np.asarray(xy),
                   times_s=np.asarray(times), initial_angles=angles, robot=robot)


def batch_rollouts(controller: Controller, robot=None, seeds: Sequence[int] = (0,), *, damage: str = "none",
                   initial_angles=None, episode_duration_s: float = EPISODE_DURATION_S,
                   env_id: str = DEFAULT_ENV_ID, **env_kwargs: Any) -> list[Rollout]:
    """One episode of ``controller`` on ``robot`` per seed, all at once on one vector env.

    Episode k is sub-env k of ``gym.make_vec(env_id, num_envs=len(seeds))``, reset with
    ``seeds[k]`` and driven by its own copy of ``controller`` (``copy.deepcopy``, then
    ``reset()``: a recurrent network's state stays its episode's), so it is :func:`rollout`
    with ``seed=seeds[k]``: the same actions and observations to the last bit, positions
    (trajectory, distance, and a return made of them) to the vector env's round-off
    (:mod:`aquafish_gym.vector_env`; episode 0 exact).

    Args:
        controller: any :class:`~gait.controller.Controller` (not modified).
        robot: as :func:`rollout`'s (default: the healthy robot).
        seeds: K >= 1 episode seeds (``reset(seed=)``), each drawing its initial angles unless
            ``initial_angles``.
        damage: as :func:`rollout`'s.
        initial_angles: as :func:`rollout`'s (the same for every episode; then the seeds draw
            nothing).
        episode_duration_s: simulated seconds of every episode.
        env_id: the task, as :func:`rollout`'s.
        **env_kwargs: further env arguments, the same for every episode.

    Returns:
        K :class:`Rollout`, in the order of ``seeds``.

    Raises:
        ValueError: no seeds or a seed that is not an integer, invalid robot or env arguments,
            or a controller action outside [-1, 1]^3.
    """
    seeds = [check_int("seed", s) for s in seeds]
    if not seeds:
        raise ValueError("batch_rollouts needs at least one seed")
    robot = as_robot(robot if robot is not None else "healthy", damage=damage)
    envs = gym.make_vec(check_env_id(env_id), num_envs=len(seeds), vectorization_mode="vector_entry_point",
                        **robot.env_kwargs(), initial_angles=initial_angles, episode_duration_s=episode_duration_s,
                        **env_kwargs)
    try:
        controllers = [copy.deepcopy(controller) for _ in seeds]
        for c in controllers:
            c.reset()
        obs, info = envs.reset(seed=seeds)
        xy = [np.column_stack([info["x_position"], info["y_position"]])]
        times = [np.asarray(info["time_s"], dtype=np.float64)]
        angles = np.asarray(info["initial_angles"], dtype=np.float64).copy()
        total = np.zeros(len(seeds))
        truncated = np.zeros(len(seeds), dtype=np.bool_)
        while not truncated.any():
            actions = np.array([c.act(o, t) for c, o, t in zip(controllers, obs, info["time_s"])], dtype=np.float64)
            obs, rewards, terminated, truncated, info = envs.step(actions)
            if terminated.any() or (truncated.any() and not truncated.all()):
                raise RuntimeError("the vector env ended some episodes and not others")  # it never does
            total += rewards
            xy.append(np.column_stack([info["x_position"], info["y_position"]]))
            times.append(np.asarray(info["time_s"], dtype=np.float64))
    finally:
        envs.close()
    trajectories, times_s = np.stack(xy, axis=1), np.stack(times, axis=1)
    return [Rollout(distance=float(info["distance"][k]), episode_return=float(total[k]), trajectory=trajectories[k],
                    times_s=times_s[k], initial_angles=angles[k], robot=robot) for k in range(len(seeds))]
