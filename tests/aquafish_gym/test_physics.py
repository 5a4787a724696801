"""Whole-robot physics in deep water (``waterline=None``): behaviours a wrong model would break.

The surface swimmer (the default) has its own tests in ``test_surface.py``."""

import math

import numpy as np
import pytest

from aquafish_gym.bullet import p
from aquafish_gym import BatchWorld, Morphology, SimParams, get_damage, simulate_batch
from aquafish_gym.robot import BODY_CYLINDER_LENGTH, BODY_RADIUS

#: Deep water: the model these tests pin (the default is the surface swimmer).
DEEP = SimParams(waterline=None)
NO_FLIPPERS = np.zeros(9)
HEALTHY = Morphology.healthy().to_array()
NO_PECTORALS = Morphology.healthy().replace(
    left_pectoral_x=0, left_pectoral_y=0, left_pectoral_z=0, right_pectoral_x=0, right_pectoral_y=0, right_pectoral_z=0
).to_array()


def push_to_terminal_velocity(params: SimParams, force: float, steps: int) -> float:
    with BatchWorld(NO_FLIPPERS[None], params) as world:
        world.reset(np.zeros((1, 3)))
        for _ in range(steps):
            p.applyExternalForce(world.bodies[0], -1, (0, force, 0), (0, 0, 0), p.LINK_FRAME, physicsClientId=world.client)
            world.step()
        return float(world.linear_velocity[0, 0, 1])


def test_constant_force_reaches_quadratic_terminal_velocity():
    params = DEEP.replace(drag_coefficient=1.0, fluid_density=1.0)
    area = math.pi * BODY_RADIUS**2  # the capsule's end-on projected area
    expected = math.sqrt(2 * 1.0 / (params.drag_coefficient * params.fluid_density * area))  # F = c_d A rho v^2 / 2
    assert push_to_terminal_velocity(params, 1.0, 1500) == pytest.approx(expected, rel=0.01)


def test_constant_force_reaches_linear_terminal_velocity():
    params = DEEP.replace(drag_law="linear", drag_coefficient=2.0)
    area = math.pi * BODY_RADIUS**2
    expected = 1.0 / (2.0 * area)  # F = c_d A v
    assert push_to_terminal_velocity(params, 1.0, 1500) == pytest.approx(expected, rel=0.01)


def test_no_actuation_stays_still():
    log = simulate_batch(HEALTHY, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 300, params=DEEP)
    np.testing.assert_allclose(log, 0.0, atol=1e-6)
    with BatchWorld(HEALTHY[None], DEEP) as world:
        world.reset(np.zeros((1, 3)), np.zeros((1, 3)))
        for _ in range(300):
            world.step()
        np.testing.assert_allclose(world.position[0, 0], world.home[0], atol=1e-6)


def test_symmetric_robot_swims_straight_and_half_flipper_turns():
    damaged = get_damage("left_pectoral_half").apply().to_array()
    log = simulate_batch(np.stack([HEALTHY, damaged]), [[0.5, 0.5, 0.0]] * 2, np.zeros((2, 3)), 500, params=DEEP)
    assert np.abs(log[0, :, 2]).max() < 1.0
    assert np.abs(log[1, :, 2]).max() > 5.0


def test_mirrored_pectorals_give_the_mirrored_response():
    # Reflection in the body's sagittal plane (x -> -x) swaps the pectorals (both hinge on the
    # lateral x axis, so their spin keeps its sign) and negates roll and yaw; pitch is unchanged.
    # The caudal fin is left still at 0: its sweep starts towards +angle whatever its initial
    # angle, so a moving fin has no mirror image (lph and rph are different targets).
    left = get_damage("left_pectoral_half").apply().to_array()
    right = get_damage("right_pectoral_half").apply().to_array()
    log = simulate_batch(np.stack([left, right]), [[0.3, -0.2, 0.0], [-0.2, 0.3, 0.0]],
                         np.array([[1.0, 2.5, 0.0], [2.5, 1.0, 0.0]]), 300)
    assert np.abs(log[0, :, 2]).max() > 5.0                       # it turns: there is something to mirror
    np.testing.assert_allclose(log[1, :, 0], -log[0, :, 0], atol=1e-4)
    np.testing.assert_allclose(log[1, :, 1], log[0, :, 1], atol=1e-4)
    np.testing.assert_allclose(log[1, :, 2], -log[0, :, 2], atol=1e-4)


def test_rolled_robot_rights_itself():
    with BatchWorld(HEALTHY[None], DEEP) as world:
        world.reset(np.zeros((1, 3)))
        q = p.getQuaternionFromAxisAngle((0, 1, 0), math.radians(30))
        p.resetBasePositionAndOrientation(world.bodies[0], world.home[0].tolist(), q, physicsClientId=world.client)
        world._read_state()
        assert world.imu_rpy_deg()[0, 0] == pytest.approx(30.0, abs=1e-4)
        rolls = []
        for _ in range(1000):
            world.step()
            rolls.append(world.imu_rpy_deg()[0, 0])
    rolls = np.abs(rolls)
    assert rolls[-100:].max() < 5.0  # back near level after 10 s
    assert rolls[:50].min() < 20.0  # and it started turning back at once


