"""aquafish.mission_table: missions' reports in one table, judged against the mission's goals."""

import json

import pytest

from aquafish.cli import main
from aquafish.mission_table import format_table, mission_row, read_missions, summarise_missions

_DESIGN = {"left_pectoral_x": 0.25, "left_pectoral_y": 1.0, "right_pectoral_x": 0.25, "right_pectoral_y": 1.0}


def _report(damage="reversed_left_pectoral", seed=0, *, alarm=32.2, in_force=30.06, false_alarm=False, after=0.8,
            oracle=1.0, compute=250.0, found=(-1.0, 0.875, 1.0), truth=(-1.0, 1.0, 1.0), shape=None):
    gains = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")
    return {"damage": damage, "seed": seed, "warm_start": True, "onset_s": 30.0, "damage_in_force_s": in_force,
            "alarm_s": alarm, "false_alarm": false_alarm, "target_experiments": 8, "compute_seconds": compute,
            "speed_before": 0.71, "speed_damaged": 0.62, "speed_after": after, "oracle_speed": oracle,
            "true_model": {**_DESIGN, **(shape or {}), **dict(zip(gains, truth))},
            "self_model_after": None if found is None else {**_DESIGN, **dict(zip(gains, found))},
            "new_gait_start_yaws_deg": [-135.0, -45.0, 45.0, 135.0]}


def test_a_row_measures_the_alarm_from_the_damage_in_force_and_the_speed_against_the_oracle():
    row = mission_row(_report())
    assert row["alarm_delay_s"] == pytest.approx(32.2 - 30.06)
    assert row["after_share"] == 0.8                                         # 80 %: just recovered
    assert row["alarm_in_time"] and row["recovered_in_window"] and row["compute_in_budget"] and row["signs_right"]
    slow = mission_row(_report(alarm=40.1, after=0.79, compute=301.0, found=(1.0, 1.0, 1.0)))
    assert slow["alarm_delay_s"] == pytest.approx(10.04) and not slow["alarm_in_time"]
    assert not slow["recovered_in_window"] and not slow["compute_in_budget"] and slow["signs_right"] is False


def test_a_false_alarm_has_no_delay_and_a_missing_oracle_no_share():
    row = mission_row(_report(alarm=11.9, false_alarm=True, oracle=None))
    assert row["alarm_delay_s"] is None and not row["alarm_in_time"]
    assert row["after_share"] is None and not row["recovered_in_window"]
    assert mission_row(_report(oracle=-0.1))["after_share"] is None          # an oracle that does not swim forward


def test_a_lost_flippers_servo_is_not_judged():
    # the right flipper lost: its servo moves nothing, so a wrong right gain is not held against the model
    row = mission_row(_report(damage="sampled:1017", truth=(-1.0, 1.0, 1.0), found=(-0.75, -1.0, 1.0),
                              shape={"right_pectoral_y": 0.0}))
    assert row["signs_right"] is True
    assert mission_row(_report(found=None))["signs_right"] is None


def test_totals_count_the_goals():
    reports = [_report(), _report(seed=1, alarm=45.0, after=0.1, compute=1500.0, found=(1.0, -1.0, 1.0)),
               _report(seed=2, alarm=12.0, false_alarm=True, oracle=None, compute=100.0)]
    t = summarise_missions(reports)["totals"]
    assert (t["missions"], t["false_alarms"], t["alarm_in_time"]) == (3, 1, 1)
    assert (t["with_oracle"], t["recovered_in_window"]) == (2, 1)
    assert (t["signs_judged"], t["signs_right"], t["compute_in_budget"]) == (3, 2, 2)
    assert t["median_compute_s"] == 250.0
    assert t["median_alarm_delay_s"] == pytest.approx((32.2 - 30.06 + 45.0 - 30.06) / 2)
    table = format_table(summarise_missions(reports))
    assert table.count("\n| `reversed_left_pectoral` |") == 3 and "false alarm" in table and "80 % ✓" in table
    assert "after recovery 80 % of the oracle on 1 of 2 with an oracle (in the window where measured, on 0; " \
           "against the 20 s oracle alone on 1)" in table


def test_the_oracle_in_the_window_judges_the_recovery_where_the_report_has_one():
    # the new gait swims 0.5 where the straight oracle's 20 s swim gave 1.0, but swum over the same
    # window from the same state the best oracle makes 0.6: recovered (83 %), though 50 % of the 20 s one
    report = _report(after=0.5) | {"oracle_in_window": {"after_s": 230.0, "straight": 0.4, "procedure": 0.6,
                                                        "best": 0.6}}
    row = mission_row(report)
    assert row["after_share"] == 0.5 and row["window_share"] == pytest.approx(0.5 / 0.6)
    assert row["recovered_in_window"] and not row["recovered_20s"]
    assert not mission_row(report | {"speed_after": 0.47})["recovered_in_window"]  # 78 % of the window's oracle
    summary = summarise_missions([report, _report(seed=1, after=0.9)])
    assert (summary["totals"]["recovered_in_window"], summary["totals"]["recovered_20s"], summary["totals"]["with_window"]) == (2, 1, 1)
    table = format_table(summary)
    assert "| 1.000 | 50 % | 0.600 | 83 % ✓ |" in table and "| 1.000 | 90 % ✓ | - | - |" in table


