"""The fluid wrench of the surface swimmer (``SimParams.waterline`` not None).

At the surface a continuous-rotation pectoral works as a paddle wheel: only the wetted
part of each stroke pushes water, so the stroke under water (blade moving backwards for a
negative speed) gives thrust and the stroke in the air gives none. In deep water the same
flipper is a fully submerged paddle wheel, whose mean thrust at constant speed is zero by
symmetry. The model per link:

* **body**: gravity at the centre of mass and buoyancy at the centre of buoyancy, from the
  submerged volume of the capsule (:mod:`aquafish_gym.hydrostatics`); face drag
  (:func:`~aquafish_gym.fluid.box_drag`) scaled by the wetted share of the hull;
* **pectorals**: blade-element strips (Blake 1979, "The mechanics of labriform
  locomotion", J. Exp. Biol. 82:255; Behbahani, Wang & Tan 2013, a robotic-fish pectoral
  fin model): each of ``SimParams.pectoral_strips`` strips along the flipper's length has
  its own velocity ``v + w x r`` relative to the water, its own wetted share, and the face
  drag of a box of its size; the strips' forces and their moments about the flipper's
  centre of mass add up. Thrust therefore rises with immersion depth, as a paddle wheel's
  does (Wray & Starrett 1970, Davidson Laboratory report SIT-DL-70-1428);
* **caudal fin**: face drag scaled by its wetted share s, and Lighthill's reactive force
  with the wetted height (added mass ``(pi/4) rho (s h)^2``).

The flippers are neutrally buoyant (their weight and buoyancy cancel wherever they are;
a pectoral's weight is 1.7 % of the body's buoyancy). A water current acts on every
wetted part (velocities are taken relative to the water). Left out: wave making, splash,
impulsive entry forces, added mass, and the free surface's own motion.

The pectorals' forces act on the body (the force at the body's centre of mass, its moment
about the flipper's centre of mass plus the strips' moment as a couple in the body's
torque), and so does the caudal reactive force's moment: the servos hold the flippers to
their commanded motion, so the rigid robot moves the same, and each robot needs two
PyBullet force calls (body and caudal fin) and one torque call per step instead of four and
one. (The pectoral servos are velocity-controlled with a torque limit far above the fluid's
torque on them; the caudal fin keeps its own force, as its position servo is soft.)

Every sum runs over a leading axis, term after term, and every product is written in the
order the compiled step evaluates it, so both paths give the same doubles.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquafish_gym.fluid import _cross
from aquafish_gym.hydrostatics import sequential_sum, hydrostatic_wrench, wetted_fraction
from aquafish_gym.params import SimParams
from aquafish_gym.robot import BODY_RADIUS, body_slices


@dataclasses.dataclass(frozen=True)
class SurfaceSpec:
    """Constants of the surface model for N robots (both paths read these doubles).

    Attributes:
        surface_z: ``(N,)`` world height of the free surface over each robot (units).
        ballast: the body's centre of mass below its centre (units).
        weight: ``(N,)`` the body's weight m g (force units).
        rho_g: rho g of the water.
        slices: ``(4, K)`` the hull's discs: axial position y, radius, weight w, w y.
        pi_weight: pi times the sum of the slice weights.
        strip_y: ``(N, 2, S)`` each pectoral strip's centre along the flipper's y axis,
            from its centre of mass (hinge end first).
        strip_areas: ``(N, 2, 3)`` a strip's face areas normal to x, y, z (units^2).
        pectoral_half: ``(N, 2, 3)`` half of (span, strip length, thickness) (units).
        caudal_half: ``(N, 3)`` half of the caudal fin's size (units).
        hinge_arm: ``(N, 2, 3)`` each pectoral's hinge from the body's centre of mass, body frame.
        fin_com: ``(N, 2, 3)`` each pectoral's centre of mass from its hinge, flipper frame.
    """

    surface_z: np.ndarray
    ballast: float
    weight: np.ndarray
    rho_g: float
    slices: np.ndarray
    pi_weight: float
    strip_y: np.ndarray
    strip_areas: np.ndarray
    pectoral_half: np.ndarray
    caudal_half: np.ndarray
    hinge_arm: np.ndarray
    fin_com: np.ndarray

    @classmethod
    def build(cls, spec, params: SimParams, home_z: np.ndarray) -> "SurfaceSpec":
        """From a :class:`~aquafish_gym.robot.RobotSpec`, the params and the ``(N,)`` home
        heights of the robots' centres of mass (where a reset puts them)."""
        n, strips = spec.masses.shape[0], params.pectoral_strips
        y, rho, w = body_slices()
        sizes = spec.sizes
        sx, sy, sz = sizes[:, :2, 0], sizes[:, :2, 1], sizes[:, :2, 2]
        seg = sy / strips
        centres = sy[..., None] / 2 - (np.arange(strips) + 0.5) * seg[..., None]
        return cls(
            surface_z=np.asarray(home_z, dtype=np.float64) + params.ballast_offset + params.waterline,
            ballast=params.ballast_offset,
            weight=spec.masses[:, 0] * params.gravity,
            rho_g=params.fluid_density * params.gravity,
            slices=np.stack([y, rho, w, w * y]),
            pi_weight=float(np.pi * np.sum(w)),
            strip_y=np.ascontiguousarray(centres),
            strip_areas=np.stack([seg * sz, sx * sz / strips, sx * seg], axis=-1),
            pectoral_half=np.stack([sx / 2, seg / 2, sz / 2], axis=-1),
            caudal_half=sizes[:, 2] / 2,
            hinge_arm=np.broadcast_to(np.array([[-BODY_RADIUS, 0.0, params.ballast_offset],
                                                [BODY_RADIUS, 0.0, params.ballast_offset]]), (n, 2, 3)).copy(),
            fin_com=spec.com_offsets[:, 1:3].copy(),
        )


