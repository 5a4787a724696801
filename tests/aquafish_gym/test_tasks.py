"""The task family: AquaFishStationKeeping-v0, AquaFishHeading-v0 and damage randomisation."""

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import aquafish_gym
from aquafish_gym import DAMAGES, ENV_IDS, Morphology

PASSIVE = np.array([0.0, 0.0, -1.0], dtype=np.float32)   # pectorals still (0 rev/s), caudal fin off (0 Hz)


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_every_task_passes_check_env_with_warnings_as_errors(env_id):
    env = gym.make(env_id, episode_duration_s=1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped)
    env.close()


@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_every_task_runs_vectorised_and_reward_terms_add_up(env_id):
    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="sync", episode_duration_s=0.5, ctrl_cost_weight=0.1)
    obs, _ = envs.reset(seed=0)
    assert obs.shape == (2,) + gym.spec(env_id).make().observation_space.shape
    action = np.array([[1.0, -1.0, 1.0], [0.5, 0.5, 0.0]], dtype=np.float32)
    for _ in range(5):
        obs, rewards, _, _, info = envs.step(action)
        terms = sum(info[k] for k in info if k.startswith("reward_") and not k.startswith("_"))
        np.testing.assert_allclose(rewards, terms, rtol=0, atol=1e-12)
        np.testing.assert_allclose(info["reward_ctrl"], [-0.3, -0.05])
    envs.close()


@pytest.mark.parametrize("direction_deg", [0.0, 90.0, 180.0, 270.0])
def test_a_passive_robot_drifts_with_the_current(direction_deg):
    env = gym.make("AquaFishStationKeeping-v0", current_speed=0.2, current_direction_deg=direction_deg,
                   episode_duration_s=5.0)
    env.reset(seed=1)
    for _ in range(50):
        *_, info = env.step(PASSIVE)
    # the water flows counter-clockwise from the initial heading (+y) seen from above
    expected = np.array([-math.sin(math.radians(direction_deg)), math.cos(math.radians(direction_deg))])
    np.testing.assert_allclose(info["current"], np.append(0.2 * expected, 0.0), atol=1e-15)
    drift = np.array([info["x_position"], info["y_position"]])
    assert 0.05 < np.linalg.norm(drift) < 0.2 * 5.0                  # carried off, never faster than the water
    assert drift @ expected / np.linalg.norm(drift) > math.cos(math.radians(10))
    assert info["distance_from_start"] == pytest.approx(np.linalg.norm(drift), abs=1e-12)
    env.close()


def test_station_keeping_reward_is_minus_the_distance_and_heading_terms():
    env = gym.make("AquaFishStationKeeping-v0", current_speed=0.3, current_direction_deg=90.0,
                   position_cost_weight=2.0, heading_cost_weight=3.0, episode_duration_s=3.0)
    _, info = env.reset(seed=0)
    assert info["distance_from_start"] == 0.0
    for _ in range(30):
        obs, reward, _, _, info = env.step(np.array([1.0, -1.0, 0.0], dtype=np.float32))  # spins the robot
    d = math.hypot(info["x_position"], info["y_position"])
    yaw = math.atan2(obs[2], obs[5])                                    # from the observation's sin, cos
    assert info["reward_position"] == pytest.approx(-2.0 * d, abs=1e-12)
    assert info["reward_heading"] == pytest.approx(-3.0 * (1.0 - math.cos(yaw)), abs=1e-12)
    assert abs(yaw) > 0.05 and reward == pytest.approx(-2.0 * d - 3.0 * (1.0 - math.cos(yaw)), abs=1e-12)


def test_the_current_is_not_observed_and_is_drawn_per_episode():
    still = gym.make("AquaFishStationKeeping-v0", current_speed=0.0)
    drawn = gym.make("AquaFishStationKeeping-v0", current_speed=(0.1, 0.4), current_direction_deg=None)
    assert still.observation_space == gym.make("AquaFish-v0").observation_space
    currents = []
    for seed in range(4):
        obs_still, _ = still.reset(seed=seed)
        obs_drawn, info = drawn.reset(seed=seed)
        np.testing.assert_array_equal(obs_still, obs_drawn)            # same start, whatever the current
        currents.append(info["current"])
    speeds = np.linalg.norm(currents, axis=1)
    assert np.all((speeds >= 0.1) & (speeds <= 0.4)) and len(np.unique(speeds)) == 4
    _, info = drawn.reset(seed=0, options={"current_speed": 0.25, "current_direction_deg": 180.0})
    np.testing.assert_allclose(info["current"], [0.0, -0.25, 0.0], atol=1e-15)


