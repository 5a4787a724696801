"""Rollout: the gait fitness is the env's summed reward, reproducible for a seed."""

import gymnasium as gym
import numpy as np
import pytest
from gait_helpers import SHORT_S

import aquafish_gym  # noqa: F401
from gait import ClockObservation, rollout, with_clock
from gait.rollout import batch_rollouts
from gait.clock import clock_features
from gait.controller import ConstantController
from gait.fitness_task import FitnessTask, evaluate_genome
from gait.robots import Robot
from aquafish_gym import Morphology


def test_score_is_reproducible_for_a_seed(controller):
    a = rollout(controller, seed=3, episode_duration_s=SHORT_S)
    b = rollout(controller, seed=3, episode_duration_s=SHORT_S)
    assert a.distance == b.distance
    np.testing.assert_array_equal(a.trajectory, b.trajectory)
    np.testing.assert_array_equal(a.initial_angles, b.initial_angles)
    c = rollout(controller, seed=4, episode_duration_s=SHORT_S)
    assert not np.allclose(c.initial_angles, a.initial_angles)


def test_fitness_equals_env_summed_reward(controller):
    """The NEAT fitness, the rollout distance and a hand-written env loop agree exactly."""
    env = gym.make("AquaFish-v0", episode_duration_s=SHORT_S)
    obs, info = env.reset(seed=5)
    controller.reset()
    total, done = 0.0, False
    while not done:
        obs, reward, terminated, truncated, info = env.step(controller.act(obs, info["time_s"]))
        total += reward
        done = terminated or truncated
    env.close()
    r = rollout(controller, seed=5, episode_duration_s=SHORT_S)
    assert r.distance == pytest.approx(total, abs=1e-12)
    assert r.episode_return == pytest.approx(total, abs=1e-12)
    task = FitnessTask(Robot(Morphology.healthy()), seed=5, episode_duration_s=SHORT_S)
    assert evaluate_genome(controller.genome, controller.config, task=task) == r.distance
    assert r.distance == pytest.approx(r.trajectory[-1, 1] - r.trajectory[0, 1], abs=1e-9)  # heading +y


def test_trajectory_every_control_step(controller):
    r = rollout(controller, seed=0, episode_duration_s=SHORT_S)
    steps = int(round(SHORT_S / 0.1))
    assert r.trajectory.shape == (steps + 1, 2)
    np.testing.assert_allclose(np.diff(r.times_s), 0.1)
    np.testing.assert_allclose(r.trajectory[0], 0.0, atol=1e-9)
    assert np.all(np.isfinite(r.trajectory))


def test_given_initial_angles_override_seed(controller):
    angles = np.array([0.5, 1.0, 0.1])
    a = rollout(controller, seed=1, initial_angles=angles, episode_duration_s=SHORT_S)
    b = rollout(controller, seed=2, initial_angles=angles, episode_duration_s=SHORT_S)
    np.testing.assert_array_equal(a.initial_angles, angles)
    assert a.distance == b.distance


def test_damage_changes_the_episode(controller):
    healthy = rollout(controller, "healthy", seed=0, episode_duration_s=SHORT_S)
    damaged = rollout(controller, "left_pectoral_half", seed=0, episode_duration_s=SHORT_S)
    np.testing.assert_array_equal(healthy.initial_angles, damaged.initial_angles)
    assert healthy.distance != damaged.distance


def test_controller_sees_the_clock(controller):
    obs = np.zeros(12)
    controller.reset()
    actions = np.array([controller.act(obs, t) for t in (0.0, 0.25, 0.5, 1.0)])
    np.testing.assert_allclose(actions[0], actions[3], atol=1e-12)  # period 1 s
    assert not np.allclose(actions[0], actions[1])


