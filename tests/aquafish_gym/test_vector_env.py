"""The batched vector envs (aquafish_gym.vector_env): sub-env i is the single env, bit for bit
where positions do not enter, and to round-off where they do (robot i sits at its own home)."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import aquafish_gym  # noqa: F401  (registers the tasks)
from aquafish_gym.vector_env import AquaFishVectorEnv, HeadingVectorEnv, StationKeepingVectorEnv

#: info entries (and reward terms) computed from positions: equal to round-off, not bit for bit
POSITIONAL = {"x_position", "y_position", "z_position", "distance", "distance_from_start", "reward_forward",
              "reward_position"}
POSITION_ATOL = 1e-9  # units; measured differences are ~1e-13 (positions 20-60 units from the origin)
STEPS = 12  # episodes of 0.5 s are 5 control steps: two ends, two autoresets


def run_vector(env_id, n, kwargs, actions, seed, vector_kwargs=None):
    venv = gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs,
                        **(vector_kwargs or {}))
    out = [(*venv.reset(seed=seed), None)]
    out[0] = (out[0][0], None, None, None, out[0][1])
    for k in range(len(actions)):
        out.append(venv.step(actions[k]))
    venv.close()
    return out


def run_single(env_id, kwargs, actions, seed):
    """The single env as SyncVectorEnv drives it (NEXT_STEP autoreset with a plain reset())."""
    env = gym.make(env_id, **kwargs)
    obs, info = env.reset(seed=seed)
    out, done = [(obs, None, None, None, info)], False
    for action in actions:
        if done:
            obs, info = env.reset()
            out.append((obs, 0.0, False, False, info))
            done = False
        else:
            out.append(env.step(action))
            done = out[-1][2] or out[-1][3]
    env.close()
    return out


CASES = [
    ("AquaFish-v0", dict(damage="reversed_left_pectoral"), 12),
    ("AquaFish-v0", dict(damage="left_pectoral_half", ctrl_cost_weight=0.1), 4),
    ("AquaFish-v0", dict(damage="random", waterline=None), 4),
    ("AquaFishStationKeeping-v0", dict(current_speed=(0.1, 0.3), current_direction_deg=None, damage="random"), 4),
    ("AquaFishHeading-v0", dict(forward_reward_weight=1.0, damage=["left_pectoral_half", "caudal_half"]), 4),
    # damage during an episode: healthy until 0.25 s (the step ending at 0.3 switches), every autoreset healthy again
    ("AquaFish-v0", dict(damage="random", damage_onset_s=0.25), 4),
    ("AquaFish-v0", dict(damage=["sampled:15", "reversed_left_pectoral", "none", "caudal_missing"], damage_onset_s=0.1,
                         waterline=None), 5),
    ("AquaFishStationKeeping-v0", dict(current_speed=0.2, damage="left_pectoral_missing", damage_onset_s=0.2), 3),
]


@pytest.mark.parametrize("env_id, kwargs, n", CASES, ids=[f"{c[0]}-{c[2]}-{i}" for i, c in enumerate(CASES)])
def test_sub_env_i_is_the_single_env_with_seed_plus_i(env_id, kwargs, n):
    kwargs = dict(kwargs, episode_duration_s=0.5)
    actions = np.random.default_rng(1).uniform(-1, 1, (STEPS, n, 3)).astype(np.float32)
    vec = run_vector(env_id, n, kwargs, actions, seed=7)
    assert vec[5][3].all() and not vec[4][3].any() and not vec[6][3].any()  # the end, then the autoreset
    np.testing.assert_array_equal(vec[6][1], np.zeros(n))
    for i in range(n):
        single = run_single(env_id, kwargs, actions[:, i], seed=7 + i)
        for k, (s, v) in enumerate(zip(single, vec)):
            np.testing.assert_array_equal(v[0][i], s[0], err_msg=f"observation, sub-env {i}, step {k}")
            if s[1] is not None:
                assert (bool(v[2][i]), bool(v[3][i])) == (s[2], s[3]), f"terminated/truncated, sub-env {i}, step {k}"
                positional = any(key in s[4] for key in ("reward_forward", "reward_position"))
                if positional and i > 0:
                    np.testing.assert_allclose(v[1][i], s[1], rtol=0, atol=POSITION_ATOL)
                else:
                    assert v[1][i] == s[1], f"reward, sub-env {i}, step {k}"
            assert set(v[4]) == set(s[4]) | {f"_{key}" for key in s[4]}
            for key, value in s[4].items():
                assert v[4][f"_{key}"][i], key
                got = v[4][key][i]
                if key in POSITIONAL and i > 0:
                    np.testing.assert_allclose(got, value, rtol=0, atol=POSITION_ATOL, err_msg=key)
                elif isinstance(value, str):
                    assert got == value
                else:  # sub-env 0 sits at the origin, as the single env: every entry to the last bit
                    np.testing.assert_array_equal(got, value, err_msg=f"{key}, sub-env {i}, step {k}")


def test_position_round_off_is_real_but_tiny():
    """Documents why positions get a tolerance: robots away from the origin round differently."""
    kwargs = dict(episode_duration_s=0.5)
    actions = np.random.default_rng(2).uniform(-1, 1, (4, 3, 3)).astype(np.float32)
    vec = run_vector("AquaFish-v0", 3, kwargs, actions, seed=0)
    single = run_single("AquaFish-v0", kwargs, actions[:, 2], seed=2)
    diff = abs(vec[-1][4]["x_position"][2] - single[-1][4]["x_position"])
    assert diff < POSITION_ATOL


def test_split_worlds_give_the_same_results():
    kwargs = dict(episode_duration_s=0.5, damage="random")
    actions = np.random.default_rng(3).uniform(-1, 1, (7, 5, 3)).astype(np.float32)
    one = run_vector("AquaFish-v0", 5, kwargs, actions, seed=11)
    venv = gym.make_vec("AquaFish-v0", num_envs=5, max_world_robots=2, **kwargs)
    venv.reset(seed=11)
    assert [w.n for w in venv.unwrapped.worlds] == [2, 2, 1]
    venv.close()
    split = run_vector("AquaFish-v0", 5, kwargs, actions, seed=11, vector_kwargs=dict(max_world_robots=2))
    for a, b in zip(one, split):
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[4]["damage"], b[4]["damage"])
        np.testing.assert_allclose(a[4]["x_position"], b[4]["x_position"], rtol=0, atol=POSITION_ATOL)


@pytest.mark.parametrize("env_id, cls, dim", [("AquaFish-v0", AquaFishVectorEnv, 12),
                                              ("AquaFishStationKeeping-v0", StationKeepingVectorEnv, 12),
                                              ("AquaFishHeading-v0", HeadingVectorEnv, 14)])
def test_make_vec_uses_the_vector_entry_point_with_batched_spaces(env_id, cls, dim):
    venv = gym.make_vec(env_id, num_envs=3, episode_duration_s=0.5)  # the default mode picks it
    assert type(venv.unwrapped) is cls
    assert venv.metadata["autoreset_mode"] is AutoresetMode.NEXT_STEP
    assert venv.num_envs == 3
    assert venv.single_observation_space == gym.make(env_id).observation_space
    assert venv.observation_space.shape == (3, dim) and venv.observation_space.dtype == np.float64
    assert venv.action_space.shape == (3, 3) and venv.action_space.dtype == np.float32
    assert venv.single_action_space.shape == (3,)
    obs, info = venv.reset(seed=0)
    assert venv.observation_space.contains(obs)
    venv.action_space.seed(0)
    obs, rewards, terminated, truncated, info = venv.step(venv.action_space.sample())
    assert venv.observation_space.contains(obs)
    assert rewards.shape == (3,) and rewards.dtype == np.float64
    assert terminated.dtype == truncated.dtype == np.bool_ and terminated.shape == truncated.shape == (3,)
    assert info["_distance"].all() and info["initial_angles"].shape == (3, 3) and info["damage"].dtype == object
    assert cls.__doc__ and "## Observation Space" in cls.__doc__ and f"(N, {dim})" in cls.__doc__
    venv.close()


def test_seeds_per_sub_env_and_determinism():
    def first_obs(seed):
        venv = gym.make_vec("AquaFishHeading-v0", num_envs=3, episode_duration_s=0.5)
        obs, info = venv.reset(seed=seed)
        venv.close()
        return obs, info

    obs, info = first_obs(5)
    obs_list, info_list = first_obs([5, 6, 7])
    np.testing.assert_array_equal(obs, obs_list)
    np.testing.assert_array_equal(info["initial_angles"], info_list["initial_angles"])
    assert len({tuple(a) for a in info["initial_angles"]}) == 3  # each sub-env its own generator
    shifted, _ = first_obs([6, 7, 8])
    np.testing.assert_array_equal(obs[1:], shifted[:2])
    assert not np.array_equal(first_obs(None)[1]["initial_angles"], info["initial_angles"])


def test_works_under_gymnasium_vector_wrappers():
    venv = gym.wrappers.vector.RecordEpisodeStatistics(gym.make_vec("AquaFish-v0", num_envs=2, episode_duration_s=0.5))
    venv.reset(seed=0)
    for _ in range(5):
        *_, info = venv.step(np.zeros((2, 3), dtype=np.float32))
    assert info["_episode"].all() and (info["episode"]["l"] == 5).all()
    np.testing.assert_allclose(info["episode"]["r"], info["distance"], rtol=0, atol=1e-6)  # ctrl cost 0
    venv.close()


@pytest.mark.parametrize("kwargs, match", [
    (dict(num_envs=0), r"num_envs \(sub-envs of AquaFish-v0\) must be an int >= 1"),
    (dict(num_envs=2.5), r"num_envs"),
    (dict(num_envs=2, max_world_robots=0), r"max_world_robots"),
    (dict(num_envs=2, render_mode="rgb_array"), r"does not render: render_mode must be None"),
    (dict(num_envs=2, wobble=1), r"unknown AquaFish-v0 argument\(s\) \['wobble'\]"),
    (dict(num_envs=2, damage="sunk"), r"sunk"),
])
def test_bad_construction_raises_value_error(kwargs, match):
    with pytest.raises(ValueError, match=match):
        AquaFishVectorEnv(**kwargs)


def test_bad_reset_and_step_raise_value_error():
    venv = AquaFishVectorEnv(num_envs=2, episode_duration_s=0.5)
    with pytest.raises(RuntimeError, match=r"reset\(\) before step\(\)"):
        venv.step(np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"list of 2 ints or None"):
        venv.reset(seed=[1, 2, 3])
    with pytest.raises(ValueError, match=r"list of 2 ints or None"):
        venv.reset(seed=1.5)
    with pytest.raises(ValueError, match=r"reset_mask'\] must be all True"):
        venv.reset(seed=0, options={"reset_mask": np.array([True, False])})
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['wind'\]"):
        venv.reset(seed=0, options={"wind": 1})
    obs, _ = venv.reset(seed=0, options={"reset_mask": np.array([True, True]), "initial_angles": [0.0, 0.0, 0.0]})
    assert obs.shape == (2, 12)
    for bad, match in [(np.zeros(3), r"shape \(2, 3\).*got shape \(3,\)"), (np.zeros((3, 3)), r"shape \(2, 3\)"),
                       (np.array([[0, 0, 0], [0, np.nan, 0]]), r"sub-env 1's action"),
                       (np.array([[1.5, 0, 0], [0, 0, 0]]), r"finite and in \[-1, 1\]; sub-env 0")]:
        with pytest.raises(ValueError, match=match):
            venv.step(bad)
    venv.close()
    assert venv.closed


def test_benchmark_runs_and_prints_its_table(capsys):
    from aquafish.benchmarks import vector_env

    vector_env.main(["--sizes", "2", "--env-steps", "4", "--repeats", "1"])
    out = capsys.readouterr().out
    assert "SyncVectorEnv" in out and "PyBullet bound" in out and out.strip().splitlines()[-1].split()[0] == "2"


def test_an_initial_yaw_turns_every_sub_env_as_it_turns_the_single_env():
    options = {"initial_yaw_deg": -135.0}
    actions = np.random.default_rng(3).uniform(-1, 1, (4, 3, 3))
    venv = gym.make_vec("AquaFish-v0", num_envs=3, vectorization_mode="vector_entry_point", damage="caudal_half")
    vec = [venv.reset(seed=4, options=options)[0]] + [venv.step(a)[0] for a in actions]
    venv.close()
    for i in range(3):
        env = gym.make("AquaFish-v0", damage="caudal_half")
        single = [env.reset(seed=4 + i, options=options)[0]] + [env.step(a[i])[0] for a in actions]
        env.close()
        np.testing.assert_array_equal(np.array(vec)[:, i], np.array(single), err_msg=f"sub-env {i}")
    assert np.degrees(np.arctan2(vec[0][:, 2], vec[0][:, 5])) == pytest.approx([-135.0] * 3)


def test_a_list_of_initial_yaws_turns_each_sub_env_by_its_own():
    venv = gym.make_vec("AquaFish-v0", num_envs=3, vectorization_mode="vector_entry_point")
    obs, _ = venv.reset(seed=0, options={"initial_yaw_deg": [-90.0, 0.0, 170.0]})
    assert np.degrees(np.arctan2(obs[:, 2], obs[:, 5])) == pytest.approx([-90.0, 0.0, 170.0])
    with pytest.raises(ValueError, match=r"one heading \(degrees\) or a list of 3 \(one per sub-env\), got 2"):
        venv.reset(seed=0, options={"initial_yaw_deg": [0.0, 1.0]})
    with pytest.raises(ValueError, match=r"initial_yaw_deg'\] must be a number of degrees in \[-180, 180\]"):
        venv.reset(seed=0, options={"initial_yaw_deg": [0.0, 1.0, 200.0]})
    venv.close()
