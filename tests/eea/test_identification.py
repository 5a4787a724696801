"""Judging identification of servo faults (eea.identification), case by case."""

import numpy as np
import pytest

from aquafish_gym import Morphology
from eea.identification import (fault_parts_named, faulty_servos, healthy_servos_named_faulty, pectoral_signs_right,
                                servo_faults_named)
from eea.encoding import get_model_space

DESIGN = Morphology.healthy().to_array()


def full(gains, dims=DESIGN):
    return np.concatenate([dims, gains])


def lost(part: str):
    dims = dict(zip(("left_pectoral", "right_pectoral", "caudal"), DESIGN.reshape(3, 3)))
    dims[part] = np.zeros(3)
    return np.concatenate(list(dims.values()))


@pytest.mark.parametrize("model_gains, named", [
    ([-1, 1, 1], True), ([-0.25, 1, 1], True),   # reversed: any negative gain
    ([0, 1, 1], False), ([0.5, 1, 1], False), ([1, 1, 1], False), ([1, -1, 1], False)])
def test_a_reversed_left_servo_needs_a_negative_left_gain(model_gains, named):
    assert servo_faults_named(full(model_gains), full([-1, 1, 1])) is named


@pytest.mark.parametrize("model_gains, named", [
    ([0.5, 1, 1], True), ([0.875, 1, 1], True),  # weak: below 1, above 0
    ([1, 1, 1], False), ([0, 1, 1], False), ([-0.5, 1, 1], False), ([1, 0.5, 1], False)])
def test_a_weak_servo_needs_a_gain_between_0_and_1(model_gains, named):
    assert servo_faults_named(full(model_gains), full([0.6, 1, 1])) is named


def test_a_dead_or_seized_servo_needs_a_gain_of_exactly_0_and_two_faults_need_both():
    truth = full([1, 0, 0.5])  # right dead (or seized), caudal weak
    assert servo_faults_named(full([1, 0, 0.5]), truth) is True
    assert servo_faults_named(full([1, 0.125, 0.5]), truth) is False
    assert servo_faults_named(full([1, 0, 1]), truth) is False  # the caudal fault missed
    # a seized servo's truth is gain 0 (eea.encoding.servo_gains): the sampled fault of a seized left servo
    truth = get_model_space("morphology+servos").truth('{"seized": [true, false, false]}')
    assert truth[9:].tolist() == [0, 1, 1] and servo_faults_named(full([0, 1, 1]), truth) is True


def test_a_lost_flippers_servo_is_not_judged():
    truth = full([0, 1, 1], lost("left_pectoral"))
    assert not faulty_servos(truth).any() and servo_faults_named(full([1, 1, 1]), truth) is None
    truth = full([1, -1, 1], lost("left_pectoral"))  # the right servo is still judged
    assert faulty_servos(truth).tolist() == [False, True, False]
    assert servo_faults_named(full([0.5, -1, 1]), truth) is True
    assert servo_faults_named(full([1, 1, 1], DESIGN), full([1, 1, 1])) is None  # no servo fault at all


@pytest.mark.parametrize("model_gains, truth_gains, right", [
    ([-0.25, 0.5, 1], [-1, 1, 1], True), ([0.25, 0.5, 1], [-1, 1, 1], False),   # any negative gain for reversed
    ([-0.5, -0.25, 1], [-1, 1, 1], False),                                      # the mirror image
    ([0, 1, 1], [-1, 1, 1], False), ([0, 1, 0.5], [0, 1, 1], True),              # seized: exactly 0; caudal not judged
    ([0.125, 1, 1], [0, 1, 1], False)])
def test_pectoral_signs_right_compares_both_pectoral_signs_only(model_gains, truth_gains, right):
    assert pectoral_signs_right(full(model_gains), full(truth_gains)) is right


def test_pectoral_signs_right_leaves_out_a_lost_flipper():
    assert pectoral_signs_right(full([-1, -1, 1]), full([-1, 1, 1], lost("right_pectoral"))) is True
    both = lost("right_pectoral")
    both[:3] = 0.0
    assert pectoral_signs_right(full([-1, -1, 1]), full([-1, 1, 1], both)) is None


def test_healthy_servos_named_faulty_counts_false_alarms_on_flippers_that_are_there():
    truth = full([-1, 1, 1], lost("caudal"))
    assert healthy_servos_named_faulty(full([-1, 1, 1]), truth) == 0
    assert healthy_servos_named_faulty(full([-1, 0.5, 0]), truth) == 1  # the lost caudal's gain is not judged
    assert healthy_servos_named_faulty(full([-1, 0.5, 0.75]), full([-1, 1, 1])) == 2


def test_bad_arrays_are_a_clear_error():
    with pytest.raises(ValueError, match=r"\(12,\)"):
        servo_faults_named(np.zeros(9), full([1, 1, 1]))
    with pytest.raises(ValueError, match="finite"):
        servo_faults_named(full([np.nan, 1, 1]), full([1, 1, 1]))


def test_fault_parts_named_also_takes_the_flipper_that_moves_alike():
    design = DESIGN.reshape(3, 3)
    right_half = np.concatenate([design[0], design[1] * [0.5, 1, 1], design[2]])
    truth = full([1, 0.26, 1])  # a weak right servo
    assert servo_faults_named(full([1, 1, 1], right_half), truth) is False
    assert fault_parts_named(full([1, 1, 1], right_half), truth) is True
    assert fault_parts_named(full([1, 1, 1], lost("left_pectoral")), truth) is False  # the wrong side
    assert fault_parts_named(full([1, 0.5, 1]), truth) is True and fault_parts_named(full([1, 1, 1]), truth) is False
    # a seized left servo: a gain of 0 or a lost left flipper; a shorter one is not enough
    truth = full([0, 1, 1])
    assert fault_parts_named(full([1, 1, 1], lost("left_pectoral")), truth) is True
    assert fault_parts_named(full([1, 1, 1], np.concatenate([design[0] * [0.5, 1, 1], design[1], design[2]])),
                             truth) is False
    # a reversed servo only by a negative gain, whatever its flipper
    assert fault_parts_named(full([1, 1, 1], lost("left_pectoral")), full([-1, 1, 1])) is False
    assert fault_parts_named(full([1, 1, 1]), full([1, 1, 1])) is None
