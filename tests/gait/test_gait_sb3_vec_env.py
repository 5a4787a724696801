"""The SB3 VecEnv over the batched vector env equals SB3's DummyVecEnv over ClockObservation envs."""

import numpy as np
import pytest

pytestmark = pytest.mark.rl
pytest.importorskip("stable_baselines3")

from stable_baselines3 import PPO  # noqa: E402
from stable_baselines3.common.env_util import make_vec_env  # noqa: E402
from stable_baselines3.common.monitor import load_results  # noqa: E402
from stable_baselines3.common.vec_env import VecEnv  # noqa: E402

from gait.rl import make_rl_env  # noqa: E402
from gait.robots import as_robot  # noqa: E402
from gait.sb3_vec_env import ClockVecEnv, make_clock_vec_env  # noqa: E402

#: The vector env's bound on position round-off (positions, distance, the forward reward).
TOL = 1e-9


def _reward_tol(rewards: np.ndarray) -> np.ndarray:
    """Rewards are float32 (as DummyVecEnv's): a 1e-13 difference may round to the neighbouring float32."""
    return np.maximum(TOL, np.spacing(np.abs(rewards).astype(np.float32)))


def _stacks(robot, n, seed, duration_s, env_id="AquaFish-v0"):
    dummy = make_vec_env(lambda: make_rl_env(robot, episode_duration_s=duration_s, env_id=env_id), n_envs=n, seed=seed)
    batched = make_clock_vec_env(robot, n, seed=seed, episode_duration_s=duration_s, env_id=env_id)
    return dummy, batched


@pytest.mark.parametrize("env_id, robot", [("AquaFish-v0", "healthy"), ("AquaFish-v0", "left_pectoral_half"),
                                           ("AquaFishHeading-v0", "healthy")])
def test_same_seeds_and_actions_give_dummy_vec_envs_results_across_episode_ends(env_id, robot):
    robot = as_robot(robot)
    n, steps_per_episode = 5, 8
    dummy, batched = _stacks(robot, n, seed=11, duration_s=0.1 * steps_per_episode, env_id=env_id)
    try:
        first = batched.reset()
        assert first.shape == (n, dummy.observation_space.shape[0]) and first.dtype == np.float64
        assert np.array_equal(dummy.reset(), first)
        rng = np.random.default_rng(3)
        ends = 0
        for t in range(2 * steps_per_episode + 3):  # two episode ends and their resets
            actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
            obs_d, rew_d, done_d, info_d = dummy.step(actions)
            obs_b, rew_b, done_b, info_b = batched.step(actions)
            assert np.array_equal(obs_d, obs_b), t  # after an end: the new episodes' first observations
            assert rew_b.dtype == rew_d.dtype == np.float32
            assert np.all(np.abs(rew_d.astype(float) - rew_b) <= _reward_tol(rew_d)), t
            assert np.array_equal(done_d, done_b), t
            assert done_b.all() == ((t + 1) % steps_per_episode == 0)
            for d, b in zip(info_d, info_b):
                assert set(d) == set(b)
                assert d["TimeLimit.truncated"] == b["TimeLimit.truncated"] == bool(done_b[0])
                assert d["time_s"] == b["time_s"]
                assert d["distance"] == pytest.approx(b["distance"], abs=TOL, rel=0)
                if done_b[0]:
                    assert np.array_equal(d["terminal_observation"], b["terminal_observation"])
                    assert d["episode"]["l"] == b["episode"]["l"] == steps_per_episode
                    assert d["episode"]["r"] == pytest.approx(float(b["episode"]["r"]), abs=1e-5)  # 6 decimals
            ends += int(done_b.all())
        assert ends == 2
    finally:
        dummy.close()
        batched.close()


def test_the_clock_follows_each_episodes_time_and_the_period():
    venv = ClockVecEnv("healthy", 2, episode_duration_s=0.3, clock_period_s=0.4)
    try:
        obs = venv.reset()
        assert np.array_equal(obs[:, -2:], [[0.0, 1.0], [0.0, 1.0]])
        for t in (0.1, 0.2):
            obs, _, dones, _ = venv.step(np.zeros((2, 3), np.float32))
            phase = 2 * np.pi * t / 0.4
            assert np.allclose(obs[:, -2:], [np.sin(phase), np.cos(phase)], atol=1e-12) and not dones.any()
        obs, _, dones, infos = venv.step(np.zeros((2, 3), np.float32))
        assert dones.all() and np.array_equal(obs[:, -2:], [[0.0, 1.0], [0.0, 1.0]])  # reset in the same step
        phase = 2 * np.pi * 0.3 / 0.4
        assert np.allclose(infos[0]["terminal_observation"][-2:], [np.sin(phase), np.cos(phase)], atol=1e-12)
    finally:
        venv.close()


