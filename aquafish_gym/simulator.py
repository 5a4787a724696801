"""Batched simulator: many robots in one PyBullet world, stepped together.

This is the boundary between ``aquafish_gym`` and the rest of the project
(docs/design.md): the EEA calls :func:`simulate_batch`; the Gymnasium env drives a
:class:`BatchWorld` of one robot. The fluid forces of all robots are computed in one NumPy
pass per step (:mod:`aquafish_gym.fluid`), then applied with one force and one torque call
per link.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from aquafish_gym.checks import check_int
from aquafish_gym import native as _native
from aquafish_gym.bullet import p
from aquafish_gym.damage import faults_array
from aquafish_gym.fluid import box_drag, caudal_reactive_force, quat_to_matrix, righting_torque
from aquafish_gym.imu import roll_pitch_yaw_deg, unwrap_yaw_deg
from aquafish_gym.morphology import validate_morphologies
from aquafish_gym.params import DT_S, SimParams
from aquafish_gym.robot import JOINTS, LINK_CAUDAL, N_LINKS, create_robot, robot_spec
from aquafish_gym.surface import SurfaceSpec, surface_wrench

#: Names of the three servo commands, units in the name, in action order.
ACTION_FIELDS: tuple[str, ...] = ("left_pectoral_rev_s", "right_pectoral_rev_s", "caudal_hz")
#: Servo command ranges: left/right pectoral speed (rev/s), caudal frequency (Hz). Paper 3.1.
ACTION_BOUNDS = np.array([[-0.5, 0.5], [-0.5, 0.5], [0.0, 1.0]])
ACTION_BOUNDS.setflags(write=False)
_LINKS = (-1, *JOINTS)
#: Robots of a batch sit on a grid this far apart (units) so that PyBullet's broadphase
#: never pairs them (collisions are masked off anyway; overlapping bounding boxes at one
#: point made stepping O(N^2)). Only the body's orientation is logged, so a robot's IMU
#: log does not depend on where it sits.
ROBOT_SPACING = 20.0
_GRID_COLUMNS = 10


@dataclasses.dataclass(frozen=True)
class WorldState:
    """A :class:`BatchWorld`'s state, kept by :meth:`BatchWorld.save_state` to go back to.

    Attributes:
        state_id: PyBullet's in-memory state (``saveState``) in the world's client.
        bodies: the world's body ids when it was saved.
        robots: the robots then (morphologies, seized servos, speed scales; a state is only
            restored into the same bodies and robots).
        time_s: the world's clock (s).
        caudal_phase: ``(N,)`` each caudal sweep's phase (rad).
        actions: ``(N, 3)`` the servo commands in force (rev/s, rev/s, Hz).
    """

    state_id: int
    bodies: tuple[int, ...]
    robots: tuple[np.ndarray, np.ndarray, np.ndarray]
    time_s: float
    caudal_phase: np.ndarray
    actions: np.ndarray


def validate_actions(actions, n: int) -> np.ndarray:
    """Check servo commands ``(n, 3)`` (rev/s, rev/s, Hz) and return them as float64.

    Raises:
        ValueError: wrong shape, NaN, or a command outside :data:`ACTION_BOUNDS`.
    """
    arr = np.asarray(actions, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.shape != (n, 3):
        raise ValueError(f"actions must have shape ({n}, 3) (left rev/s, right rev/s, caudal Hz), got {np.shape(actions)}")
    names = ("left pectoral speed (rev/s)", "right pectoral speed (rev/s)", "caudal frequency (Hz)")
    bad = ~np.isfinite(arr) | (arr < ACTION_BOUNDS[:, 0]) | (arr > ACTION_BOUNDS[:, 1])
    if bad.any():
        i, j = np.argwhere(bad)[0]
        raise ValueError(f"actions[{i}] {names[j]} must be in {ACTION_BOUNDS[j].tolist()}, got {arr[i, j]!r}")
    return arr


def validate_initial_angles(angles, n: int, caudal_amplitude_rad: float) -> np.ndarray:
    """Check initial flipper angles ``(n, 3)`` in radians and return them as float64.

    Pectoral angles may be any finite value (they are taken modulo 2 pi); the caudal angle
    must lie within the sweep [-amplitude, amplitude].

    Raises:
        ValueError: wrong shape, NaN, or a caudal angle outside the sweep.
    """
    arr = np.asarray(angles, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.shape != (n, 3):
        raise ValueError(f"initial_angles must have shape ({n}, 3) (left, right, caudal; rad), got {np.shape(angles)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("initial_angles must be finite (radians)")
    if np.any(np.abs(arr[:, 2]) > caudal_amplitude_rad + 1e-12):
        raise ValueError(f"initial caudal angles must be in [-{caudal_amplitude_rad:.4f}, {caudal_amplitude_rad:.4f}] rad, got {arr[:, 2].tolist()}")
    return arr


#: A robot's start motion at rest: level (the identity quaternion, x, y, z, w) and not turning
#: (angular velocity 0 rad/s); see :func:`validate_start_motion`.
AT_REST = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)


def validate_start_motion(motion, n: int) -> np.ndarray:
    """Check start motions ``(n, 7)`` and return them as float64, each quaternion normalised.

    A start motion is what an IMU measures of a robot's body when a simulation starts, with
    the robot's heading taken out: its orientation as a unit quaternion ``(x, y, z, w)`` of a
    body turned to yaw 0 (its roll and pitch), then its angular velocity ``(3,)`` (rad/s) in
    the world's axes turned by the same yaw. :data:`AT_REST` is the level robot at rest.

    Raises:
        ValueError: wrong shape, a non-finite entry, or a quaternion whose norm is not within
            1e-6 of 1.
    """
    arr = np.array(motion, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None]
    if arr.shape != (n, 7):
        raise ValueError(f"start_motion must have shape ({n}, 7) (quaternion x, y, z, w; angular velocity "
                         f"rad/s x, y, z), got {np.shape(motion)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError("start_motion must be finite (a unit quaternion, then rad/s)")
    norms = np.linalg.norm(arr[:, :4], axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-6):
        raise ValueError(f"start_motion's orientations must be unit quaternions (x, y, z, w), got norms "
                         f"{norms.round(6).tolist()}")
    arr[:, :4] /= norms[:, None]
    return arr


def validate_water_currents(currents, n: int, default=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Check per-robot water velocities ``(n, 3)`` (units/s, world frame; None: ``default`` for
    every robot) and return them as float64.

    Raises:
        ValueError: wrong shape or a non-finite entry.
    """
    arr = np.tile(np.asarray(default, dtype=np.float64), (n, 1)) if currents is None else np.asarray(currents, dtype=np.float64)
    if arr.shape != (n, 3) or not np.all(np.isfinite(arr)):
        raise ValueError(f"water_current must be None or {n} finite velocities, shape ({n}, 3) (units/s, world frame), "
                         f"got shape {np.shape(currents)}")
    return np.ascontiguousarray(arr)