def test_heading_observation_and_reward_follow_the_target():
    env = gym.make("AquaFishHeading-v0", heading_reward_weight=2.0, forward_reward_weight=1.0, episode_duration_s=2.0)
    obs, info = env.reset(seed=0, options={"target_heading_deg": 90.0})
    assert info["target_heading_rad"] == pytest.approx(math.pi / 2)
    np.testing.assert_allclose(obs[12:], [1.0, 0.0], atol=1e-6)       # at rest, heading 0: 90 deg to turn left
    for _ in range(10):
        obs, reward, _, _, info = env.step(np.array([-1.0, -1.0, 1.0], dtype=np.float32))
    error = info["heading_error_rad"]
    yaw = math.atan2(obs[2], obs[5])
    assert error == pytest.approx(math.remainder(math.pi / 2 - yaw, 2 * math.pi), abs=1e-12)
    np.testing.assert_allclose(obs[12:], [math.sin(error), math.cos(error)], atol=1e-12)
    assert info["reward_heading"] == pytest.approx(2.0 * math.cos(error), abs=1e-12)
    # forward term: displacement along the target heading (-x for 90 deg) in the step
    targets = [env.reset(seed=s)[1]["target_heading_rad"] for s in range(5)]
    assert all(-math.pi <= t <= math.pi for t in targets) and len(set(targets)) == 5


def test_heading_forward_term_is_the_displacement_along_the_target():
    env = gym.make("AquaFishHeading-v0", target_heading_deg=90.0, heading_reward_weight=0.0,
                   forward_reward_weight=1.0, episode_duration_s=2.0)
    _, info = env.reset(seed=0)
    x0 = info["x_position"]
    total = 0.0
    for _ in range(20):
        _, reward, _, _, info = env.step(np.array([0.0, 0.0, 1.0], dtype=np.float32))
        total += reward
    assert total == pytest.approx(-(info["x_position"] - x0), abs=1e-12)


def test_damage_randomisation_draws_presets_and_reports_them():
    env = gym.make("AquaFish-v0", damage="random", episode_duration_s=0.2)
    seen = set()
    for seed in range(30):
        _, info = env.reset(seed=seed)
        seen.add(info["damage"])
        assert env.unwrapped.morphology == DAMAGES[info["damage"]].apply(Morphology.healthy())
        assert env.unwrapped.faults == DAMAGES[info["damage"]].faults
    assert len(seen) >= 5 and seen <= set(DAMAGES)
    two = gym.make("AquaFishHeading-v0", damage=["caudal_half", "left_pectoral_missing"], episode_duration_s=0.2)
    assert {two.reset(seed=s)[1]["damage"] for s in range(20)} == {"caudal_half", "left_pectoral_missing"}
    _, info = two.reset(seed=0, options={"damage": "none"})
    assert info["damage"] == "none" and two.unwrapped.morphology == Morphology.healthy()


@pytest.mark.parametrize("env_id, kwargs, match", [
    ("AquaFish-v0", {"damage": "broken_everything"}, "unknown damage"),
    ("AquaFish-v0", {"damage": []}, "non-empty list"),
    ("AquaFishStationKeeping-v0", {"current_speed": -0.1}, r"current_speed .* within \[0, 5\]"),
    ("AquaFishStationKeeping-v0", {"current_direction_deg": (90.0, 10.0)}, "current_direction_deg"),
    ("AquaFishStationKeeping-v0", {"water_current": (0.1, 0.0, 0.0)}, "current_speed and current_direction_deg"),
    ("AquaFishStationKeeping-v0", {"position_cost_weight": float("nan")}, "position_cost_weight"),
    ("AquaFishHeading-v0", {"target_heading_deg": 270.0}, r"within \[-180, 180\]"),
    ("AquaFishHeading-v0", {"forward_reward_weight": -1.0}, "forward_reward_weight"),
])
def test_bad_task_settings_raise(env_id, kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make(env_id, **kwargs)


def test_env_ids_are_registered_on_import():
    assert set(ENV_IDS) <= set(gym.registry) and aquafish_gym.ENV_IDS["AquaFish-v0"].endswith(":AquaFishEnv")
