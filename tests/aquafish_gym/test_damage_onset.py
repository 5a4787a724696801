"""Damage during an episode: ``damage_onset_s`` (docs/simulator.md, "Damage during an episode").

The robot swims healthy until the first control step at or after the onset, then is the
damaged robot in the same world, without a reset (``BatchWorld.change_robot``).
"""

import copy
import math

import gymnasium as gym
import numpy as np
import pytest

import aquafish_gym  # noqa: F401  (registers the tasks)
from aquafish_gym import Morphology, get_damage
from aquafish_gym.bullet import p
from aquafish_gym.robot import JOINTS, robot_spec
from aquafish_gym.simulator import BatchWorld

ACTIONS = np.random.default_rng(0).uniform(-1, 1, (12, 3)).astype(np.float32)


def rollout(seed=3, actions=ACTIONS, **kwargs):
    """``[(obs, info)]`` of reset and every step (one episode of 1.2 s unless told)."""
    env = gym.make("AquaFish-v0", **{"episode_duration_s": 1.2, **kwargs})
    obs, info = env.reset(seed=seed)
    out = [(obs, info)]
    for action in actions:
        obs, _, _, _, info = env.step(action)
        out.append((obs, info))
    env.close()
    return out


def joint_speeds(world: BatchWorld, i: int = 0) -> np.ndarray:
    """``(3,)`` flipper joint speeds (rad/s) of robot ``i``, as PyBullet holds them."""
    return np.array([s[1] for s in p.getJointStates(world.bodies[i], JOINTS, physicsClientId=world.client)])


