"""Tests of eea.arc: smallest inclusive arcs for In-Band inference (paper section 3.3)."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from eea.arc import (
    angle_distance,
    in_arc,
    sample_arc,
    smallest_inclusive_arc,
    smallest_inclusive_interval,
    widen_arc,
)

TWO_PI = 2 * np.pi


def test_wraps_around_zero():
    start, width = smallest_inclusive_arc([6.2, 0.1])
    assert start == pytest.approx(6.2)
    assert width == pytest.approx(0.1 + TWO_PI - 6.2)   # about 0.183, not 6.1
    assert in_arc(0.0, start, width) and in_arc(6.25, start, width)
    assert not in_arc(3.0, start, width)


def test_no_wrap_and_single_angle():
    assert smallest_inclusive_arc([1.0, 2.0, 1.5]) == pytest.approx((1.0, 1.0))
    assert smallest_inclusive_arc([4.0]) == (4.0, 0.0)
    assert smallest_inclusive_arc([4.0, 4.0]) == (4.0, 0.0)


def test_inputs_outside_one_turn_are_wrapped():
    start, width = smallest_inclusive_arc([-0.1, TWO_PI + 0.2])
    assert start == pytest.approx(TWO_PI - 0.1)
    assert width == pytest.approx(0.3)


def test_other_period_degrees():
    assert smallest_inclusive_arc([350.0, 10.0], period=360.0) == pytest.approx((350.0, 20.0))


def test_samples_land_inside_the_arc():
    rng = np.random.default_rng(0)
    start, width = smallest_inclusive_arc([6.0, 0.5, 6.2])
    x = sample_arc(start, width, rng, size=2000)
    assert x.shape == (2000,)
    assert np.all((x >= 0) & (x < TWO_PI))
    assert np.all(in_arc(x, start, width))
    assert (x < 1).any() and (x > 6).any()   # both sides of the wrap are used
    assert isinstance(sample_arc(start, width, rng), float)


def test_sample_is_deterministic_for_a_seed():
    a = sample_arc(1.0, 2.0, np.random.default_rng(5), size=10)
    b = sample_arc(1.0, 2.0, np.random.default_rng(5), size=10)
    np.testing.assert_array_equal(a, b)


def test_caudal_interval_does_not_wrap():
    caudal = np.deg2rad([-25.0, 20.0, 5.0])
    start, width = smallest_inclusive_interval(caudal)
    assert (start, width) == pytest.approx((np.deg2rad(-25.0), np.deg2rad(45.0)))
    x = sample_arc(start, width, np.random.default_rng(1), size=500, period=None)
    assert np.all((x >= start) & (x <= start + width))
    assert np.all(in_arc(x, start, width, period=None))
    assert not in_arc(np.deg2rad(-30.0), start, width, period=None)


def test_widen_arc_by_twenty_percent():
    assert widen_arc(1.0, 1.0) == pytest.approx((0.8, 1.4))
    start, width = widen_arc(0.05, 0.5)
    assert start == pytest.approx(TWO_PI - 0.05) and width == pytest.approx(0.7)
    assert widen_arc(0.0, 6.0, 0.5) == pytest.approx((TWO_PI - 3.0, TWO_PI))
    assert widen_arc(-0.5, 0.5, period=None) == pytest.approx((-0.6, 0.7))


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: smallest_inclusive_arc([]), "angles_rad"),
        (lambda: smallest_inclusive_arc([[1.0, 2.0]]), "angles_rad"),
        (lambda: smallest_inclusive_arc([1.0, np.nan]), "NaN"),
        (lambda: smallest_inclusive_arc([1.0], period=0.0), "period"),
        (lambda: smallest_inclusive_interval([]), "values"),
        (lambda: sample_arc(0.0, -0.1, np.random.default_rng(0)), "width"),
        (lambda: sample_arc(0.0, 7.0, np.random.default_rng(0)), "width"),
        (lambda: sample_arc(np.nan, 1.0, np.random.default_rng(0)), "start"),
        (lambda: sample_arc(0.0, 1.0, np.random.RandomState(0)), "rng"),
        (lambda: in_arc(np.nan, 0.0, 1.0), "angle"),
        (lambda: widen_arc(0.0, 1.0, -0.2), "fraction"),
    ],
)
def test_bad_input_raises(call, match):
    with pytest.raises(ValueError, match=match):
        call()


angle_lists = st.lists(
    st.floats(0.0, TWO_PI, exclude_max=True, allow_nan=False), min_size=1, max_size=8
)


@given(angle_lists)
def test_arc_contains_inputs_and_is_smallest(angles):
    start, width = smallest_inclusive_arc(angles)
    assert 0.0 <= start < TWO_PI and 0.0 <= width < TWO_PI
    assert np.all(in_arc(np.array(angles), start, width))
    a = np.array(angles)
    # The arc starting at input i that holds every input has width max_j (a_j - a_i) mod 2pi.
    for s in a:
        assert width <= np.max(np.mod(a - s, TWO_PI)) + 1e-9


def test_angle_distance_goes_the_short_way_round():
    # 6.2 and 0.1 rad: 2 pi - 6.1 = 0.18319 apart through 0, not 6.1
    np.testing.assert_allclose(angle_distance(6.2, 0.1), TWO_PI - 6.1)
    np.testing.assert_allclose(angle_distance([0.0, np.pi, 1.0], [np.pi, 0.0, 1.0 + 4 * np.pi]), [np.pi, np.pi, 0.0],
                               atol=1e-12)
    np.testing.assert_allclose(angle_distance(350.0, 10.0, period=360.0), 20.0)
    # the caudal fin's line does not wrap
    np.testing.assert_allclose(angle_distance(-0.5, 0.4, period=None), 0.9)
    with pytest.raises(ValueError, match="NaN"):
        angle_distance(np.nan, 0.0)
    with pytest.raises(ValueError, match="period"):
        angle_distance(1.0, 0.0, period=0.0)
