"""The Gymnasium corners fail safe (cause 19 of the third fail-safe round): a vector env of a
million sub-envs is refused up front, a vector env stepped after ``close()`` says so, and
complex actions are refused instead of losing their imaginary parts."""

from __future__ import annotations

import time

import gymnasium as gym
import numpy as np
import pytest

import aquafish_gym  # noqa: F401  (registers the envs)


@pytest.mark.parametrize("env_id", ["AquaFish-v0", "AquaFishHeading-v0"])
def test_a_vector_env_of_a_million_sub_envs_is_refused_at_once(env_id):
    start = time.monotonic()
    with pytest.raises(ValueError, match=r"num_envs .* <= 100000, got 1000000"):
        gym.make_vec(env_id, num_envs=10**6, vectorization_mode="vector_entry_point")
    assert time.monotonic() - start < 5


def test_a_vector_env_stepped_after_close_says_so_and_reset_starts_again():
    envs = gym.make_vec("AquaFish-v0", num_envs=2, vectorization_mode="vector_entry_point")
    envs.reset(seed=0)
    envs.step(np.zeros((2, 3)))
    envs.close()
    with pytest.raises(RuntimeError, match="closed"):
        envs.step(np.zeros((2, 3)))
    envs.reset(seed=0)  # new worlds, closed by the next close()
    envs.step(np.zeros((2, 3)))
    worlds = envs.unwrapped.worlds
    envs.close()
    assert envs.unwrapped.worlds == [] and worlds


@pytest.mark.parametrize("vector", [False, True])
@pytest.mark.parametrize("action", [np.zeros(3, dtype=np.complex128), [0.5j, 0, 0], np.array([1 + 0j, 0, 0])],
                         ids=["complex array", "complex list", "zero imaginary part"])
def test_complex_actions_are_refused(vector, action):
    if vector:
        env = gym.make_vec("AquaFish-v0", num_envs=2, vectorization_mode="vector_entry_point")
        action = np.stack([np.asarray(action)] * 2)
    else:
        env = gym.make("AquaFish-v0")
    env.reset(seed=0)
    try:
        with pytest.raises(ValueError, match="real numbers"):
            env.step(action)
    finally:
        env.close()