def dynamics(world: BatchWorld, i: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(4,)`` masses, ``(4, 3)`` inertias and ``(4, 3)`` centres of mass (link frame) of robot i's
    PyBullet body (base first)."""
    infos = [p.getDynamicsInfo(world.bodies[i], link, physicsClientId=world.client) for link in (-1, *JOINTS)]
    return (np.array([d[0] for d in infos]), np.array([d[2] for d in infos]), np.array([d[3] for d in infos]))


@pytest.mark.parametrize("damage", ["left_pectoral_missing", "reversed_left_pectoral", "sampled:15",
                                    '{"gains": [1, 1, 0.3], "scale": {"caudal_y": 0.5}}'])
def test_before_the_onset_the_trajectory_is_the_healthy_robots_bit_for_bit(damage):
    onset = 0.55  # switched after the 6th step (t = 0.6)
    healthy, damaged = rollout(), rollout(damage=damage, damage_onset_s=onset)
    for k, ((obs_h, info_h), (obs_d, info_d)) in enumerate(zip(healthy, damaged)):
        if info_d["time_s"] < 0.6 + 1e-9:  # every observation up to and including the switch
            np.testing.assert_array_equal(obs_d, obs_h, err_msg=f"step {k}")
            for key in ("x_position", "y_position", "z_position", "distance", "initial_angles"):
                np.testing.assert_array_equal(info_d[key], info_h[key], err_msg=f"{key}, step {k}")
    assert not np.array_equal(damaged[-1][0], healthy[-1][0])  # and the damage tells afterwards
    assert damaged[-1][1]["damage"] == get_damage(damage).name


def test_the_info_flag_flips_at_exactly_the_first_step_at_or_after_the_onset():
    out = rollout(damage="left_pectoral_half", damage_onset_s=0.35)  # steps end at 0.1, 0.2, ...
    assert [info["damaged"] for _, info in out] == [False] * 4 + [True] * 9  # reset, 0.1 .. 0.3; then 0.4 ..
    assert all(type(info["damaged"]) is bool for _, info in out)
    out = rollout(damage="left_pectoral_half", damage_onset_s=0.3)  # 3 * 0.1 rounds to 0.30000000000000004
    assert [info["time_s"] for _, info in out if info["damaged"]][0] == pytest.approx(0.3)
    out = rollout(damage="left_pectoral_half", damage_onset_s=0.12, frame_skip=5)  # 0.05 s control steps
    assert [info["time_s"] for _, info in out if info["damaged"]][0] == pytest.approx(0.15)
    assert rollout(damage="left_pectoral_half", damage_onset_s=0)[0][1]["damaged"]  # at reset
    assert all(info["damaged"] for _, info in rollout(damage="left_pectoral_half"))  # no onset: from the start
    assert not any(info["damaged"] for _, info in rollout(damage="left_pectoral_half", damage_onset_s=5.0))
    assert not any(info["damaged"] for _, info in rollout())  # "none" is no damage


def test_onset_zero_is_the_episode_without_an_onset():
    a, b = rollout(damage="sampled:15", damage_onset_s=0.0), rollout(damage="sampled:15")
    for (obs_a, info_a), (obs_b, info_b) in zip(a, b):
        np.testing.assert_array_equal(obs_a, obs_b)
        assert info_a["damaged"] is info_b["damaged"] is True
        for key in ("x_position", "y_position", "z_position", "distance", "time_s"):
            assert info_a[key] == info_b[key]


def test_a_reversed_servo_turns_its_flipper_the_other_way_after_the_onset():
    env = gym.make("AquaFish-v0", damage="reversed_left_pectoral", damage_onset_s=0.5, episode_duration_s=2.0)
    env.reset(seed=0)
    action = np.array([1.0, 1.0, -1.0], dtype=np.float32)  # both pectorals +0.5 rev/s = +pi rad/s, caudal still
    speeds = []
    for _ in range(10):
        env.step(action)
        speeds.append(joint_speeds(env.unwrapped.world))
    speeds = np.array(speeds)  # after steps ending at 0.1 .. 1.0 s; the switch is after the step ending at 0.5
    np.testing.assert_allclose(speeds[:5, :2], math.pi, rtol=0.02)   # healthy: both at +pi rad/s
    np.testing.assert_allclose(speeds[5:, 0], -math.pi, rtol=0.02)   # reversed: the left one at -pi
    np.testing.assert_allclose(speeds[5:, 1], math.pi, rtol=0.02)    # the right one as before
    env.close()


def _state(world: BatchWorld, i: int = 0):
    """Robot i's state as PyBullet reports it: base pose, base velocity, joint angles and speeds."""
    c, body = world.client, world.bodies[i]
    return (p.getBasePositionAndOrientation(body, physicsClientId=c), p.getBaseVelocity(body, physicsClientId=c),
            [s[:2] for s in p.getJointStates(body, JOINTS, physicsClientId=c)])


def _built_in_state(morphology, faults, params, state, phase, commands, native=None) -> BatchWorld:
    """A world of one robot built with ``morphology`` and put in ``state``."""
    world = BatchWorld(np.asarray(morphology)[None], params, faults, native=native)
    world.reset(np.zeros((1, 3)))
    (position, orientation), (linear, angular), joints = state
    body, c = world.bodies[0], world.client
    p.resetBasePositionAndOrientation(body, position, orientation, physicsClientId=c)
    p.resetBaseVelocity(body, linear, angular, physicsClientId=c)
    for j, (angle, speed) in zip(JOINTS, joints):
        p.resetJointState(body, j, angle, speed, physicsClientId=c)
    world._caudal_phase = phase.copy()
    world.set_actions(commands)
    world._read_state()
    return world


@pytest.mark.parametrize("waterline", [0.3, None], ids=["surface", "deep"])
@pytest.mark.parametrize("damage", ["left_pectoral_missing", "caudal_missing", "left_pectoral_half", "sampled:15"])
def test_after_the_onset_the_robot_has_the_mass_drag_and_motion_of_a_robot_built_damaged(damage, waterline,
                                                                                        monkeypatch):
    """Masses, inertias, centres of mass, drag dimensions and the links that feel drag are the
    damaged robot's, and the motion from the onset is a robot's built damaged and put in the
    state PyBullet reported at the onset: equal to the last bit (tolerance 0) over the next
    control steps."""
    env = gym.make("AquaFish-v0", damage=damage, damage_onset_s=0.3, waterline=waterline, episode_duration_s=1.0)
    env.reset(seed=1)
    u = env.unwrapped
    world, switch = u.world, u.world.change_robot
    at_onset = []

    def spy(i, *args, **kwargs):  # the state at the switch, as PyBullet reports it
        at_onset.append((_state(world, i), world._caudal_phase.copy(), world.actions.copy()))
        switch(i, *args, **kwargs)

    monkeypatch.setattr(world, "change_robot", spy)
    action = np.array([0.6, -0.4, 0.9], dtype=np.float32)
    for _ in range(3):
        info = env.step(action)[4]
    assert info["damaged"] and len(at_onset) == 1
    target = get_damage(damage).apply().to_array()
    spec = robot_spec(target[None], u.params)
    masses, inertias, com = dynamics(world)
    np.testing.assert_array_equal(masses, spec.masses[0])
    np.testing.assert_array_equal(inertias, spec.inertias[0])
    np.testing.assert_allclose(com, spec.com_offsets[0], rtol=0, atol=1e-15)
    for field in ("face_areas", "axis_areas", "box_offsets", "caudal_half_length", "caudal_added_mass", "sizes"):
        np.testing.assert_array_equal(getattr(world.spec, field), getattr(spec, field), err_msg=field)
    reference = _built_in_state(target, u.faults, u.params, *at_onset[0])
    assert world._active == reference._active
    for k in range(3):
        before = world.linear_velocity.copy(), world.angular_velocity.copy()
        env.step(action)
        reference.set_actions(u.servo_command(action)[None])
        reference.advance(u.frame_skip)
        for name in ("position", "orientation", "linear_velocity", "angular_velocity"):  # both robots at the origin
            np.testing.assert_array_equal(getattr(world, name), getattr(reference, name),
                                          err_msg=f"{name}, control step {k}")
        np.testing.assert_array_equal(joint_speeds(world), joint_speeds(reference))
        assert not np.array_equal(world.linear_velocity, before[0])  # it moves
    reference.close()
    env.close()


def test_a_lost_flipper_mid_episode_is_not_the_healthy_body_with_changed_masses():
    """Why a new body: the healthy body's inertial frame cannot be moved (no changeDynamics
    argument for it), and a halved flipper's centre of mass moves by a quarter unit."""
    env = gym.make("AquaFish-v0", damage="left_pectoral_half", damage_onset_s=0.1, render_mode="rgb_array",
                   width=32, height=24)
    env.reset(seed=0)
    u = env.unwrapped
    healthy_body = u.world.bodies[0]
    healthy_com = dynamics(u.world)[2]
    assert len(p.getVisualShapeData(healthy_body, physicsClientId=u.world.client)) == 4
    env.step(env.action_space.sample())
    assert p.getNumBodies(physicsClientId=u.world.client) == 1  # replaced, not added (PyBullet may reuse the id)
    np.testing.assert_allclose(dynamics(u.world)[2][1] - healthy_com[1], [0.0, 0.25, 0.0], atol=1e-12)
    # render draws the new flipper: its box is half as long
    shapes = {s[1]: s[3] for s in p.getVisualShapeData(u.world.bodies[0], physicsClientId=u.world.client)}
    np.testing.assert_allclose(shapes[0], [0.25, 0.5, 0.0625])
    assert env.render().shape == (24, 32, 3)
    env.close()


def test_a_lost_flipper_has_no_visual_shape_after_the_onset():
    env = gym.make("AquaFish-v0", damage="caudal_missing", damage_onset_s=0.1, render_mode="rgb_array",
                   width=32, height=24)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    w = env.unwrapped.world
    assert sorted(s[1] for s in p.getVisualShapeData(w.bodies[0], physicsClientId=w.client)) == [-1, 0, 1]
    env.close()


@pytest.mark.parametrize("damage", ["random", ["sampled:4", '{"seized": [false, true, false]}', "caudal_half"]])
def test_every_damage_form_switches_at_the_onset_and_each_reset_starts_healthy(damage):
    env = gym.make("AquaFish-v0", damage=damage, damage_onset_s=0.2, episode_duration_s=0.4)
    u = env.unwrapped
    healthy = Morphology.healthy().to_array()
    for seed in range(4):
        _, info = env.reset(seed=seed)
        assert not info["damaged"]
        np.testing.assert_array_equal(u.world.morphologies[0], healthy)
        assert not u.world.seized.any() and (u.world.speed_scale == 1).all()
        for _ in range(2):
            info = env.step(env.action_space.sample())[4]
        d = get_damage(info["damage"])
        np.testing.assert_array_equal(u.world.morphologies[0], d.apply().to_array())
        np.testing.assert_array_equal(u.world.seized[0], d.faults.seized)
        np.testing.assert_array_equal(u.world.speed_scale[0], d.faults.speed_scale)
        assert info["damaged"] == (d.name != "none")
    env.close()


def test_an_onset_with_the_damage_none_is_allowed_and_changes_nothing():
    a, b = rollout(damage="none", damage_onset_s=0.2), rollout()
    for (obs_a, info_a), (obs_b, info_b) in zip(a, b):
        np.testing.assert_array_equal(obs_a, obs_b)
        assert info_a["damaged"] is False


@pytest.mark.parametrize("onset", [-0.1, -1, float("nan"), float("inf"), -float("inf"), True, "1.0", [0.5]])
def test_a_bad_onset_is_refused_naming_the_argument(onset):
    with pytest.raises(ValueError, match=r"damage_onset_s must be None .* finite number of seconds .* >= 0"):
        gym.make("AquaFish-v0", damage="left_pectoral_half", damage_onset_s=onset)


@pytest.mark.parametrize("onset", [0, 0.0, 3, np.float64(1.5), 1e9])
def test_a_good_onset_is_accepted_and_copied(onset):
    env = gym.make("AquaFish-v0", damage="left_pectoral_half", damage_onset_s=onset)
    assert env.unwrapped.damage_onset_s == float(onset)
    assert copy.deepcopy(env.unwrapped).damage_onset_s == float(onset)


def test_vector_env_switches_per_sub_env_and_autoreset_restarts_healthy():
    venv = gym.make_vec("AquaFish-v0", num_envs=3, vectorization_mode="vector_entry_point", episode_duration_s=0.3,
                        damage=["none", "left_pectoral_missing", "reversed_left_pectoral"], damage_onset_s=0.15)
    _, info = venv.reset(seed=[2, 0, 1])
    names = list(info["damage"])
    flags = [info["damaged"].copy()]
    for _ in range(4):  # steps ending at 0.1, 0.2, 0.3 (the end), then the autoreset
        flags.append(venv.step(np.zeros((3, 3), dtype=np.float32))[4]["damaged"].copy())
    changes = np.array([name != "none" for name in names])
    expected = [np.zeros(3, bool), np.zeros(3, bool), changes, changes, np.zeros(3, bool)]
    for got, want in zip(flags, expected):
        np.testing.assert_array_equal(got, want)
    venv.close()


def test_apply_damage_onset_switches_the_robot_as_an_onset_inside_step_does():
    """A caller with its own clock (a mission) brings the damage in force at the same step as
    ``step`` would: the observations then agree to the last bit."""
    kwargs = dict(damage="left_pectoral_missing", episode_duration_s=1.2)
    by_step = gym.make("AquaFish-v0", damage_onset_s=0.3, **kwargs).unwrapped  # the 3rd step switches it
    by_call = gym.make("AquaFish-v0", damage_onset_s=100.0, **kwargs).unwrapped
    with pytest.raises(RuntimeError, match="reset"):
        by_call.apply_damage_onset()
    for env in (by_step, by_call):
        env.reset(seed=2)
    assert by_call.damage_pending and by_step.damage_pending
    for k, action in enumerate(ACTIONS[:8]):
        obs_a = by_step.step(action)[0]
        obs_b = by_call.step(action)[0]
        if k == 2:  # the 3rd step's end: step() switched by_step; the call switches by_call
            assert not by_step.damage_pending and by_call.damage_pending
            assert by_call.apply_damage_onset() is True
            assert not by_call.damage_pending
        np.testing.assert_array_equal(obs_b, obs_a, err_msg=f"step {k}")
    assert by_call.apply_damage_onset() is True  # once in force, calling again changes nothing


def test_sync_caudal_phase_restarts_the_sweep_at_the_fins_angle():
    """phase = asin(angle / amplitude): a fin held at half the amplitude is at phase pi/6, one
    at -amplitude at -pi/2; only the robot named is changed."""
    world = BatchWorld(np.asarray(Morphology.healthy().to_array())[None, :].repeat(2, 0))
    amp = world.params.caudal_amplitude_rad
    world.reset(np.array([[0.0, 0.0, 0.5 * amp], [0.0, 0.0, -amp]]))
    world._caudal_phase[:] = 0.0  # as if the sweep had run elsewhere
    world.sync_caudal_phase(0)
    np.testing.assert_allclose(world._caudal_phase, [math.asin(world.joint_angles()[0, 2] / amp), 0.0])
    assert abs(world._caudal_phase[0] - math.pi / 6) < 0.02  # the joint holds about half the amplitude
    world.sync_caudal_phase()
    assert abs(world._caudal_phase[1] + math.pi / 2) < 0.1
    with pytest.raises(IndexError, match="2 robots"):
        world.sync_caudal_phase(2)
    world.close()
