"""The compiled step: :class:`~aquafish_gym.BatchWorld`'s physics loop without Python.

A :class:`BatchWorld` step is mostly Python calling PyBullet: about nine calls per robot
(base pose, base velocity, link states, four forces and a torque, the caudal servo), each
1-3 us, against a few us of physics. ``aquafish_step.cpp`` runs the same loop (fluid
wrench, force and servo commands, ``stepSimulation``, state read-back) in C++, inside a
PyBullet plugin, with the arithmetic of :mod:`aquafish_gym.fluid` operation for operation
in NumPy's order and without fused multiply-adds: a world gives the same IMU log bit for
bit on either path (tests check it). The NumPy path stays the reference.

``pip install .`` and ``pip install -e .`` build it (``setup.py``, with the system C++
compiler and the project's own header of PyBullet's C ABI, ``pybullet_abi.h``; nothing is
downloaded); ``python -m aquafish_gym.native.build`` rebuilds it in place. It supports the
PyBullet releases of :data:`PYBULLET_RANGE` and refuses others. ``aquafish doctor`` says
whether it is active, and if not why and how to get it.

A world uses it whenever it is built (``BatchWorld(..., native=None)``); ``native=False``
forces the NumPy path, ``native=True`` requires the compiled one. ``AQUAFISH_NATIVE=0`` in
the environment turns it off for the whole process.

When it is missing, the first world of a process says so once, through :mod:`logging`
(logger ``aquafish_gym.native``, level WARNING), not :mod:`warnings`: code that turns
warnings into errors (``warnings.simplefilter("error")``, as for a strict Gymnasium
``check_env``) is not tripped by it. To silence it, set ``AQUAFISH_NATIVE=0`` (use the
NumPy path on purpose) or ``logging.getLogger("aquafish_gym.native").setLevel(logging.ERROR)``.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import logging
import os
import re
from pathlib import Path

import numpy as np

from aquafish_gym.bullet import p

__all__ = ["LIBRARY", "PYBULLET_RANGE", "NativeStep", "NativeUnavailable", "available", "check_pybullet",
           "client_handle", "pybullet_version", "status", "unavailable_reason", "warn_unavailable_once"]

#: The plugin built by :mod:`aquafish_gym.native.build`.
LIBRARY = Path(__file__).with_name("_aquafish_step.so")
_VERSION = 5  # af_run's signature; the library must match
_POSTFIX = "_aquafish"

_lib: ctypes.CDLL | None = None
_warned = False
_handles: dict[int, int] = {}  # PyBullet client id -> the plugin's client handle on that server

#: PyBullet releases whose C ABI ``pybullet_abi.h`` matches: ``>= first, < second`` (pyproject.toml's pin).
PYBULLET_RANGE = ("3.2.6", "3.3")
#: How to get the compiled step when it is not built (``pip install`` compiles it when it finds a C++ compiler).
HOW_TO_BUILD = ("install a C++ compiler (e.g. `apt install g++`) and reinstall: `pip install -e .` in a checkout, "
                "or rebuild in place with `python -m aquafish_gym.native.build`")
_log = logging.getLogger(__name__)


class NativeUnavailable(RuntimeError):
    """The compiled step is not built or cannot be loaded; the message says how to get it."""


def _release(version: str) -> tuple[int, int, int]:
    """A version's release numbers, padded to three: ``"3.3"`` -> ``(3, 3, 0)`` (``(-1, -1, -1)``: none)."""
    match = re.match(r"\d+(?:\.\d+)*", version.strip())
    if match is None:
        return (-1, -1, -1)
    numbers = [int(n) for n in match.group().split(".")[:3]]
    return tuple(numbers + [0] * (3 - len(numbers)))


def pybullet_version() -> str | None:
    """The installed pybullet's version (its package metadata), or None if unknown."""
    try:
        return importlib.metadata.version("pybullet")
    except importlib.metadata.PackageNotFoundError:
        return None


def check_pybullet(version: str | None = None) -> None:
    """Refuse a pybullet outside :data:`PYBULLET_RANGE` (``version``: the installed one by default).

    Raises:
        NativeUnavailable: naming the version, the supported range and how to install it.
    """
    version = pybullet_version() if version is None else version
    if version is None:
        return  # no metadata: the API-version check in _load still guards the ABI
    low, below = PYBULLET_RANGE
    if not _release(low) <= _release(version) < _release(below):
        raise NativeUnavailable(f"PyBullet {version} is outside the range whose C ABI the compiled step was written "
                                f"for (>={low},<{below}): install a supported release with "
                                f"`pip install \"pybullet>={low},<{below}\"`")


