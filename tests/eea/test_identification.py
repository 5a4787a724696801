"""Judging identification of servo faults (eea.identification), case by case."""

import json

import numpy as np
import pytest

from aquafish_gym import Morphology
from eea.identification import (FLIPPER_KINDS, PART_CLASSES, SERVO_KINDS, SERVO_PARTS, fault_parts_named,
                                faulty_servos, flipper_kind, healthy_servos_named_faulty, identification,
                                identification_confusion, part_kinds, pectoral_signs_right, servo_faults_named,
                                servo_kind)
from eea.encoding import get_model_space
from eea.inference.selection import fault_hypotheses

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


# -- the strict judgement ------------------------------------------------------------------------


@pytest.mark.parametrize("gain, part, kind", [
    (1.0, "left_pectoral", "healthy"), (0.95, "left_pectoral", "healthy"), (0.9, "right_pectoral", "healthy"),
    (0.9375, "caudal", "healthy"),                                  # the caudal grid's level next to 1
    (0.875, "left_pectoral", "weak"), (0.8, "caudal", "weak"), (0.5, "left_pectoral", "weak"),
    (0.2, "caudal", "weak"), (0.125, "left_pectoral", "weak"), (0.1, "left_pectoral", "weak"),
    (0.05, "left_pectoral", "dead"), (0.0, "caudal", "dead"), (-0.05, "right_pectoral", "dead"),
    (-0.1, "left_pectoral", "reversed"), (-0.5, "left_pectoral", "reversed"), (-1.0, "right_pectoral", "reversed")])
def test_servo_kind_by_gain(gain, part, kind):
    assert servo_kind(gain, part) == kind


@pytest.mark.parametrize("factors, kind", [
    ((1, 1, 1), "present"), ((1.5, 2, 1), "present"), ((1, 0.875, 1), "present"), ((1, 0.75, 1), "shortened"),
    ((0.5, 1, 1), "shortened"), ((1, 0.25, 1), "shortened"), ((1, 0.0625, 1), "lost"), ((0, 0, 0), "lost"),
    ((0, 1, 1), "lost"), ((1, 1, 0), "present")])   # the thickness is not read
def test_flipper_kind_against_the_design(factors, kind):
    for i, part in enumerate(SERVO_PARTS):
        assert flipper_kind(DESIGN[3 * i:3 * i + 3] * factors, part) == kind


def test_every_sampled_fault_is_classed_as_the_kind_it_was_drawn():
    from aquafish_gym.faults import draw_faults

    space, seen = get_model_space("morphology+servos"), set()
    servo_of = {"reversed": "reversed", "weak": "weak", "dead": "dead", "seized": "dead"}
    for seed in range(300):
        expected = {part: {"servo": "healthy", "flipper": "present"} for part in SERVO_PARTS}
        for draw in draw_faults(seed):
            if draw.kind in servo_of:
                expected[draw.part]["servo"] = servo_of[draw.kind]
            else:
                expected[draw.part]["flipper"] = draw.kind
            seen.add(draw.kind)
        assert part_kinds(space.truth(f"sampled:{seed}")) == expected, seed
    assert seen == {"reversed", "weak", "dead", "seized", "shortened", "lost"}


def test_the_hypotheses_hold_every_class_of_part_the_sampled_faults_make():
    hypotheses = fault_hypotheses(DESIGN)
    classes = {f"{k['servo']}/{k['flipper']}" for h in hypotheses for k in part_kinds(h).values()}
    assert {"healthy/present", "weak/present", "dead/present", "reversed/present", "healthy/shortened",
            "healthy/lost"} <= classes
    healthy = [h for h in hypotheses if all(k == {"servo": "healthy", "flipper": "present"}
                                            for k in part_kinds(h).values())]
    assert len(healthy) == 1 and healthy[0].tolist() == full([1, 1, 1]).tolist()


def test_a_healthy_servo_held_weak_fails_strict_identification_but_not_servo_faults_named():
    truth, model = full([-1, 1, 1]), full([-1, 0.5, 1])
    assert servo_faults_named(model, truth) is True
    judged = identification(model, truth)
    assert judged["strict"] is False
    right = judged["parts"]["right_pectoral"]
    assert right["named"] is False and right["servo_judged"] is True
    assert right["truth"]["servo"] == "healthy" and right["model"]["servo"] == "weak"
    assert judged["parts"]["left_pectoral"]["named"] is True and judged["parts"]["caudal"]["named"] is True
    # a healthy flipper held shortened is a miss too, and a shorter flipper does not stand in for a weak servo
    design = DESIGN.reshape(3, 3)
    shorter_right = np.concatenate([design[0], design[1] * [1, 0.5, 1], design[2]])
    assert identification(full([-1, 1, 1], shorter_right), truth)["strict"] is False
    assert fault_parts_named(full([1, 1, 1], shorter_right), full([1, 0.5, 1])) is True
    assert identification(full([1, 1, 1], shorter_right), full([1, 0.5, 1]))["strict"] is False


def test_a_reversed_servo_named_with_its_kind_and_the_rest_healthy_is_strict():
    truth = full([-1, 1, 1])
    judged = identification(full([-1, 1, 1]), truth)
    assert judged["strict"] is True and all(p["named"] for p in judged["parts"].values())
    assert judged["parts"]["left_pectoral"]["truth"] == {"servo": "reversed", "flipper": "present", "gain": -1.0,
                                                         "dims": DESIGN[:3].tolist()}
    assert judged["gain_abs_error"] == [0.0, 0.0, 0.0] and judged["morphology_abs_error"] == 0.0
    # the kind, not the size: half reversed is reversed; a caudal one polish step off 1 is healthy
    assert identification(full([-0.5, 1, 0.9375]), truth)["strict"] is True
    assert identification(full([0, 1, 1]), truth)["strict"] is False      # held dead
    assert identification(full([1, -1, 1]), truth)["strict"] is False     # the mirror image
    assert identification(full([1, 1, 1]), full([1, 1, 1]))["strict"] is True   # nothing faulty, nothing held so


