"""simulate_batch: shapes, validation, batch independence, IMU conventions (docs/design.md)."""

import math

import numpy as np
import pytest

from aquafish_gym.bullet import p
from aquafish_gym import BatchWorld, Morphology, SimParams, simulate_batch
from aquafish_gym.imu import roll_pitch_yaw_deg, unwrap_yaw_deg
from aquafish_gym.morphology import MORPHOLOGY_BOUNDS
from aquafish_gym.simulator import AT_REST, validate_start_motion


def random_inputs(n, seed=0):
    rng = np.random.default_rng(seed)
    morph = rng.uniform(MORPHOLOGY_BOUNDS[:, 0], MORPHOLOGY_BOUNDS[:, 1], size=(n, 9))
    actions = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(0, 1, n)])
    angles = np.column_stack([rng.uniform(0, 2 * np.pi, (n, 2)), rng.uniform(-0.5, 0.5, n)])
    return morph, actions, angles


def test_batch_equals_members_run_one_at_a_time():
    morph, actions, angles = random_inputs(4)
    batch = simulate_batch(morph, actions, angles, 128)
    assert batch.shape == (4, 128, 3)
    for i in range(4):
        single = simulate_batch(morph[i : i + 1], actions[i : i + 1], angles[i : i + 1], 128)
        np.testing.assert_allclose(batch[i], single[0], atol=1e-9, rtol=0)


def test_same_inputs_give_identical_logs():
    morph, actions, angles = random_inputs(3, seed=1)
    np.testing.assert_array_equal(simulate_batch(morph, actions, angles, 64), simulate_batch(morph, actions, angles, 64))


def test_imu_noise_is_gaussian_with_given_std():
    morph, actions, angles = random_inputs(1)
    clean = simulate_batch(morph, actions, angles, 200)
    noisy = simulate_batch(morph, actions, angles, 200, params=SimParams(imu_noise_deg=0.5), rng=np.random.default_rng(0))
    assert np.std(noisy - clean) == pytest.approx(0.5, rel=0.1)


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"morphologies": np.zeros((2, 8))}, r"\(N, 9\)"),
        ({"morphologies": np.full((2, 9), np.nan)}, "left_pectoral_x"),
        ({"morphologies": np.full((2, 9), 0.1) + np.eye(9)[1] * 5}, "left_pectoral_y"),
        ({"actions": [[0.6, 0, 0], [0, 0, 0]]}, "left pectoral"),
        ({"actions": [[0, 0, -0.1], [0, 0, 0]]}, "caudal frequency"),
        ({"actions": np.zeros((3, 3))}, r"\(2, 3\)"),
        ({"initial_angles": [[0, 0, 1.0], [0, 0, 0]]}, "caudal"),
        ({"initial_angles": [[np.nan, 0, 0], [0, 0, 0]]}, "finite"),
        ({"steps": 0}, "steps"),
    ],
)
def test_bad_input_raises_value_error(kwargs, match):
    args = {"morphologies": np.full((2, 9), 0.1), "actions": np.zeros((2, 3)), "initial_angles": np.zeros((2, 3)), "steps": 4}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        simulate_batch(args["morphologies"], args["actions"], args["initial_angles"], args["steps"])


def rot_x(deg):
    t = math.radians(deg)
    return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])


def test_imu_angle_conventions():
    np.testing.assert_allclose(roll_pitch_yaw_deg(rot_x(20)), [0, 20, 0], atol=1e-12)  # nose up = pitch
    t = math.radians(15)
    rot_y = np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])
    np.testing.assert_allclose(roll_pitch_yaw_deg(rot_y), [15, 0, 0], atol=1e-12)
    t = math.radians(40)
    rot_z = np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])
    np.testing.assert_allclose(roll_pitch_yaw_deg(rot_z), [0, 0, 40], atol=1e-12)