def _load() -> ctypes.CDLL:
    global _lib
    if _lib is not None:
        return _lib
    check_pybullet()
    if not LIBRARY.exists():
        raise NativeUnavailable(f"the compiled step is not built ({LIBRARY.name} missing; it is compiled at install "
                                f"time when a C++ compiler is found): {HOW_TO_BUILD}")
    lib = ctypes.CDLL(str(LIBRARY))
    if lib.af_version() != _VERSION:
        raise NativeUnavailable(f"{LIBRARY.name} is version {lib.af_version()}, expected {_VERSION}: rebuild it "
                                "with `python -m aquafish_gym.native.build --force` or `pip install -e .`")
    try:
        built_for = lib.af_pybullet_api_version()
    except AttributeError:
        raise NativeUnavailable(f"{LIBRARY.name} predates the PyBullet API check: rebuild it with "
                                "`python -m aquafish_gym.native.build --force` or `pip install -e .`") from None
    if built_for != p.getAPIVersion():
        raise NativeUnavailable(f"PyBullet {pybullet_version()} has C API version {p.getAPIVersion()}, the compiled "
                                f"step was written for {built_for} (PyBullet >={PYBULLET_RANGE[0]},"
                                f"<{PYBULLET_RANGE[1]}): install a supported PyBullet")
    code = lib.af_bind(p.__file__.encode())
    if code != 0:
        raise NativeUnavailable(f"{LIBRARY.name} cannot find PyBullet's C API in {p.__file__} (code {code})")
    lib.af_last_client.restype = ctypes.c_void_p
    lib.af_run.restype = ctypes.c_int
    _lib = lib
    return lib


def unavailable_reason() -> str | None:
    """None if the compiled step can be used, else why not (switched off, not built, not loadable)."""
    if os.environ.get("AQUAFISH_NATIVE", "1") == "0":
        return "switched off by AQUAFISH_NATIVE=0"
    try:
        _load()
    except (NativeUnavailable, OSError) as err:
        return str(err)
    return None


def available() -> bool:
    """Whether the compiled step is built, loads, and is not switched off (``AQUAFISH_NATIVE=0``)."""
    return unavailable_reason() is None


def status() -> list[str]:
    """Lines saying which simulator path is active and, if it is the NumPy one, why and how to change it."""
    reason = unavailable_reason()
    versions = f"PyBullet {pybullet_version()}, supported >={PYBULLET_RANGE[0]},<{PYBULLET_RANGE[1]}"
    if reason is None:
        return [f"simulator step: compiled ({LIBRARY})", versions]
    from aquafish_gym.native.build import find_compiler

    compiler = find_compiler()
    lines = ["simulator step: NumPy path (the same results, 3-4x slower than the compiled one)", f"why: {reason}",
             versions, f"C++ compiler: {' '.join(compiler) if compiler else 'none on PATH (set CXX or install g++)'}"]
    if os.environ.get("AQUAFISH_NATIVE", "1") == "0":
        lines.append("to use the compiled step: unset AQUAFISH_NATIVE")
    return lines


def warn_unavailable_once() -> None:
    """Say (once per process, through :mod:`logging`) that worlds fall back to the NumPy path, unless asked for.

    Not a :mod:`warnings` warning, so ``warnings.simplefilter("error")`` does not turn it into
    an exception; silence it with ``AQUAFISH_NATIVE=0`` or by raising the level of the
    ``aquafish_gym.native`` logger.
    """
    global _warned
    if _warned or os.environ.get("AQUAFISH_NATIVE", "1") == "0":
        return
    reason = unavailable_reason()
    if reason is not None:
        _warned = True
        _log.warning("aquafish_gym: the simulator runs its NumPy path (same results, 3-4x slower): %s. "
                     "`aquafish doctor` tells more; AQUAFISH_NATIVE=0 silences this.", reason)


def client_handle(client: int) -> int:
    """The plugin's handle on PyBullet client ``client``'s server (loading the plugin there once).

    Raises:
        NativeUnavailable: if the library is not built or PyBullet refuses the plugin.
    """
    lib = _load()
    for _ in range(2):
        lib.af_forget_last()
        uid = p.loadPlugin(str(LIBRARY), _POSTFIX, physicsClientId=client)
        if uid < 0:
            raise NativeUnavailable(f"PyBullet could not load the plugin {LIBRARY}")
        fresh = lib.af_last_client()
        if fresh:
            _handles[client] = fresh
            return fresh
        if client in _handles:
            return _handles[client]
        p.unloadPlugin(uid, physicsClientId=client)  # loaded before we kept its handle: load it afresh
    raise NativeUnavailable("the plugin did not report its client handle")


def _doubles(a: np.ndarray):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _ints(a: np.ndarray):
    return a.ctypes.data_as(ctypes.POINTER(ctypes.c_int))