def test_an_oracle_that_does_not_swim_in_the_window_leaves_the_judgement_to_the_20s_oracle():
    # the robot points backwards with a lost flipper: neither oracle turns it in the window (0.009),
    # and a new gait that crawls at 0.014 would be 156 % of it; the 20 s oracle (0.5) judges: 3 %
    report = _report(after=0.014, oracle=0.5) | {"oracle_in_window": {"after_s": 228.6, "straight": -0.06,
                                                                      "procedure": 0.009, "best": 0.009}}
    row = mission_row(report)
    assert row["window_share"] == pytest.approx(0.014 / 0.009) and not row["window_judges"]
    assert not row["recovered_in_window"]
    edge = report | {"oracle_in_window": {"best": 0.125}, "speed_after": 0.1}   # 25 % of the 20 s oracle: judges
    assert mission_row(edge)["window_judges"] and mission_row(edge)["recovered_in_window"]
    summary = summarise_missions([report])
    assert summary["totals"]["with_window"] == 0
    table = format_table(summary)
    assert "| 0.009 † | 156 % |" in table and "†: the oracle in the window swims less than 25 %" in table


def test_bad_input_is_named(tmp_path):
    with pytest.raises(ValueError, match="at least one mission directory"):
        read_missions([])
    with pytest.raises(ValueError, match="no mission.json"):
        read_missions([tmp_path])
    (tmp_path / "mission.json").write_text("{")
    with pytest.raises(ValueError, match="cannot be read as a mission report"):
        read_missions([tmp_path])
    (tmp_path / "mission.json").write_text(json.dumps(_report()))
    with pytest.raises(ValueError, match="given twice"):
        read_missions([tmp_path, tmp_path / "."])
    with pytest.raises(ValueError, match="no 'oracle_speed' field"):
        mission_row({k: v for k, v in _report().items() if k != "oracle_speed"})


def test_the_command_prints_and_writes_the_table(tmp_path, capsys):
    dirs = []
    for seed in (0, 1):
        d = tmp_path / f"m{seed}"
        d.mkdir()
        (d / "mission.json").write_text(json.dumps(_report(seed=seed)))
        dirs.append(str(d))
    assert main(["mission-table", *dirs, "--out", str(tmp_path / "table")]) == 0
    out = capsys.readouterr().out
    assert "2 missions: alarm within 10 s of the damage on 2" in out
    written = json.loads((tmp_path / "table" / "summary.json").read_text())
    assert written["totals"]["recovered_in_window"] == 2 and len(written["rows"]) == 2
    assert (tmp_path / "table" / "summary.md").read_text() in out
    with pytest.raises(SystemExit) as exit_:                                     # fails safe, one line
        main(["mission-table", str(tmp_path / "nowhere")])
    assert exit_.value.code == 2 and "no mission.json" in capsys.readouterr().err


def test_own_self_model_settings_are_marked_per_row_and_named_once_below_the_table():
    lean = {"lineages": 1, "estimation_generations": 15}
    reports = [_report(), {**_report(seed=1), "self_model_fields": lean},
               {**_report(seed=2), "self_model_fields": dict(reversed(list(lean.items())))}]
    rows = summarise_missions(reports)["rows"]
    assert [r["self_model_fields"] for r in rows] == [{}, lean, lean]   # a report from before the field: none
    table = format_table(summarise_missions(reports))
    lines = table.splitlines()
    assert "| warm |" in lines[2] and "| warm ‡1 |" in lines[3] and "| warm ‡1 |" in lines[4]
    assert table.count("‡1:") == 1 and "‡2" not in table
    assert "‡1: the recovery's self-model EEA with `estimation_generations = 15`, `lineages = 1`" in table


def test_an_earlier_versions_new_gait_started_one_way_is_marked_in_its_row():
    earlier = {k: v for k, v in _report(seed=1).items() if k != "new_gait_start_yaws_deg"}
    reports = [_report(), earlier, {**earlier, "seed": 2, "new_gait_start": "robot_heading"}]
    rows = summarise_missions(reports)["rows"]
    assert [r["new_gait"] for r in rows] == ["spread", "mission_heading", "robot_heading"]
    lines = format_table(summarise_missions(reports)).splitlines()
    assert "| warm |" in lines[2] and "| warm, gait from +y only |" in lines[3]
    assert "| warm, gait from the robot's heading |" in lines[4]


def test_a_mission_is_judged_against_carrying_on_and_the_oracle_from_the_alarm():
    cf = {"keep_old": {"start_s": 30.0, "net_displacement": 40.0, "final_speed": 0.1},
          "oracle_at_alarm": {"start_s": 32.2, "net_displacement": 150.0, "final_speed": 0.6}}
    report = _report() | {"net_displacement": 90.0, "final_speed": 0.5, "counterfactuals": cf, "recovered": True}
    row = mission_row(report)
    assert (row["keep_old_net"], row["oracle_at_alarm_net"], row["oracle_at_alarm_final"]) == (40.0, 150.0, 0.6)
    assert row["beats_keep_old"] is True and row["final_share"] == pytest.approx(0.5 / 0.6) and row["recovered"]
    lost = report | {"net_displacement": 30.0, "recovered": False}     # carrying on went further
    old = _report()                                                     # a report made before the counterfactuals
    totals = summarise_missions([report, lost, old])["totals"]
    assert (totals["judged"], totals["recovered"], totals["beats_keep_old"], totals["final_80"]) == (2, 1, 1, 2)
    assert mission_row(old)["recovered"] is None and mission_row(old)["beats_keep_old"] is None
    text = format_table(summarise_missions([report, lost, old]))
    assert "| 90.0 | 40.0 | 150.0 | 0.500 | 0.100 | 0.600 | 83 % | **yes** |" in text
    assert "recovered (net displacement beyond keeping the old gait" in text and "on 1 of 2 judged" in text
