"""Vectorised fluid model: per-face drag, buoyancy righting moment (docs/physics.md).

Every link (body, left pectoral, right pectoral, caudal) is described by six faces with
outward normal n, area A and centre r (relative to the link's centre of mass, link frame).
For each face the velocity relative to the water is v_f = v + w x r - v_water; only faces
moving into the water (v_n = v_f . n > 0) feel a force

    F = -c_d * A * g(v_n) * n,   g(v) = rho v^2 / 2 (quadratic) or g(v) = v (linear),

applied at the face centre, so it also exerts a torque r x F about the link's centre of
mass. All faces of all links of all robots are computed in one NumPy pass.

For a box whose faces sit at +-h_k along its own axes, this reduces exactly to a closed
form (used by the simulator, :func:`box_drag`): with o the box centre relative to the
centre of mass and u = R^T (v - v_water) + w_l x o the box-centre velocity in the link
frame, face +-k moves into the water at speed +-u_k (the w x (h_k e_k) part is normal to
e_k), so the link-frame force is F_k = -c_d A_k g(|u_k|) sign(u_k) and the torque about the
centre of mass is o x F (e_k x e_k = 0). :func:`drag_wrench` is the general per-face
reference; a test checks that both agree.

Normal drag alone cannot propel a rigid fin (the mean thrust of a plate pitching in still
water is zero by symmetry), so the caudal fin also feels the *reactive* force of the water
it accelerates and sheds at its trailing edge (:func:`reactive_force`, Lighthill 1971).

This module is pure NumPy (no PyBullet): it is tested against hand-computed values.
"""

from __future__ import annotations

import numpy as np

# Face normals of a box in its own frame: +x, -x, +y, -y, +z, -z.
BOX_NORMALS = np.array(
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64
)


