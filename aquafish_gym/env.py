"""The Gymnasium env ``AquaFish-v0``: the robot learning to swim forward.

A thin layer over :class:`~aquafish_gym.simulator.BatchWorld` (a world of one robot), in
the manner of Gymnasium's MuJoCo ``swimmer_v5``.
"""

from __future__ import annotations

import dataclasses
import inspect
import logging
import math
import os
import sys
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import EzPickle

from aquafish_gym.checks import check_int, check_seconds, check_weight, check_yaw_deg
from aquafish_gym.bullet import p
from aquafish_gym.damage import DAMAGES, NO_FAULTS, ServoFaults, get_damage
from aquafish_gym.imu import roll_pitch_yaw_deg
from aquafish_gym.morphology import Morphology
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.simulator import ACTION_BOUNDS, BatchWorld

#: What ``options["initial_yaw_deg"]``'s message says the heading is.
_YAW_NOTE = " (the robot's heading at reset, counter-clockwise from +y)"

logger = logging.getLogger(__name__)

FRAME_SKIP = 10  #: default physics steps per control step (0.1 s of control period)
OBS_VELOCITY_LIMIT = 100.0  #: bound of the velocity entries of the observation (rad/s, units/s)


def _damage_names(damage) -> tuple[str, ...]:
    """The damages an env draws from, as canonical text (:func:`get_damage`'s ``name``).

    ``damage`` is one damage (a preset name, a JSON fault inline or as a ``.json`` file, or
    ``sampled:SEED``), ``"random"`` (every preset) or a non-empty list of damages (the forms
    may be mixed); a file is read here, once.

    Raises:
        ValueError: anything else, or an invalid damage (:func:`get_damage`'s message).
    """
    if isinstance(damage, str):
        names = tuple(sorted(DAMAGES)) if damage == "random" else (damage,)
    elif isinstance(damage, (list, tuple)) and damage and all(isinstance(d, str) for d in damage):
        names = tuple(damage)
    else:
        raise ValueError(f"damage must be a damage (preset name, JSON fault or sampled:SEED), 'random' or a non-empty "
                         f"list of damages, got {damage!r}")
    return tuple(get_damage(name).name for name in names)  # raises on an invalid one, naming what is valid


def check_onset(damage_onset_s) -> float | None:
    """``damage_onset_s`` as a float (None stays None: damaged from the start).

    Raises:
        ValueError: not None and not a finite number of seconds >= 0 (a bool, NaN, an
            infinity or a negative number included).
    """
    if damage_onset_s is None:
        return None
    valid = isinstance(damage_onset_s, (int, float, np.integer, np.floating)) and not isinstance(damage_onset_s, bool)
    if valid:
        valid = math.isfinite(float(damage_onset_s)) and float(damage_onset_s) >= 0.0
    if not valid:
        raise ValueError(f"damage_onset_s must be None (damaged from the start) or a finite number of seconds of "
                         f"simulated time >= 0 (the damage's onset), got {damage_onset_s!r}")
    return float(damage_onset_s)


def check_task_value(name: str, value, low: float, high: float) -> tuple[float, float]:
    """A task setting given as a number or as a ``(lo, hi)`` range drawn per episode.

    Returns:
        ``(lo, hi)`` (``lo == hi`` for a fixed number).

    Raises:
        ValueError: not a finite number or pair with ``low <= lo <= hi <= high``.
    """
    pair = (value, value) if isinstance(value, (int, float)) and not isinstance(value, bool) else value
    try:
        lo, hi = (float(v) for v in pair)
        valid = math.isfinite(lo) and math.isfinite(hi) and low <= lo <= hi <= high
    except (TypeError, ValueError):
        valid = False
    if not valid:
        raise ValueError(f"{name} must be a number or a (lo, hi) range within [{low:g}, {high:g}], got {value!r}")
    return lo, hi


#: Cameras of ``render()``: ``"follow"`` (behind and above the robot, the default) and
#: ``"top"`` (straight down on the robot, its heading up the frame).
CAMERAS = ("follow", "top")


def display_available() -> bool:
    """Whether a window can be opened: on Linux and other X11/Wayland systems, ``DISPLAY`` or
    ``WAYLAND_DISPLAY`` is set; macOS and Windows always have one."""
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


_said_no_display = False


def _gui_possible() -> bool:
    """Whether ``render_mode="human"`` can open PyBullet's GUI; without a display, log (once per
    process) that the env runs headless instead."""
    global _said_no_display
    if display_available():
        return True
    if not _said_no_display:
        _said_no_display = True
        logger.warning('render_mode="human": no display (DISPLAY and WAYLAND_DISPLAY are unset), so PyBullet\'s GUI '
                       'is not opened and the env runs headless; use render_mode="rgb_array" for frames')
    return False


#: The initial heading of every robot (world frame): +y.
INITIAL_HEADING = np.array([0.0, 1.0, 0.0])
INITIAL_HEADING.setflags(write=False)


