"""The damage-recovery case study end to end, on the smoke preset (paper section 5)."""

import json

import pytest

from aquafish.case_study import PRESETS, render_report, run_case_study
from aquafish.cli import main
from aquafish_gym import MORPHOLOGY_FIELDS, get_damage


@pytest.mark.slow
def test_smoke_case_study_writes_report_and_figures(tmp_path):
    report = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["controllers"] == report["controllers"]
    target = get_damage("left_pectoral_half").apply().to_array()
    assert [saved["target_morphology"][f] for f in MORPHOLOGY_FIELDS] == pytest.approx(target.tolist())
    assert set(report["models"]) == {"none", "out_of_band"}
    for model in report["models"].values():
        assert 0.0 <= model["objective_fitness"] <= 1.0
        assert model["target_experiments"] == PRESETS["smoke"].eea["rounds"]
    assert {"healthy", "plain EEA model", "out-of-band EEA model"} <= set(report["controllers"])
    for name in report["figures"].values():
        assert (tmp_path / name).stat().st_size > 5000
    md = (tmp_path / "report.md").read_text()
    assert md == render_report(saved) and "| healthy |" in md
    # a finished case study is reused, not recomputed
    again = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    assert again["controllers"] == report["controllers"]


def test_unknown_preset_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["case-study", "--preset", "huge", "--out", str(tmp_path)])
    assert "invalid choice" in capsys.readouterr().err
    with pytest.raises(ValueError, match="valid"):
        run_case_study("huge", "left_pectoral_half", 0, tmp_path)
