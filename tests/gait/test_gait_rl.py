"""RL baselines (stable-baselines3): env check, hyperparameters, a short PPO run end to end."""

import json

import gymnasium as gym
import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.rl
pytest.importorskip("stable_baselines3")

import aquafish_gym  # noqa: E402
from stable_baselines3.common.env_checker import check_env  # noqa: E402

from gait import (ClockObservation, SB3PolicyController, load_controller, rollout, score_transfer, train_or_load_rl,  # noqa: E402
                  train_rl, with_clock)
from gait.rl import load_hyperparams  # noqa: E402


@pytest.mark.parametrize("env_id", sorted(aquafish_gym.ENV_IDS))
def test_sb3_check_env_passes_with_warnings_as_errors(env_id):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id, episode_duration_s=1.0).unwrapped, warn=True)
        check_env(ClockObservation(gym.make(env_id, episode_duration_s=1.0)), warn=True)


@pytest.mark.parametrize("algo", ["ppo", "sac", "recurrent_ppo"])
def test_shipped_hyperparams(algo):
    hp = load_hyperparams(algo)
    assert hp["policy"] == ("MlpLstmPolicy" if algo == "recurrent_ppo" else "MlpPolicy")
    assert hp["n_timesteps"] == 100_000
    assert isinstance(hp["policy_kwargs"], dict)


def test_cli_offers_every_rl_algorithm():
    from gait.cli import RL_ALGOS
    from gait.controller import SB3_ALGOS

    assert RL_ALGOS == SB3_ALGOS


def test_recurrent_policy_keeps_its_memory_within_an_episode_and_clears_it_at_reset(tmp_path):
    pytest.importorskip("sb3_contrib")
    hp = tmp_path / "hp.yml"
    hp.write_text(yaml.safe_dump({"recurrent_ppo": {"AquaFish-v0": {
        "n_timesteps": 64, "policy": "MlpLstmPolicy", "n_envs": 1, "n_steps": 32, "batch_size": 32, "n_epochs": 1,
        "policy_kwargs": {"net_arch": [8], "lstm_hidden_size": 8}}}}))
    path = train_rl("recurrent_ppo", "healthy", 64, 0, tmp_path / "lstm", hyperparams_path=hp, episode_duration_s=1.0,
                    num_threads=1)
    meta = json.loads(path.with_suffix(".json").read_text())
    controller = load_controller(path)
    assert type(controller.model).__name__ == "RecurrentPPO"
    obs = np.zeros(12)
    first = controller.act(obs, 0.0)
    second = controller.act(obs, 0.0)  # the same input, but the LSTM has seen one step
    assert not np.array_equal(first, second)
    controller.reset()
    np.testing.assert_array_equal(controller.act(obs, 0.0), first)
    # the saved score is reproduced by the loaded policy, its memory carried through the episode
    assert rollout(controller, seed=meta["eval_seed"]).distance == pytest.approx(meta["eval_distance"], abs=1e-9)


def test_hyperparams_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown RL algorithm"):
        load_hyperparams("dqn")
    path = tmp_path / "h.yml"
    path.write_text(yaml.safe_dump({"ppo": {"AquaFish-v0": {"policy": "MlpPolicy", "n_timesteps": 10, "normalize": True}}}))
    with pytest.raises(ValueError, match="normalize"):
        load_hyperparams("ppo", path)
    with pytest.raises(ValueError, match="no section sac"):
        load_hyperparams("sac", path)
    path.write_text(yaml.safe_dump({"ppo": {"AquaFish-v0": {"policy": "MlpPolicy", "n_timesteps": 10, "learning_rate": "lin_1e-3"}}}))
    assert load_hyperparams("ppo", path)["learning_rate"](0.5) == pytest.approx(5e-4)


def test_short_ppo_trains_saves_loads_and_scores(tmp_path):
    hp = tmp_path / "hp.yml"
    hp.write_text(yaml.safe_dump({"ppo": {"AquaFish-v0": {
        "n_timesteps": 256, "policy": "MlpPolicy", "n_envs": 1, "n_steps": 64, "batch_size": 32, "n_epochs": 2,
        "policy_kwargs": {"net_arch": [16, 16]}}}}))
    path = train_rl("ppo", "healthy", 256, 0, tmp_path / "ppo", hyperparams_path=hp, episode_duration_s=2.0, num_threads=1)
    assert path.name == "model.zip" and path.is_file()
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta["algo"] == "ppo" and meta["timesteps"] == 256
    assert (tmp_path / "ppo" / "learning_curve.png").is_file()
    assert yaml.safe_load((tmp_path / "ppo" / "hyperparams.yml").read_text())["ppo"]["AquaFish-v0"]["n_steps"] == 64

    controller = load_controller(tmp_path / "ppo")
    assert isinstance(controller, SB3PolicyController)
    # the loaded policy sees the clock of the period recorded in model.json, deterministically
    raw, _ = controller.model.predict(with_clock(np.zeros(12), 0.3, meta["clock_period_s"]), deterministic=True)
    np.testing.assert_array_equal(controller.act(np.zeros(12), 0.3), np.clip(np.asarray(raw, dtype=np.float64), -1, 1))
    # the saved score is reproduced by the loaded policy (deterministic actions, same seed)
    assert rollout(controller, seed=meta["eval_seed"]).distance == pytest.approx(meta["eval_distance"], abs=1e-9)
    t = score_transfer(controller, "healthy", "left_pectoral_half", seed=0, episode_duration_s=2.0)
    assert np.isfinite(t.native_distance) and np.isfinite(t.target_distance)
    assert t.target_trajectory.shape == (21, 2)