def swim(morphologies, actions, steps: int, params: SimParams | None = None):
    """Swim robots from rest (flippers at 0) for ``steps``; return (displacement (N, 3), body velocity (N, steps, 3))."""
    morphologies = np.atleast_2d(morphologies)
    n = len(morphologies)
    velocity = np.empty((n, steps, 3))
    with BatchWorld(morphologies, params if params is not None else DEEP) as world:
        world.reset(np.zeros((n, 3)), np.broadcast_to(actions, (n, 3)))
        for k in range(steps):
            world.step()
            velocity[:, k] = world.linear_velocity[:, 0]
        return world.position[:, 0] - world.home, velocity


def test_caudal_fin_alone_swims_forward():
    ((dx, dy, _),), _ = swim(NO_PECTORALS, [0.0, 0.0, 1.0], 1000)
    assert dy > 1.0 and abs(dx) < 0.1 * dy


def test_caudal_thrust_from_rest_is_positive_and_grows_with_frequency():
    displacement, _ = swim(np.tile(NO_PECTORALS, (3, 1)), [[0, 0, 0.25], [0, 0, 0.5], [0, 0, 1.0]], 500)
    forward = displacement[:, 1]
    assert 0 < forward[0] < forward[1] < forward[2]


def test_pure_drag_model_barely_swims():
    """``reactive_thrust=False`` is the lab's pure-drag model: a rigid fin gives almost no thrust."""
    ((_, dy_drag, _),), _ = swim(NO_PECTORALS, [0.0, 0.0, 1.0], 1000, DEEP.replace(reactive_thrust=False))
    ((_, dy, _),), _ = swim(NO_PECTORALS, [0.0, 0.0, 1.0], 1000)
    assert 0 < dy_drag < 0.05 * dy


def test_caudal_only_steady_speed_and_strouhal_number():
    """Steady speed of the caudal fin at 1 Hz against Lighthill's small-amplitude estimate.

    Mean thrust of a fin pitching with amplitude A about a hinge L ahead of its trailing
    edge (lateral excursion h = L sin(A sin wt), slope ~ A sin wt): Lighthill's
    T = (m / 2) <h_t^2 - U^2 h_x^2> = (m A^2 / 4) (L^2 w^2 - U^2). Against quadratic drag
    (rho c_d S / 2) U^2 on the frontal area S (capsule end pi r^2 plus the fin's edge) this
    gives U = L w sqrt((m A^2 / 4) / (rho c_d S / 2 + m A^2 / 4)) = 0.715 units/s. The
    simulated robot also pays for the fin's lateral drag and its yaw recoil, so it must be
    somewhat slower, never faster. Literature band: small servo-driven robotic fish swim
    0.2-1 body lengths/s; the pure-drag model gave St ~ 34.
    """
    prm = DEEP
    morph = Morphology.from_array(NO_PECTORALS)
    length, height, thickness = morph.caudal_y, morph.caudal_z, morph.caudal_x
    amplitude, omega = prm.caudal_amplitude_rad, 2 * math.pi * 1.0
    m = math.pi / 4 * prm.fluid_density * height**2
    frontal = math.pi * BODY_RADIUS**2 + thickness * height
    drag = 0.5 * prm.fluid_density * prm.drag_coefficient * frontal
    u_lighthill = length * omega * math.sqrt((m * amplitude**2 / 4) / (drag + m * amplitude**2 / 4))
    assert u_lighthill == pytest.approx(0.715, abs=0.002)

    _, velocity = swim(NO_PECTORALS, [0.0, 0.0, 1.0], 2000)
    speed = velocity[0, -500:, 1].mean()  # mean over the last 5 s (5 beats)
    assert 0.5 * u_lighthill < speed < 1.05 * u_lighthill
    body_lengths_per_s = speed / (2 * BODY_RADIUS + BODY_CYLINDER_LENGTH)
    assert 0.2 <= body_lengths_per_s <= 1.0
    strouhal = 1.0 * 2 * length * math.sin(amplitude) / speed  # f x peak-to-peak trailing-edge excursion / U
    assert 1.0 < strouhal < 2.5


def test_robot_without_caudal_fin_does_not_move_under_a_caudal_command():
    tailless = get_damage("caudal_missing").apply().to_array()
    displacement, _ = swim(tailless, [0.0, 0.0, 1.0], 1000)
    assert np.abs(displacement).max() < 1e-3


