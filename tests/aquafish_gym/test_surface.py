"""The surface swimmer (the default physics): hydrostatics and wetted paddles against hand-computed values.

Reference numbers for the level capsule (radius r = 0.5, cylinder length L = 0.625) with
the free surface h above its centre come from closed forms: a circular segment for the
cylinder, a spherical cap for the two hemispheres (together one sphere).
"""

import math

import numpy as np
import pytest

from aquafish_gym import BatchWorld, Morphology, SimParams, get_damage
from aquafish_gym.bullet import p
from aquafish_gym.hydrostatics import acos_poly, capsule_slices, hydrostatic_wrench, submerged_slices
from aquafish_gym.robot import BODY_CYLINDER_LENGTH as L, BODY_RADIUS as R, robot_spec
from aquafish_gym.surface import SurfaceSpec, surface_wrench

HEALTHY = Morphology.healthy().to_array()
NO_TAIL = Morphology.healthy().replace(caudal_x=0, caudal_y=0, caudal_z=0).to_array()
SLICES = capsule_slices(R, L)


def level_capsule(h):
    """Closed forms at surface height h above the centre: volume, centre-of-buoyancy height,
    waterplane area, waterplane second moments about the long (roll) and lateral (pitch) axes."""
    segment = R * R * (math.pi - math.acos(h / R)) + h * math.sqrt(R * R - h * h)
    cap = math.pi * (R - h) ** 2 * (3 * R - (R - h)) / 3          # the sphere above the surface
    volume = segment * L + 4 / 3 * math.pi * R**3 - cap
    moment = -(2 / 3) * (R * R - h * h) ** 1.5 * L + math.pi * ((R * R * h * h / 2 - h**4 / 4) - R**4 / 4)
    b = math.sqrt(R * R - h * h)                                  # half-width of the waterplane
    area = 2 * b * L + math.pi * b * b
    i_roll = L * (2 * b) ** 3 / 12 + math.pi * b**4 / 4
    half_disc = math.pi * b * b / 2
    i_pitch = 2 * b * L**3 / 12 + 2 * ((L / 2) ** 2 * half_disc + 2 * (L / 2) * (2 * b**3 / 3) + math.pi * b**4 / 8)
    return volume, moment / volume, area, i_roll, i_pitch


def rotation_about(axis, angle):
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def test_acos_polynomial_is_within_its_published_error():
    x = np.linspace(-1, 1, 20001)
    assert np.abs(acos_poly(x) - np.arccos(x)).max() < 2.5e-8


@pytest.mark.parametrize("h", [-0.4, -0.1, 0.0, 0.3, 0.45])
def test_level_submerged_volume_and_centre_of_buoyancy_match_closed_forms(h):
    volume, zb, *_ = level_capsule(h)
    v, moment, wetted = submerged_slices(np.eye(3), np.float64(0.0), h, *SLICES)
    assert v == pytest.approx(volume, abs=1e-4)
    assert moment[2] / v == pytest.approx(zb, abs=2e-4)
    assert moment[0] == pytest.approx(0.0, abs=1e-12) and moment[1] == pytest.approx(0.0, abs=1e-12)
    # wetted share of the hull: the cylinder's wet arc, and the sphere's zone below h (2 pi r (r + h))
    hull = 2 * math.pi * R * L + 4 * math.pi * R * R
    wet = 2 * R * (math.pi - math.acos(h / R)) * L + 2 * math.pi * R * (R + h)
    assert wetted == pytest.approx(wet / hull, abs=2e-3)


@pytest.mark.parametrize("axis, which", [("y", "roll"), ("x", "pitch")])
def test_small_tilt_restoring_moment_matches_the_metacentric_height(axis, which):
    # M = rho g V GM sin(theta), GM = z_B + I / V - z_G (Fossen 2011, sec. 4.2); for the roll
    # of a body with circular sections the metacentre is the centre: GM_T = ballast offset.
    prm = SimParams()
    h, ballast, rho_g = prm.waterline, prm.ballast_offset, prm.fluid_density * prm.gravity
    volume, zb, _, i_roll, i_pitch = level_capsule(h)
    gm = zb + (i_roll if which == "roll" else i_pitch) / volume + ballast
    if which == "roll":
        assert gm == pytest.approx(ballast, abs=1e-9)
    theta = math.radians(2.0)
    rot = rotation_about(axis, theta)
    _, torque, _ = hydrostatic_wrench(rot, np.float64(0.0), h, np.array([0, 0, -ballast]), rho_g * volume, rho_g,
                                      *SLICES)
    k = 1 if axis == "y" else 0
    assert torque[k] == pytest.approx(-rho_g * volume * gm * math.sin(theta), rel=0.03)