class BatchWorld:
    """N robots in one PyBullet world (collisions masked off), stepped together.

    Args:
        morphologies: ``(N, 9)`` flipper dimensions (see :class:`~aquafish_gym.Morphology`).
        params: :class:`SimParams` (default: the defaults).
        faults: ``None``, one :class:`~aquafish_gym.ServoFaults`, or ``N`` of them.
        visual: create visual shapes (for rendering).
        client: an existing PyBullet client to use (it is reset); default: a new
            ``DIRECT`` client owned by this object.
        native: step with the compiled loop (:mod:`aquafish_gym.native`, same results bit
            for bit); None (default): whenever it is built, False: the NumPy path, True:
            require it.
        water_current: ``(N, 3)`` each robot's own uniform water velocity (units/s, world
            frame), overriding ``params.water_current`` (robots never interact, so each can
            swim in its own current); default: ``params.water_current`` for every robot.

    Raises:
        ValueError: invalid morphologies, faults or water currents, or ``native=True``
            without the compiled step (the message says how to build it).
    """

    def __init__(self, morphologies, params: SimParams | None = None, faults=None, *, visual: bool = False,
                 client: int | None = None, native: bool | None = None, water_current=None):
        self.params = params if params is not None else SimParams()
        self.morphologies = validate_morphologies(morphologies)
        self.n = self.morphologies.shape[0]
        self.water_current = validate_water_currents(water_current, self.n, self.params.water_current)
        self.seized, self.speed_scale = faults_array(faults, self.n)
        self.spec = robot_spec(self.morphologies, self.params)
        self.visual = bool(visual)
        self._owns_client = client is None
        self.client = p.connect(p.DIRECT) if client is None else client
        p.resetSimulation(physicsClientId=self.client)
        p.setGravity(0, 0, 0, physicsClientId=self.client)  # gravity and buoyancy enter as their couple
        p.setTimeStep(DT_S, physicsClientId=self.client)
        self.home = np.array([[ROBOT_SPACING * (i % _GRID_COLUMNS), ROBOT_SPACING * (i // _GRID_COLUMNS), 0.0] for i in range(self.n)])
        self.bodies = [create_robot(self.client, self.spec, i, position=self.home[i], visual=visual) for i in range(self.n)]
        self._active = [self._active_links(i) for i in range(self.n)]
        self.time_s = 0.0
        self.actions = np.zeros((self.n, 3))
        self.initial_angles = np.zeros((self.n, 3))
        self._caudal_phase = np.zeros(self.n)
        self.surface = SurfaceSpec.build(self.spec, self.params, self.home[:, 2]) if self.params.surface else None
        self._read_state()
        self._native = self._bind_native(native)

    def _bind_native(self, native: bool | None):
        if native is False:
            return None
        if native is None and not _native.available():
            _native.warn_unavailable_once()
            return None
        try:
            return _native.NativeStep(self)
        except _native.NativeUnavailable as err:
            if native:
                raise ValueError(f"native=True: {err}") from None
            return None

    def _active_links(self, i: int) -> list[int]:
        """The links of robot ``i`` that feel drag: the body always, flippers only when they have
        area; at the surface the body carries the pectorals' forces (:mod:`aquafish_gym.surface`)."""
        fins = (3,) if self.params.surface else (1, 2, 3)
        return [0] + [k for k in fins if self.spec.face_areas[i, k].any()]

    @property
    def native(self) -> bool:
        """Whether this world steps with the compiled loop."""
        return self._native is not None

    # -- lifecycle -------------------------------------------------------------------
    def close(self) -> None:
        """Disconnect the PyBullet client if this world created it."""
        if self._owns_client and self.client is not None and p.isConnected(self.client):
            p.disconnect(self.client)
        self.client = None

    def __enter__(self) -> "BatchWorld":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def reset(self, initial_angles, actions=None, yaw_rad=None, start_motion=None) -> None:
        """Put every robot at its home position, level, at rest, flippers at ``initial_angles`` ``(N, 3)`` rad.

        ``yaw_rad``: ``(N,)`` each robot's heading, counter-clockwise from +y seen from above
        (None: every robot heads +y). The fluid model and the surface are the same in every
        horizontal direction, so a robot turned by ``yaw`` swims its trajectory turned by ``yaw``.

        ``start_motion``: ``(N, 7)`` each robot's roll and pitch and angular velocity instead of
        level and at rest (:func:`validate_start_motion`; turned by ``yaw_rad`` with the robot;
        None: every robot :data:`AT_REST`). A robot still starts at its home position with no
        linear velocity: the models of a target experiment start from what the target's IMU
        measured (:class:`aquafish.mission.MissionTarget`).

        Raises:
            ValueError: bad ``initial_angles`` (:func:`validate_initial_angles`), a ``yaw_rad``
                that is not ``(N,)`` finite numbers, or a bad ``start_motion``.
        """
        self.initial_angles = validate_initial_angles(initial_angles, self.n, self.params.caudal_amplitude_rad)
        if yaw_rad is None:
            yaw = np.zeros(self.n)
        else:
            yaw = np.asarray(yaw_rad, dtype=np.float64)
            if yaw.shape != (self.n,) or not np.all(np.isfinite(yaw)):
                raise ValueError(f"yaw_rad must be {self.n} finite headings (rad), one per robot, got {yaw_rad!r}")
        motion = np.tile(AT_REST, (self.n, 1)) if start_motion is None else validate_start_motion(start_motion, self.n)
        turns = [(0.0, 0.0, float(np.sin(y / 2)), float(np.cos(y / 2))) for y in yaw]
        for body, home, angles, turn, m in zip(self.bodies, self.home.tolist(), self.initial_angles, turns,
                                               motion.tolist()):
            orientation, angular = (0, 0, 0, 1), (0, 0, 0)
            if yaw_rad is not None:
                orientation = turn
            if m != list(AT_REST):  # level and at rest takes the exact path it always took
                orientation = p.multiplyTransforms((0, 0, 0), turn, (0, 0, 0), m[:4])[1]
                rot = np.array(p.getMatrixFromQuaternion(turn)).reshape(3, 3)
                angular = tuple((rot @ np.array(m[4:])).tolist())
            p.resetBasePositionAndOrientation(body, home, orientation, physicsClientId=self.client)
            p.resetBaseVelocity(body, (0, 0, 0), angular, physicsClientId=self.client)
            for j, a in zip(JOINTS, angles):
                p.resetJointState(body, j, float(a), 0.0, physicsClientId=self.client)
        self.time_s = 0.0
        self._caudal_phase = self._sweep_phase(self.initial_angles[:, 2])
        self.actions = np.zeros((self.n, 3))
        self.set_actions(np.zeros((self.n, 3)) if actions is None else actions)
        self._read_state()

    def save_state(self) -> WorldState:
        """Keep the world's state (PyBullet's bodies, the clock, the caudal sweeps, the commands)
        to go back to with :meth:`restore_state` (a mission's oracle swims from where its robot
        stood). The state lives in the world's PyBullet client until it disconnects."""
        return WorldState(p.saveState(physicsClientId=self.client), tuple(self.bodies), self._robots(), self.time_s,
                          self._caudal_phase.copy(), self.actions.copy())

    def _robots(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.morphologies.copy(), self.seized.copy(), self.speed_scale.copy()

    def restore_state(self, state: WorldState) -> None:
        """Put the world back in ``state`` (:meth:`save_state`).

        PyBullet's restored state leaves out the link poses it caches from its last step, so
        the first step after a restore differs from the step the saved world took next (by
        about 1e-4 of the observation's entries), and a run from the restored state is not the
        saved world's own continuation bit for bit. Every run from one restored state is the
        same to the last bit (tested): to compare two runs from one moment, restore the state
        before each.

        Raises:
            ValueError: ``state`` was saved from other bodies (another world, or before a
                :meth:`change_robot` that rebuilt one).
        """
        same = tuple(state.bodies) == tuple(self.bodies) and all(
            a.shape == b.shape and np.array_equal(a, b) for a, b in zip(state.robots, self._robots()))
        if not same:
            raise ValueError("the state was saved from other robots (another world's, or before change_robot "
                             "changed one): it can only be restored into the bodies and robots it was saved from")
        p.restoreState(stateId=state.state_id, physicsClientId=self.client)
        self.time_s = state.time_s
        self._caudal_phase = state.caudal_phase.copy()
        self.set_actions(state.actions)
        self._read_state()

    def sync_caudal_phase(self, i: int | None = None) -> None:
        """Restart the caudal sweep of robot ``i`` (every robot if None) from its fin's current angle.

        The sweep is ``amplitude * sin(phase)``; this sets ``phase = asin(angle / amplitude)``
        (the angle clipped to the amplitude), as :meth:`reset` does for the initial angles, so a
        robot commanded anew mid-run (a mission's target experiment) sweeps on from where its fin
        is, as a model started at that angle does. The flippers' angles are not changed.

        Raises:
            IndexError: ``i`` is not a robot of this world.
        """
        idx = np.arange(self.n) if i is None else np.array([int(i)])
        if np.any((idx < 0) | (idx >= self.n)):
            raise IndexError(f"robot index {i} out of range for a world of {self.n} robots")
        self._caudal_phase[idx] = self._sweep_phase(self.joint_angles()[idx, 2])

    def _sweep_phase(self, caudal_angles: np.ndarray) -> np.ndarray:
        """The caudal sweep's phase (rad) at which ``amplitude * sin(phase)`` is each fin angle (rad), clipped."""
        return np.arcsin(np.clip(caudal_angles / self.params.caudal_amplitude_rad, -1.0, 1.0))

    def change_robot(self, i: int, morphology, faults=None) -> None:
        """Turn robot ``i`` into another robot mid-run, in the same state (a damage's onset).

        The world is not reset: the other robots, the time and robot ``i``'s state (base pose
        and velocity, flipper angles and speeds, the caudal sweep's phase) carry on. Servo
        faults take effect at once (the motors are commanded again with the current actions:
        a servo seized now holds its flipper where it is now). A new morphology replaces the
        robot's PyBullet body by one built for it, exactly as :meth:`__init__` builds one
        (link masses, inertias and centres of mass, visual shapes, none for a flipper without
        volume), put in the old body's state; the fluid model's dimensions (drag areas, the
        caudal fin's length and added mass, the surface model's strips) and the set of links
        that feel drag are recomputed. A new body rather than ``changeDynamics``: PyBullet
        cannot move a link's centre of mass (its inertial frame) nor change its visual shape,
        and a resized flipper's centre of mass moves. So from here on robot ``i`` is, to the
        last bit, a robot built with ``morphology`` and put in this state as PyBullet reports
        it (tested); :attr:`bodies` holds the new body's id (PyBullet may reuse the old one). (PyBullet reports
        the base's orientation rounded by up to an ulp of what it integrates, so a body put in
        the reported state is that much off the old body's internal one; positions,
        velocities and joint states carry over exactly.) Robot ``i``'s state arrays
        (:attr:`position`, ...) are replaced, not written into.

        Args:
            i: the robot's index.
            morphology: ``(9,)`` its new flipper dimensions (or a :class:`~aquafish_gym.Morphology`).
            faults: its servo faults, a :class:`~aquafish_gym.ServoFaults` (None: none).

        Raises:
            ValueError: ``i`` out of range, or an invalid morphology or faults.
        """
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.n:
            raise ValueError(f"robot index i must be an int in [0, {self.n}), got {i!r}")
        i = int(i)
        morph = validate_morphologies(morphology)[0]
        seized, speed_scale = faults_array(faults, 1)
        self.seized[i], self.speed_scale[i] = seized[0], speed_scale[0]
        if not np.array_equal(morph, self.morphologies[i]):
            c, old = self.client, self.bodies[i]
            position, orientation = p.getBasePositionAndOrientation(old, physicsClientId=c)
            linear, angular = p.getBaseVelocity(old, physicsClientId=c)
            joints = [s[:2] for s in p.getJointStates(old, JOINTS, physicsClientId=c)]
            morphologies = self.morphologies.copy()  # not the caller's array
            morphologies[i] = morph
            self.morphologies = morphologies
            self.spec = robot_spec(self.morphologies, self.params)
            p.removeBody(old, physicsClientId=c)
            body = create_robot(c, self.spec, i, position=self.home[i], visual=self.visual)
            p.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=c)
            p.resetBaseVelocity(body, linear, angular, physicsClientId=c)
            for j, (angle, speed) in zip(JOINTS, joints):
                p.resetJointState(body, j, angle, speed, physicsClientId=c)
            self.bodies[i] = body
            self._active[i] = self._active_links(i)
            if self.surface is not None:
                self.surface = SurfaceSpec.build(self.spec, self.params, self.home[:, 2])
        self.set_actions(self.actions)  # every robot's motors again: the same commands for the others
        if self._native is not None:
            self._native = _native.NativeStep(self)  # it copies the bodies and the fluid model's dimensions
        self._read_state()

    def set_actions(self, actions) -> None:
        """Command the servos: ``(N, 3)`` left/right pectoral rev/s, caudal Hz.

        Pectoral motors are velocity-controlled; a seized servo holds its angle. The caudal
        fin follows ``A sin(2 pi f t + phi0)`` from its current phase (``phi0`` chosen so
        that the sweep starts at the initial angle).
        """
        actions = validate_actions(actions, self.n)
        self.actions = actions
        target = 2 * math.pi * actions[:, :2] * self.speed_scale[:, :2]
        target[self.seized[:, :2]] = 0.0
        for i, body in enumerate(self.bodies):
            p.setJointMotorControlArray(body, JOINTS[:2], p.VELOCITY_CONTROL, targetVelocities=target[i].tolist(),
                                        forces=[self.params.pectoral_max_torque] * 2, physicsClientId=self.client)
        self._caudal_omega = 2 * math.pi * np.where(self.seized[:, 2], 0.0, actions[:, 2] * self.speed_scale[:, 2])
        self._oscillating = np.flatnonzero(self._caudal_omega > 0)
        amp = self.params.caudal_amplitude_rad
        for i in np.flatnonzero(self._caudal_omega == 0):  # hold the current angle
            self._command_caudal(int(i), float(amp * np.sin(self._caudal_phase[i])), 0.0)

    def _command_caudal(self, i: int, angle: float, velocity: float) -> None:
        prm = self.params
        p.setJointMotorControl2(self.bodies[i], LINK_CAUDAL, p.POSITION_CONTROL, targetPosition=angle,
                                targetVelocity=velocity, force=prm.caudal_max_torque, positionGain=prm.caudal_position_gain,
                                velocityGain=prm.caudal_velocity_gain, physicsClientId=self.client)

    # -- physics ---------------------------------------------------------------------
    def _read_state(self) -> None:
        """Read every link's pose and velocity into ``(N, 4, ...)`` arrays (one conversion)."""
        c = self.client
        rows = []
        for body in self.bodies:
            bp, bo = p.getBasePositionAndOrientation(body, physicsClientId=c)
            bl, ba = p.getBaseVelocity(body, physicsClientId=c)
            s0, s1, s2 = p.getLinkStates(body, JOINTS, computeLinkVelocity=1, physicsClientId=c)
            rows.append(bp + s0[0] + s1[0] + s2[0] + bo + s0[1] + s1[1] + s2[1]
                        + bl + s0[6] + s1[6] + s2[6] + ba + s0[7] + s1[7] + s2[7])
        state = np.array(rows)
        n = self.n
        self.position = state[:, :12].reshape(n, N_LINKS, 3)
        self.orientation = state[:, 12:28].reshape(n, N_LINKS, 4)
        self.linear_velocity = state[:, 28:40].reshape(n, N_LINKS, 3)
        self.angular_velocity = state[:, 40:52].reshape(n, N_LINKS, 3)
        self.rotation = quat_to_matrix(self.orientation)

    def fluid_wrench(self) -> tuple[np.ndarray, np.ndarray]:
        """Fluid force and torque on every link, ``(N, 4, 3)`` each, in each link's own frame.

        At the surface (``params.waterline`` set): :func:`aquafish_gym.surface.surface_wrench`.
        In deep water: drag on every face of every link (:func:`~aquafish_gym.fluid.box_drag`), the
        gravity-buoyancy couple on the body and, with ``params.reactive_thrust``, the
        reactive force at the caudal fin's trailing edge
        (:func:`~aquafish_gym.fluid.caudal_reactive_force`). Torques are about each link's centre
        of mass.

        The reactive force acts at the trailing edge, i.e. at the fin's centre of mass plus
        the couple ``trailing_edge x F``. The couple is added to the body's torque instead of
        the fin's: a couple is a free vector, and the caudal servo holds the fin to its
        commanded sweep (its torque limit is far above any fluid torque), so fin and body
        move as one rigid body under it. This saves a PyBullet call per robot-step; a test
        checks it against the force applied at the trailing edge itself.
        """
        prm = self.params
        if self.surface is not None:
            return surface_wrench(self.surface, self.spec, prm, self.rotation, self.position, self.linear_velocity,
                                  self.angular_velocity, water_current=self.water_current)
        force, torque = box_drag(
            self.rotation, self.linear_velocity, self.angular_velocity, self.spec.box_offsets, self.spec.axis_areas,
            drag_coefficient=prm.drag_coefficient, fluid_density=prm.fluid_density,
            drag_law=prm.drag_law, water_current=self.water_current[:, None],
        )
        body_rot = self.rotation[:, 0]
        righting = righting_torque(body_rot, self.spec.masses[:, 0], prm.gravity, prm.ballast_offset)
        if prm.reactive_thrust:
            fin_rot = self.rotation[:, 3]
            f_fin, t_fin = caudal_reactive_force(
                fin_rot, self.linear_velocity[:, 3], self.angular_velocity[:, 3], self.spec.caudal_half_length,
                self.spec.caudal_added_mass, water_current=self.water_current,
            )
            force[:, 3] += f_fin
            righting += np.einsum("nij,nj->ni", fin_rot, t_fin)  # the couple, in the world frame
        torque[:, 0] += (body_rot * righting[:, :, None]).sum(axis=-2)  # world -> body frame
        return force, torque

    def _caudal_targets(self, steps: int) -> tuple[np.ndarray, np.ndarray]:
        """The caudal sweep ``A sin(phase)``: target angles and velocities ``(steps, K)`` of
        the K oscillating robots for the next ``steps`` steps, advancing their phase by
        ``2 pi f dt`` per step (both paths use it, so both command the same doubles)."""
        idx = self._oscillating
        amp, w = self.params.caudal_amplitude_rad, self._caudal_omega[idx]
        # The phase after each step, added one step at a time (cumsum adds in order), as a
        # loop of ``phase += w * dt`` would: the same doubles whatever ``steps``.
        increments = np.empty((steps + 1, idx.size))
        increments[0], increments[1:] = self._caudal_phase[idx], w * DT_S
        phases = np.cumsum(increments, axis=0)[1:]
        if steps:
            self._caudal_phase[idx] = phases[-1]
        return amp * np.sin(phases), amp * w * np.cos(phases)

    def _step_native(self, steps: int, log: bool) -> np.ndarray | None:
        angles, velocities = self._caudal_targets(steps)
        quats = self._native.run(steps, angles, velocities, self._oscillating, log)
        for _ in range(steps):  # summed step by step, as step() does, so time_s is the same double
            self.time_s += DT_S
        self.rotation = quat_to_matrix(self.orientation)
        return quats

    def step(self) -> None:
        """Advance all robots by one physics step of :data:`DT_S` seconds.

        One force call per link that has drag (link frame, at its centre of mass) and one
        torque call for the body; a flipper's drag box is centred on its centre of mass,
        so its drag torque is identically zero (see :mod:`aquafish_gym.fluid`). With the
        compiled loop (:attr:`native`) the same calls are made from C++.
        """
        if self._native is not None:
            self._step_native(1, log=False)
            return
        c = self.client
        force, torque = self.fluid_wrench()
        force_l, torque_l = force.tolist(), torque[:, 0].tolist()
        origin, frame = (0.0, 0.0, 0.0), p.LINK_FRAME
        apply_force, apply_torque = p.applyExternalForce, p.applyExternalTorque
        for body, active, fi, ti in zip(self.bodies, self._active, force_l, torque_l):
            for k in active:
                apply_force(body, _LINKS[k], fi[k], origin, frame, physicsClientId=c)
            apply_torque(body, -1, ti, frame, physicsClientId=c)
        if self._oscillating.size:
            angles, velocities = self._caudal_targets(1)
            prm, motor, bodies = self.params, p.setJointMotorControl2, self.bodies
            torque_max, kp, kd = prm.caudal_max_torque, prm.caudal_position_gain, prm.caudal_velocity_gain
            for i, a, v in zip(self._oscillating.tolist(), angles[0].tolist(), velocities[0].tolist()):
                motor(bodies[i], LINK_CAUDAL, p.POSITION_CONTROL, targetPosition=a, targetVelocity=v, force=torque_max,
                      positionGain=kp, velocityGain=kd, physicsClientId=c)
        p.stepSimulation(physicsClientId=c)
        self.time_s += DT_S
        self._read_state()

    # -- sensing ---------------------------------------------------------------------
    def imu_rpy_deg(self) -> np.ndarray:
        """``(N, 3)`` roll, pitch, yaw (degrees, wrapped) of every robot's body."""
        return roll_pitch_yaw_deg(self.rotation[:, 0])

    def start_motion(self) -> np.ndarray:
        """``(N, 7)`` every robot's motion now as a start motion (:func:`validate_start_motion`):
        its orientation turned back by its IMU yaw (:meth:`imu_rpy_deg`) to yaw 0, and its
        angular velocity (rad/s) turned the same way. A simulation that starts from it
        (:meth:`reset`) starts with the same roll, pitch and turning, its IMU yaw 0."""
        yaw = np.radians(self.imu_rpy_deg()[:, 2])
        out = np.empty((self.n, 7))
        for i, y in enumerate(yaw):
            unturn = (0.0, 0.0, float(-np.sin(y / 2)), float(np.cos(y / 2)))
            out[i, :4] = p.multiplyTransforms((0, 0, 0), unturn, (0, 0, 0), self.orientation[i, 0].tolist())[1]
            out[i, 4:] = np.array(p.getMatrixFromQuaternion(unturn)).reshape(3, 3) @ self.angular_velocity[i, 0]
        out[:, :4] /= np.linalg.norm(out[:, :4], axis=1, keepdims=True)
        return out

    def joint_angles(self) -> np.ndarray:
        """``(N, 3)`` current flipper angles (rad): left, right pectoral, caudal."""
        return np.array([[s[0] for s in p.getJointStates(b, JOINTS, physicsClientId=self.client)] for b in self.bodies])

    def advance(self, steps: int) -> None:
        """Step ``steps`` times (one compiled call with :attr:`native`), logging nothing."""
        if self._native is not None:
            self._step_native(steps, log=False)
        else:
            for _ in range(steps):
                self.step()

    def run(self, steps: int, rng: np.random.Generator | None = None) -> np.ndarray:
        """Step ``steps`` times and return the IMU log ``(N, steps, 3)`` (deg, yaw unwrapped)."""
        if self._native is not None:
            log = roll_pitch_yaw_deg(quat_to_matrix(self._step_native(steps, log=True)))
        else:
            log = np.empty((self.n, steps, 3))
            for k in range(steps):
                self.step()
                log[:, k] = self.imu_rpy_deg()
        log = unwrap_yaw_deg(log)
        if self.params.imu_noise_deg > 0:
            rng = rng if rng is not None else np.random.default_rng()
            log += rng.normal(0.0, self.params.imu_noise_deg, size=log.shape)
        return log


_SHARED_CLIENT: dict[int, int] = {}


def _shared_client() -> int:
    """One DIRECT client per process, reused across :func:`simulate_batch` calls."""
    import os

    pid = os.getpid()
    client = _SHARED_CLIENT.get(pid)
    if client is None or not p.isConnected(client):
        client = _SHARED_CLIENT[pid] = p.connect(p.DIRECT)
    return client


def simulate_batch(morphologies, actions, initial_angles, steps: int, *, faults=None, params: SimParams | None = None,
                   rng: np.random.Generator | None = None, native: bool | None = None,
                   start_motion=None) -> np.ndarray:
    """Simulate N robots performing one action each; return their IMU logs.

    All N robots live in one PyBullet world with collisions masked off and are stepped
    together; robot i's result does not depend on N or on its neighbours (docs/design.md).
    ``dt`` = 0.01 s.

    Args:
        morphologies: ``(N, 9)`` flipper dimensions (simulator units), or ``(9,)``.
        actions: ``(N, 3)`` servo commands: left and right pectoral speed (rev/s, in
            [-0.5, 0.5]) and caudal frequency (Hz, in [0, 1]).
        initial_angles: ``(N, 3)`` initial flipper angles (rad): left and right pectoral
            (any value, 0 = arms back), caudal (within the +-30 degree sweep).
        steps: number of 0.01 s steps (the paper uses powers of two, 128 ... 1024).
        faults: ``None``, one :class:`~aquafish_gym.ServoFaults` or ``N`` of them.
        params: :class:`~aquafish_gym.SimParams`; default: the defaults.
        rng: source of IMU noise (used only if ``params.imu_noise_deg > 0``).
        native: the compiled loop (as :class:`BatchWorld`; None: whenever it is built).
            Either path gives the same logs bit for bit.
        start_motion: ``(N, 7)`` each robot's roll and pitch (a yaw-free unit quaternion) and
            angular velocity (rad/s) at the start (:func:`validate_start_motion`); None: level
            and at rest.

    Returns:
        ``(N, steps, 3)`` float64: roll, pitch, yaw of each robot's body after each step,
        in degrees, yaw unwrapped.

    Raises:
        ValueError: bad shapes, out-of-range values, NaN, or ``steps < 1``.
    """
    check_int("steps (0.01 s each)", steps, 1)
    morph = validate_morphologies(morphologies)
    n = morph.shape[0]
    prm = params if params is not None else SimParams()
    acts = validate_actions(actions, n)
    angles = validate_initial_angles(initial_angles, n, prm.caudal_amplitude_rad)
    world = BatchWorld(morph, prm, faults, client=_shared_client(), native=native)
    world.reset(angles, acts, start_motion=start_motion)
    return world.run(int(steps), rng)