def test_clock_features_and_errors():
    np.testing.assert_allclose(clock_features(0.25, 1.0), [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(with_clock(np.arange(14.0), 0.5, 2.0), np.r_[np.arange(14.0), 1.0, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="non-empty 1-D"):
        with_clock(np.zeros((2, 6)), 0.0)
    with pytest.raises(ValueError, match="clock_period_s"):
        ClockObservation(gym.make("AquaFish-v0"), period_s=0.0)


def test_clock_observation_wrapper_matches_controller_inputs():
    env = ClockObservation(gym.make("AquaFish-v0", episode_duration_s=SHORT_S), period_s=1.0)
    assert env.observation_space.shape == (14,)
    obs, info = env.reset(seed=0)
    np.testing.assert_allclose(obs[12:], [0.0, 1.0])
    obs, *_, info = env.step(np.zeros(3))
    np.testing.assert_allclose(obs[12:], clock_features(info["time_s"]), atol=1e-12)
    assert env.observation_space.contains(obs)
    env.close()


def test_bad_action_from_controller_raises():
    class Wild:
        def reset(self):
            pass

        def act(self, obs, time_s):
            return np.full(3, 2.0)

    with pytest.raises(ValueError, match=r"\[-1, 1\]"):
        rollout(Wild(), episode_duration_s=SHORT_S)


def _recurrent_controller(tmp_path):
    """A NEAT controller of a recurrent network (``feed_forward = False``)."""
    import neat

    from gait import NEATController, load_neat_config
    from gait.neat_evolution import DEFAULT_CONFIG

    path = tmp_path / "recurrent.ini"
    path.write_text(DEFAULT_CONFIG.read_text().replace("feed_forward            = True", "feed_forward            = False"))
    config = load_neat_config(path, population_size=2)
    return NEATController(next(iter(neat.Population(config, seed=1).population.values())), config)


def test_recurrent_network_option_is_reproducible(tmp_path):
    """feed_forward = False gives neat.nn.RecurrentNetwork; reset() clears its state between episodes."""
    import neat

    c = _recurrent_controller(tmp_path)
    assert not c.feed_forward
    a, b = (rollout(c, seed=0, episode_duration_s=SHORT_S) for _ in range(2))
    assert isinstance(c._net, neat.nn.RecurrentNetwork)
    assert a.distance == b.distance


@pytest.mark.parametrize("robot", ["healthy", "left_pectoral_half"])
def test_batch_rollouts_are_the_single_env_episodes(controller, robot):
    """Episode k of the vector env is rollout(seed=seeds[k]): the same initial angles, times and
    return terms not made of positions to the bit, positions to round-off (episode 0 exact)."""
    seeds = [5, 2, 9]
    batch = batch_rollouts(controller, robot, seeds, episode_duration_s=SHORT_S)
    for k, (seed, got) in enumerate(zip(seeds, batch)):
        alone = rollout(controller, robot, seed=seed, episode_duration_s=SHORT_S)
        np.testing.assert_array_equal(got.initial_angles, alone.initial_angles)
        np.testing.assert_array_equal(got.times_s, alone.times_s)
        assert got.trajectory.shape == alone.trajectory.shape == (21, 2) and got.robot == alone.robot
        if k == 0:
            np.testing.assert_array_equal(got.trajectory, alone.trajectory)
            assert got.distance == alone.distance and got.episode_return == alone.episode_return
        np.testing.assert_allclose(got.trajectory, alone.trajectory, rtol=0, atol=1e-9)
        assert got.distance == pytest.approx(alone.distance, abs=1e-9)
        assert got.episode_return == pytest.approx(alone.episode_return, abs=1e-9)
    assert len({r.distance for r in batch}) == 3                     # three different starts


def test_batch_rollouts_give_each_episode_its_own_recurrent_state(tmp_path):
    """A recurrent network keeps state between steps: each sub-env drives its own copy."""
    c = _recurrent_controller(tmp_path)
    batch = batch_rollouts(c, "healthy", [0, 1], episode_duration_s=SHORT_S)
    for seed, got in zip([0, 1], batch):
        assert got.distance == pytest.approx(rollout(c, seed=seed, episode_duration_s=SHORT_S).distance, abs=1e-9)


def test_batch_rollouts_refuse_no_seeds_and_bad_seeds(controller):
    with pytest.raises(ValueError, match="at least one seed"):
        batch_rollouts(controller, "healthy", [], episode_duration_s=SHORT_S)
    with pytest.raises(ValueError, match="seed"):
        batch_rollouts(controller, "healthy", [1.5], episode_duration_s=SHORT_S)


def test_constant_controller_caudal_only_matches_the_simulator():
    """(0, 0, 1) is pectorals still and the caudal fin at 1 Hz; its distance is the body's forward displacement."""
    from aquafish_gym import BatchWorld

    out = rollout(ConstantController([0.0, 0.0, 1.0]), "healthy", initial_angles=(0.0, 0.0, 0.0), episode_duration_s=2.0)
    with BatchWorld(Morphology.healthy().to_array()[None]) as world:
        world.reset(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
        for _ in range(200):
            world.step()
        forward = world.position[0, 0, 1] - world.home[0, 1]
    assert forward > 0.1
    assert out.distance == pytest.approx(forward, abs=1e-9)


@pytest.mark.parametrize("action", [[0.0, 0.0], [0.0, 0.0, 1.5], [float("nan"), 0.0, 0.0]])
def test_constant_controller_rejects_bad_actions(action):
    with pytest.raises(ValueError, match="action"):
        ConstantController(action)