def _world(morph=HEALTHY, params=None, faults=None, n=1):
    morph = np.asarray(morph)
    return BatchWorld(morph if morph.ndim == 2 else np.tile(morph, (n, 1)), params if params is not None else SimParams(), faults, native=False)


def _drop(world, dz):
    """Put the robot dz above (+) or below its floating height, at rest."""
    pos, orn = p.getBasePositionAndOrientation(world.bodies[0], physicsClientId=world.client)
    p.resetBasePositionAndOrientation(world.bodies[0], (pos[0], pos[1], pos[2] + dz), orn, physicsClientId=world.client)
    world._read_state()


def test_robot_at_its_draft_is_in_equilibrium():
    with _world() as world:
        world.reset(np.zeros((1, 3)))
        force, torque = world.fluid_wrench()
        assert np.abs(force[0, 0]).max() < 1e-9 and np.abs(torque[0, 0]).max() < 1e-9


@pytest.mark.parametrize("dz", [0.15, -0.15])
def test_robot_released_off_its_draft_settles_to_it(dz):
    # It bobs about its draft, damped by drag alone (no wave radiation in the model): the
    # mean height over the last six heave periods (3.27 s) is the draft, and the bobbing
    # has died down.
    with _world() as world:
        world.reset(np.zeros((1, 3)))
        _drop(world, dz)
        z = []
        for _ in range(800):
            world.step()
            z.append(world.position[0, 0, 2] - world.home[0, 2])
    last = np.array(z[-327:])
    assert abs(last.mean()) < 2e-3 and np.abs(last[-100:]).max() < 0.35 * abs(dz)


def test_heave_period_matches_waterplane_stiffness_and_mass():
    # T = 2 pi sqrt(m / (rho g A_wp)) for the hull alone (flippers would couple heave with
    # pitch: their mass sits aft of the centre of buoyancy); the model has no added mass
    # (PyBullet integrates the rigid-body mass only; a real hull's would lengthen T).
    prm = SimParams()
    _, _, area, _, _ = level_capsule(prm.waterline)
    with _world(np.zeros(9), params=prm) as world:
        mass = world.spec.masses[0].sum()
        world.reset(np.zeros((1, 3)))
        _drop(world, 0.01)
        z = []
        for _ in range(200):
            world.step()
            z.append(world.position[0, 0, 2] - world.home[0, 2])
    z = np.array(z)
    up = np.flatnonzero((z[:-1] < 0) & (z[1:] >= 0))             # upward zero crossings
    period = (up[-1] - up[0]) / (len(up) - 1) * 0.01
    assert period == pytest.approx(2 * math.pi * math.sqrt(mass / (prm.fluid_density * prm.gravity * area)), rel=0.03)


def _pectoral_held_still(angle, omega, strips, waterline=0.3):
    """The surface wrench on a robot at rest at its draft, its left pectoral at ``angle`` (rad,
    + turns the tip down) turning at ``omega`` (rad/s) about the lateral axis: the pectoral's
    force in its own frame and in the body's."""
    prm = SimParams(pectoral_strips=strips, reactive_thrust=False, waterline=waterline)
    spec = robot_spec(HEALTHY[None], prm)
    surface = SurfaceSpec.build(spec, prm, np.zeros(1))          # body's centre of mass at z = 0
    rot = np.tile(np.eye(3), (1, 4, 1, 1))
    rot[0, 1] = rotation_about("x", angle)
    hinge = np.array([-R, 0, prm.ballast_offset])                 # on the body's centre line
    position = np.zeros((1, 4, 3))
    position[0, 1] = hinge + rot[0, 1] @ np.array([0, -HEALTHY[1] / 2, 0])   # the flipper's centre of mass
    angular = np.zeros((1, 4, 3))
    angular[0, 1, 0] = omega
    linear = np.zeros((1, 4, 3))
    linear[0, 1] = np.cross(angular[0, 1], position[0, 1] - hinge)
    force, _ = surface_wrench(surface, spec, prm, rot, position, linear, angular)
    # the body carries the pectoral's force; the level body at rest at its draft feels nothing else
    on_body = force[0, 0]
    assert np.all(force[0, 1:3] == 0)
    return rot[0, 1].T @ on_body, on_body, prm


