"""Whole-robot physics: behaviours that a wrong model would break (DESIGN.md section 3)."""

import math

import numpy as np
import pybullet as p
import pytest

from aquafish_gym import BatchWorld, Morphology, SimParams, get_damage, simulate_batch
from aquafish_gym.robot import BODY_CYLINDER_LENGTH, BODY_RADIUS

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
    params = SimParams(drag_coefficient=1.0, fluid_density=1.0)
    area = math.pi * BODY_RADIUS**2  # the capsule's end-on projected area
    expected = math.sqrt(2 * 1.0 / (params.drag_coefficient * params.fluid_density * area))  # F = c_d A rho v^2 / 2
    assert push_to_terminal_velocity(params, 1.0, 1500) == pytest.approx(expected, rel=0.01)


def test_constant_force_reaches_linear_terminal_velocity():
    params = SimParams(drag_law="linear", drag_coefficient=2.0)
    area = math.pi * BODY_RADIUS**2
    expected = 1.0 / (2.0 * area)  # F = c_d A v
    assert push_to_terminal_velocity(params, 1.0, 1500) == pytest.approx(expected, rel=0.01)


def test_no_actuation_stays_still():
    log = simulate_batch(HEALTHY, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 300)
    np.testing.assert_allclose(log, 0.0, atol=1e-6)
    with BatchWorld(HEALTHY[None]) as world:
        world.reset(np.zeros((1, 3)), np.zeros((1, 3)))
        for _ in range(300):
            world.step()
        np.testing.assert_allclose(world.position[0, 0], world.home[0], atol=1e-6)


def test_symmetric_robot_swims_straight_and_half_flipper_turns():
    damaged = get_damage("left_pectoral_half").apply().to_array()
    log = simulate_batch(np.stack([HEALTHY, damaged]), [[0.5, 0.5, 0.0]] * 2, np.zeros((2, 3)), 500)
    assert np.abs(log[0, :, 2]).max() < 1.0
    assert np.abs(log[1, :, 2]).max() > 5.0


def test_rolled_robot_rights_itself():
    with BatchWorld(HEALTHY[None]) as world:
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


def test_caudal_fin_alone_swims_forward():
    with BatchWorld(NO_PECTORALS[None]) as world:
        world.reset(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
        for _ in range(1000):
            world.step()
        dx, dy, _ = world.position[0, 0] - world.home[0]
    assert dy > 0.03 and abs(dx) < dy


def test_zero_size_flippers_never_give_nan():
    morph = np.array([NO_FLIPPERS, [0, 2, 0.5, 1, 0, 0.5, 0.5, 2, 0], [1, 2, 0, 1, 2, 0, 0, 2, 1]])
    log = simulate_batch(morph, [[0.5, -0.5, 1.0]] * 3, [[1.0, 2.0, 0.3]] * 3, 256)
    assert np.all(np.isfinite(log))


def test_seized_pectoral_holds_its_initial_angle():
    damage = get_damage("seized_left_pectoral")
    with BatchWorld(HEALTHY[None], faults=damage.faults) as world:
        world.reset(np.array([[1.0, 1.0, 0.0]]), np.array([[0.5, 0.5, 0.0]]))
        for _ in range(100):
            world.step()
        left, right, _ = world.joint_angles()[0]
    assert left == pytest.approx(1.0, abs=0.02)
    assert right == pytest.approx(1.0 + 2 * math.pi * 0.5 * 1.0, abs=0.05)  # 0.5 rev/s for 1 s


def test_caudal_fin_sweeps_thirty_degrees_from_its_initial_angle():
    with BatchWorld(HEALTHY[None]) as world:
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

    spec = robot_spec(HEALTHY[None], SimParams())
    volume = math.pi * BODY_RADIUS**2 * BODY_CYLINDER_LENGTH + 4 / 3 * math.pi * BODY_RADIUS**3
    assert spec.masses[0, 0] == pytest.approx(volume)
    assert spec.masses[0, 1] == pytest.approx(0.25 * 1.0 * 0.0625)
