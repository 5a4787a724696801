"""The Gymnasium env ``AquaFish-v0``: the robot learning to swim forward.

A thin layer over :class:`~aquafish_gym.simulator.BatchWorld` (a world of one robot), in
the manner of Gymnasium's MuJoCo ``swimmer_v5``.
"""

from __future__ import annotations

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

from aquafish_gym.checks import check_int, check_weight
from aquafish_gym.bullet import p
from aquafish_gym.damage import DAMAGES, ServoFaults, get_damage
from aquafish_gym.morphology import Morphology
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.simulator import ACTION_BOUNDS, BatchWorld

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
    ``damage``. ``reset``'s ``options`` is None or a dict with keys from
    :attr:`reset_options` (``"damage"`` and ``"initial_angles"`` here; each task adds its
    own); any other ``options`` is refused with a ``ValueError``.

    ## Episode End
    Never terminated; truncated after ``episode_duration_s`` of simulated time.

    ## Arguments
    | Parameter            | Default             | Description                                   |
    |----------------------|---------------------|-----------------------------------------------|
    | `morphology`         | healthy             | `Morphology`, or 9 numbers (simulator units)  |
    | `damage`             | `"none"`            | name in `aquafish_gym.DAMAGES` applied to the morphology; `"random"` or a list of names draws one per episode (damage randomisation, reported as `info["damage"]`) |
    | `faults`             | from `damage`       | `ServoFaults` overriding the damage's faults  |
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
        ValueError: an unknown keyword, or a value out of range (named in the message).
    """

    #: ``"human"`` opens PyBullet's GUI where a display exists (:func:`display_available`);
    #: without one the env runs headless and says so once per process (a logged warning, not a
    #: Python warning, so Gymnasium's strict ``check_env`` passes on headless machines too).
    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}

    #: The id this class is registered under (:data:`aquafish_gym.ENV_IDS`), named in its errors.
    env_id = "AquaFish-v0"
    #: The keys ``reset``'s ``options`` accepts (each task adds its own).
    reset_options: tuple[str, ...] = ("damage", "initial_angles")
    #: ``SimParams`` fields the task sets itself, so not arguments of its constructor.
    _task_sim_params: tuple[str, ...] = ()

    def __init__(
        self,
        morphology=None,
        damage: str = "none",
        faults: ServoFaults | None = None,
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
        check_int(f"frame_skip (physics steps of {DT_S} s)", frame_skip, 1)
        if not (isinstance(episode_duration_s, (int, float)) and math.isfinite(episode_duration_s) and episode_duration_s > 0):
            raise ValueError(f"episode_duration_s must be a positive number of seconds, got {episode_duration_s!r}")
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
        self.ctrl_cost_weight = check_weight("ctrl_cost_weight", ctrl_cost_weight)
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)

        self.action_space = spaces.Box(-1.0, 1.0, shape=(3,), dtype=np.float32)
        task_high = self._task_observation_high()
        high = np.concatenate([np.ones(6), np.full(6, OBS_VELOCITY_LIMIT), task_high])
        self.observation_space = spaces.Box(-high, high, dtype=np.float64)
        self._world: BatchWorld | None = None
        self._steps = 0
        self._distance = 0.0
        self._heading = np.array([0.0, 1.0, 0.0])
        # copy and pickle by the constructor's arguments (a task records its own after this)
        EzPickle.__init__(self, morphology=morphology, damage=damage, faults=faults, initial_angles=initial_angles,
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
    def _task_observation_high(self) -> np.ndarray:
        """Bounds (+-) of the task's entries appended to the 12 IMU entries (none here)."""
        return np.empty(0)

    def _task_observation(self) -> np.ndarray:
        """The task's entries of the observation (none here)."""
        return np.empty(0)

    def _reset_task(self, options: dict | None) -> SimParams:
        """Draw the episode's task variables from ``self.np_random``; return its simulator parameters."""
        return self.params

    def _task_info(self) -> dict[str, Any]:
        """The task's entries of ``info`` (none here)."""
        return {}

    def _draw_task_value(self, options: dict | None, key: str, default: tuple[float, float],
                         bounds: tuple[float, float], name: str | None = None) -> float:
        """Draw a task variable uniformly from ``options[key]`` (a number or a ``(lo, hi)``
        range, checked as :func:`check_task_value` does) or else from ``default``."""
        if options and key in options:
            default = check_task_value(name or key, options[key], *bounds)
        return float(self.np_random.uniform(*default))

    # -- helpers ---------------------------------------------------------------------
    def _set_damage(self, name: str) -> None:
        self.damage_name = name
        self.damage = get_damage(name)
        self.morphology = self.damage.apply(self.base_morphology)
        self.faults = self.fixed_faults if self.fixed_faults is not None else self.damage.faults

    def _check_angles(self, angles) -> np.ndarray:
        arr = np.asarray(angles, dtype=np.float64)
        amp = self.params.caudal_amplitude_rad
        if arr.shape != (3,) or not np.all(np.isfinite(arr)) or abs(arr[2]) > amp + 1e-12:
            raise ValueError(f"initial_angles must be 3 finite angles (rad) with |caudal| <= {amp:.4f}, got {angles!r}")
        return arr

    @staticmethod
    def servo_command(action) -> np.ndarray:
        """Map an env action in [-1, 1]^3 to servo units ``(3,)``: rev/s, rev/s, Hz."""
        a = np.asarray(action, dtype=np.float64)
        lo, hi = ACTION_BOUNDS[:, 0], ACTION_BOUNDS[:, 1]
        return lo + (a + 1.0) * 0.5 * (hi - lo)

    @property
    def world(self) -> BatchWorld:
        if self._world is None:
            raise RuntimeError("call reset() before step()")
        return self._world

    def _get_obs(self) -> np.ndarray:
        w = self.world
        rpy = np.radians(w.imu_rpy_deg()[0])
        rot = w.rotation[0, 0]
        ang = rot.T @ w.angular_velocity[0, 0]
        lin = rot.T @ w.linear_velocity[0, 0]
        vel = np.clip(np.concatenate([ang, lin]), -OBS_VELOCITY_LIMIT, OBS_VELOCITY_LIMIT)
        return np.concatenate([np.sin(rpy), np.cos(rpy), vel, self._task_observation()])

    def _position(self) -> np.ndarray:
        return self.world.position[0, 0].copy()

    def _get_info(self) -> dict[str, Any]:
        pos = self._position()
        return {
            "x_position": float(pos[0]),
            "y_position": float(pos[1]),
            "z_position": float(pos[2]),
            "distance": float(self._distance),
            "time_s": float(self._steps * self.frame_skip * DT_S),
            "initial_angles": self._initial_angles.copy(),
            "damage": self.damage_name,
        } | self._task_info()

    def _get_rew(self, displacement: np.ndarray, action: np.ndarray) -> tuple[float, dict[str, float]]:
        forward = float(displacement @ self._heading)
        ctrl = self.ctrl_cost_weight * float(np.sum(np.square(action)))
        return forward - ctrl, {"reward_forward": forward, "reward_ctrl": -ctrl}

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

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        """Start an episode (see the class docstring's Starting State).

        Raises:
            ValueError: ``options`` is not None or a dict, has a key not in
                :attr:`reset_options`, or a value out of range (named in the message).
        """
        options = self._check_options(options)
        super().reset(seed=seed)
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
        params = self._reset_task(options)
        if self._world is None:
            client = p.connect(p.GUI) if self.render_mode == "human" and _gui_possible() else None
            self._world = BatchWorld(self.morphology.to_array()[None], params, self.faults,
                                     visual=self.render_mode is not None, client=client)
            self._world._owns_client = True
        else:  # rebuild: a fresh world makes every episode bit-for-bit reproducible
            self._world = BatchWorld(self.morphology.to_array()[None], params, self.faults,
                                     visual=self.render_mode is not None, client=self._world.client)
            self._world._owns_client = True
        self._world.reset(self._initial_angles[None])
        self._steps = 0
        self._distance = 0.0
        return self._get_obs(), self._get_info()

    def step(self, action):
        action = np.asarray(action, dtype=np.float64)
        if action.shape != (3,):
            raise ValueError(f"action must have shape (3,), got {action.shape}")
        if not np.all(np.isfinite(action)) or np.any(np.abs(action) > 1.0 + 1e-6):
            raise ValueError(f"action entries must be finite and in [-1, 1], got {action.tolist()}")
        action = np.clip(action, -1.0, 1.0)  # only float32 round-off beyond +-1 reaches here
        w = self.world
        w.set_actions(self.servo_command(action)[None])
        before = self._position()
        w.advance(self.frame_skip)
        displacement = self._position() - before
        self._distance += float(displacement @ self._heading)
        reward, reward_info = self._get_rew(displacement, action)
        self._steps += 1
        truncated = self._steps >= self.max_control_steps
        info = self._get_info() | reward_info
        return self._get_obs(), reward, False, bool(truncated), info

    def camera_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The ``(4, 4)`` view and projection matrices of the next ``render()`` (OpenGL
        convention, for column vectors): a world point ``x`` lands at normalised device
        coordinates ``(proj @ view @ [x, 1])[:3] / w``. Used to draw on a frame (e.g. a
        trajectory, :func:`aquafish_gym.video.project`)."""
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