@pytest.mark.parametrize("angle_deg", [30.0, -15.0, -30.0, -60.0])
def test_blade_element_thrust_of_a_robot_held_still_equals_the_strip_integral(angle_deg):
    # A blade strip at distance s from the hinge moves at omega s along its normal: drag
    # rho c_d span (omega s)^2 / 2 per length, on the wetted part s < depth / sin(tip up).
    omega, span, length = math.pi, HEALTHY[0], HEALTHY[1]
    force, _, prm = _pectoral_held_still(math.radians(angle_deg), omega, strips=64)
    rise = -math.sin(math.radians(angle_deg))                     # tip height per unit of s
    wet = length if rise <= 0 else min(length, prm.waterline / rise)
    expected = 0.5 * prm.fluid_density * prm.drag_coefficient * span * omega**2 * wet**3 / 3
    assert force[2] == pytest.approx(expected, rel=0.02)          # along the blade's normal (+z of the flipper)
    assert abs(force[0]) < 1e-12 and abs(force[1]) < 1e-12
    coarse, _, _ = _pectoral_held_still(math.radians(angle_deg), omega, strips=12)   # the default resolution
    assert coarse[2] == pytest.approx(expected, rel=0.08)


def _swim(actions, morph=HEALTHY, params=None, faults=None, seconds=20.0, angles=None):
    """Displacement (world x, y, z) and final yaw (deg) of robots from rest, zero initial angles."""
    actions = np.atleast_2d(actions)
    n = len(actions)
    with _world(morph, params, faults, n) as world:
        world.reset(np.zeros((n, 3)) if angles is None else angles, actions)
        start = world.position[:, 0].copy()
        for _ in range(int(round(seconds / 0.01))):
            world.step()
        return world.position[:, 0] - start, world.imu_rpy_deg()[:, 2]


def test_tailless_robot_paddles_forward_and_reversed_paddles_swim_it_backwards():
    (forward, backward), _ = _swim([[-0.5, -0.5, 0.0], [0.5, 0.5, 0.0]], NO_TAIL, seconds=10.0)
    assert forward[1] > 3.0 and backward[1] < -3.0               # units in 10 s
    assert abs(forward[0]) < 0.05 * forward[1]                    # and straight


def test_mean_paddle_thrust_vanishes_in_the_deep_limit():
    # Over a revolution of a paddle held at constant speed on a still robot: forward thrust
    # at the surface (the stroke under water pushes backwards), none when the free surface
    # is far above (a fully submerged paddle wheel, zero by symmetry).
    angles = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    def mean_thrust(waterline):
        return np.mean([_pectoral_held_still(a, -math.pi, 12, waterline)[1][1] for a in angles])
    surface, deep = mean_thrust(0.3), mean_thrust(40.0)
    assert surface > 0.05
    assert abs(deep) < 1e-3 * surface


def test_robot_is_symmetric_left_right():
    # Mirrored paddling (x -> -x) gives the mirrored path: x and yaw flip, y is the same.
    (a, b), yaw = _swim([[-0.5, -0.2, 0.0], [-0.2, -0.5, 0.0]], NO_TAIL, seconds=5.0)
    assert a[0] == pytest.approx(-b[0], rel=1e-3, abs=1e-6) and a[1] == pytest.approx(b[1], rel=1e-3)
    assert yaw[0] == pytest.approx(-yaw[1], rel=1e-3) and abs(yaw[0]) > 10.0


def test_differential_paddling_turns_towards_the_slower_side():
    # Only the left paddle pushes: the left side is driven forward, the robot turns right
    # (yaw decreases, z up); only the right one: it turns left.
    _, yaw = _swim([[-0.5, 0.0, 0.0], [0.0, -0.5, 0.0]], NO_TAIL, seconds=5.0)
    assert yaw[0] < -20.0 and yaw[1] > 20.0


def test_weaker_left_pectoral_turns_the_robot_left():
    # A half-length left paddle pushes less water than the right one: the robot turns left.
    damaged = get_damage("left_pectoral_half").apply().to_array()
    _, (healthy_yaw, damaged_yaw) = _swim([[-0.5, -0.5, 0.0]] * 2, np.stack([NO_TAIL, np.concatenate([damaged[:6], np.zeros(3)])]),
                                          seconds=5.0)
    assert abs(healthy_yaw) < 1.0 and damaged_yaw > 10.0