def test_water_current_carries_the_robot():
    """A body at rest in a current accelerates by quadratic drag: c - v(t) = c / (1 + c k t), k = rho c_d S / (2 M)."""
    current = 0.5
    prm = DEEP.replace(water_current=(0.0, current, 0.0))
    _, velocity = swim(NO_FLIPPERS, [0.0, 0.0, 0.0], 1000, prm)
    mass = math.pi * BODY_RADIUS**2 * BODY_CYLINDER_LENGTH + 4 / 3 * math.pi * BODY_RADIUS**3
    k = 0.5 * prm.fluid_density * prm.drag_coefficient * math.pi * BODY_RADIUS**2 / mass
    expected = current - current / (1 + current * k * 10.0)  # 0.330 units/s after 10 s
    assert velocity[0, -1, 1] == pytest.approx(expected, rel=0.02)
    assert np.all(velocity[0, :, 1] <= current)


def test_reactive_couple_on_the_body_equals_the_force_at_the_trailing_edge():
    """The simulator adds the reactive force's couple to the body (one PyBullet call fewer); the same
    force applied at the trailing edge itself must give the same motion."""
    from aquafish_gym.fluid import reactive_force
    from aquafish_gym.robot import LINK_CAUDAL

    angles, action = np.array([[0.3, 1.0, 0.1]]), np.array([[0.2, -0.3, 1.0]])
    with BatchWorld(HEALTHY[None], DEEP) as ref, BatchWorld(HEALTHY[None], DEEP.replace(reactive_thrust=False)) as world:
        ref.reset(angles, action)
        world.reset(angles, action)
        for _ in range(300):
            ref.step()
            rot = world.rotation[0, 3]
            trailing_edge = np.array([0.0, -world.spec.caudal_half_length[0], 0.0])
            force, _ = reactive_force(rot, world.linear_velocity[0, 3], world.angular_velocity[0, 3], trailing_edge,
                                      np.array([0.0, -1.0, 0.0]), np.array([1.0, 0.0, 0.0]),
                                      world.spec.caudal_added_mass[0])
            edge = world.position[0, 3] + rot @ trailing_edge
            p.applyExternalForce(world.bodies[0], LINK_CAUDAL, (rot @ force).tolist(), edge.tolist(), p.WORLD_FRAME,
                                 physicsClientId=world.client)
            world.step()
        moved = np.linalg.norm(ref.position[0, 0] - ref.home[0])
        assert moved > 0.2
        np.testing.assert_allclose(world.position[0, 0], ref.position[0, 0], atol=1e-5)
        np.testing.assert_allclose(world.imu_rpy_deg(), ref.imu_rpy_deg(), atol=1e-3)


def test_zero_size_flippers_never_give_nan():
    morph = np.array([NO_FLIPPERS, [0, 2, 0.5, 1, 0, 0.5, 0.5, 2, 0], [1, 2, 0, 1, 2, 0, 0, 2, 1]])
    log = simulate_batch(morph, [[0.5, -0.5, 1.0]] * 3, [[1.0, 2.0, 0.3]] * 3, 256, params=DEEP)
    assert np.all(np.isfinite(log))


def test_seized_pectoral_holds_its_initial_angle():
    damage = get_damage("seized_left_pectoral")
    with BatchWorld(HEALTHY[None], DEEP, faults=damage.faults) as world:
        world.reset(np.array([[1.0, 1.0, 0.0]]), np.array([[0.5, 0.5, 0.0]]))
        for _ in range(100):
            world.step()
        left, right, _ = world.joint_angles()[0]
    assert left == pytest.approx(1.0, abs=0.02)
    assert right == pytest.approx(1.0 + 2 * math.pi * 0.5 * 1.0, abs=0.05)  # 0.5 rev/s for 1 s


def test_caudal_fin_sweeps_thirty_degrees_from_its_initial_angle():
    with BatchWorld(HEALTHY[None], DEEP) as world:
        world.reset(np.array([[0.0, 0.0, 0.2]]), np.array([[0.0, 0.0, 1.0]]))
        angles = []
        for _ in range(200):
            world.step()
            angles.append(world.joint_angles()[0, 2])
    angles = np.degrees(angles)
    assert angles[0] == pytest.approx(math.degrees(0.2), abs=3.0)
    assert 25.0 < angles.max() <= 33.0 and -33.0 <= angles.min() < -25.0


def test_body_mass_is_neutral_capsule():
    from aquafish_gym.robot import robot_spec

    spec = robot_spec(HEALTHY[None], DEEP)
    volume = math.pi * BODY_RADIUS**2 * BODY_CYLINDER_LENGTH + 4 / 3 * math.pi * BODY_RADIUS**3
    assert spec.masses[0, 0] == pytest.approx(volume)
    assert spec.masses[0, 1] == pytest.approx(0.25 * 1.0 * 0.0625)
