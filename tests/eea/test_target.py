"""The target: the damaged robot, with fresh random initial angles for every experiment."""

import numpy as np
import pytest

import eea.target
from aquafish_gym import get_damage
from eea.experiment import CAUDAL_LIMIT_RAD
from eea.target import Target


def test_perform_simulates_the_damaged_robot_from_random_angles(monkeypatch):
    calls = []

    def fake(morphologies, actions, initial_angles, steps, *, faults=None, params=None):
        calls.append((np.array(morphologies), np.array(actions), np.array(initial_angles), steps, faults))
        return np.zeros((len(morphologies), steps, 3)) + len(calls)

    monkeypatch.setattr(eea.target, "simulate_batch", fake)
    target = Target("seized_left_pectoral", 16, np.random.default_rng(0))
    logs, angles = zip(*(target.perform([0.1, -0.2, 0.5]) for _ in range(200)))
    morph, action, initial, steps, faults = calls[0]
    np.testing.assert_array_equal(morph, [get_damage("seized_left_pectoral").apply().to_array()])
    np.testing.assert_array_equal(action, [[0.1, -0.2, 0.5]])
    assert steps == 16 and faults.seized == (True, False, False)
    assert logs[0].shape == (16, 3) and logs[1][0, 0] == 2
    angles = np.array(angles)
    np.testing.assert_array_equal(angles, np.array([c[2][0] for c in calls]))   # the angles returned are the ones simulated
    assert len(np.unique(angles[:, 0])) == 200                                   # new angles every experiment
    assert angles[:, :2].min() >= 0 and angles[:, :2].max() < 2 * np.pi and angles[:, :2].max() > 6.0
    assert np.abs(angles[:, 2]).max() <= CAUDAL_LIMIT_RAD and np.abs(angles[:, 2]).max() > 0.45


def test_same_seed_same_angles_and_half_left_pectoral():
    a = Target("left_pectoral_half", 8, np.random.default_rng(5))
    b = Target("left_pectoral_half", 8, np.random.default_rng(5))
    assert a.morphology.left_pectoral_y == 0.5 and a.morphology.right_pectoral_y == 1.0
    la, ta = a.perform([0.5, 0.5, 1.0])
    lb, tb = b.perform([0.5, 0.5, 1.0])
    np.testing.assert_array_equal(ta, tb)
    np.testing.assert_array_equal(la, lb)


def test_bad_arguments():
    with pytest.raises(ValueError, match="valid names"):
        Target("crushed", 8, np.random.default_rng())
    with pytest.raises(ValueError, match="shape"):
        Target("none", 8, np.random.default_rng()).perform([0.1, 0.2])
