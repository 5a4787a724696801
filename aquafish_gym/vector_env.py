"""Batched vector envs: the N sub-envs of an AquaFish task are N robots in one PyBullet world.

``gym.make_vec(ID, num_envs=N, ...)`` (``vectorization_mode="vector_entry_point"``, the
default for these ids) builds one of the classes here instead of N single envs with Python
between them: the N robots are stepped together by the compiled step, and the observation,
reward and info of all N are computed at once by the single env's own methods over
``(N, ...)`` arrays (:class:`~aquafish_gym.env.BodyState`, :class:`~aquafish_gym.env.Episodes`).
The simulator layer (:class:`~aquafish_gym.BatchWorld`) knows nothing of Gymnasium.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from aquafish_gym.checks import check_int
from aquafish_gym.env import AquaFishEnv, BodyState, Episodes
from aquafish_gym.heading import HeadingEnv
from aquafish_gym.simulator import BatchWorld
from aquafish_gym.station_keeping import StationKeepingEnv

__all__ = ["AquaFishVectorEnv", "HeadingVectorEnv", "MAX_NUM_ENVS", "MAX_WORLD_ROBOTS", "StationKeepingVectorEnv"]

#: Default largest number of robots in one PyBullet world: PyBullet's cost per robot grows
#: with the world's size (docs/performance.md), so more sub-envs are split over several worlds.
#: 64, as the EEA's ``max_batch_robots``: 256 sub-envs stepped 1.6x faster as four worlds of
#: 64 than as one world of 256 (2026-11-25, shared machine).
MAX_WORLD_ROBOTS = 64
#: The most sub-envs one vector env takes: each is a robot with its own episode state (about
#: 4 kB before its world is built, far more in PyBullet), so a million would take minutes and
#: gigabytes before the first step; a gait's population, a PPO run's envs, an EEA batch are far fewer.
MAX_NUM_ENVS = 100_000

_DOC = """N sub-envs of ``{env_id}`` stepped together as N robots of one PyBullet world.

    ## Description
    The task of :class:`~{module}.{task}` (``help(gym.spec("{env_id}").entry_point)``), N
    times over: ``gym.make_vec("{env_id}", num_envs=N, **kwargs)`` (or
    ``vectorization_mode="vector_entry_point"``). Robots of a world never interact; worlds
    hold at most ``max_world_robots`` robots, more sub-envs are split over several worlds.

    ## Equivalence with the single env
    Sub-env i gives what ``gym.make("{env_id}", **kwargs)`` reset with sub-env i's seed and
    given the same actions gives (autoresets included), with the same random draws (damage
    preset, initial angles, task variables) from its own generator. Observations,
    ``terminated``/``truncated``, the task's angles and every term not made of positions are
    equal to the last bit. Robot i sits at its own home, 20 units from its neighbours (robots
    closer than that perturb each other through PyBullet's solver), and a position
    ``home + x`` rounds differently from ``x``: positions, ``distance``, and the reward
    terms made of them (``reward_forward``, ``reward_position``, ``distance_from_start``)
    differ from the single env's by round-off (at most 6e-13 units over 20 s episodes of 64
    sub-envs, measured; tested to 1e-9). Observations never see positions. Sub-env 0, at
    the origin like the single env's robot, is exact in everything.

    ## Action Space
    ``Box(-1, 1, (N, 3), float32)``: row i is sub-env i's action (``single_action_space``
    is the single env's ``Box(-1, 1, (3,), float32)``: left, right pectoral speed, caudal
    frequency, mapped onto [-0.5, 0.5] rev/s and [0, 1] Hz).

    ## Observation Space
    ``Box((N, {obs_dim}), float64)``: row i is sub-env i's observation
    (``single_observation_space``, {obs_text}).

    ## Rewards
    ``(N,)`` float64, the single env's reward per sub-env; each reward term is in ``info``.

    ## Starting State
    As the single env, per sub-env. ``reset(seed=s)`` seeds sub-env i with ``s + i``
    (as :class:`gymnasium.vector.SyncVectorEnv`), ``reset(seed=[s0, ..., sN-1])`` each
    with its own (None: fresh entropy); ``options`` (the single env's keys) apply to
    every sub-env, except ``initial_yaw_deg``, which may also be a list of N headings (sub-env
    i starts turned by entry i). Every sub-env is reset at once: a partial reset
    (``options["reset_mask"]`` not all True) is refused. With ``damage_onset_s`` every
    sub-env starts healthy and switches to its own damage at the onset of its episode's
    time, as the single env does (``info["damaged"]``); an autoreset starts healthy again.

    ## Episode End
    As the single env: never terminated; every sub-env is truncated at the same step,
    after ``episode_duration_s``. Autoreset: ``metadata["autoreset_mode"]`` is
    ``AutoresetMode.NEXT_STEP``: the step after the episode ends resets every sub-env
    (its generator continues, as ``SyncVectorEnv``'s ``env.reset()``), ignores the
    actions and returns the first observations with reward 0 and terminated/truncated False.

    ## Info
    A dict of ``(N, ...)`` arrays with a ``"_key"`` boolean mask beside every ``"key"``, as
    Gymnasium's vector envs give it (damage names: an object array).

    ## Arguments
    | Parameter          | Default | Description                                        |
    |--------------------|---------|----------------------------------------------------|
    | `num_envs`         | 1       | number of sub-envs N (1 to {max_envs})             |
    | `max_world_robots` | {max_robots}     | most robots in one PyBullet world (>= 1)           |
    | every argument of ``{env_id}`` | | the same for every sub-env, except ``render_mode``, which must be None (no rendering) |

    Shapes: ``reset() -> (obs (N, {obs_dim}), info)``; ``step(actions (N, 3)) -> (obs (N, {obs_dim}),
    rewards (N,), terminated (N,), truncated (N,), info)``.

    Raises:
        ValueError: ``num_envs`` not an integer in [1, {max_envs}] (refused before any sub-env is
            made), ``max_world_robots`` not an integer >= 1, a
            ``render_mode``, any argument the single env refuses; in ``reset``: seeds that
            are not None, an int or N of them, a partial ``reset_mask``, bad ``options``;
            in ``step``: actions not of shape ``(N, 3)``, not finite or outside [-1, 1]
            (naming the sub-env).
        RuntimeError: ``step`` before ``reset``, or after ``close`` (``reset`` starts new worlds).
    """


class AquaFishVectorEnv(VectorEnv):
    task_class: type[AquaFishEnv] = AquaFishEnv
    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(self, num_envs: int = 1, *, max_world_robots: int = MAX_WORLD_ROBOTS, **kwargs: Any):
        env_id = self.task_class.env_id
        check_int(f"num_envs (sub-envs of {env_id})", num_envs, 1, MAX_NUM_ENVS)
        check_int("max_world_robots (robots in one PyBullet world)", max_world_robots, 1)
        if kwargs.get("render_mode") is not None:
            raise ValueError(f"the vector env of {env_id} does not render: render_mode must be None, got "
                             f"{kwargs['render_mode']!r} (render a single env, or use vectorization_mode='sync')")
        self.num_envs = int(num_envs)
        self.max_world_robots = int(max_world_robots)
        # one single env per sub-env draws its episodes (seeding, damage, angles, task variables)
        # and never builds a world; the first computes what every sub-env observes and earns
        self.envs: list[AquaFishEnv] = [self.task_class(**kwargs) for _ in range(self.num_envs)]
        self.task = self.envs[0]
        self.single_observation_space = self.task.observation_space
        self.single_action_space = self.task.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = dict(type(self).metadata)
        self.render_mode = None
        starts = range(0, self.num_envs, self.max_world_robots)
        self._slices = [slice(s, min(s + self.max_world_robots, self.num_envs)) for s in starts]
        self._worlds: list[BatchWorld] = []
        self._episodes: Episodes | None = None
        self._autoreset = False
        self._closed = False

    @property
    def worlds(self) -> list[BatchWorld]:
        """The PyBullet worlds, each of at most ``max_world_robots`` robots (empty before ``reset``)."""
        return list(self._worlds)

    def _seeds(self, seed) -> list[int | None]:
        n = self.num_envs
        if seed is None:
            return [None] * n
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            return [int(seed) + i for i in range(n)]
        if isinstance(seed, (list, tuple)) and len(seed) == n and all(
                s is None or (isinstance(s, (int, np.integer)) and not isinstance(s, (bool, np.bool_))) for s in seed):
            return [None if s is None else int(s) for s in seed]
        raise ValueError(f"seed must be None, an int (sub-env i gets seed + i) or a list of {n} ints or None "
                         f"(one per sub-env), got {seed!r}")

    def _options(self, options) -> dict | None:
        if not isinstance(options, dict) or "reset_mask" not in options:
            return options  # the single env checks the rest
        options = dict(options)
        mask = np.asarray(options.pop("reset_mask"))
        if mask.shape != (self.num_envs,) or mask.dtype != np.bool_:
            raise ValueError(f"options['reset_mask'] must be a bool array of shape ({self.num_envs},), "
                             f"got {mask.dtype} {mask.shape}")
        if not mask.all():
            raise ValueError(f"{type(self).__name__} resets every sub-env at once (all episodes have the same "
                             "length, so they end together): options['reset_mask'] must be all True")
        return options or None

    def _sub_env_options(self, options) -> list:
        """``options`` for each sub-env: the same dict, or one per sub-env when
        ``options["initial_yaw_deg"]`` is a list (or array) of N headings."""
        yaw = options.get("initial_yaw_deg") if isinstance(options, dict) else None
        if not isinstance(yaw, (list, tuple, np.ndarray)):
            return [options] * self.num_envs
        if len(yaw) != self.num_envs:
            raise ValueError(f"options['initial_yaw_deg'] must be one heading (degrees) or a list of {self.num_envs} "
                             f"(one per sub-env), got {len(yaw)}")
        return [options | {"initial_yaw_deg": y} for y in yaw]

    def _start_episodes(self, seeds: list[int | None], options) -> tuple[np.ndarray, dict[str, Any]]:
        for env, seed, env_options in zip(self.envs, seeds, self._sub_env_options(options)):
            env._draw_episode(seed, env_options)
        worlds = []
        for k, part in enumerate(self._slices):
            envs = self.envs[part]
            # a fresh world every episode, on the same client, as the single env does
            client = self._worlds[k].client if k < len(self._worlds) else None
            robots = [env._start_robot() for env in envs]  # healthy while a damage waits for its onset
            world = BatchWorld(np.stack([m.to_array() for m, _ in robots]), self.task.params,
                               [f for _, f in robots], client=client,
                               water_current=np.stack([env._water_current() for env in envs]))
            world._owns_client = True
            world.reset(np.stack([env._initial_angles for env in envs]),
                        yaw_rad=np.array([env._initial_yaw_rad for env in envs]))
            worlds.append(world)
        self._worlds = worlds
        state = BodyState.of(self._worlds)
        self._episodes = Episodes.stack(self.envs, state.position)
        self._autoreset = False
        self._closed = self.closed = False  # reset after close(): these worlds are closed by the next close()
        obs, info = self.task._reset_results(state, self._episodes)
        return obs, self._vector_info(info)

    def _vector_info(self, info: dict[str, np.ndarray]) -> dict[str, Any]:
        """Gymnasium's vector info: every key with a ``"_key"`` mask (all True: every sub-env has it)."""
        out: dict[str, Any] = {}
        for key, value in info.items():
            out[key] = value
            out[f"_{key}"] = np.ones(self.num_envs, dtype=np.bool_)
        return out

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict[str, Any] | None = None):
        """Start an episode in every sub-env (see the class docstring's Starting State).

        Returns:
            ``observations (N, D)`` and the info dict.

        Raises:
            ValueError: bad ``seed``, a partial ``reset_mask``, or ``options`` the single
                env refuses.
        """
        seeds = self._seeds(seed)
        return self._start_episodes(seeds, self._options(options))

    def step(self, actions):
        """Step every sub-env by one control step (``frame_skip`` physics steps).

        Args:
            actions: ``(N, 3)`` in [-1, 1], row i for sub-env i.

        Returns:
            ``observations (N, D), rewards (N,), terminated (N,), truncated (N,), info``.

        Raises:
            ValueError: ``actions`` not of shape ``(N, 3)``, or an entry not finite or
                outside [-1, 1] (the message names the sub-env).
            RuntimeError: before ``reset``, or after ``close`` (until a ``reset``).
        """
        if self._closed:
            raise RuntimeError(f"step() of a closed {type(self).__name__}: its worlds are gone; call reset() to start "
                               "new ones, or make a new vector env")
        if self._episodes is None:
            raise RuntimeError("call reset() before step()")
        actions = self.task.check_actions(actions, self.num_envs)
        n = self.num_envs
        if self._autoreset:  # NEXT_STEP: the episodes ended at the last step; start new ones
            obs, info = self._start_episodes([None] * n, None)
            return obs, np.zeros(n), np.zeros(n, dtype=np.bool_), np.zeros(n, dtype=np.bool_), info
        commands = self.task.servo_command(actions)
        for world, part in zip(self._worlds, self._slices):
            world.set_actions(commands[part])
        before = BodyState.of(self._worlds).position
        for world in self._worlds:
            world.advance(self.task.frame_skip)
        state = BodyState.of(self._worlds)  # before an onset's switch, as the single env
        self.task._damage_onsets(self._worlds, self._slices, self.envs, self._episodes, self._episodes.steps + 1)
        obs, rewards, truncated, info = self.task._step_results(state, self._episodes, before, actions)
        self._autoreset = bool(truncated)
        return (obs, rewards, np.zeros(n, dtype=np.bool_), np.full(n, bool(truncated)), self._vector_info(info))

    def close_extras(self, **kwargs: Any) -> None:
        """Disconnect the worlds' PyBullet clients."""
        for world in self._worlds:
            world.close()
        self._worlds = []
        self._episodes = None
        self._closed = True


class StationKeepingVectorEnv(AquaFishVectorEnv):
    task_class = StationKeepingEnv


class HeadingVectorEnv(AquaFishVectorEnv):
    task_class = HeadingEnv


_OBS = {
    AquaFishVectorEnv: (12, "the IMU: sin and cos of roll, pitch, yaw; body-frame angular velocity in rad/s and "
                            "linear velocity in units/s"),
    StationKeepingVectorEnv: (12, "the IMU as ``AquaFish-v0``'s; the current is not observed"),
    HeadingVectorEnv: (14, "the IMU, then sin and cos of the heading error"),
}
for _cls, (_dim, _text) in _OBS.items():
    _task = _cls.task_class
    _cls.__doc__ = _DOC.format(env_id=_task.env_id, module=_task.__module__, task=_task.__name__, obs_dim=_dim,
                               obs_text=_text, max_robots=MAX_WORLD_ROBOTS, max_envs=MAX_NUM_ENVS)
