"""The case study's stage timings table (``aquafish bench case_study_stages``)."""

import json

import pytest

from aquafish.benchmarks.case_study_stages import main, stage_table


def test_stage_table_lists_stages_longest_first_with_their_share_and_the_rest():
    report = {"wall_seconds": 200.0, "stage_seconds": {"gait_healthy": 20.0, "eea_self_model": 120.0, "transfer": 10.0}}
    lines = stage_table(report).splitlines()
    assert lines[2:] == ["| eea_self_model | 120.0 | 60% |", "| gait_healthy | 20.0 | 10% |", "| transfer | 10.0 | 5% |",
                         "| the rest (figures, report) | 50.0 | 25% |", "| **case study** | **200.0** | 100% |"]


def test_a_report_without_stage_seconds_is_refused_and_the_flags_are_checked(tmp_path, capsys):
    with pytest.raises(ValueError, match="no stage_seconds"):
        stage_table({"wall_seconds": 1.0})
    path = tmp_path / "report.json"
    path.write_text(json.dumps({"preset": "quick", "damage": "caudal_half", "seed": 3, "wall_seconds": 4.0,
                                "stage_seconds": {"transfer": 1.0}}))
    main(["--report", str(path)])
    out = capsys.readouterr().out
    assert "'quick', caudal_half, seed 3" in out and "| transfer | 1.0 | 25% |" in out
    with pytest.raises(SystemExit):
        main([])  # neither --out nor --report