def box_faces(size) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Faces of boxes centred at their own origin.

    Args:
        size: ``(..., 3)`` box edge lengths (units).

    Returns:
        ``centres (..., 6, 3)``, ``normals (..., 6, 3)``, ``areas (..., 6)`` (units^2),
        faces ordered +x, -x, +y, -y, +z, -z. A zero edge gives zero-area faces, no NaN.
    """
    size = np.asarray(size, dtype=np.float64)
    half = size[..., None, :] / 2.0
    centres = BOX_NORMALS * half
    sx, sy, sz = size[..., 0], size[..., 1], size[..., 2]
    areas = np.stack([sy * sz, sy * sz, sx * sz, sx * sz, sx * sy, sx * sy], axis=-1)
    normals = np.broadcast_to(BOX_NORMALS, centres.shape).copy()
    return centres, normals, areas


def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrices from unit quaternions ``(..., 4)`` in PyBullet's (x, y, z, w) order -> ``(..., 3, 3)``."""
    q = np.asarray(q, dtype=np.float64)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    x2, y2, z2 = x + x, y + y, z + z
    xx, yy, zz, xy, xz, yz = x * x2, y * y2, z * z2, x * y2, x * z2, y * z2
    wx, wy, wz = w * x2, w * y2, w * z2
    out = np.empty(q.shape[:-1] + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = 1 - (yy + zz), xy - wz, xz + wy
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = xy + wz, 1 - (xx + zz), yz - wx
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = xz - wy, yz + wx, 1 - (xx + yy)
    return out


def drag_wrench(
    rotation: np.ndarray,
    linear_velocity: np.ndarray,
    angular_velocity: np.ndarray,
    face_centres: np.ndarray,
    face_normals: np.ndarray,
    face_areas: np.ndarray,
    *,
    drag_coefficient: float,
    fluid_density: float,
    drag_law: str = "quadratic",
    water_current=(0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Drag force and torque on many links at once.

    Args:
        rotation: ``(..., 3, 3)`` link-to-world rotation of each link's inertial frame.
        linear_velocity: ``(..., 3)`` world velocity of each link's centre of mass (units/s).
        angular_velocity: ``(..., 3)`` world angular velocity (rad/s).
        face_centres: ``(..., F, 3)`` face centres relative to the centre of mass, link frame.
        face_normals: ``(..., F, 3)`` outward unit normals, link frame.
        face_areas: ``(..., F)`` areas (units^2).
        drag_coefficient: c_d.
        fluid_density: rho (used by the quadratic law only).
        drag_law: ``"quadratic"`` or ``"linear"``.
        water_current: ``(3,)`` uniform water velocity, world frame (units/s), or any shape
            broadcasting against ``linear_velocity`` (one current per robot).

    Returns:
        ``force (..., 3)`` (world frame, to apply at the centre of mass) and
        ``torque (..., 3)`` (world frame, about the centre of mass).

    Raises:
        ValueError: unknown drag law.
    """
    r = np.einsum("...ij,...fj->...fi", rotation, face_centres)
    n = np.einsum("...ij,...fj->...fi", rotation, face_normals)
    v_face = (linear_velocity - np.asarray(water_current))[..., None, :] + _cross(angular_velocity[..., None, :], r)
    v_n = np.einsum("...fi,...fi->...f", v_face, n)
    v_n = np.maximum(v_n, 0.0)  # only faces moving into the water
    if drag_law == "quadratic":
        g = 0.5 * fluid_density * v_n * v_n
    elif drag_law == "linear":
        g = v_n
    else:
        raise ValueError(f"drag_law must be 'quadratic' or 'linear', got {drag_law!r}")
    face_force = -(drag_coefficient * face_areas * g)[..., None] * n
    force = face_force.sum(axis=-2)
    torque = _cross(r, face_force).sum(axis=-2)
    return force, torque


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product over the last axis (faster than ``np.cross`` for small arrays)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def box_drag(
    rotation: np.ndarray,
    linear_velocity: np.ndarray,
    angular_velocity: np.ndarray,
    box_offset: np.ndarray,
    axis_areas: np.ndarray,
    *,
    drag_coefficient: float,
    fluid_density: float,
    drag_law: str = "quadratic",
    water_current=(0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Drag on boxes in closed form, identical to :func:`drag_wrench` on their six faces.

    Args:
        rotation: ``(..., 3, 3)`` link-to-world rotation.
        linear_velocity: ``(..., 3)`` world velocity of the centre of mass (units/s).
        angular_velocity: ``(..., 3)`` world angular velocity (rad/s).
        box_offset: ``(..., 3)`` box centre relative to the centre of mass, link frame.
        axis_areas: ``(..., 3)`` area of the pair of faces normal to x, y, z (units^2).
        drag_coefficient: as :func:`drag_wrench`.
        fluid_density: as :func:`drag_wrench`.
        drag_law: as :func:`drag_wrench`.
        water_current: as :func:`drag_wrench`.

    Returns:
        ``force (..., 3)`` and ``torque (..., 3)`` about the centre of mass, both in the
        **link** frame.

    Raises:
        ValueError: unknown drag law.
    """
    rel = linear_velocity - np.asarray(water_current)
    v_local = (rotation * rel[..., :, None]).sum(axis=-2)  # R^T v
    w_local = (rotation * angular_velocity[..., :, None]).sum(axis=-2)
    u = v_local + _cross(w_local, box_offset)
    if drag_law == "quadratic":
        force = (-0.5 * drag_coefficient * fluid_density) * axis_areas * u * np.abs(u)
    elif drag_law == "linear":
        force = -drag_coefficient * axis_areas * u
    else:
        raise ValueError(f"drag_law must be 'quadratic' or 'linear', got {drag_law!r}")
    return force, _cross(box_offset, force)


def added_mass_per_length(height, fluid_density: float) -> np.ndarray:
    """Added mass per unit length of a flat fin section of height ``s``: m = (pi / 4) rho s^2.

    The added mass of a flat plate of width s accelerated normal to itself (the mass of a
    water cylinder of diameter s), per unit length, as in Lighthill (1971).

    Args:
        height: ``(...)`` fin height s (units), normal to both the fin's length and its normal.
        fluid_density: rho (mass units / unit^3).

    Returns:
        ``(...)`` m (mass units / unit); 0 for a fin of zero height.
    """
    height = np.asarray(height, dtype=np.float64)
    return 0.25 * np.pi * fluid_density * height * height


def reactive_force(
    rotation: np.ndarray,
    linear_velocity: np.ndarray,
    angular_velocity: np.ndarray,
    trailing_edge: np.ndarray,
    tangent: np.ndarray,
    normal: np.ndarray,
    added_mass: np.ndarray,
    *,
    water_current=(0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """Lighthill's reactive force at a fin's trailing edge, on many fins at once.

    Large-amplitude elongated-body theory (Lighthill 1971, "Large-amplitude elongated-body
    theory of fish locomotion", Proc. R. Soc. Lond. B 179:125-138): of the reactive force,
    the trailing-edge term, where the water shed into the wake carries away lateral
    momentum (the other term, the time derivative of the lateral momentum of the water
    along the fin, averages to zero over a beat and is left out). The fin feels

        F = m w u n - (1/2) m w^2 t,

    with t the unit vector along the fin towards its trailing edge, n the fin's normal,
    u = v_te . t and w = v_te . n the tangential and normal components of the trailing-edge
    velocity relative to the water, and m = (pi / 4) rho s^2 the added mass per unit length
    (:func:`added_mass_per_length`). The same term drives the tail-actuated robotic-fish
    models of Wang & Tan (e.g. "A dynamic model for tail-actuated robotic fish with drag
    coefficient adaptation", Mechatronics 23, 2013). For a fin pitching about a hinge in
    still water u = 0 and F = -(1/2) m w^2 t points from the tip towards the hinge: thrust.
    (Flipping n flips w too, so F does not depend on the normal's sign.)

    Args:
        rotation: ``(..., 3, 3)`` link-to-world rotation.
        linear_velocity: ``(..., 3)`` world velocity of the link's centre of mass (units/s).
        angular_velocity: ``(..., 3)`` world angular velocity (rad/s).
        trailing_edge: ``(..., 3)`` trailing-edge midpoint relative to the centre of mass,
            link frame (units).
        tangent: ``(..., 3)`` unit t (towards the trailing edge), link frame.
        normal: ``(..., 3)`` unit n, link frame.
        added_mass: ``(...)`` m (mass units / unit); 0 switches a fin off.
        water_current: ``(3,)`` uniform water velocity, world frame (units/s), or any shape
            broadcasting against ``linear_velocity`` (one current per robot).

    Returns:
        ``force (..., 3)`` (link frame, acting at the trailing edge) and ``torque (..., 3)``
        (link frame, its moment ``trailing_edge x force`` about the centre of mass).
    """
    rel = linear_velocity - np.asarray(water_current)
    v_local = (rotation * rel[..., :, None]).sum(axis=-2)  # R^T v
    w_local = (rotation * angular_velocity[..., :, None]).sum(axis=-2)
    v_te = v_local + _cross(w_local, trailing_edge)
    u = (v_te * tangent).sum(axis=-1)
    w = (v_te * normal).sum(axis=-1)
    m = np.asarray(added_mass, dtype=np.float64)
    force = (m * w * u)[..., None] * normal - (0.5 * m * w * w)[..., None] * tangent
    return force, _cross(trailing_edge, force)


def caudal_reactive_force(
    rotation: np.ndarray,
    linear_velocity: np.ndarray,
    angular_velocity: np.ndarray,
    half_length: np.ndarray,
    added_mass: np.ndarray,
    *,
    water_current=(0.0, 0.0, 0.0),
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`reactive_force` in closed form for fins lying along -y of their link frame.

    The caudal fin's link frame has the fin along -y from the hinge (t = -y), its normal
    along x (n = x) and the centre of mass halfway, so the trailing edge is at
    r = (0, -l/2, 0) from it. Then, with (v, w_l) the centre-of-mass velocity relative to the
    water and the angular velocity in the link frame, u = -v_y, w = v_x + (l/2) w_z and

        F = (m w u, m w^2 / 2, 0),   r x F = (0, 0, (l/2) F_x).

    Identical to :func:`reactive_force` with those vectors (a test checks it), at a
    fraction of the NumPy calls; the simulator uses this one.

    Args:
        rotation: ``(..., 3, 3)`` link-to-world rotation.
        linear_velocity: ``(..., 3)`` world velocity of the centre of mass (units/s).
        angular_velocity: ``(..., 3)`` world angular velocity (rad/s).
        half_length: ``(...)`` l/2, centre of mass to trailing edge (units).
        added_mass: ``(...)`` m (mass units / unit); 0 switches a fin off.
        water_current: ``(3,)`` uniform water velocity, world frame (units/s), or any shape
            broadcasting against ``linear_velocity`` (one current per robot).

    Returns:
        ``force (..., 3)`` and ``torque (..., 3)`` about the centre of mass, link frame.
    """
    rel = linear_velocity - np.asarray(water_current)
    vx = (rotation[..., :, 0] * rel).sum(axis=-1)  # (R^T v)_x
    vy = (rotation[..., :, 1] * rel).sum(axis=-1)
    wz = (rotation[..., :, 2] * angular_velocity).sum(axis=-1)
    w = vx + half_length * wz
    mw = added_mass * w
    force = np.zeros(np.shape(w) + (3,))
    force[..., 0] = -mw * vy
    force[..., 1] = 0.5 * mw * w
    torque = np.zeros_like(force)
    torque[..., 2] = half_length * force[..., 0]
    return force, torque


def righting_torque(rotation: np.ndarray, mass: np.ndarray, gravity: float, ballast_offset: float) -> np.ndarray:
    """Couple of gravity and buoyancy on a neutrally buoyant, ballasted body.

    Gravity (-m g z) acts at the centre of mass, buoyancy (+m g z) at the centre of
    buoyancy, ``ballast_offset`` above it in the body frame. Their resultant is no force
    and the torque (R @ [0, 0, h]) x (0, 0, m g).

    Args:
        rotation: ``(..., 3, 3)`` body-to-world rotation.
        mass: ``(...)`` mass of the robot (mass units).
        gravity: units/s^2.
        ballast_offset: h (units).

    Returns:
        ``(..., 3)`` torque (world frame) about the centre of mass.
    """
    w = np.asarray(mass) * gravity * ballast_offset
    out = np.zeros(rotation.shape[:-1])
    out[..., 0] = rotation[..., 1, 2] * w  # (R z_b h) x (0, 0, m g)
    out[..., 1] = -rotation[..., 0, 2] * w
    return out
