"""The damage-recovery case study end to end, on the smoke preset (paper section 5)."""

import json

import pytest

from aquafish.case_study import CONTROLLER_KEYS, PRESETS, render_report, run_case_study, verdict
from aquafish.cli import main
from aquafish_gym import MORPHOLOGY_FIELDS, get_damage


@pytest.mark.slow
def test_smoke_case_study_writes_report_and_figures(tmp_path):
    report = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["controllers"] == report["controllers"]
    target = get_damage("left_pectoral_half").apply().to_array()
    assert [saved["target_morphology"][f] for f in MORPHOLOGY_FIELDS] == pytest.approx(target.tolist())
    assert {k: m["inference"] for k, m in report["models"].items()} == {"plain_eea": "none", "self_model": "out_of_band"}
    for model in report["models"].values():
        assert 0.0 <= model["objective_fitness"] <= 1.0
        assert model["target_experiments"] == PRESETS["smoke"].eea["rounds"]
    assert {"healthy", "plain_eea", "self_model", "true_damaged"} <= set(report["controllers"]) <= set(CONTROLLER_KEYS)
    for c in report["controllers"].values():
        assert c["target_distance"] == pytest.approx(sum(c["target_distances"]) / len(c["target_distances"]))
    assert report["verdict"] == verdict(report["controllers"]) and report["verdict"]["line"] in (tmp_path / "report.md").read_text()
    for name in report["figures"].values():
        assert (tmp_path / name).stat().st_size > 5000
    md = (tmp_path / "report.md").read_text()
    assert md == render_report(saved) and "| the healthy robot (`healthy`) |" in md
    # a finished case study is reused, not recomputed
    again = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    assert again["controllers"] == report["controllers"]


def test_unknown_preset_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["case-study", "--preset", "huge", "--out", str(tmp_path)])
    assert "invalid choice" in capsys.readouterr().err
    with pytest.raises(ValueError, match="valid"):
        run_case_study("huge", "left_pectoral_half", 0, tmp_path)


def _controllers(**target):
    return {key: {"target_distance": value} for key, value in target.items()}


def test_verdict_hand_computed():
    recovered = verdict(_controllers(healthy=1.0, plain_eea=2.0, self_model=3.5, true_damaged=4.0))
    assert recovered["breaks"] and recovered["recovers"] and recovered["plain_eea_below"]
    assert recovered["self_model_share"] == pytest.approx(0.875) and recovered["healthy_share"] == 0.25
    assert "breaks the healthy gait (it keeps 25% of the oracle gait's 4.00 units" in recovered["line"]
    assert "recovers: 88% of the oracle, 3.5x the healthy gait" in recovered["line"]
    # not broken: the healthy gait keeps 60%; the self-model gait has 88% of the oracle but 3.5 < 1.5 x 2.4
    kept = verdict(_controllers(healthy=2.4, plain_eea=3.9, self_model=3.5, true_damaged=4.0))
    assert not kept["breaks"] and not kept["recovers"] and not kept["plain_eea_below"]
    nothing = verdict(_controllers(healthy=0.1, plain_eea=0.0, self_model=0.0, true_damaged=-0.2))
    assert not nothing["breaks"] and nothing["self_model_share"] is None and "nothing to recover" in nothing["line"]