def test_ppo_on_another_task_uses_its_section_and_reports_its_return(tmp_path):
    hp = tmp_path / "hp.yml"
    section = {"n_timesteps": 128, "policy": "MlpPolicy", "n_envs": 1, "n_steps": 64, "batch_size": 32, "n_epochs": 1,
               "policy_kwargs": {"net_arch": [8]}}
    hp.write_text(yaml.safe_dump({"ppo": {"AquaFishStationKeeping-v0": section}}))
    with pytest.raises(ValueError, match="no section ppo -> AquaFish-v0"):
        train_rl("ppo", "healthy", 128, 0, tmp_path / "fwd", hyperparams_path=hp, episode_duration_s=1.0)
    path = train_rl("ppo", "healthy", 128, 0, tmp_path / "sk", hyperparams_path=hp, episode_duration_s=1.0,
                    num_threads=1, env_id="AquaFishStationKeeping-v0")
    meta = json.loads(path.with_suffix(".json").read_text())
    controller = load_controller(path)
    again = rollout(controller, seed=meta["eval_seed"], env_id="AquaFishStationKeeping-v0")
    assert meta["env_id"] == "AquaFishStationKeeping-v0"
    assert meta["eval_return"] == pytest.approx(again.episode_return, abs=1e-9) and meta["eval_return"] < 0
    # a finished run is reused, not trained again (train_rl would rewrite model.json)
    written = path.with_suffix(".json").stat().st_mtime_ns
    assert train_or_load_rl("ppo", "healthy", 128, 0, tmp_path / "sk", hyperparams_path=hp, episode_duration_s=1.0,
                            env_id="AquaFishStationKeeping-v0") == path
    assert path.with_suffix(".json").stat().st_mtime_ns == written
    for algo in ("ppo", "sac", "recurrent_ppo"):  # the shipped file has a section for every task
        for env_id in aquafish_gym.ENV_IDS:
            assert load_hyperparams(algo, env_id=env_id)["policy"].startswith("Mlp")


class _Payload:
    """Pickles to a call that creates the directory ``marker`` when it is unpickled."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        import os
        return os.mkdir, (self.marker,)


def _rewrite_data(model, edit):
    """Rewrite the ``data`` JSON of the SB3 zip ``model`` with ``edit(data)``."""
    import zipfile

    with zipfile.ZipFile(model) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    data = json.loads(entries["data"])
    edit(data)
    entries["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(model, "w") as archive:
        for name, content in entries.items():
            archive.writestr(name, content)


def test_loading_an_sb3_model_runs_no_pickle_from_it(tmp_path):
    import base64
    import inspect

    import cloudpickle
    from stable_baselines3.common import save_util

    from aquafish_gym.rundir import FileError

    hp = tmp_path / "hp.yml"
    hp.write_text(yaml.safe_dump({"ppo": {"AquaFish-v0": {
        "n_timesteps": 64, "policy": "MlpPolicy", "n_envs": 1, "n_steps": 32, "batch_size": 16, "n_epochs": 1,
        "policy_kwargs": {"net_arch": [8]}}}}))
    path = train_rl("ppo", "healthy", 64, 0, tmp_path / "ppo", hyperparams_path=hp, episode_duration_s=0.5,
                    num_threads=1)
    original = load_controller(path)
    marker = tmp_path / "ran"
    payload = base64.b64encode(cloudpickle.dumps(_Payload(marker))).decode()
    cloudpickle.loads(base64.b64decode(payload))  # the payload does run when unpickled
    assert marker.exists()
    marker.rmdir()

    def poison(data):  # every pickled entry of SB3's data carries the payload
        for value in data.values():
            if isinstance(value, dict) and ":serialized:" in value:
                value[":serialized:"] = payload

    _rewrite_data(path, poison)
    loaded = load_controller(path)
    assert not marker.exists()
    rng = np.random.default_rng(0)
    for _ in range(3):
        obs, t = rng.normal(size=12), float(rng.uniform(0, 5))
        assert loaded.act(obs, t).tobytes() == original.act(obs, t).tobytes()
    # a pickled entry that cannot be rebuilt safely is refused, not unpickled
    _rewrite_data(path, lambda data: data.update(extra={":type:": "x", ":serialized:": payload}))
    with pytest.raises(FileError, match="extra.*not loaded"):
        load_controller(path)
    assert not marker.exists()
    # the weights are read without pickles (a torch.load with weights_only=True)
    assert "weights_only=True" in inspect.getsource(save_util.load_from_zip_file)
