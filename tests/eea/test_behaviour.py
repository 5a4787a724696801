"""Tests of eea.behaviour: DFT behaviour summaries and similarity (paper equation 2)."""

import numpy as np
import pytest

from eea.behaviour import MAX_COEFFICIENTS, angular_rates, behaviour_summary, similarity, summarise


def test_summary_shape_and_unnormalised_scale():
    steps = 256
    t = np.arange(steps) * 0.01
    log = np.zeros((2, steps, 3))
    log[0, :, 1] = 10.0 * np.sin(2 * np.pi * 2.0 * t)    # pitch: 10 deg at 2 Hz
    log[1, :, 0] = 5.0                                     # roll: constant 5 deg
    s = behaviour_summary(log)
    assert s.shape == (2, 3, steps // 2 + 1)
    # 2 Hz is not on the 1/2.56 Hz grid exactly; the peak is near A * N / 2 = 1280.
    assert 900 < s[0, 1].max() < 1300
    np.testing.assert_allclose(s[1, 0, 0], 5.0 * steps)  # DC term is the unnormalised sum
    np.testing.assert_allclose(s[1, 0, 1:], 0.0, atol=1e-9)
    np.testing.assert_array_equal(behaviour_summary(log[0]), s[0])


def test_unnormalised_summary_separates_a_small_amplitude_change():
    # docs/self_modeling.md: normalised DFT coefficients make sim ~ 0.999 (blind search).
    steps = 256
    t = np.arange(steps) * 0.01
    log_a = np.zeros((steps, 3))
    log_b = np.zeros((steps, 3))
    log_a[:, 1] = 10.0 * np.sin(2 * np.pi * 1.5625 * t)
    log_b[:, 1] = 12.0 * np.sin(2 * np.pi * 1.5625 * t)
    sa, sb = behaviour_summary(log_a), behaviour_summary(log_b)
    assert similarity(sa / steps, sb / steps) > 0.999
    assert similarity(sa, sb) < 0.999 - 0.001


def test_identical_is_one():
    a = np.random.default_rng(0).uniform(0, 500, (3, 9))
    assert similarity(a, a) == 1.0


def test_hand_computed_two_coefficients_per_channel():
    a = np.zeros((3, 2))
    b = np.zeros((3, 2))
    b[0, 0] = 50.0   # term 0.5
    b[2, 1] = 25.0   # term 0.75
    assert similarity(a, b) == pytest.approx((0.5 + 0.75 + 4) / 6)
    assert similarity(a, b, max_coefficient=200.0) == pytest.approx((0.75 + 0.875 + 4) / 6)


def test_difference_above_max_clips_to_zero_not_negative():
    a = np.zeros((3, 1))
    b = np.zeros((3, 1))
    b[0, 0] = 1000.0
    assert similarity(a, b) == pytest.approx(2 / 3)
    assert similarity(a, a + 1e6) == 0.0


def test_symmetry():
    rng = np.random.default_rng(1)
    a, b = rng.uniform(0, 300, (2, 4, 3, 17))
    np.testing.assert_allclose(similarity(a, b), similarity(b, a))


def test_broadcast_population_against_one_summary():
    rng = np.random.default_rng(2)
    pop = rng.uniform(0, 300, (5, 3, 17))
    target = rng.uniform(0, 300, (3, 17))
    s = similarity(pop, target)
    assert s.shape == (5,)
    np.testing.assert_allclose(s, [similarity(p, target) for p in pop])
    pop[3] = target + 1.0                          # every coefficient 1 away: (1 - 1/100) each
    s = similarity(pop, target)
    assert s[3] == pytest.approx(0.99) and np.argmax(s) == 3 and np.all(np.delete(s, 3) < 0.9)


@pytest.mark.parametrize(
    "a, b, kwargs, match",
    [
        (np.zeros((3, 5)), np.zeros((3, 6)), {}, "same"),
        (np.zeros((2, 5)), np.zeros((2, 5)), {}, r"\(\.\.\., 3, F\)"),
        (np.zeros((4, 3, 5)), np.zeros((2, 3, 5)), {}, "broadcast"),
        (np.zeros((3, 5)), np.zeros((3, 5)), {"max_coefficient": 0.0}, "max_coefficient"),
        (np.zeros((3, 5)), np.zeros((3, 5)), {"max_coefficient": -1.0}, "max_coefficient"),
        (np.full((3, 5), np.nan), np.zeros((3, 5)), {}, "NaN"),
    ],
)
def test_similarity_rejects_bad_input(a, b, kwargs, match):
    for function in (similarity,):
        with pytest.raises(ValueError, match=match):
            function(a, b, **kwargs)

@pytest.mark.parametrize("log", [np.zeros((256, 4)), np.zeros(256), np.zeros((1, 0, 3))])
def test_summary_rejects_bad_shape(log):
    with pytest.raises(ValueError, match="imu_log"):
        behaviour_summary(log)


def test_summary_rejects_nan():
    log = np.zeros((8, 3))
    log[3, 2] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        behaviour_summary(log)


def test_signed_summary_keeps_the_sign_of_the_zero_frequency_term_only():
    """The paper's |DFT| cannot tell a series from its negation (a robot turning left from its
    mirror image turning right); signed_dft keeps the sum's sign and changes nothing else."""
    t = np.arange(64) * 0.01
    log = np.stack([3.0 + np.sin(2 * np.pi * t), 0.5 * np.cos(4 * np.pi * t), 20.0 * t], axis=-1)  # (64, 3), degrees
    plain, signed = behaviour_summary(log), behaviour_summary(log, signed=True)
    np.testing.assert_array_equal(signed[:, 1:], plain[:, 1:])
    np.testing.assert_allclose(signed[:, 0], log.sum(axis=0))            # roll 3*64 + ~0, pitch ~0, yaw 20*sum(t)
    np.testing.assert_allclose(signed[2, 0], 20.0 * 0.01 * 63 * 64 / 2)
    mirror = log * np.array([-1.0, 1.0, -1.0])                            # roll and yaw negated
    np.testing.assert_array_equal(behaviour_summary(mirror), plain)     # the paper's summary: the same
    assert similarity(behaviour_summary(mirror, signed=True), signed) < similarity(behaviour_summary(mirror), plain) == 1.0
    np.testing.assert_allclose(behaviour_summary(mirror, signed=True)[[0, 2], 0], -signed[[0, 2], 0])


def test_angular_rates_are_the_change_per_step_over_10_ms():
    """A yaw ramp of 0.5 degrees a step is 50 degrees/s from the second row on; the first row's
    rate is 0; roll and pitch follow their own differences."""
    steps = np.arange(8)
    log = np.stack([np.where(steps >= 4, 2.0, 0.0), np.zeros(8), 0.5 * steps], axis=-1)   # roll steps up at row 4
    rates = angular_rates(log)
    np.testing.assert_allclose(rates[:, 2], [0.0] + [50.0] * 7)
    np.testing.assert_allclose(rates[:, 0], [0, 0, 0, 0, 200.0, 0, 0, 0])               # 2 degrees in 0.01 s
    np.testing.assert_array_equal(rates[:, 1], 0.0)
    np.testing.assert_allclose(angular_rates(np.stack([log, 2 * log]))[1], 2 * rates)     # batched alike
    with pytest.raises(ValueError, match="NaN"):
        angular_rates(np.where(steps[:, None] == 3, np.nan, log))


def test_summaries_by_name_and_their_max():
    """gyro_dft is the paper's DFT of the rates (a constant turn of 50 degrees/s over 63 of 64
    rows: zero-frequency term 50 * 63) and is compared at MAX 1000; dft and signed_dft are
    behaviour_summary's."""
    t = np.arange(64) * 0.01
    log = np.stack([3.0 + np.sin(2 * np.pi * t), np.zeros(64), -50.0 * t], axis=-1)
    np.testing.assert_array_equal(summarise(log, "dft"), behaviour_summary(log))
    np.testing.assert_array_equal(summarise(log, "signed_dft"), behaviour_summary(log, signed=True))
    gyro = summarise(log, "gyro_dft")
    assert gyro.shape == (3, 33)
    np.testing.assert_allclose(gyro[2, 0], 50.0 * 63)
    np.testing.assert_array_equal(gyro, behaviour_summary(angular_rates(log)))
    assert MAX_COEFFICIENTS == {"dft": 100.0, "signed_dft": 100.0, "gyro_dft": 1000.0}
    with pytest.raises(ValueError, match="unknown behaviour summary 'gyro'; valid names: dft, signed_dft, gyro_dft"):
        summarise(log, "gyro")
