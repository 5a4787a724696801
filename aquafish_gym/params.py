"""Physical parameters of the robot, its servos and the water (docs/physics.md).

Units: length in simulator units (1 unit = body diameter = 8 cm), mass in units of
(water density x unit volume) so that water has density 1, time in seconds. Gravity is
therefore 9.81 m/s^2 / 0.08 m = 122.6 units/s^2.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

DT_S = 0.01  #: physics step (s), paper section 4.
DRAG_LAWS = ("quadratic", "linear")
#: Default height of the free surface above the body's centre at rest (units): the surface
#: swimmer floats with the top 0.2 units (1.6 cm) of its 1.0-unit hull above water, its
#: pectoral hinges 0.3 units (2.4 cm) deep (docs/physics.md).
DEFAULT_WATERLINE = 0.3


@dataclasses.dataclass(frozen=True)
class SimParams:
    """Fluid, body and servo parameters; every field is also an ``AquaFish-v0`` kwarg.

    Attributes:
        drag_coefficient: c_d of every face (dimensionless), default 1.0.
        fluid_density: rho (mass units / unit^3), default 1.0 (water).
        drag_law: ``"quadratic"`` g(v) = rho v^2 / 2 (default) or ``"linear"`` g(v) = v,
            the lab's ODE model (Moore, Clark & McKinley, GECCO 2013, Algorithm 1).
        water_current: uniform water velocity (units/s, world frame), shape ``(3,)``.
        gravity: units/s^2 (default 122.6 = 9.81 m/s^2 at 1 unit = 8 cm).
        ballast_offset: distance (units) of the body's centre of mass below its centre of
            buoyancy; gives the righting moment. Default 0.05 (4 mm).
        pectoral_max_torque: servo torque limit of each pectoral motor.
        caudal_max_torque: servo torque limit of the caudal motor.
        caudal_amplitude_deg: half sweep of the caudal fin (degrees), paper: 30.
        caudal_position_gain, caudal_velocity_gain: PyBullet position-control gains.
        imu_noise_deg: standard deviation of Gaussian noise added to the IMU angles (deg).
        reactive_thrust: apply Lighthill's reactive force at the caudal fin's trailing
            edge (:func:`~aquafish_gym.fluid.reactive_force`), the fin's source of thrust.
            Default True; False gives the pure-drag model of the paper's lab, in which a
            rigid fin barely propels the robot.
        waterline: height (units) of the free surface above the body's centre of a robot
            at rest; default :data:`DEFAULT_WATERLINE` (0.3), a surface swimmer whose
            pectorals work as paddle wheels (:mod:`aquafish_gym.surface`). Must be > -0.5
            (the hull must displace water). ``None`` is deep water: the robot neutrally
            buoyant, far from any surface, gravity and buoyancy a couple (the model of
            every result published before the surface swimmer, kept bit for bit).
        pectoral_strips: blade-element strips along each pectoral flipper at the surface
            (each with its own velocity and wetted share; Blake 1979), default 12.
            Unused in deep water.

    Raises:
        ValueError: a field out of its allowed range (named in the message).
    """

    drag_coefficient: float = 1.0
    fluid_density: float = 1.0
    drag_law: str = "quadratic"
    water_current: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gravity: float = 122.6
    ballast_offset: float = 0.05
    pectoral_max_torque: float = 50.0
    caudal_max_torque: float = 50.0
    caudal_amplitude_deg: float = 30.0
    caudal_position_gain: float = 0.3
    caudal_velocity_gain: float = 1.0
    imu_noise_deg: float = 0.0
    reactive_thrust: bool = True
    waterline: float | None = DEFAULT_WATERLINE
    pectoral_strips: int = 12

    def __post_init__(self) -> None:
        nonneg = ("drag_coefficient", "fluid_density", "gravity", "ballast_offset", "imu_noise_deg")
        positive = ("pectoral_max_torque", "caudal_max_torque", "caudal_position_gain", "caudal_velocity_gain")
        for name in nonneg + positive:
            value = getattr(self, name)
            if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value):
                raise ValueError(f"SimParams.{name} must be a finite number, got {value!r}")
            if value < 0 or (name in positive and value == 0):
                kind = "> 0" if name in positive else ">= 0"
                raise ValueError(f"SimParams.{name} must be {kind}, got {value!r}")
            object.__setattr__(self, name, float(value))
        if self.ballast_offset >= 0.5:
            raise ValueError(f"SimParams.ballast_offset must be < 0.5 (the body radius), got {self.ballast_offset}")
        if not 0 < self.caudal_amplitude_deg <= 90:
            raise ValueError(f"SimParams.caudal_amplitude_deg must be in (0, 90], got {self.caudal_amplitude_deg}")
        if not isinstance(self.reactive_thrust, (bool, np.bool_)):
            raise ValueError(f"SimParams.reactive_thrust must be True or False, got {self.reactive_thrust!r}")
        object.__setattr__(self, "reactive_thrust", bool(self.reactive_thrust))
        if self.drag_law not in DRAG_LAWS:
            raise ValueError(f"SimParams.drag_law must be one of {DRAG_LAWS}, got {self.drag_law!r}")
        current = np.asarray(self.water_current, dtype=np.float64)
        if current.shape != (3,) or not np.all(np.isfinite(current)):
            raise ValueError(f"SimParams.water_current must be 3 finite numbers (units/s), got {self.water_current!r}")
        object.__setattr__(self, "water_current", tuple(current.tolist()))
        if self.waterline is not None:
            value = self.waterline
            if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.floating, np.integer)) \
                    or not math.isfinite(value) or value <= -0.5:
                raise ValueError(f"SimParams.waterline must be None (deep water) or a finite height > -0.5 units "
                                 f"(the surface above the body's centre), got {value!r}")
            object.__setattr__(self, "waterline", float(value))
            if self.fluid_density == 0 or self.gravity == 0:
                raise ValueError("SimParams.fluid_density and gravity must be > 0 at a free surface (the robot "
                                 f"floats on its buoyancy), got {self.fluid_density} and {self.gravity}; "
                                 "use waterline=None for deep water")
        strips = self.pectoral_strips
        if isinstance(strips, (bool, np.bool_)) or not isinstance(strips, (int, np.integer)) or not 1 <= strips <= 64:
            raise ValueError(f"SimParams.pectoral_strips must be an integer in [1, 64], got {strips!r}")
        object.__setattr__(self, "pectoral_strips", int(strips))

    @property
    def surface(self) -> bool:
        """Whether the robot floats at a free surface (``waterline`` is not None)."""
        return self.waterline is not None

    def replace(self, **changes) -> "SimParams":
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def field_names(cls) -> tuple[str, ...]:
        """Names of all parameters (usable as env kwargs)."""
        return tuple(f.name for f in dataclasses.fields(cls))

    @property
    def caudal_amplitude_rad(self) -> float:
        return math.radians(self.caudal_amplitude_deg)
