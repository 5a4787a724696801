"""The Gymnasium env AquaFish-v0 (docs/simulator.md)."""

import copy
import logging
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import aquafish_gym  # noqa: F401  (registers AquaFish-v0)
from aquafish_gym import DAMAGES, ENV_IDS, Morphology


def test_check_env_passes_with_warnings_as_errors():
    env = gym.make("AquaFish-v0", render_mode="rgb_array", episode_duration_s=2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


def test_reset_with_seed_is_deterministic():
    def rollout():
        env = gym.make("AquaFish-v0", episode_duration_s=1.0)
        obs0, info = env.reset(seed=7)
        obs = [obs0]
        for k in range(10):
            obs.append(env.step(np.array([0.5, -0.2, 0.8 - 0.1 * k], dtype=np.float32))[0])
        env.close()
        return np.array(obs), info["initial_angles"]

    (a, angles_a), (b, angles_b) = rollout(), rollout()
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(angles_a, angles_b)


def test_reward_terms_add_up_and_distance_is_their_sum():
    env = gym.make("AquaFish-v0", ctrl_cost_weight=0.1, episode_duration_s=2.0)
    env.reset(seed=0)
    total_forward, truncated, steps = 0.0, False, 0
    while not truncated:
        _, reward, terminated, truncated, info = env.step(np.array([-1.0, -1.0, 1.0], dtype=np.float32))
        assert reward == pytest.approx(info["reward_forward"] + info["reward_ctrl"])
        assert info["reward_ctrl"] == pytest.approx(-0.1 * 3.0)
        assert not terminated
        total_forward += info["reward_forward"]
        steps += 1
    assert steps == 20  # 2 s of 0.1 s control steps
    assert info["distance"] == pytest.approx(total_forward)
    assert info["y_position"] == pytest.approx(info["distance"], abs=1e-9)  # initial heading is +y
    env.close()


def test_render_top_camera_and_its_matrices_project_the_robot_to_the_frame_centre():
    env = gym.make("AquaFish-v0", render_mode="rgb_array", camera="top", camera_distance=3.0, width=64, height=64)
    _, info = env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (64, 64, 3) and frame.min() < 200
    pos = [info["x_position"], info["y_position"], info["z_position"]]
    assert env.unwrapped.world_to_pixels([pos])[0] == pytest.approx([32, 32], abs=1e-6)
    # +y (the initial heading) is up the frame, +x to the right
    ahead, right = env.unwrapped.world_to_pixels([[pos[0], pos[1] + 1, pos[2]], [pos[0] + 1, pos[1], pos[2]]])
    assert ahead[1] < 32 and ahead[0] == pytest.approx(32) and right[0] > 32
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        env.unwrapped.world_to_pixels([[0.0, 0.0]])
    with pytest.raises(ValueError, match="finite"):
        env.unwrapped.world_to_pixels([[0.0, 0.0, float("nan")]])
    env.close()
    with pytest.raises(ValueError, match="camera"):
        gym.make("AquaFish-v0", camera="side")


def test_human_render_mode_without_a_display_runs_headless_and_says_so_once(monkeypatch, caplog):
    import aquafish_gym.env as env_module

    monkeypatch.setattr(env_module, "display_available", lambda: False)
    monkeypatch.setattr(env_module, "_said_no_display", False)
    caplog.set_level(logging.WARNING, logger="aquafish_gym.env")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a logged message, never a Python warning
        for _ in range(2):
            env = gym.make("AquaFish-v0", render_mode="human", episode_duration_s=0.2)
            env.reset(seed=0)
            env.step(np.zeros(3))
            assert env.render() is None
            env.close()
    said = [r.getMessage() for r in caplog.records if r.name == "aquafish_gym.env"]
    assert len(said) == 1 and "no display" in said[0] and "rgb_array" in said[0]


@pytest.mark.skipif(not __import__("aquafish_gym.env").env.display_available(), reason="no display: PyBullet's GUI cannot open")
def test_human_render_mode_opens_the_gui():
    env = gym.make("AquaFish-v0", render_mode="human", episode_duration_s=0.2)
    env.reset(seed=0)
    env.step(np.zeros(3))
    assert env.render() is None
    env.close()


def test_render_returns_rgb_frame_headless():
    env = gym.make("AquaFish-v0", render_mode="rgb_array", width=64, height=48)
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (48, 64, 3) and frame.dtype == np.uint8
    assert frame.min() < 200  # the robot is in view, not a blank frame
    env.close()


def test_vector_env_async():
    envs = gym.make_vec("AquaFish-v0", num_envs=2, vectorization_mode="async", episode_duration_s=0.5)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (2, 12)
    obs, rewards, *_ = envs.step(np.zeros((2, 3), dtype=np.float32))
    assert rewards.shape == (2,)
    envs.close()


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_every_damage_preset_makes_an_env(damage):
    env = gym.make("AquaFish-v0", damage=damage, episode_duration_s=0.2)
    env.reset(seed=0)
    obs, *_ = env.step(env.action_space.sample())
    assert np.all(np.isfinite(obs))
    expected = DAMAGES[damage].apply(Morphology.healthy())
    assert env.unwrapped.morphology == expected
    env.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"damage": "broken"}, "valid names"),
        ({"drag_coefficient": -1.0}, "drag_coefficient"),
        ({"drag_law": "cubic"}, "drag_law"),
        ({"frame_skip": 0}, "frame_skip"),
        ({"morphology": [1.0] * 8}, "shape"),
        ({"no_such_option": 1}, "unknown"),
        ({"initial_angles": [0, 0, 2.0]}, "initial_angles"),
        ({"render_mode": "ansi"}, "render_mode"),
    ],
)
def test_bad_kwargs_raise_value_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make("AquaFish-v0", **kwargs)