def test_seed_sets_the_next_reset_only_and_bad_input_is_refused():
    venv = ClockVecEnv("healthy", 3, episode_duration_s=1.0)
    try:
        assert isinstance(venv, VecEnv) and venv.num_envs == 3
        assert venv.seed(5) == [5, 6, 7]
        first = venv.reset()
        for i in range(3):  # sub-env i is the single env seeded 5 + i
            single = make_rl_env(as_robot("healthy"), episode_duration_s=1.0)
            obs, info = single.reset(seed=5 + i)
            single.close()
            assert np.array_equal(first[i], obs)
            assert np.array_equal(venv.reset_infos[i]["initial_angles"], info["initial_angles"])
        angles = np.array([info["initial_angles"] for info in venv.reset_infos])
        venv.reset()  # the generators continue: other initial angles
        assert not np.array_equal([info["initial_angles"] for info in venv.reset_infos], angles)
        venv.seed(5)
        venv.reset()
        assert np.array_equal([info["initial_angles"] for info in venv.reset_infos], angles)
        assert venv.get_attr("render_mode") == [None] * 3
        assert venv.env_is_wrapped(object) == [False] * 3
        assert venv.get_attr("env_id", indices=1) == ["AquaFish-v0"]
        with pytest.raises(ValueError):
            venv.step(np.full((3, 3), 2.0, np.float32))
        with pytest.raises(ValueError):
            venv.step(np.zeros((2, 3), np.float32))
        venv.set_options([{"initial_angles": [0, 0, 0]}, {}, {}])
        with pytest.raises(ValueError, match="same options"):
            venv.reset()
    finally:
        venv.close()
    with pytest.raises(ValueError):
        ClockVecEnv("healthy", 0)
    with pytest.raises(ValueError):
        ClockVecEnv("healthy", 2, clock_period_s=0.0)


def test_ppo_trains_a_few_hundred_steps_and_logs_its_episodes(tmp_path):
    venv = make_clock_vec_env("healthy", 4, seed=0, episode_duration_s=2.0, monitor_dir=tmp_path / "monitor")
    model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=2, seed=0, device="cpu",
                policy_kwargs={"net_arch": [16]})
    model.learn(total_timesteps=512)
    venv.close()
    assert model.num_timesteps == 512
    curve = load_results(str(tmp_path / "monitor"))
    assert len(curve) == 4 * (128 // 20) and (curve["l"] == 20).all()  # 4 sub-envs x 128 steps, 20-step episodes
    assert np.isfinite(curve["r"]).all() and len(model.ep_info_buffer) == len(curve)


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_one_sub_env_trains_the_same_model_as_dummy_vec_env_bit_for_bit(algo):
    """Sub-env 0 is exact (its robot sits at the world's origin), so with one sub-env the training
    (episode ends every 10 steps: terminal observations, time-limit bootstrapping) is the same."""
    import torch
    from stable_baselines3 import SAC

    torch.set_num_threads(1)
    params = []
    for make in (lambda: make_vec_env(lambda: make_rl_env(as_robot("healthy"), episode_duration_s=1.0), n_envs=1,
                                      seed=2),
                 lambda: make_clock_vec_env("healthy", 1, seed=2, episode_duration_s=1.0)):
        venv = make()
        if algo == "ppo":
            model = PPO("MlpPolicy", venv, n_steps=32, batch_size=16, n_epochs=2, seed=2, device="cpu",
                        policy_kwargs={"net_arch": [8]})
        else:
            model = SAC("MlpPolicy", venv, learning_starts=16, batch_size=8, seed=2, device="cpu",
                        policy_kwargs={"net_arch": [8]})
        model.learn(total_timesteps=64)
        venv.close()
        params.append(np.concatenate([p.detach().numpy().ravel() for p in model.policy.parameters()]))
        assert [e["l"] for e in model.ep_info_buffer] == [10] * 6
    assert np.array_equal(params[0], params[1])


def test_train_rl_logs_one_episode_file_and_drops_an_unfinished_runs_logs(tmp_path):
    import yaml

    from gait import train_rl

    hp = tmp_path / "hp.yml"
    hp.write_text(yaml.safe_dump({"ppo": {"AquaFish-v0": {"n_timesteps": 64, "policy": "MlpPolicy", "n_envs": 2,
                                                          "n_steps": 32, "batch_size": 32, "n_epochs": 1,
                                                          "policy_kwargs": {"net_arch": [8]}}}}))
    stale = tmp_path / "run" / "monitor" / "0.monitor.csv"  # left by an interrupted run
    stale.parent.mkdir(parents=True)
    stale.write_text('#{"t_start": 0.0, "env_id": "None"}\nr,l,t\n99.0,10,0.1\n')
    train_rl("ppo", "healthy", 64, 0, tmp_path / "run", hyperparams_path=hp, episode_duration_s=1.0, num_threads=1,
             progress=False)
    assert sorted(p.name for p in stale.parent.iterdir()) == ["monitor.csv"]
    curve = load_results(str(stale.parent))
    assert len(curve) == 2 * (32 // 10) and (curve["l"] == 10).all() and (curve["r"] != 99.0).all()