class NativeStep:
    """The compiled loop bound to one :class:`~aquafish_gym.BatchWorld` (its robots and params).

    Args:
        world: the world; its spec, bodies, active links and params are copied once.

    Raises:
        NativeUnavailable: as :func:`client_handle`.
    """

    def __init__(self, world) -> None:
        from aquafish_gym.robot import LINK_CAUDAL

        prm, spec, n = world.params, world.spec, world.n
        self.world = world
        self.handle = ctypes.c_void_p(client_handle(world.client))
        self.bodies = np.ascontiguousarray(world.bodies, dtype=np.intc)
        self.active = np.zeros((n, 4), dtype=np.intc)
        for i, links in enumerate(world._active):
            self.active[i, links] = 1
        self.box_offsets = np.ascontiguousarray(spec.box_offsets, dtype=np.float64)
        self.axis_areas = np.ascontiguousarray(spec.axis_areas, dtype=np.float64)
        # the same expressions as fluid.righting_torque and fluid.box_drag, so the same doubles
        self.righting_w = np.ascontiguousarray(np.asarray(spec.masses[:, 0]) * prm.gravity * prm.ballast_offset)
        self.caudal_half = np.ascontiguousarray(spec.caudal_half_length, dtype=np.float64)
        self.caudal_mass = np.ascontiguousarray(spec.caudal_added_mass, dtype=np.float64)
        self.quadratic = prm.drag_law == "quadratic"
        self.drag_c = (-0.5 * prm.drag_coefficient * prm.fluid_density) if self.quadratic else -prm.drag_coefficient
        self.current = np.ascontiguousarray(world.water_current, dtype=np.float64)  # (N, 3), one per robot
        self.surface = None
        if world.surface is not None:  # the surface swimmer's constants (aquafish_gym.surface.SurfaceSpec)
            sf = world.surface
            robot = np.column_stack([sf.surface_z, sf.weight, sf.strip_areas.reshape(n, 6),
                                     sf.pectoral_half.reshape(n, 6), sf.caudal_half, sf.hinge_arm.reshape(n, 6),
                                     sf.fin_com.reshape(n, 6)])
            self.surface = (np.ascontiguousarray(robot, dtype=np.float64),
                            np.ascontiguousarray(sf.strip_y, dtype=np.float64), sf.strip_y.shape[-1],
                            np.ascontiguousarray(sf.slices, dtype=np.float64), sf.slices.shape[1],
                            sf.pi_weight, sf.rho_g, sf.ballast)
        info = p.getJointInfo(world.bodies[0], LINK_CAUDAL, physicsClientId=world.client)
        self.caudal_q, self.caudal_u = info[3], info[4]  # the caudal joint's position and velocity indices

    def _surface_args(self) -> tuple:
        if self.surface is None:
            return (None, None, ctypes.c_int(0), None, ctypes.c_int(0), ctypes.c_double(0.0), ctypes.c_double(0.0),
                    ctypes.c_double(0.0))
        robot, strip_y, n_strips, slices, n_slices, pi_weight, rho_g, ballast = self.surface
        return (_doubles(robot), _doubles(strip_y), ctypes.c_int(n_strips), _doubles(slices), ctypes.c_int(n_slices),
                ctypes.c_double(pi_weight), ctypes.c_double(rho_g), ctypes.c_double(ballast))

    def run(self, steps: int, caudal_angle: np.ndarray, caudal_velocity: np.ndarray, oscillating: np.ndarray,
            log: bool) -> np.ndarray | None:
        """Step the world ``steps`` times; its state arrays are read and replaced.

        Args:
            steps: physics steps of 0.01 s.
            caudal_angle: ``(steps, K)`` the caudal servo's target angle (rad) of the K
                oscillating robots at every step.
            caudal_velocity: ``(steps, K)`` its target velocity (rad/s).
            oscillating: ``(K,)`` their indices.
            log: return the body orientation after every step.

        Returns:
            ``(N, steps, 4)`` body quaternions (x, y, z, w) if ``log``, else None.

        Raises:
            RuntimeError: if PyBullet did not answer a state request as expected.
        """
        w, prm = self.world, self.world.params
        state = [np.ascontiguousarray(a, dtype=np.float64) for a in
                 (w.position, w.orientation, w.linear_velocity, w.angular_velocity)]
        quats = np.empty((w.n, steps, 4)) if log else None
        angle = np.ascontiguousarray(caudal_angle, dtype=np.float64)
        velocity = np.ascontiguousarray(caudal_velocity, dtype=np.float64)
        osc = np.ascontiguousarray(oscillating, dtype=np.intc)
        code = _lib.af_run(
            self.handle, ctypes.c_int(w.n), ctypes.c_int(steps), _ints(self.bodies), _ints(self.active),
            _doubles(self.box_offsets), _doubles(self.axis_areas), _doubles(self.righting_w),
            _doubles(self.caudal_half), _doubles(self.caudal_mass), ctypes.c_double(self.drag_c),
            ctypes.c_int(self.quadratic), _doubles(self.current), ctypes.c_int(bool(prm.reactive_thrust)),
            ctypes.c_int(self.caudal_q), ctypes.c_int(self.caudal_u),
            ctypes.c_double(prm.caudal_position_gain), ctypes.c_double(prm.caudal_velocity_gain),
            ctypes.c_double(prm.caudal_max_torque), ctypes.c_int(len(osc)), _ints(osc), _doubles(angle),
            _doubles(velocity), *(_doubles(a) for a in state), _doubles(quats) if log else None,
            *self._surface_args())
        if code != 0:
            raise RuntimeError(f"compiled step failed with code {code} (-2: a state request failed, "
                               "-3: a robot without 3 joints)")
        w.position, w.orientation, w.linear_velocity, w.angular_velocity = state
        return quats