def test_out_of_range_action_raises():
    env = gym.make("AquaFish-v0", episode_duration_s=0.2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"\[-1, 1\]"):
        env.step(np.array([2.0, 0.0, 0.0], dtype=np.float32))
    env.close()


def test_action_maps_to_servo_ranges():
    env = gym.make("AquaFish-v0").unwrapped
    np.testing.assert_allclose(env.servo_command([-1, 1, -1]), [-0.5, 0.5, 0.0])
    np.testing.assert_allclose(env.servo_command([0, 0, 1]), [0.0, 0.0, 1.0])


#: The ``reset`` options each task accepts.
RESET_OPTIONS = {
    "AquaFish-v0": ["damage", "initial_angles", "initial_yaw_deg"],
    "AquaFishStationKeeping-v0": ["current_direction_deg", "current_speed", "damage", "initial_angles",
                                  "initial_yaw_deg"],
    "AquaFishHeading-v0": ["damage", "initial_angles", "initial_yaw_deg", "target_heading_deg"],
}


def test_reset_options_are_listed_for_every_task():
    assert sorted(RESET_OPTIONS) == sorted(ENV_IDS)
    for env_id, keys in RESET_OPTIONS.items():
        assert sorted(gym.make(env_id).unwrapped.reset_options) == keys


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
@pytest.mark.parametrize("options", ["x", "damage", ["damage"], 3, ("damage", "none")])
def test_reset_options_that_are_not_a_dict_raise_value_error(env_id, options):
    env = gym.make(env_id, episode_duration_s=0.2).unwrapped
    with pytest.raises(ValueError) as err:
        env.reset(seed=0, options=options)
    message = str(err.value)
    assert "options" in message and repr(options) in message and "dict" in message, message
    for key in RESET_OPTIONS[env_id]:
        assert key in message, (key, message)
    env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_unknown_reset_options_raise_value_error_naming_the_allowed_keys(env_id):
    env = gym.make(env_id, episode_duration_s=0.2).unwrapped
    others = sorted({k for keys in RESET_OPTIONS.values() for k in keys} - set(RESET_OPTIONS[env_id]))
    for key in ["bogus", *others]:  # another task's option is unknown here too
        with pytest.raises(ValueError) as err:
            env.reset(seed=0, options={key: 1, "damage": "none"})
        message = str(err.value)
        assert "options" in message and repr([key]) in message and env_id in message, message  # only it blamed
        for allowed in RESET_OPTIONS[env_id]:
            assert allowed in message, (allowed, message)
    # None and {} are no options; a known key still works after the refusals
    reference, _ = env.reset(seed=3)
    np.testing.assert_array_equal(env.reset(seed=3, options=None)[0], reference)
    np.testing.assert_array_equal(env.reset(seed=3, options={})[0], reference)
    assert env.reset(seed=3, options={"damage": "left_pectoral_half"})[1]["damage"] == "left_pectoral_half"
    env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_a_reset_env_copies_and_pickles_as_a_fresh_env_with_the_same_arguments(env_id, how):
    env = gym.make(env_id, damage="left_pectoral_half", episode_duration_s=0.5).unwrapped
    env.reset(seed=1)
    env.step(np.array([1.0, -1.0, 1.0], dtype=np.float32))
    twin = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    assert type(twin) is type(env) and twin is not env
    assert (twin.damage_name, twin.morphology, twin.faults) == (env.damage_name, env.morphology, env.faults)
    assert twin.morphology != Morphology.healthy()
    assert twin.max_control_steps == env.max_control_steps == 5
    with pytest.raises(RuntimeError, match="reset"):  # a copy is a new env: reset before step
        twin.step(np.zeros(3, dtype=np.float32))
    obs_twin, info_twin = twin.reset(seed=0)
    obs_env, info_env = env.reset(seed=0)
    np.testing.assert_array_equal(obs_twin, obs_env)
    np.testing.assert_array_equal(info_twin["initial_angles"], info_env["initial_angles"])
    action = np.array([0.5, -0.5, 1.0], dtype=np.float32)
    for _ in range(3):  # and they step alike, each in its own world
        np.testing.assert_array_equal(twin.step(action)[0], env.step(action)[0])
    assert twin.world.client != env.world.client
    twin.close()
    env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_an_unknown_argument_is_reported_for_its_own_task(env_id):
    with pytest.raises(ValueError) as err:
        gym.make(env_id, bogus=1)
    message = str(err.value)
    assert f"unknown {env_id} argument(s) ['bogus']" in message, message
    assert not any(other in message for other in ENV_IDS if other != env_id), message
    assert "damage" in message and "drag_coefficient" in message, message  # what is allowed
    if env_id == "AquaFishStationKeeping-v0":
        assert "current_speed" in message, message
    if env_id == "AquaFishHeading-v0":
        assert "target_heading_deg" in message, message