def world_to_body(rotation: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``R^T v`` for ``(N, 3, 3)`` rotations and ``(N, 3)`` vectors, element by element in a
    fixed order, so row i does not depend on N (the same doubles as ``rotation[i].T @ vector[i]``)."""
    return rotation[:, 0, :] * vector[:, 0:1] + rotation[:, 1, :] * vector[:, 1:2] + rotation[:, 2, :] * vector[:, 2:3]


@dataclasses.dataclass
class BodyState:
    """The bodies of N robots, what the tasks' observations, rewards and infos are computed from.

    Attributes:
        rotation: ``(N, 3, 3)`` body-to-world rotations.
        angular_velocity: ``(N, 3)`` world-frame angular velocities (rad/s).
        linear_velocity: ``(N, 3)`` world-frame velocities of the body's centre of mass (units/s).
        position: ``(N, 3)`` the body's centre of mass relative to the robot's home, where it
            starts every episode (units).
    """

    rotation: np.ndarray
    angular_velocity: np.ndarray
    linear_velocity: np.ndarray
    position: np.ndarray

    @classmethod
    def of(cls, worlds: list[BatchWorld]) -> "BodyState":
        """The bodies of the robots of ``worlds``, in order (robot j of world k after those of
        worlds 0..k-1)."""
        parts = [(w.rotation[:, 0], w.angular_velocity[:, 0], w.linear_velocity[:, 0], w.position[:, 0] - w.home)
                 for w in worlds]
        if len(parts) == 1:
            return cls(*parts[0])
        return cls(*(np.concatenate(arrays) for arrays in zip(*parts)))

    def rpy_rad(self) -> np.ndarray:
        """``(N, 3)`` roll, pitch, yaw (rad) as the IMU reports them (:mod:`aquafish_gym.imu`)."""
        return np.radians(roll_pitch_yaw_deg(self.rotation))


@dataclasses.dataclass
class Episodes:
    """What N episodes drew at reset and have accumulated since (one row per robot).

    Attributes:
        damage: ``(N,)`` object array of damage preset names.
        initial_angles: ``(N, 3)`` initial flipper angles (rad).
        task: the task's variables drawn per episode, ``(N, ...)`` arrays by name (e.g.
            ``"current"`` ``(N, 3)``, ``"target_heading_rad"`` ``(N,)``; none for ``AquaFish-v0``).
        start: ``(N, 3)`` the body's position at reset (units, relative to its home).
        distance: ``(N,)`` summed forward displacement along the initial heading (units).
        pending: ``(N,)`` True while the episode's damage waits for its onset (the robot is
            still the healthy one).
        damaged: ``(N,)`` True while the damage is in force and changes the robot
            (``info["damaged"]``; never for a damage that changes nothing, such as ``"none"``).
        steps: control steps taken in these episodes.
    """

    damage: np.ndarray
    initial_angles: np.ndarray
    task: dict[str, np.ndarray]
    start: np.ndarray
    distance: np.ndarray
    pending: np.ndarray
    damaged: np.ndarray
    steps: int = 0

    @classmethod
    def stack(cls, envs: list["AquaFishEnv"], start: np.ndarray) -> "Episodes":
        """The episodes ``envs`` have just drawn at reset (:meth:`AquaFishEnv._draw_episode`)."""
        variables = [env._task_variables() for env in envs]
        pending = np.array([env._damage_pending for env in envs], dtype=np.bool_)
        return cls(damage=np.array([env.damage_name for env in envs], dtype=object),
                   initial_angles=np.stack([env._initial_angles for env in envs]),
                   task={key: np.stack([v[key] for v in variables]) for key in variables[0]},
                   start=start.copy(), distance=np.zeros(len(envs)), pending=pending,
                   damaged=np.array([env.damage_changes_robot for env in envs], dtype=np.bool_) & ~pending)


def info_row(info: dict[str, np.ndarray], i: int) -> dict[str, Any]:
    """Row ``i`` of a batched info as the single env gives it: floats, strings, ``(k,)`` arrays."""
    row: dict[str, Any] = {}
    for key, value in info.items():
        item = value[i]
        if isinstance(item, np.ndarray):
            row[key] = item.copy()
        elif value.dtype == object:
            row[key] = item
        else:
            row[key] = bool(item) if value.dtype == np.bool_ else float(item)
    return row


def _as_morphology(morphology) -> Morphology:
    if morphology is None:
        return Morphology.healthy()
    if isinstance(morphology, Morphology):
        return morphology
    return Morphology.from_array(morphology)


class AquaFishEnv(gym.Env, EzPickle):
    """Swim forward with a capsule robot, two pectoral flippers and a caudal fin.

    ## Description
    The aquatic robot of Rose et al. (ERLARS 2013, section 3.1) in PyBullet with a
    per-face fluid-drag model and Lighthill's reactive thrust at the caudal fin's trailing
    edge (docs/physics.md; ``reactive_thrust=False`` for pure drag). Two pectoral flippers on
    continuous-rotation servos (no position feedback) and a caudal fin oscillating over
    a +-30 degree sweep. The goal is to swim as far as possible along the initial heading.
    Morphology (nine flipper dimensions) and damage are parameters, so the same env is
    the damaged *target* and every *candidate model* of the self-modeling algorithm.

    ## Action Space
    ``Box(-1, 1, (3,), float32)``, mapped linearly onto the servo ranges:

    | Num | Action                              | Min | Max | Servo range      | Unit  |
    |-----|-------------------------------------|-----|-----|------------------|-------|
    | 0   | left pectoral angular velocity      | -1  | 1   | [-0.5, 0.5]      | rev/s |
    | 1   | right pectoral angular velocity     | -1  | 1   | [-0.5, 0.5]      | rev/s |
    | 2   | caudal fin oscillation frequency    | -1  | 1   | [0, 1]           | Hz    |

    ## Observation Space
    ``Box(12,), float64``: the IMU.

    | Num | Observation                                   | Min  | Max | Unit    |
    |-----|-----------------------------------------------|------|-----|---------|
    | 0-2 | sin of roll, pitch, yaw                       | -1   | 1   | -       |
    | 3-5 | cos of roll, pitch, yaw                       | -1   | 1   | -       |
    | 6-8 | angular velocity (body frame x, y, z)         | -100 | 100 | rad/s   |
    | 9-11| linear velocity (body frame x, y, z)          | -100 | 100 | units/s |

    Roll is about the longitudinal (y) axis, pitch about the lateral (x) axis, yaw about
    z (see :mod:`aquafish_gym.imu`). 1 unit = 8 cm (the body diameter). Velocities are
    clipped to +-100 (never reached by the robot).

    ## Rewards
    ``reward = forward_reward - ctrl_cost``: ``forward_reward`` is the displacement
    (units) of the body's centre of mass along the initial heading during the step;
    ``ctrl_cost = ctrl_cost_weight * sum(action**2)``. Both terms are in ``info``. The
    episode's summed ``forward_reward`` is the gait fitness (forward distance).

    ## Starting State
    The body at the origin, level, heading +y, at rest. Initial flipper angles: uniform
    on [0, 2 pi) (pectorals) and [-30, 30] degrees (caudal) from ``reset(seed=...)``'s
    generator, unless given by ``initial_angles`` or ``options={"initial_angles": ...}``.
    ``options={"damage": name}`` sets the episode's damage preset (``"random"`` or a list
    draws one from ``reset``'s generator); without it the episode takes the constructor's
    ``damage``. ``options={"initial_yaw_deg": a}`` starts the robot turned by ``a`` degrees
    (in [-180, 180], counter-clockwise seen from above) from +y: the IMU's yaw starts at ``a``
    while the task's heading stays +y (the forward reward is still measured along +y, the
    heading tasks' targets are still angles from +y). The water is the same in every
    horizontal direction, so the robot's own motion (body-frame velocities, roll, pitch) is
    the unturned robot's; what changes is what a controller that reads the yaw does.
    ``reset``'s ``options`` is None or a dict with keys from :attr:`reset_options`
    (``"damage"``, ``"initial_angles"`` and ``"initial_yaw_deg"`` here; each task adds its
    own); any other ``options`` is refused with a ``ValueError``.

    ## Episode End
    Never terminated; truncated after ``episode_duration_s`` of simulated time.

    ## Damage onset
    With ``damage_onset_s=t`` the episode starts with the healthy robot (``morphology``
    without the damage, no servo faults) and the damage comes in force, in the same world
    and without a reset, at the first control step boundary at or after ``t`` s of
    simulated time (the first ``k * frame_skip * 0.01 >= t``, to 1e-9 of round-off): the
    step that returns ``info["time_s"] >= t`` swam healthy and switches the robot after it,
    so every action from then on acts on the damaged robot. Until then the trajectory is the
    healthy robot's to the last bit. Servo faults switch at that instant (a servo seized
    there holds its flipper where it is). A morphology change (a flipper resized or lost)
    replaces the robot's PyBullet body by one built damaged, put in the same state (base
    pose and velocity, flipper angles and speeds, the caudal sweep's phase): masses,
    inertias, centres of mass, drag areas, the caudal fin's reactive thrust and the shapes
    ``render()`` draws are the damaged robot's, and the motion from there is a robot's built
    damaged and started in that state, to the last bit
    (:meth:`~aquafish_gym.BatchWorld.change_robot`). ``t = 0`` is the same episode as None.
    Every damage form works (presets, JSON faults, ``sampled:SEED``, ``"random"``, lists);
    an onset with a damage that changes nothing (``"none"``) is allowed and does nothing.
    Each ``reset`` starts healthy again. ``info["damaged"]`` (bool, on ``reset`` and every
    step) is True while the damage is in force and changes the robot: from ``reset`` on
    without an onset, from the switch on with one, never for ``"none"``. ``morphology`` and
    ``faults`` (attributes) are the episode's damaged robot's throughout.

    ## Arguments
    | Parameter            | Default             | Description                                   |
    |----------------------|---------------------|-----------------------------------------------|
    | `morphology`         | healthy             | `Morphology`, or 9 numbers (simulator units)  |
    | `damage`             | `"none"`            | applied to the morphology: a preset name (`aquafish_gym.DAMAGES`), a JSON fault (inline or a `.json` file: `scale`, `seized`, `gains`) or `"sampled:SEED"` (`aquafish_gym.get_damage`); `"random"` (every preset) or a list draws one per episode (damage randomisation, reported as `info["damage"]`) |
    | `faults`             | from `damage`       | `ServoFaults` overriding the damage's faults  |
    | `damage_onset_s`     | None                | simulated time (s, a finite number >= 0) at which the damage comes in force mid-episode (see Damage onset); None: damaged from the start |
    | `initial_angles`     | random              | (3,) left, right pectoral, caudal (rad)       |
    | `frame_skip`         | 10                  | 0.01 s physics steps per control step         |
    | `episode_duration_s` | 20.0                | simulated seconds per episode                 |
    | `ctrl_cost_weight`   | 0.0                 | weight of the control cost                    |
    | `render_mode`        | None                | `"rgb_array"` (headless TinyRenderer) or `"human"` (PyBullet's GUI window where a display exists; headless, with a logged warning, where none does) |
    | `width`, `height`    | 320, 240            | frame size (pixels)                           |
    | `camera`             | `"follow"`          | `render()`'s camera: `"follow"` (behind, above) or `"top"` (from above, heading up) |
    | `camera_distance`    | 4.0                 | camera distance from the robot (units)        |
    | every `SimParams` field | see `SimParams`  | fluid, body and servo parameters              |

    ## Copying and pickling
    ``copy.deepcopy(env)`` and ``pickle`` work at any time, as for Gymnasium's MuJoCo envs
    (:class:`gymnasium.utils.EzPickle`): what is recorded is the constructor's arguments,
    and the copy is a fresh env built from them, not a snapshot of the episode. It holds no
    PyBullet world and no random generator yet: like any new env it must be ``reset``
    before ``step`` (``step`` raises ``RuntimeError`` otherwise), and its
    ``reset(seed=s)`` gives what the original's ``reset(seed=s)`` gives.

    Raises:
        ValueError: an unknown keyword, or a value out of range (named in the message);
            ``damage_onset_s`` not None and not a finite number >= 0 (NaN, an infinity, a
            negative number or a bool).
    """

    #: ``"human"`` opens PyBullet's GUI where a display exists (:func:`display_available`);
    #: without one the env runs headless and says so once per process (a logged warning, not a
    #: Python warning, so Gymnasium's strict ``check_env`` passes on headless machines too).
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    #: The id this class is registered under (:data:`aquafish_gym.ENV_IDS`), named in its errors.
    env_id = "AquaFish-v0"
    #: The keys ``reset``'s ``options`` accepts (each task adds its own).
    reset_options: tuple[str, ...] = ("damage", "initial_angles", "initial_yaw_deg")
    #: ``SimParams`` fields the task sets itself, so not arguments of its constructor.
    _task_sim_params: tuple[str, ...] = ()

    def __init__(
        self,
        morphology=None,
        damage: str = "none",
        faults: ServoFaults | None = None,
        damage_onset_s: float | None = None,
        initial_angles=None,
        frame_skip: int = FRAME_SKIP,
        episode_duration_s: float = 20.0,
        ctrl_cost_weight: float = 0.0,
        render_mode: str | None = None,
        width: int = 320,
        height: int = 240,
        camera: str = "follow",
        camera_distance: float = 4.0,
        **sim_params: Any,
    ):
        unknown = set(sim_params) - set(SimParams.field_names())
        if unknown:
            sim_names = [n for n in SimParams.field_names() if n not in self._task_sim_params]
            raise ValueError(f"unknown {self.env_id} argument(s) {sorted(unknown)}; its arguments are "
                             f"{self.argument_names()} and the simulator parameters {sim_names}")
        self.params = SimParams(**sim_params)
        self.damage_names = _damage_names(damage)
        self.base_morphology = _as_morphology(morphology)
        if faults is not None and not isinstance(faults, ServoFaults):
            raise ValueError(f"faults must be a ServoFaults, got {type(faults).__name__}")
        self.fixed_faults = faults
        self._set_damage(self.damage_names[0])
        self.damage_onset_s = check_onset(damage_onset_s)
        check_int(f"frame_skip (physics steps of {DT_S} s)", frame_skip, 1)
        check_seconds("episode_duration_s", episode_duration_s)
        if render_mode is not None and render_mode not in ("human", "rgb_array"):
            raise ValueError(f"render_mode must be None, 'human' or 'rgb_array', got {render_mode!r}")
        if camera not in CAMERAS:
            raise ValueError(f"camera must be one of {CAMERAS}, got {camera!r}")
        if not (isinstance(camera_distance, (int, float)) and math.isfinite(camera_distance) and camera_distance > 0):
            raise ValueError(f"camera_distance must be a positive number of units, got {camera_distance!r}")
        self.camera, self.camera_distance = camera, float(camera_distance)
        self.fixed_initial_angles = None if initial_angles is None else self._check_angles(initial_angles)
        self.frame_skip = int(frame_skip)
        self.episode_duration_s = float(episode_duration_s)
        self.max_control_steps = int(round(self.episode_duration_s / (DT_S * self.frame_skip)))
        #: the control steps swum healthy before the damage's onset (None: no onset)
        self.onset_step = (None if self.damage_onset_s is None
                           else max(0, math.ceil(self.damage_onset_s / (DT_S * self.frame_skip) - 1e-9)))
        self._damage_pending = False
        self.ctrl_cost_weight = check_weight("ctrl_cost_weight", ctrl_cost_weight)
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)

        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        task_high = self._task_observation_high()
        high = np.concatenate([np.ones(6), np.full(6, OBS_VELOCITY_LIMIT), task_high])
        self.observation_space = spaces.Box(-high, high, dtype=np.float64)
        self._world: BatchWorld | None = None
        self._episodes: Episodes | None = None
        # copy and pickle by the constructor's arguments (a task records its own after this)
        # the damage as resolved text (a fault file is read once: a copy does not read it again)
        recorded = damage if damage == "random" else (self.damage_names[0] if isinstance(damage, str)
                                                      else list(self.damage_names))
        EzPickle.__init__(self, morphology=morphology, damage=recorded, faults=faults, damage_onset_s=damage_onset_s,
                          initial_angles=initial_angles,
                          frame_skip=frame_skip, episode_duration_s=episode_duration_s,
                          ctrl_cost_weight=ctrl_cost_weight, render_mode=render_mode, width=width, height=height,
                          camera=camera, camera_distance=camera_distance, **sim_params)

    @classmethod
    def argument_names(cls) -> list[str]:
        """The named constructor arguments of this task (its own first, then ``AquaFish-v0``'s);
        every ``SimParams`` field is an argument too."""
        names: list[str] = []
        for klass in cls.__mro__:
            if issubclass(klass, AquaFishEnv) and "__init__" in vars(klass):
                names += [name for name, param in inspect.signature(klass.__init__).parameters.items()
                          if name != "self" and param.kind in (param.POSITIONAL_OR_KEYWORD, param.KEYWORD_ONLY)]
        return names

    # -- task hooks (overridden by the other tasks of the family) ---------------------
    # The observation, reward and info of N robots are computed over (N, ...) arrays: the
    # env (N = 1) and its vector env (aquafish_gym.vector_env) call the same methods.
    def _task_observation_high(self) -> np.ndarray:
        """Bounds (+-) of the task's entries appended to the 12 IMU entries (none here)."""
        return np.empty(0)

    def _task_observations(self, state: BodyState, episodes: Episodes) -> np.ndarray:
        """``(N, k)`` the task's entries of the observation (none here)."""
        return np.empty((state.rotation.shape[0], 0))

    def _reset_task(self, options: dict | None) -> None:
        """Draw the episode's task variables from ``self.np_random`` (none here)."""

    def _task_variables(self) -> dict[str, np.ndarray]:
        """The episode's task variables by name, as arrays (stacked into :attr:`Episodes.task`)."""
        return {}

    def _water_current(self) -> np.ndarray:
        """``(3,)`` the episode's water velocity (world frame, units/s)."""
        return np.asarray(self.params.water_current, dtype=np.float64)

    def _task_infos(self, state: BodyState, episodes: Episodes) -> dict[str, np.ndarray]:
        """The task's entries of ``info``, ``(N, ...)`` arrays (none here)."""
        return {}

    def _rewards(self, state: BodyState, episodes: Episodes, displacement: np.ndarray,
                 actions: np.ndarray) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """``(N,)`` rewards of a control step and their terms (``(N,)`` each, in ``info``).

        Args:
            state: the bodies after the step.
            episodes: the episodes' variables.
            displacement: ``(N, 3)`` the bodies' displacement during the step (units).
            actions: ``(N, 3)`` the env actions in [-1, 1].
        """
        forward = displacement @ INITIAL_HEADING
        ctrl = self.ctrl_cost_weight * np.sum(np.square(actions), axis=1)
        return forward - ctrl, {"reward_forward": forward, "reward_ctrl": -ctrl}

    def _draw_task_value(self, options: dict | None, key: str, default: tuple[float, float],
                         bounds: tuple[float, float], name: str | None = None) -> float:
        """Draw a task variable uniformly from ``options[key]`` (a number or a ``(lo, hi)``
        range, checked as :func:`check_task_value` does) or else from ``default``."""
        if options and key in options:
            default = check_task_value(name or key, options[key], *bounds)
        return float(self.np_random.uniform(*default))

    # -- N robots at once: the env's and the vector env's one implementation -----------
    def _observations(self, state: BodyState, episodes: Episodes) -> np.ndarray:
        """``(N, D)`` observations (see the class docstring's Observation Space)."""
        rpy = state.rpy_rad()
        ang = world_to_body(state.rotation, state.angular_velocity)
        lin = world_to_body(state.rotation, state.linear_velocity)
        vel = np.clip(np.concatenate([ang, lin], axis=1), -OBS_VELOCITY_LIMIT, OBS_VELOCITY_LIMIT)
        return np.concatenate([np.sin(rpy), np.cos(rpy), vel, self._task_observations(state, episodes)], axis=1)

    def _infos(self, state: BodyState, episodes: Episodes) -> dict[str, np.ndarray]:
        """``info`` of N robots, ``(N, ...)`` arrays by key (damage names: an object array)."""
        n, pos = state.position.shape[0], state.position
        return {
            "x_position": pos[:, 0].copy(),
            "y_position": pos[:, 1].copy(),
            "z_position": pos[:, 2].copy(),
            "distance": episodes.distance.copy(),
            "time_s": np.full(n, float(episodes.steps * self.frame_skip * DT_S)),
            "initial_angles": episodes.initial_angles.copy(),
            "damage": episodes.damage.copy(),
            "damaged": episodes.damaged.copy(),
        } | self._task_infos(state, episodes)

    def _reset_results(self, state: BodyState, episodes: Episodes) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Observations ``(N, D)`` and infos of episodes just started."""
        return self._observations(state, episodes), self._infos(state, episodes)

    def _step_results(self, state: BodyState, episodes: Episodes, before: np.ndarray, actions: np.ndarray):
        """Finish a control step of N robots (``episodes`` is advanced in place).

        Args:
            state: the bodies after the step.
            episodes: the episodes' variables (``distance`` and ``steps`` are updated).
            before: ``(N, 3)`` the bodies' positions before the step.
            actions: ``(N, 3)`` the env actions in [-1, 1].

        Returns:
            ``(observations (N, D), rewards (N,), truncated, info)``; ``truncated`` (a bool)
            holds for all N, as every episode has the same length.
        """
        displacement = state.position - before
        episodes.distance += displacement @ INITIAL_HEADING
        episodes.steps += 1
        rewards, terms = self._rewards(state, episodes, displacement, actions)
        truncated = episodes.steps >= self.max_control_steps
        return self._observations(state, episodes), rewards, truncated, self._infos(state, episodes) | terms

    # -- helpers ---------------------------------------------------------------------
    def _set_damage(self, name: str) -> None:
        self.damage_name = name
        self.damage = get_damage(name)
        self.morphology = self.damage.apply(self.base_morphology)
        self.faults = self.fixed_faults if self.fixed_faults is not None else self.damage.faults

    @property
    def damage_changes_robot(self) -> bool:
        """Whether the episode's damage makes a robot other than the healthy one (``morphology``
        differs from the constructor's, or a servo is faulty); False for ``"none"``."""
        return self.morphology != self.base_morphology or not self.faults.healthy

    def _start_robot(self) -> tuple[Morphology, ServoFaults]:
        """The robot an episode starts with: the damaged one, or the healthy one while the
        damage waits for its onset (:attr:`onset_step` > 0)."""
        if self._damage_pending:
            return self.base_morphology, NO_FAULTS
        return self.morphology, self.faults

    def _damage_onsets(self, worlds: list[BatchWorld], slices: list[slice], envs: list["AquaFishEnv"],
                       episodes: Episodes, steps: int) -> None:
        """Bring the pending damages in force once ``steps`` control steps have been swum (the
        onset): robot i of ``envs`` (robot ``i - part.start`` of the world of ``part``)
        becomes ``envs[i]``'s damaged robot in place (:meth:`BatchWorld.change_robot`).

        Call it after taking the step's :class:`BodyState`: a new body is put in the old one's
        state through PyBullet's API, whose orientation rounds by up to an ulp, so the step's
        observation is taken from the robot that swam it (``change_robot`` replaces the
        world's state arrays, it does not write into them).
        """
        if self.onset_step is None or steps < self.onset_step or not episodes.pending.any():
            return
        for world, part in zip(worlds, slices):
            for i in range(part.start, part.stop):
                if not episodes.pending[i]:
                    continue
                env = envs[i]
                if env.damage_changes_robot:
                    world.change_robot(i - part.start, env.morphology.to_array(), env.faults)
                episodes.damaged[i] = env.damage_changes_robot
                episodes.pending[i] = False

    @property
    def damage_pending(self) -> bool:
        """Whether this episode's damage is scheduled (``damage_onset_s``) and not yet in force."""
        return self._episodes is not None and bool(self._episodes.pending[0])

    def apply_damage_onset(self) -> bool:
        """Bring a scheduled damage in force now, whatever the episode's step count.

        :meth:`step` applies the damage at its onset by the env's own count of control steps.
        A caller that also moves :attr:`world` outside :meth:`step` (a mission running target
        experiments on the world between gait steps) keeps its own clock and calls this when
        that clock reaches ``damage_onset_s``. The robot changes in place, in its current
        state (:meth:`BatchWorld.change_robot`), exactly as at an onset inside :meth:`step`.

        Returns:
            Whether the damage changes the robot and is now in force (``info["damaged"]``).

        Raises:
            RuntimeError: called before :meth:`reset`.
        """
        if self._episodes is None:
            raise RuntimeError(f"{self.env_id}: apply_damage_onset() needs an episode; call reset() first")
        if self._episodes.pending[0]:
            self._damage_onsets([self.world], [slice(0, 1)], [self], self._episodes, self.onset_step)
        return bool(self._episodes.damaged[0])

    def _check_angles(self, angles) -> np.ndarray:
        arr = np.asarray(angles, dtype=np.float64)
        amp = self.params.caudal_amplitude_rad
        if arr.shape != (3,) or not np.all(np.isfinite(arr)) or abs(arr[2]) > amp + 1e-12:
            raise ValueError(f"initial_angles must be 3 finite angles (rad) with |caudal| <= {amp:.4f}, got {angles!r}")
        return arr

    @staticmethod
    def servo_command(action) -> np.ndarray:
        """Map env actions in [-1, 1]^3 (``(3,)`` or ``(N, 3)``) to servo units: rev/s, rev/s, Hz."""
        a = np.asarray(action, dtype=np.float64)
        lo, hi = ACTION_BOUNDS[:, 0], ACTION_BOUNDS[:, 1]
        return lo + (a + 1.0) * 0.5 * (hi - lo)

    @staticmethod
    def check_actions(actions, n: int | None = None) -> np.ndarray:
        """Check env actions, ``(3,)`` (``n`` None) or ``(n, 3)``, and return them as float64.

        Entries beyond +-1 by float32 round-off (1e-6) are clipped; nothing else is.

        Raises:
            ValueError: wrong shape, complex entries (NumPy would drop their imaginary parts), or
                an entry not finite or outside [-1, 1] (named).
        """
        if np.iscomplexobj(actions):
            raise ValueError(f"action entries must be real numbers in [-1, 1], got complex numbers "
                             f"({np.asarray(actions).dtype}, shape {np.shape(actions)})")
        arr = np.asarray(actions, dtype=np.float64)
        shape = (3,) if n is None else (n, 3)
        if arr.shape != shape:
            what = "(left pectoral, right pectoral, caudal) in [-1, 1]"
            raise ValueError(f"action must have shape {shape}: {'one' if n is None else 'a row per sub-env:'} {what}, "
                             f"got shape {np.shape(actions)}")
        bad = ~np.isfinite(arr) | (np.abs(arr) > 1.0 + 1e-6)
        if bad.any():
            if n is None:
                raise ValueError(f"action entries must be finite and in [-1, 1], got {arr.tolist()}")
            i = int(np.argwhere(bad)[0][0])
            raise ValueError(f"action entries must be finite and in [-1, 1]; sub-env {i}'s action is {arr[i].tolist()}")
        return np.clip(arr, -1.0, 1.0)  # only float32 round-off beyond +-1 reaches here

    @property
    def world(self) -> BatchWorld:
        if self._world is None:
            raise RuntimeError("call reset() before step()")
        return self._world

    def _position(self) -> np.ndarray:
        return self.world.position[0, 0].copy()

    # -- gymnasium API ---------------------------------------------------------------
    def _check_options(self, options) -> dict[str, Any]:
        """``reset``'s ``options`` as a dict (``{}`` for None), refusing anything else."""
        allowed = list(self.reset_options)
        if options is None:
            return {}
        if not isinstance(options, dict):
            raise ValueError(f"options of {self.env_id}'s reset must be None or a dict with keys from {allowed}, "
                             f"got {options!r}")
        unknown = sorted((key for key in options if key not in allowed), key=str)
        if unknown:
            raise ValueError(f"unknown key(s) {unknown} in the options of {self.env_id}'s reset; "
                             f"allowed keys are {allowed}")
        return options

    def _draw_episode(self, seed: int | None, options) -> None:
        """Seed (if ``seed`` is given) and draw an episode: damage, initial angles, task variables.

        Sets ``damage_name``, ``morphology``, ``faults``, ``_initial_angles`` and the task's
        variables; builds no world (the vector env draws each sub-env's episode with this).
        """
        options = self._check_options(options)
        gym.Env.reset(self, seed=seed)
        names = _damage_names(options["damage"]) if "damage" in options else self.damage_names
        self._set_damage(names[int(self.np_random.integers(len(names)))] if len(names) > 1 else names[0])
        if "initial_angles" in options:
            angles = self._check_angles(options["initial_angles"])
        elif self.fixed_initial_angles is not None:
            angles = self.fixed_initial_angles
        else:
            amp = self.params.caudal_amplitude_rad
            angles = np.array([self.np_random.uniform(0, 2 * np.pi), self.np_random.uniform(0, 2 * np.pi), self.np_random.uniform(-amp, amp)])
        self._initial_angles = np.asarray(angles, dtype=np.float64)
        self._initial_yaw_rad = math.radians(check_yaw_deg("options['initial_yaw_deg']", options["initial_yaw_deg"], _YAW_NOTE)) \
            if "initial_yaw_deg" in options else 0.0
        self._damage_pending = self.onset_step is not None and self.onset_step > 0
        self._reset_task(options)

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode (see the class docstring's Starting State).

        Raises:
            ValueError: ``options`` is not None or a dict, has a key not in
                :attr:`reset_options`, or a value out of range (named in the message).
        """
        self._draw_episode(seed, options)
        # a fresh world every episode makes every episode bit-for-bit reproducible
        if self._world is None:
            client = p.connect(p.GUI) if self.render_mode == "human" and _gui_possible() else None
        else:
            client = self._world.client
        morphology, faults = self._start_robot()
        self._world = BatchWorld(morphology.to_array()[None], self.params, faults,
                                 visual=self.render_mode is not None, client=client,
                                 water_current=self._water_current()[None])
        self._world._owns_client = True
        self._world.reset(self._initial_angles[None], yaw_rad=np.array([self._initial_yaw_rad]))
        state = BodyState.of([self._world])
        self._episodes = Episodes.stack([self], state.position)
        obs, info = self._reset_results(state, self._episodes)
        return obs[0], info_row(info, 0)

    def step(self, action):
        action = self.check_actions(action)
        w = self.world
        w.set_actions(self.servo_command(action)[None])
        before = w.position[:, 0] - w.home
        w.advance(self.frame_skip)
        state = BodyState.of([w])  # before an onset's switch: the step's end as the healthy robot swam it
        self._damage_onsets([w], [slice(0, 1)], [self], self._episodes, self._episodes.steps + 1)
        obs, reward, truncated, info = self._step_results(state, self._episodes, before, action[None])
        return obs[0], float(reward[0]), False, bool(truncated), info_row(info, 0)

    def camera_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The ``(4, 4)`` view and projection matrices of the next ``render()`` (OpenGL
        convention, for column vectors): a world point ``x`` lands at normalised device
        coordinates ``(proj @ view @ [x, 1])[:3] / w``. :meth:`world_to_pixels` applies them."""
        c = self.world.client
        target = self._position()
        if self.camera == "top":  # straight down, the initial heading (+y) up the frame
            view = p.computeViewMatrix(target + [0.0, 0.0, self.camera_distance], target, [0.0, 1.0, 0.0],
                                       physicsClientId=c)
        else:
            view = p.computeViewMatrixFromYawPitchRoll(target.tolist(), self.camera_distance, 210.0, -30.0, 0.0, 2,
                                                       physicsClientId=c)
        proj = p.computeProjectionMatrixFOV(60.0, self.width / self.height, 0.05, 50.0, physicsClientId=c)
        return (np.asarray(view, dtype=np.float64).reshape(4, 4).T, np.asarray(proj, dtype=np.float64).reshape(4, 4).T)

    def world_to_pixels(self, points) -> np.ndarray:
        """Where world points land in the next ``render()`` frame, to draw on it (a trajectory,
        a target).

        Args:
            points: ``(n, 3)`` world positions (simulator units).

        Returns:
            ``(n, 2)`` float64 pixel coordinates (column, row; row 0 at the top) in a frame of
            ``width`` x ``height`` pixels; a point outside the camera's view lands outside
            ``[0, width] x [0, height]``.

        Raises:
            ValueError: ``points`` is not an ``(n, 3)`` array of finite numbers.
        """
        xyz = np.asarray(points, dtype=np.float64)
        if xyz.ndim != 2 or xyz.shape[1] != 3 or not np.all(np.isfinite(xyz)):
            raise ValueError(f"points must be an (n, 3) array of finite world positions, got shape {xyz.shape}")
        view, proj = self.camera_matrices()
        h = np.c_[xyz, np.ones(len(xyz))] @ (proj @ view).T
        ndc = h[:, :3] / h[:, 3:4]
        return np.c_[(ndc[:, 0] + 1) * 0.5 * self.width, (1 - ndc[:, 1]) * 0.5 * self.height]

    def render(self):
        """``rgb_array``: the camera's ``(height, width, 3)`` uint8 frame (TinyRenderer, no
        display needed); ``human``: None (the GUI window shows the world as it steps)."""
        if self.render_mode != "rgb_array":
            return None
        c = self.world.client
        view, proj = self.camera_matrices()
        _, _, rgba, _, _ = p.getCameraImage(self.width, self.height, view.T.ravel().tolist(), proj.T.ravel().tolist(),
                                            renderer=p.ER_TINY_RENDERER, physicsClientId=c)
        return np.asarray(rgba, dtype=np.uint8).reshape(self.height, self.width, 4)[:, :, :3].copy()

    def close(self):
        if self._world is not None:
            self._world.close()
            self._world = None
