"""The strict identification in the recovery benchmark's summary and the case study's report
(eea.identification.identification through aquafish.recovery and aquafish.case_study)."""

import json
from types import SimpleNamespace

import numpy as np
import pytest

from aquafish import case_study
from aquafish.case_study import verdict
from aquafish.recovery import faults_named, render_summary, self_model_identification, summarize
from aquafish_gym import MORPHOLOGY_FIELDS, Morphology, get_damage
from eea.identification import PART_CLASSES

DESIGN = dict(zip(MORPHOLOGY_FIELDS, Morphology.healthy().to_array().tolist()))
GAINS = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")


def _gains(left, right, caudal):
    return dict(zip(GAINS, (left, right, caudal)))


def _report(damage, model_gains, target_gains, model_dims=DESIGN, target_dims=DESIGN):
    """A case-study report with the fields the summary reads; the oracle swims 10, the healthy
    gait 2 (the damage breaks it), the self-model's gait 9."""
    controllers = {key: {"target_distance": d} for key, d in
                   {"healthy": 2, "plain_eea": 5, "self_model": 9, "true_damaged": 10}.items()}
    return {"damage": damage, "seed": 0, "controllers": controllers, "verdict": verdict(controllers),
            "models": {"plain_eea": {"servo_gains": None, "target_experiments": 3},
                       "self_model": {"servo_gains": model_gains, "morphology": model_dims, "target_experiments": 4}},
            "target_morphology": target_dims, "target_servo_gains": target_gains, "wall_seconds": 1.0}


LEFT_LOST = {**DESIGN, "left_pectoral_x": 0.0, "left_pectoral_y": 0.0, "left_pectoral_z": 0.0}

#: A: the reversed left servo named, nothing else held faulty (strict); B: the reversed left
#: named, the healthy right held weak (lenient yes, strict no); C: the left flipper lost and
#: held lost, its servo held dead (not judged: strict); D: a morphology-space self-model (no gains).
REPORTS = [
    _report("reversed_left_pectoral", _gains(-1.0, 1.0, 1.0), _gains(-1.0, 1.0, 1.0)),
    _report("reversed_left_pectoral", _gains(-1.0, 0.5, 1.0), _gains(-1.0, 1.0, 1.0)),
    _report("left_pectoral_missing", _gains(0.0, 1.0, 1.0), _gains(1.0, 1.0, 1.0), model_dims=LEFT_LOST,
            target_dims=LEFT_LOST),
    _report("caudal_half", None, _gains(1.0, 1.0, 1.0)),
]


def test_the_summary_counts_strict_identification_and_the_parts_confusion():
    summary = summarize(REPORTS)
    a, b, c, d = summary["cells"]
    assert [x["faults_named"] for x in (a, b, c, d)] == [True, True, None, None]   # lenient: B passes
    assert [x["identification"] and x["identification"]["strict"] for x in (a, b, c, d)] == [True, False, True, None]
    assert b["identification"]["parts"]["right_pectoral"]["model"] == {
        "servo": "weak", "flipper": "present", "gain": 0.5, "dims": [DESIGN[f"right_pectoral_{a}"] for a in "xyz"]}
    assert b["identification"]["gain_abs_error"] == [0.0, 0.5, 0.0] and b["identification"]["morphology_abs_error"] == 0
    assert c["identification"]["parts"]["left_pectoral"]["servo_judged"] is False
    totals = summary["totals"]
    assert totals["faults_named"] == {"named": 2, "of": 2, "rate": 1.0}
    assert totals["strict_identification"] == {"strict": 2, "of": 3, "rate": pytest.approx(2 / 3)}
    confusion = totals["confusion"]
    assert list(confusion) == list(PART_CLASSES)
    nonzero = {(r, m): n for r, cols in confusion.items() for m, n in cols.items() if n}
    assert nonzero == {("reversed/present", "reversed/present"): 2, ("healthy/present", "healthy/present"): 5,
                       ("healthy/present", "weak/present"): 1, ("healthy/lost", "healthy/lost"): 1}
    assert json.loads(json.dumps(summary)) == summary   # summary.json as written

    md = render_summary({"settings": {"preset": "smoke", "episode_duration_s": 20.0}, **summary})
    assert ("Faulty servos named, each with the sign of its gain: 2 of the 2 cells whose target has a faulty servo "
            "on a flipper it still has (the lenient measure: a healthy servo held faulty is not counted).") in md
    assert ("Identified strictly (every faulty part named with its kind, no healthy part held faulty): "
            "2 of 3 cells.") in md
    # the confusion matrix: only the classes that occur, the truth's per row, the model's per column
    assert ("| truth ↓, model → | `healthy/present` | `healthy/lost` | `weak/present` | `reversed/present` |\n"
            "|---|---|---|---|---|\n"
            "| `healthy/present` | 5 | 0 | 1 | 0 |\n"
            "| `healthy/lost` | 0 | 1 | 0 | 0 |\n"
            "| `reversed/present` | 0 | 0 | 0 | 2 |\n") in md
    assert "dead/present" not in md


def test_a_cell_without_a_self_model_of_gains_has_no_identification_and_no_table():
    assert self_model_identification(REPORTS[3]) is None
    assert self_model_identification({**REPORTS[0], "models": {}}) is None
    assert self_model_identification({k: v for k, v in REPORTS[0].items() if k != "target_morphology"}) is None
    summary = summarize(REPORTS[3:])
    assert summary["totals"]["strict_identification"] == {"strict": 0, "of": 0, "rate": None}
    assert not any(any(cols.values()) for cols in summary["totals"]["confusion"].values())
    md = render_summary({"settings": {"preset": "smoke", "episode_duration_s": 20.0}, **summary})
    assert "Identified strictly" not in md and "truth ↓" not in md


def test_a_summary_written_before_strict_identification_still_renders():
    summary = summarize(REPORTS)
    for cell in summary["cells"]:
        del cell["identification"]
    for key in ("strict_identification", "confusion"):
        del summary["totals"][key]
    md = render_summary({"settings": {"preset": "smoke", "episode_duration_s": 20.0}, **summary})
    assert "Faulty servos named" in md and "Identified strictly" not in md


def test_the_case_studys_identification_is_the_summarys():
    """The report's ``identification`` (case_study._identification) judges the same (12,) arrays
    as the summary's (recovery.self_model_identification) from the report's own fields."""
    damage = "reversed_left_pectoral"
    target = get_damage(damage).apply()
    model = Morphology.healthy().replace(right_pectoral_y=0.5)
    gains = [-0.75, 1.0, 0.9375]
    results = {"self_model": SimpleNamespace(self_model=np.r_[model.to_array(), gains]),
               "plain_eea": SimpleNamespace(self_model=model.to_array())}
    models = {"self_model": model, "plain_eea": model}
    judged = case_study._identification(models, results, target, damage)
    report = _report(damage, dict(zip(GAINS, gains)), dict(zip(GAINS, case_study._true_gains(damage))),
                     model_dims=case_study._dims(model), target_dims=case_study._dims(target))
    assert judged == self_model_identification(report)
    assert judged["strict"] is False and judged["parts"]["right_pectoral"]["model"]["flipper"] == "shortened"
    assert judged["parts"]["caudal"]["named"] is True and faults_named(report) is True
    # a morphology-space self-model, or none at all
    assert case_study._identification(models, {"self_model": results["plain_eea"]}, target, damage) is None
    assert case_study._identification({}, {}, target, damage) is None