def test_nose_up_rotation_in_pybullet_shows_as_pitch():
    with BatchWorld(Morphology.healthy().to_array()[None]) as world:
        world.reset(np.zeros((1, 3)))
        q = p.getQuaternionFromAxisAngle((1, 0, 0), math.radians(25))
        p.resetBasePositionAndOrientation(world.bodies[0], (0, 0, 0), q, physicsClientId=world.client)
        world._read_state()
        np.testing.assert_allclose(world.imu_rpy_deg()[0], [0, 25, 0], atol=1e-6)


def test_yaw_is_unwrapped():
    log = np.zeros((1, 4, 3))
    log[0, :, 2] = [170.0, 179.0, -172.0, -160.0]
    np.testing.assert_allclose(unwrap_yaw_deg(log)[0, :, 2], [170, 179, 188, 200])


@pytest.mark.parametrize("waterline", [0.3, None])
def test_per_robot_water_current_matches_a_world_in_that_current(waterline):
    """BatchWorld(water_current=(N, 3)): robot i swims as a one-robot world whose params carry
    its current, bit for bit, on the compiled and the NumPy path."""
    morph = np.stack([Morphology.healthy().to_array()] * 3)
    currents = np.array([[0.1, 0.2, 0.0], [0.0, -0.3, 0.0], [0.05, 0.0, 0.0]])
    angles, actions = np.array([[0.3, 1.2, 0.1]] * 3), np.array([[-0.4, 0.3, 0.8]] * 3)
    logs = {}
    for native in (None, False):
        with BatchWorld(morph, SimParams(waterline=waterline), native=native, water_current=currents) as w:
            w.reset(angles, actions)
            logs[native] = w.run(30)
    np.testing.assert_array_equal(logs[None], logs[False])
    for i in range(3):
        with BatchWorld(morph[:1], SimParams(waterline=waterline, water_current=tuple(currents[i]))) as w:
            w.reset(angles[:1], actions[:1])
            np.testing.assert_array_equal(w.run(30)[0], logs[None][i])
    with pytest.raises(ValueError, match=r"water_current must be None or 3 finite velocities"):
        BatchWorld(morph, water_current=np.zeros((2, 3)))


def test_caudal_sweep_phase_is_added_one_step_at_a_time():
    """The caudal sweep's phase after k steps is ``phase += 2 pi f dt`` done k times (the
    same doubles whatever the chunks a run is stepped in), and its targets are ``A sin``."""
    from aquafish_gym.simulator import DT_S

    morph, actions, angles = random_inputs(3, seed=2)
    actions[:, 2] = [0.3, 0.0, 0.9]  # the middle robot's fin holds still
    with BatchWorld(morph) as world:
        world.reset(angles, actions)
        start = world._caudal_phase.copy()
        targets, _ = world._caudal_targets(5)
        expected = start.copy()
        for _ in range(5):
            expected[[0, 2]] = expected[[0, 2]] + world._caudal_omega[[0, 2]] * DT_S
        np.testing.assert_array_equal(world._caudal_phase, expected)
        np.testing.assert_array_equal(targets[-1], SimParams().caudal_amplitude_rad * np.sin(expected[[0, 2]]))
        assert world._caudal_targets(0)[0].shape == (0, 2)
        np.testing.assert_array_equal(world._caudal_phase, expected)  # zero steps move nothing
    with BatchWorld(morph) as whole, BatchWorld(morph) as chunks:
        whole.reset(angles, actions)
        chunks.reset(angles, actions)
        whole.run(64)
        chunks.run(23)
        chunks.run(41)
        np.testing.assert_array_equal(whole._caudal_phase, chunks._caudal_phase)
        np.testing.assert_array_equal(whole.joint_angles(), chunks.joint_angles())


def test_body_slices_are_computed_once_and_read_only():
    from aquafish_gym.robot import body_slices

    assert body_slices() is body_slices()
    with pytest.raises(ValueError, match="read-only"):
        body_slices()[0][0] = 1.0