def test_a_lost_flippers_servo_is_not_judged_strictly_either():
    truth = full([1, 1, 1], lost("left_pectoral"))
    judged = identification(full([0, 1, 1], lost("left_pectoral")), truth)
    left = judged["parts"]["left_pectoral"]
    assert judged["strict"] is True and left["servo_judged"] is False and left["named"] is True
    assert left["model"]["servo"] == "dead" and left["truth"]["servo"] == "healthy"
    assert identification(full([-1, 1, 1], lost("left_pectoral")), truth)["strict"] is True
    # the flipper still is: held there, it is a miss, whatever the servo
    assert identification(full([0, 1, 1]), truth)["strict"] is False
    # a lost flipper the truth still has: both its kinds are judged
    judged = identification(full([1, 1, 1], lost("caudal")), full([1, 1, 0.5]))
    assert judged["parts"]["caudal"]["servo_judged"] is True and judged["strict"] is False


def test_the_errors_by_hand():
    design = DESIGN.reshape(3, 3)
    model = np.concatenate([design[0], design[1] * [1, 0.5, 1], design[2]])  # right length 1 -> 0.5
    judged = identification(full([-0.5, 1, 0.75], model), full([-1, 1, 1]))
    assert judged["gain_abs_error"] == [0.5, 0.0, 0.25]
    assert judged["morphology_abs_error"] == pytest.approx(0.5 / 9)
    # the left flipper lost: its span 0.25, length 1 and thickness 0.0625 missed by the design's model
    judged = identification(full([1, 1, 1]), full([1, 0.5, 1], lost("left_pectoral")))
    assert judged["morphology_abs_error"] == pytest.approx((0.25 + 1 + 0.0625) / 9)
    assert judged["gain_abs_error"] == [0.0, 0.5, 0.0]
    assert judged["parts"]["right_pectoral"]["model"]["gain"] == 1.0


def test_confusion_counts_every_part_truth_against_model():
    judged = [
        identification(full([-1, 1, 1]), full([-1, 1, 1])),                     # 3 on the diagonal
        identification(full([-1, 0.5, 1]), full([-1, 1, 1])),                   # right healthy held weak
        identification(full([0, 1, 1], lost("left_pectoral")), full([1, 1, 1], lost("left_pectoral"))),
        identification(full([1, 1, 1]), full([1, 1, 1], lost("caudal"))),       # caudal lost held present
        None,                                                                   # a cell without gains
    ]
    counts = identification_confusion(judged)
    assert list(counts) == list(PART_CLASSES) and all(list(row) == list(PART_CLASSES) for row in counts.values())
    assert len(PART_CLASSES) == len(SERVO_KINDS) * len(FLIPPER_KINDS) == 12
    nonzero = {(row, col): n for row, cols in counts.items() for col, n in cols.items() if n}
    assert nonzero == {("reversed/present", "reversed/present"): 2, ("healthy/present", "healthy/present"): 7,
                       ("healthy/present", "weak/present"): 1,
                       ("healthy/lost", "healthy/lost"): 1,      # the lost left's servo (held dead) not judged
                       ("healthy/lost", "healthy/present"): 1}
    off_diagonal = sum(n for (row, col), n in nonzero.items() if row != col)
    assert off_diagonal == sum(not p["named"] for j in judged if j for p in j["parts"].values())
    assert identification_confusion(json.loads(json.dumps(judged))) == counts   # JSON read back
    assert identification_confusion([]) == {row: dict.fromkeys(PART_CLASSES, 0) for row in PART_CLASSES}


def test_strict_implies_servo_faults_named_on_sampled_truths_and_the_hypotheses():
    space, hypotheses = get_model_space("morphology+servos"), fault_hypotheses(DESIGN)
    for seed in range(40):
        truth = space.truth(f"sampled:{seed}")
        for model in hypotheses:
            if identification(model, truth)["strict"]:
                assert servo_faults_named(model, truth) is not False, (seed, model)


def test_bad_input_to_the_strict_judgement_is_a_clear_error():
    with pytest.raises(ValueError, match=r"model must be a finite \(12,\)"):
        identification(np.zeros(9), full([1, 1, 1]))
    with pytest.raises(ValueError, match=r"truth must be a finite \(12,\).*not finite"):
        identification(full([1, 1, 1]), full([np.nan, 1, 1]))
    with pytest.raises(ValueError, match=r"caudal servo's gain must be a finite number in \[0, 1\]"):
        identification(full([1, 1, -0.5]), full([1, 1, 1]))
    with pytest.raises(ValueError, match=r"left_pectoral servo's gain .* in \[-1, 1\]"):
        part_kinds(full([1.5, 1, 1]))
    with pytest.raises(ValueError, match=">= 0"):
        identification(full([1, 1, 1], -DESIGN), full([1, 1, 1]))
    with pytest.raises(ValueError, match="part must be one of left_pectoral, right_pectoral, caudal"):
        servo_kind(1.0, "tail")
    with pytest.raises(ValueError, match=r"3 finite numbers >= 0"):
        flipper_kind([0.25, 1.0], "caudal")
    with pytest.raises(ValueError, match="identification dicts"):
        identification_confusion([{"strict": True}])
    bad = identification(full([1, 1, 1]), full([1, 1, 1]))
    bad["parts"]["caudal"]["model"]["servo"] = "sluggish"
    with pytest.raises(ValueError, match="a part's class must be one of"):
        identification_confusion([bad])
