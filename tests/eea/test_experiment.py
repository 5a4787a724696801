"""Experiments and contexts: PERFORM() sampling, circular ranges, angle grid (paper 3.3)."""

import numpy as np
import pytest

from eea.arc import in_arc
from eea.experiment import ANGLE_RESOLUTION_RAD, CAUDAL_LIMIT_RAD, Context, Experiment, quantise_angles, random_angles

TWO_PI = 2 * np.pi


def test_random_angles_ranges():
    a = random_angles(np.random.default_rng(0), 4000)
    assert a.shape == (4000, 3)
    assert np.all((a[:, :2] >= 0) & (a[:, :2] < TWO_PI))
    assert np.all(np.abs(a[:, 2]) <= CAUDAL_LIMIT_RAD) and CAUDAL_LIMIT_RAD == pytest.approx(np.pi / 6)
    assert a[:, :2].min() < 0.05 and a[:, :2].max() > TWO_PI - 0.05  # covers the circle
    assert a[:, 2].min() < -0.5 and a[:, 2].max() > 0.5


def test_sample_with_confidence_one_stays_on_a_wrapping_arc():
    ctx = Context((6.0, 1.0, -0.1), (0.5, 0.0, 0.2), 1.0)   # left arc 6.0 -> 0.217 through 0
    a = ctx.sample(np.random.default_rng(1), 500)
    assert np.all(in_arc(a[:, 0], 6.0, 0.5))
    assert np.any(a[:, 0] < 0.2) and np.any(a[:, 0] > 6.1)  # both sides of 0 are used
    assert np.all(a[:, 0] < TWO_PI)
    np.testing.assert_array_equal(a[:, 1], 1.0)
    assert np.all((a[:, 2] >= -0.1) & (a[:, 2] <= 0.1))


def test_sample_confidence_is_the_probability_of_using_the_ranges():
    ctx = Context((3.0, 3.0, 0.0), (0.0, 0.0, 0.0), 0.5)
    a = ctx.sample(np.random.default_rng(2), 4000)
    from_range = np.all(a == [3.0, 3.0, 0.0], axis=1)
    assert 0.45 < from_range.mean() < 0.55
    assert not np.any(np.all(Context.exact([3.0, 3.0, 0.0]).with_confidence(0.0).sample(
        np.random.default_rng(3), 100) == [3.0, 3.0, 0.0], axis=1))


def test_estimate_is_the_middle_of_each_range_on_the_circle():
    ctx = Context((6.0, 1.0, -0.2), (1.0, 2.0, 0.2), 1.0)
    np.testing.assert_allclose(ctx.estimate(), [6.5 - TWO_PI, 2.0, -0.1])
    np.testing.assert_allclose(Context.exact([0.3, 5.0, -0.4]).estimate(), [0.3, 5.0, -0.4])
    unknown = Context.unknown()
    assert unknown.widths == (TWO_PI, TWO_PI, 2 * CAUDAL_LIMIT_RAD) and unknown.confidence == 0.0


@pytest.mark.parametrize("args, match", [
    (((0, 0, 0), (0, 0, 0), 1.5), "confidence"),
    (((0, 0, 0), (7.0, 0, 0), 1.0), "widths"),
    (((0, 0, 0.4), (0, 0, 0.4), 1.0), "caudal interval"),
    (((0, 0), (0, 0, 0), 1.0), "3 entries"),
    (((np.nan, 0, 0), (0, 0, 0), 1.0), "finite"),
])
def test_context_validation(args, match):
    with pytest.raises(ValueError, match=match):
        Context(*args)


def test_context_wraps_pectoral_starts():
    assert Context((TWO_PI + 0.5, -0.5, 0.0), (0, 0, 0), 1).starts == pytest.approx((0.5, TWO_PI - 0.5, 0.0))


def test_quantise_angles_grid_wrap_and_clip():
    levels, values = quantise_angles([[TWO_PI - 1e-9, -0.25, CAUDAL_LIMIT_RAD], [1.0000004, 7.0, -0.1]])
    np.testing.assert_array_equal(levels[0, :2], [0, round((TWO_PI - 0.25) / ANGLE_RESOLUTION_RAD)])
    assert values[0, 0] == 0.0 and abs(values[0, 2]) <= CAUDAL_LIMIT_RAD
    assert values[1, 0] == pytest.approx(1.0, abs=1e-12) and values[1, 1] == pytest.approx(7.0 - TWO_PI, abs=1e-6)
    again_levels, again = quantise_angles(values)
    np.testing.assert_array_equal(again_levels, levels)   # idempotent: cached keys are stable
    np.testing.assert_array_equal(again, values)


def test_experiment_state_round_trip(make_experiment):
    e = make_experiment(3, context=Context((6.0, 1.0, -0.2), (1.0, 2.0, 0.2), 0.5))
    back = Experiment.from_state_dict(e.state_dict())
    assert back.index == 3 and back.context == e.context
    for name in ("action", "imu_log", "summary", "true_angles"):
        np.testing.assert_array_equal(getattr(back, name), getattr(e, name))