@pytest.mark.parametrize("native", [False, None])
def test_runs_from_a_restored_state_repeat_to_the_bit(native):
    morph, actions, angles = random_inputs(2, seed=4)
    with BatchWorld(morph, native=native) as world:
        world.reset(angles, actions)
        world.advance(37)
        state = world.save_state()
        world.set_actions(actions[::-1] * [1, 1, 0.5])
        later = world.run(25)
        runs = []
        for _ in range(2):  # the state, however far the world has gone on since
            world.restore_state(state)
            assert world.time_s == state.time_s
            np.testing.assert_array_equal(world.actions, actions)
            world.set_actions(actions[::-1] * [1, 1, 0.5])
            runs.append((world.run(25), world.joint_angles(), world.position.copy()))
            world.advance(11)
        for a, b in zip(*runs):
            np.testing.assert_array_equal(a, b)
        # PyBullet's cached link poses are not in its saved state: close to the saved world's own
        # continuation, not equal to it
        np.testing.assert_allclose(runs[0][0], later, atol=0.05)


def test_a_state_restores_only_into_the_robots_it_was_saved_from():
    morph, actions, angles = random_inputs(1, seed=5)
    with BatchWorld(morph) as world, BatchWorld(morph) as other:
        world.reset(angles, actions)
        other.reset(angles, actions)
        state = world.save_state()
        world.change_robot(0, Morphology.healthy())
        with pytest.raises(ValueError, match="saved from other robots"):
            world.restore_state(state)
        other.advance(3)
        other.restore_state(other.save_state())  # its own state: fine


HEALTHY = Morphology.healthy().to_array()


def _swum_world() -> BatchWorld:
    """Two robots turned and swum for 3 s: rolling, pitching and turning, at headings of their own."""
    world = BatchWorld(np.tile(HEALTHY, (2, 1)))
    world.reset(np.zeros((2, 3)), np.array([[0.3, -0.1, 0.8], [0.2, 0.4, 0.5]]), yaw_rad=np.array([0.7, -2.0]))
    world.advance(300)
    return world


def test_a_start_motion_starts_a_robot_with_the_measured_roll_pitch_and_turning_at_yaw_0():
    world = _swum_world()
    motion = world.start_motion()
    rpy = world.imu_rpy_deg()
    assert np.all(np.abs(rpy[:, :2]) > 0.1) and np.all(np.linalg.norm(motion[:, 4:], axis=1) > 0.01)  # it moves
    again = BatchWorld(np.tile(HEALTHY, (2, 1)))
    again.reset(np.zeros((2, 3)), start_motion=motion)
    np.testing.assert_allclose(again.imu_rpy_deg()[:, :2], rpy[:, :2], atol=1e-5)  # the roll and pitch
    np.testing.assert_allclose(again.imu_rpy_deg()[:, 2], 0.0, atol=1e-4)  # the heading taken out
    np.testing.assert_allclose(again.start_motion(), motion, atol=1e-6)
    # turned back to the robots' headings: the very angular velocity (world frame) they had
    again.reset(np.zeros((2, 3)), start_motion=motion, yaw_rad=np.radians(rpy[:, 2]))
    np.testing.assert_allclose(again.angular_velocity[:, 0], world.angular_velocity[:, 0], atol=1e-6)
    np.testing.assert_allclose(again.imu_rpy_deg(), rpy, atol=1e-4)


def test_a_start_at_rest_is_the_reset_it_always_was():
    actions, angles = np.array([[0.3, -0.1, 0.8]]), np.array([[0.5, 4.0, 0.1]])
    plain = simulate_batch(HEALTHY, actions, angles, 64)
    np.testing.assert_array_equal(simulate_batch(HEALTHY, actions, angles, 64, start_motion=np.array([AT_REST])), plain)
    moving = _swum_world().start_motion()[:1]
    assert np.max(np.abs(simulate_batch(HEALTHY, actions, angles, 64, start_motion=moving) - plain)) > 0.1


@pytest.mark.parametrize("motion, match", [
    (np.zeros((1, 6)), "shape"),
    ([[0.0, 0.0, 0.0, 1.0, np.nan, 0.0, 0.0]], "finite"),
    ([[0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0]], "unit quaternions"),
])
def test_bad_start_motion_raises(motion, match):
    with pytest.raises(ValueError, match=match):
        validate_start_motion(motion, 1)