def _drag(drag_c: float, quadratic: bool, area, u):
    """Face drag of one axis: ``drag_c * area * u * |u|`` or ``drag_c * area * u``."""
    return drag_c * area * u * np.abs(u) if quadratic else drag_c * area * u


def _local(rotation, vector):
    """``R^T a`` over the last axis, summed i = 0, 1, 2 (``(..., 3, 3)``, ``(..., 3)``)."""
    return rotation[..., 0, :] * vector[..., 0, None] + rotation[..., 1, :] * vector[..., 1, None] \
        + rotation[..., 2, :] * vector[..., 2, None]


def _half_height(rotation, half):
    """Vertical half-extent of boxes with half-sizes ``half`` ``(..., 3)`` rotated by ``rotation``."""
    return np.abs(rotation[..., 2, 0]) * half[..., 0] + np.abs(rotation[..., 2, 1]) * half[..., 1] \
        + np.abs(rotation[..., 2, 2]) * half[..., 2]


def surface_wrench(surface: SurfaceSpec, spec, params: SimParams, rotation, position, linear_velocity,
                   angular_velocity, water_current=None) -> tuple[np.ndarray, np.ndarray]:
    """Fluid and hydrostatic force and torque on every link of N surface swimmers.

    Args:
        surface: the model's constants (:class:`SurfaceSpec`).
        spec: the robots' :class:`~aquafish_gym.robot.RobotSpec`.
        params: :class:`SimParams` with a waterline.
        rotation: ``(N, 4, 3, 3)`` link-to-world rotations (body, left, right, caudal).
        position: ``(N, 4, 3)`` world positions of the links' centres of mass (units).
        linear_velocity: ``(N, 4, 3)`` their world velocities (units/s).
        angular_velocity: ``(N, 4, 3)`` world angular velocities (rad/s).
        water_current: ``(N, 3)`` each robot's water velocity (units/s, world frame);
            default: ``params.water_current`` for all.

    Returns:
        ``force (N, 4, 3)`` at each link's centre of mass and ``torque (N, 4, 3)`` about
        it, each in the link's own frame; the pectorals' forces and every torque but the
        body's are zero (the body carries them, see the module docstring).
    """
    quadratic = params.drag_law == "quadratic"
    drag_c = (-0.5 * params.drag_coefficient * params.fluid_density) if quadratic else -params.drag_coefficient
    current = np.asarray(params.water_current) if water_current is None else np.asarray(water_current)[:, None]
    n = rotation.shape[0]
    force = np.zeros((n, 4, 3))
    torque = np.zeros((n, 4, 3))
    rel = linear_velocity - current
    v_local = _local(rotation, rel)           # (N, 4, 3) link-frame velocity of each centre of mass
    w_local = _local(rotation, angular_velocity)
    surface_z = surface.surface_z

    # body: hydrostatics and wetted face drag about its centre of mass
    body = rotation[:, 0]
    centre_z = position[:, 0, 2] + body[:, 2, 2] * surface.ballast
    com_offset = np.array([0.0, 0.0, -surface.ballast])
    y, rho, w, _ = surface.slices
    f_hs, t_hs, wet = hydrostatic_wrench(body, centre_z, surface_z, com_offset, surface.weight, surface.rho_g,
                                         y, rho, w)
    offset = spec.box_offsets[:, 0]
    wb = w_local[:, 0]
    u = v_local[:, 0] + _cross(wb, offset)
    f_drag = _drag(drag_c, quadratic, spec.axis_areas[:, 0] * wet[:, None], u)
    force[:, 0] = f_hs + f_drag
    t_drag = _cross(offset, f_drag)
    couple = np.zeros((n, 3))  # world frame: the fins' couples, carried by the body

    # pectorals: wetted blade-element strips
    fins = rotation[:, 1:3]                                      # (N, 2, 3, 3)
    ys = np.moveaxis(surface.strip_y, -1, 0)                     # (S, N, 2)
    vl, wl = v_local[:, 1:3], w_local[:, 1:3]
    ux = vl[..., 0] - wl[..., 2] * ys
    uz = vl[..., 2] + wl[..., 0] * ys
    uy = vl[..., 1]
    z = position[:, 1:3, 2] + fins[..., 2, 1] * ys
    strip_wet = wetted_fraction(z, _half_height(fins, surface.pectoral_half), surface_z[:, None])
    areas = surface.strip_areas
    fx = _drag(drag_c, quadratic, areas[..., 0] * strip_wet, ux)
    fy = _drag(drag_c, quadratic, areas[..., 1] * strip_wet, uy)
    fz = _drag(drag_c, quadratic, areas[..., 2] * strip_wet, uz)
    fin_force = (sequential_sum(fx), sequential_sum(fy), sequential_sum(fz))                # (N, 2) each, flipper frame
    tx, tz = sequential_sum(ys * fz), sequential_sum(-(ys * fx))     # (0, y, 0) x F, about the centre of mass
    push = np.zeros((n, 3))                        # world frame: the pectorals' forces, carried by the body
    for k in range(2):
        r = fins[:, k]
        world = [r[:, i, 0] * fin_force[0][:, k] + r[:, i, 1] * fin_force[1][:, k] + r[:, i, 2] * fin_force[2][:, k]
                 for i in range(3)]
        # the flipper's centre of mass from the body's, from rotations only (not from the
        # world positions, whose rounding would depend on where the robot sits in the batch)
        h, c = surface.hinge_arm[:, k], surface.fin_com[:, k]
        arm = np.stack([(body[:, i, 0] * h[:, 0] + body[:, i, 1] * h[:, 1] + body[:, i, 2] * h[:, 2])
                        + (r[:, i, 0] * c[:, 0] + r[:, i, 1] * c[:, 1] + r[:, i, 2] * c[:, 2]) for i in range(3)],
                       axis=-1)
        world = np.stack(world, axis=-1)
        moment = _cross(arm, world)
        couple = couple + np.stack([(r[:, i, 0] * tx[:, k] + r[:, i, 2] * tz[:, k]) + moment[:, i] for i in range(3)],
                                   axis=-1)
        push = push + world
    force[:, 0] = force[:, 0] + _local(body, push)

    # caudal fin: wetted drag and the reactive force of its wetted height
    fin = rotation[:, 3]
    fin_wet = wetted_fraction(position[:, 3, 2], _half_height(fin, surface.caudal_half), surface_z)
    force[:, 3] = _drag(drag_c, quadratic, spec.axis_areas[:, 3] * fin_wet[:, None], v_local[:, 3])
    if params.reactive_thrust:
        half = spec.caudal_half_length
        wv = v_local[:, 3, 0] + half * w_local[:, 3, 2]
        mw = spec.caudal_added_mass * (fin_wet * fin_wet) * wv
        fx = -mw * v_local[:, 3, 1]
        force[:, 3, 0] += fx
        force[:, 3, 1] += 0.5 * mw * wv
        tzc = half * fx
        couple = couple + fin[:, :, 2] * tzc[:, None]
    torque[:, 0] = t_hs + t_drag + _local(body, couple)
    return force, torque


__all__ = ["SurfaceSpec", "surface_wrench"]