def test_a_damage_option_holds_for_its_episode_and_random_draws_from_the_presets():
    env = gym.make("AquaFish-v0", episode_duration_s=0.2).unwrapped
    assert env.reset(seed=0, options={"damage": "left_pectoral_half"})[1]["damage"] == "left_pectoral_half"
    _, info = env.reset(seed=0)  # the next episode is the constructor's damage again
    assert info["damage"] == "none" and env.morphology == Morphology.healthy()
    drawn = {env.reset(seed=s, options={"damage": "random"})[1]["damage"] for s in range(20)}
    assert len(drawn) >= 3 and drawn <= set(DAMAGES)
    listed = {env.reset(seed=s, options={"damage": ["caudal_half", "left_pectoral_missing"]})[1]["damage"]
              for s in range(20)}
    assert listed == {"caudal_half", "left_pectoral_missing"}
    env.close()


def _swim_turned(yaw_deg, steps=40):
    env = gym.make("AquaFish-v0", damage="left_pectoral_half").unwrapped
    options = {"initial_angles": [0.3, 2.0, 0.1]} | ({} if yaw_deg is None else {"initial_yaw_deg": yaw_deg})
    obs, _ = env.reset(seed=0, options=options)
    observations, rewards = [obs], []
    for k in range(steps):
        obs, reward, *_ = env.step(np.array([np.sin(k / 5), 0.5, 0.8]))
        observations.append(obs)
        rewards.append(reward)
    moved = env.world.position[0, 0] - env.world.home[0]
    env.close()
    return np.array(observations), np.array(rewards), moved


def test_a_robot_started_turned_swims_the_same_motion_turned_and_is_rewarded_along_plus_y():
    straight, straight_rewards, straight_moved = _swim_turned(None)
    zero, zero_rewards, _ = _swim_turned(0.0)
    np.testing.assert_array_equal(zero, straight)                      # 0 degrees is the default start, bit for bit
    np.testing.assert_array_equal(zero_rewards, straight_rewards)
    turned, turned_rewards, turned_moved = _swim_turned(90.0)
    assert np.degrees(np.arctan2(turned[0, 2], turned[0, 5])) == pytest.approx(90.0)   # the IMU's yaw starts there
    body = [0, 1, 3, 4, 6, 7, 8, 9, 10, 11]                             # all but sin and cos of the yaw
    np.testing.assert_allclose(turned[:, body], straight[:, body], atol=1e-12)   # isotropic water: the same motion
    np.testing.assert_allclose(np.degrees(np.arctan2(turned[:, 2], turned[:, 5])),
                               (np.degrees(np.arctan2(straight[:, 2], straight[:, 5])) + 90.0 + 180.0) % 360.0 - 180.0,
                               atol=1e-9)
    x, y = straight_moved[:2]
    np.testing.assert_allclose(turned_moved[:2], [-y, x], atol=1e-12)   # the path turned 90 degrees counter-clockwise
    assert turned_rewards.sum() == pytest.approx(x, abs=1e-12)          # forward is still +y: the path's old x
    assert straight_rewards.sum() == pytest.approx(y, abs=1e-12)


@pytest.mark.parametrize("yaw", [181.0, -180.5, float("nan"), float("inf"), "north", True, None, [10.0]])
def test_a_bad_initial_yaw_is_refused_naming_the_allowed_range(yaw):
    env = gym.make("AquaFish-v0", episode_duration_s=0.2).unwrapped
    with pytest.raises(ValueError, match=r"initial_yaw_deg'\] must be a number of degrees in \[-180, 180\]"):
        env.reset(seed=0, options={"initial_yaw_deg": yaw})
    env.close()
