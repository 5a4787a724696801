"""Tests of eea.fitness: paper equations 1, 3 and 4."""

import numpy as np
import pytest

from eea.behaviour import similarity
from aquafish_gym import MORPHOLOGY_BOUNDS as MODEL_BOUNDS
from eea.fitness import action_fitness, model_fitness, objective_fitness, robust_action_fitness


def _three_models():
    """Summaries (3, 3, 1) whose pairwise sims are known: 2/3 + x/3 terms."""
    s = np.zeros((3, 3, 1))
    s[1, 0, 0] = 30.0    # sim(0, 1) = (0.7 + 2) / 3
    s[2, 0, 0] = 90.0    # sim(0, 2) = (0.1 + 2) / 3, sim(1, 2) = (0.4 + 2) / 3
    return s


def test_action_fitness_three_models_hand_computed():
    sims = np.array([2.7, 2.1, 2.4]) / 3
    assert action_fitness(_three_models()) == pytest.approx(np.mean(1 - sims))
    assert isinstance(action_fitness(_three_models()), float)


def test_action_fitness_identical_models_is_zero():
    assert action_fitness(np.ones((4, 3, 5))) == 0.0


def test_action_fitness_batched_matches_loop():
    rng = np.random.default_rng(3)
    s = rng.uniform(0, 200, (6, 5, 3, 9))
    batched = action_fitness(s)
    assert batched.shape == (6,)
    np.testing.assert_allclose(batched, [action_fitness(x) for x in s])
    m = s.shape[1]
    brute = [np.mean([1 - similarity(x[i], x[j]) for i in range(m) for j in range(i + 1, m)])
             for x in s]
    np.testing.assert_allclose(batched, brute)


@pytest.mark.parametrize("shape", [(1, 3, 5), (4, 1, 3, 5), (3, 5)])
def test_action_fitness_rejects_fewer_than_two_models(shape):
    with pytest.raises(ValueError, match="M"):
        action_fitness(np.zeros(shape))


def test_model_fitness_hand_computed():
    target = np.zeros((2, 3, 1))           # E = 2 experiments, F = 1
    models = np.zeros((3, 2, 3, 1))
    models[1, 0, 0, 0] = 60.0              # experiment 0 sim (0.4 + 2) / 3, experiment 1 sim 1
    models[2, :, :, 0] = 500.0             # every term clipped to 0
    fit = model_fitness(models, target)
    assert fit.shape == (3,)
    np.testing.assert_allclose(fit, [1.0, (2.4 / 3 + 1) / 2, 0.0])


@pytest.mark.parametrize(
    "models, target",
    [
        (np.zeros((3, 2, 3, 4)), np.zeros((3, 3, 4))),   # E differs
        (np.zeros((3, 2, 3, 4)), np.zeros((2, 3, 5))),   # F differs
        (np.zeros((3, 0, 3, 4)), np.zeros((0, 3, 4))),   # no experiments
        (np.zeros((3, 2, 3, 4)), np.zeros((3, 4))),      # target not (E, 3, F)
    ],
)
def test_model_fitness_rejects_mismatch(models, target):
    with pytest.raises(ValueError, match="summaries"):
        model_fitness(models, target)


def test_objective_fitness_hand_computed():
    target = np.array([0.25, 1.0, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375])
    model = target.copy()
    model[0] += 0.5        # error 0.5 / 1
    model[7] -= 0.5        # error 0.5 / 2
    model[8] += 0.125      # error 0.125 / 1
    expected = 1 - (0.5 + 0.25 + 0.125) / 9
    assert objective_fitness(model, target, MODEL_BOUNDS) == pytest.approx(expected)
    assert objective_fitness(target, target) == 1.0


def test_objective_fitness_extremes_and_batch():
    lo, hi = MODEL_BOUNDS[:, 0], MODEL_BOUNDS[:, 1]
    fit = objective_fitness(np.stack([lo, hi, (lo + hi) / 2]), hi)
    np.testing.assert_allclose(fit, [0.0, 1.0, 0.5])
    bounds = np.array([[-1.0, 1.0], [0.0, 4.0]])
    assert objective_fitness([1.0, 0.0], [-1.0, 2.0], bounds) == pytest.approx(0.25)


@pytest.mark.parametrize(
    "model, target, match",
    [
        (np.zeros(8), np.zeros(9), "model_dims"),
        (np.zeros(9), np.zeros(8), "target_dims"),
        (np.r_[np.nan, np.zeros(8)], np.zeros(9), "model_dims"),
        (np.zeros(9), np.r_[np.zeros(8), 1.5], "target_dims"),
    ],
)
def test_objective_fitness_rejects_bad_input(model, target, match):
    with pytest.raises(ValueError, match=match):
        objective_fitness(model, target)


def test_objective_fitness_rejects_degenerate_bounds():
    with pytest.raises(ValueError, match="bounds"):
        objective_fitness(np.zeros(2), np.zeros(2), np.array([[0.0, 1.0], [1.0, 1.0]]))


def test_robust_action_fitness_hand_computed():
    # K = 2 angle sets x M = 2 models, one coefficient per channel (MAX = 100)
    s = np.array([[0.0, 50.0], [20.0, 50.0]])[:, :, None, None] * np.ones((2, 2, 3, 1))
    # between models: set 0 |0 - 50| -> 0.5, set 1 |20 - 50| -> 0.3, mean 0.4;
    # spread over angles: model 0 |0 - 20| -> 0.2, model 1 |50 - 50| -> 0, mean 0.1
    assert robust_action_fitness(s) == pytest.approx(0.4 - 0.1)
    batched = robust_action_fitness(np.stack([s, s[:, ::-1], np.zeros_like(s)]))
    np.testing.assert_allclose(batched, [0.3, 0.3, 0.0])
    # a response the angles change as much as the morphology scores <= 0
    assert robust_action_fitness(np.array([[0.0, 40.0], [40.0, 0.0]])[:, :, None, None] * np.ones((2, 2, 3, 1))) \
        == pytest.approx(0.0)
    with pytest.raises(ValueError, match="K >= 2"):
        robust_action_fitness(np.zeros((1, 3, 3, 4)))
