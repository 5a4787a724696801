"""The compiled step gives the NumPy path's results bit for bit (aquafish_gym.native)."""

import os

import gymnasium as gym
import numpy as np
import pytest

from aquafish_gym import BatchWorld, Morphology, ServoFaults, SimParams, get_damage
from aquafish_gym import native

if not native.available():
    if os.environ.get("AQUAFISH_REQUIRE_NATIVE") == "1":  # set by `make test`: the build must have worked
        pytest.fail("the compiled step is not built although AQUAFISH_REQUIRE_NATIVE=1", pytrace=False)
    pytest.skip("compiled step not built (python -m aquafish_gym.native.build)", allow_module_level=True)


def _inputs(n, seed):
    rng = np.random.default_rng(seed)
    morph = rng.uniform(0.05, 1.0, (n, 9)) * np.array([1, 2, 0.5, 1, 2, 0.5, 0.5, 2, 1])
    morph[0] = Morphology.healthy().to_array()
    morph[-1, 6:] = 0.0                                      # a robot without a caudal fin
    actions = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(0, 1, n)])
    actions[1 % n, 2] = 0.0                                  # a caudal fin held still
    angles = np.column_stack([rng.uniform(0, 2 * np.pi, (n, 2)), rng.uniform(-0.5, 0.5, n)])
    return morph, actions, angles


def _run(native_flag, morph, actions, angles, params, faults=None, steps=96):
    with BatchWorld(morph, params, faults, native=native_flag) as world:
        assert world.native is native_flag
        world.reset(angles, actions)
        log = world.run(steps)
        return log, world.position.copy(), world.angular_velocity.copy(), world.time_s


_DEEP = SimParams(waterline=None)


@pytest.mark.parametrize("params", [SimParams(), SimParams(reactive_thrust=False),
                                    SimParams(drag_law="linear", water_current=(0.2, -0.1, 0.05)),
                                    SimParams(waterline=-0.3, pectoral_strips=5),
                                    _DEEP, _DEEP.replace(reactive_thrust=False),
                                    _DEEP.replace(drag_law="linear", water_current=(0.2, -0.1, 0.05))],
                         ids=["surface", "surface_pure_drag", "surface_linear_current", "surface_low_5_strips",
                              "deep", "deep_pure_drag", "deep_linear_current"])
@pytest.mark.parametrize("n", [1, 6])
def test_compiled_and_numpy_paths_are_bit_identical(params, n):
    morph, actions, angles = _inputs(n, seed=n)
    faults = [ServoFaults(seized=(False, True, False)) if i == 2 else ServoFaults(speed_scale=(0.5, 1.0, 0.7))
              for i in range(n)] if n > 2 else None
    numpy_run = _run(False, morph, actions, angles, params, faults)
    compiled = _run(True, morph, actions, angles, params, faults)
    assert np.abs(numpy_run[0]).max() > 0.1                      # the robots did move
    for a, b in zip(numpy_run, compiled):
        np.testing.assert_array_equal(a, b)


def test_env_episode_is_the_same_on_both_paths(monkeypatch):
    def episode():
        env = gym.make("AquaFish-v0", damage="left_pectoral_half")
        obs, _ = env.reset(seed=3)
        rewards = []
        for k in range(12):
            obs, reward, *_ = env.step(np.array([0.4, -0.2 + 0.05 * k, 0.9]))
            rewards.append(reward)
        native_used = env.unwrapped.world.native
        env.close()
        return obs, np.array(rewards), native_used

    obs_c, rew_c, used_c = episode()
    monkeypatch.setenv("AQUAFISH_NATIVE", "0")
    obs_n, rew_n, used_n = episode()
    assert used_c and not used_n
    np.testing.assert_array_equal(obs_c, obs_n)
    np.testing.assert_array_equal(rew_c, rew_n)


def test_a_damaged_robot_keeps_its_faults_on_the_compiled_path():
    damage = get_damage("left_pectoral_half")
    morph = damage.apply(Morphology.healthy()).to_array()[None]
    faults = ServoFaults(seized=(True, False, True))
    angles = np.array([[1.0, 2.0, 0.2]])
    with BatchWorld(morph, faults=faults, native=True) as world:
        world.reset(angles, np.array([[0.5, 0.5, 1.0]]))
        world.advance(50)
        joints = world.joint_angles()[0]
    assert joints[0] == pytest.approx(1.0, abs=0.02) and joints[2] == pytest.approx(0.2, abs=0.02)  # seized hold
    assert abs(joints[1] - 2.0) > 1.0                                                               # the other turns


def test_native_true_without_the_library_names_the_build_command(monkeypatch, tmp_path):
    monkeypatch.setattr(native, "_lib", None)
    monkeypatch.setattr(native, "_warned", False)
    monkeypatch.setattr(native, "LIBRARY", tmp_path / "missing.so")
    assert not native.available()
    with pytest.raises(ValueError, match="aquafish_gym.native.build"):
        BatchWorld(Morphology.healthy().to_array()[None], native=True)
    with BatchWorld(Morphology.healthy().to_array()[None]) as world:       # default: falls back to NumPy
        assert not world.native                                            # (said once: test_native_install.py)