def test_zero_size_fins_give_no_nan_on_either_surface_or_deep_limit():
    morph = np.zeros((2, 9))
    morph[1, :3] = [0.25, 1.0, 0.0]                               # a flipper without thickness
    for params in (SimParams(), SimParams(waterline=-0.45), SimParams(waterline=30.0)):
        displacement, yaw = _swim([[0.5, -0.5, 1.0]] * 2, morph, params, seconds=1.0)
        assert np.all(np.isfinite(displacement)) and np.all(np.isfinite(yaw))


@pytest.mark.parametrize("value", [-0.5, -1.0, float("nan"), float("inf"), True, "0.3"])
def test_bad_waterline_is_refused(value):
    with pytest.raises(ValueError, match="waterline"):
        SimParams(waterline=value)


def test_a_reversed_servo_turns_the_wrong_way_and_the_mirrored_command_undoes_it():
    # reversed_left_pectoral: gain -1 on the left servo. The healthy command paddles the left
    # flipper backwards (the robot veers); flipping the left command swims it exactly as the
    # healthy robot swims under the healthy command.
    reversed_left = get_damage("reversed_left_pectoral").faults
    (broken,), _ = _swim([[-0.5, -0.5, 0.0]], NO_TAIL, faults=reversed_left, seconds=5.0)
    (fixed,), fixed_yaw = _swim([[0.5, -0.5, 0.0]], NO_TAIL, faults=reversed_left, seconds=5.0)
    (healthy,), healthy_yaw = _swim([[-0.5, -0.5, 0.0]], NO_TAIL, seconds=5.0)
    np.testing.assert_array_equal(fixed, healthy)
    np.testing.assert_array_equal(fixed_yaw, healthy_yaw)
    assert broken[1] < 0.3 * healthy[1]


@pytest.mark.parametrize("scale", [(-1.5, 1.0, 1.0), (1.0, 1.0, -0.5)])
def test_servo_gains_out_of_range_are_refused(scale):
    from aquafish_gym import ServoFaults

    with pytest.raises(ValueError, match="speed_scale"):
        ServoFaults(speed_scale=scale)


def test_tilted_submerged_volume_and_centre_match_a_fine_slicing():
    # Where the robot swims (drafts 0.1-0.45 above the centre, tilts up to 30 deg) the default
    # 26 discs agree with 1,200 to 1.2e-4 of the volume and 1e-4 units of the centre.
    fine = capsule_slices(R, L, 400, 400)
    rng = np.random.default_rng(1)
    for _ in range(40):
        axis = np.array([*rng.normal(size=2), 0.0])
        axis /= np.linalg.norm(axis)
        tilt, turn = math.radians(rng.uniform(0, 30)), rng.uniform(0, 2 * math.pi)
        k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
        rot = (np.eye(3) + math.sin(tilt) * k + (1 - math.cos(tilt)) * k @ k) @ np.array(
            [[math.cos(turn), -math.sin(turn), 0], [math.sin(turn), math.cos(turn), 0], [0, 0, 1]])
        h = rng.uniform(0.1, 0.45)
        v, m, _ = submerged_slices(rot, np.float64(0.0), h, *SLICES)
        v_ref, m_ref, _ = submerged_slices(rot, np.float64(0.0), h, *fine)
        assert v == pytest.approx(v_ref, rel=1.5e-4)
        np.testing.assert_allclose(m / v, m_ref / v_ref, atol=1.5e-4)


@pytest.mark.parametrize("native", [False, None])
def test_a_robots_log_does_not_depend_on_its_place_in_the_batch(native):
    # bit for bit: nothing of the surface model may read the robots' world positions but their height
    from aquafish_gym import simulate_batch

    damaged = get_damage("left_pectoral_half").apply().to_array()
    alone = simulate_batch(damaged, [[-0.5, 0.3, 1.0]], [[1.0, 2.0, 0.2]], 64, native=native)
    morph = np.tile(HEALTHY, (13, 1))
    morph[12] = damaged                                           # the 13th robot: another row and column
    actions, angles = np.tile([0.4, -0.5, 0.5], (13, 1)), np.zeros((13, 3))
    actions[12], angles[12] = [-0.5, 0.3, 1.0], [1.0, 2.0, 0.2]
    np.testing.assert_array_equal(simulate_batch(morph, actions, angles, 64, native=native)[12], alone[0])
