"""The recovery benchmark (``aquafish recovery``): cells, shared rows, the summary."""

import json
from pathlib import Path

import pytest

from aquafish.case_study import BREAKS_SHARE, breaks, verdict
from aquafish.cli import main
from aquafish.recovery import (MANIFEST_FILE, cell_dir, check_spec, check_stale, faults_named, merge_manifest,
                               oracle_dir, render_summary, signs_right, summarize, summary_so_far)
from aquafish_gym import MORPHOLOGY_FIELDS, Morphology
from aquafish_gym.rundir import MismatchError


DESIGN = dict(zip(MORPHOLOGY_FIELDS, Morphology.healthy().to_array().tolist()))


def _report(damage, seed, distances, gains=None, shapes=False, check=None):
    """A case-study report with the fields the summary reads; ``distances``: target distance per row;
    ``shapes``: the self-model's and the target's morphology (the design) too; ``check``: the
    self-model's ``fault_check`` record."""
    controllers = {key: {"target_distance": d} for key, d in distances.items()}
    return {"preset": "smoke", "episode_duration_s": 20.0, "damage": damage, "seed": seed,
            "controllers": controllers, "verdict": verdict(controllers),
            "models": {"plain_eea": {"servo_gains": None, "target_experiments": 3},
                       "self_model": {"servo_gains": gains, "target_experiments": 4,
                                      **({"morphology": DESIGN} if shapes else {}),
                                      **({"fault_check": check} if check is not None else {})}},
            "target_servo_gains": {"left_pectoral_gain": 0.5, "right_pectoral_gain": 1.0, "caudal_gain": 1.0},
            **({"target_morphology": DESIGN} if shapes else {}), "wall_seconds": 12.5}


#: Four cells (oracle = true_damaged): A and B break the healthy gait (20 % and 40 % of the
#: oracle), C does not (80 %), D's oracle does not swim forward (and has no PPO rows).
REPORTS = [
    _report("a", 0, {"healthy": 2, "plain_eea": 5, "self_model": 9, "out_of_band": 8.5, "true_damaged": 10,
                     "robust": 3, "ppo": 1, "robust_ppo": 9}, gains={"left_pectoral_gain": 0.4},
            check={"replaced": False}),
    _report("b", 0, {"healthy": 4, "plain_eea": 9, "self_model": 8.5, "out_of_band": 2, "true_damaged": 10,
                     "robust": 8, "ppo": 5, "robust_ppo": 1},
            gains={"left_pectoral_gain": 0.25, "right_pectoral_gain": 1.0, "caudal_gain": 0.5}, shapes=True,
            check={"replaced": True, "procedure": "screen, polish"}),
    _report("c", 0, {"healthy": 8, "plain_eea": 9, "self_model": 9.5, "out_of_band": 9, "true_damaged": 10,
                     "robust": 9, "ppo": 9, "robust_ppo": 9}),
    _report("d", 0, {"healthy": 1, "plain_eea": 1, "self_model": 1, "out_of_band": 1, "true_damaged": -1,
                     "robust": 1}),
]


def test_summary_totals_hand_computed():
    summary = summarize(REPORTS)
    a, b, c, d = summary["cells"]
    assert [x["breaks"] for x in (a, b, c, d)] == [True, True, False, False]
    assert a["shares"] == pytest.approx({"healthy": 0.2, "plain_eea": 0.5, "out_of_band": 0.85, "self_model": 0.9,
                                         "robust": 0.3, "robust_ppo": 0.9, "ppo": 0.1})
    assert a["recovers"] == {"plain_eea": False, "out_of_band": True, "self_model": True, "robust": False,
                             "robust_ppo": True, "ppo": False}
    # c: 95 % of the oracle but not 1.5x the healthy gait; d: nothing to recover, no PPO rows
    assert not any(c["recovers"].values()) and c["breaks"] is False
    assert set(d["shares"].values()) == {None} and "ppo" not in d["shares"]
    assert a["gains"] == {"self_model": {"left_pectoral_gain": 0.4}, "target": REPORTS[0]["target_servo_gains"]}
    assert a["target_experiments"] == {"plain_eea": 3, "self_model": 4} and a["wall_seconds"] == 12.5
    totals = summary["totals"]
    assert (totals["cells"], totals["breaking"]) == (4, 2)
    assert {k: (r["recovers"], r["of"]) for k, r in totals["rows"].items()} == {
        "plain_eea": (1, 2), "out_of_band": (1, 2), "self_model": (2, 2), "robust": (1, 2), "robust_ppo": (1, 2),
        "ppo": (0, 2)}
    assert totals["rows"]["self_model"]["rate"] == 1.0 and totals["rows"]["ppo"]["rate"] == 0.0
    # a's self-model lacks the right gain: not judged; b's has both signs of the truth (+0.5, +1)
    assert [x["signs_right"] for x in (a, b, c, d)] == [None, True, None, None]
    assert totals["identified"] == {"right": 1, "of": 1, "rate": 1.0}
    # b's target has a weak left servo (0.5): its self-model's 0.25 names it (a healthy caudal held at
    # 0.5 is a false alarm, not a miss); the others lack the shapes or the gains
    assert [x["faults_named"] for x in (a, b, c, d)] == [None, True, None, None]
    assert totals["faults_named"] == {"named": 1, "of": 1, "rate": 1.0}
    weak = {**REPORTS[1], "models": {"self_model": {**REPORTS[1]["models"]["self_model"],
                                                    "servo_gains": {**REPORTS[1]["models"]["self_model"]["servo_gains"],
                                                                    "left_pectoral_gain": 1.0}}}}
    assert faults_named(weak) is False  # the weak servo held healthy
    # a's check predates named procedures, b's names its own; c and d have none
    assert [x["check_procedure"] for x in (a, b, c, d)] == ["", "screen, polish", None, None]
    assert totals["check_procedures"] == {"": 1, "screen, polish": 1}

    md = render_summary({"settings": {"preset": "smoke", "episode_duration_s": 20.0}, **summary})
    assert "| `a` | 0 | yes | 20% | 50% | 85% ✓ | 90% ✓ | 30% | 90% ✓ | 10% |" in md
    assert "| `d` | 0 | no | n/a | n/a | n/a | n/a | n/a |  |  |" in md
    assert "Breaks the healthy gait (seeds): `a` 1/1, `b` 1/1, `c` 0/1, `d` 0/1." in md
    assert "Recovers in the 2 of 4 cells that break: `plain_eea` 1/2, `out_of_band` 1/2, `self_model` 2/2" in md
    assert "| 50% | +0.25, +1 (+0.5, +1) ✓ |" in md and "| 10% |  |" in md
    assert "Pectoral signs right: 1 of the 1 cells with a self-model of servo gains." in md
    assert "Faulty servos named, each with the sign of its gain: 1 of the 1 cells" in md
    assert ("checked against fault hypotheses by: an earlier, unnamed procedure (1 cells); "
            "screen, polish (1 cells).") in md


@pytest.mark.parametrize("model, target, right", [
    ((-1.0, 0.75), (-1.0, 1.0), True),      # the reversed left servo found
    ((0.25, 0.75), (-1.0, 1.0), False),     # the healthy left taken
    ((-0.5, -0.25), (-1.0, 1.0), False),    # the mirror image
    ((0.0, 0.5), (0.0, 1.0), True),         # a dead servo needs exactly 0
    ((0.125, 0.5), (0.0, 1.0), False),
])
def test_signs_right_compares_both_pectoral_signs(model, target, right):
    keys = ("left_pectoral_gain", "right_pectoral_gain")
    gains = {"self_model": {**dict(zip(keys, model)), "caudal_gain": 1.0},
             "target": {**dict(zip(keys, target)), "caudal_gain": 1.0}}
    assert signs_right(gains) is right
    assert signs_right({"self_model": None, "target": gains["target"]}) is None


def test_a_lost_flipper_s_servo_is_not_judged():
    keys = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")
    gains = {"self_model": dict(zip(keys, (-0.625, -0.125, 1.0))), "target": dict(zip(keys, (-1.0, 1.0, 1.0)))}
    whole = {f"{side}_pectoral_{a}": 0.5 for side in ("left", "right") for a in "xyz"}
    assert signs_right(gains, whole) is False                       # the right gain's sign is wrong
    no_right = {**whole, "right_pectoral_x": 0.0, "right_pectoral_y": 0.0, "right_pectoral_z": 0.0}
    assert signs_right(gains, no_right) is True                     # ...but that servo moves no flipper
    no_pectorals = {**no_right, "left_pectoral_y": 0.0}
    assert signs_right(gains, no_pectorals) is None


def test_a_rerun_extends_the_manifest_with_damages_and_seeds_but_refuses_another_preset(tmp_path):
    merge_manifest(tmp_path, check_spec("smoke", ["left_pectoral_half"], [0]))
    merged = merge_manifest(tmp_path, check_spec("smoke", ["sampled:3", "left_pectoral_half"], [2, 1]))
    assert merged.damages == ("left_pectoral_half", "sampled:3") and merged.seeds == (0, 1, 2)
    assert json.loads((tmp_path / MANIFEST_FILE).read_text())["seeds"] == [0, 1, 2]
    with pytest.raises(MismatchError, match=r"preset: \"smoke\" -> \"quick\".*episode_duration_s: 20.0 -> 60.0"):
        merge_manifest(tmp_path, check_spec("quick", ["left_pectoral_half"], [0], 60))
    assert cell_dir(tmp_path, "sampled:3", 1) == tmp_path / "cells" / "sampled_3" / "seed1"


def test_a_benchmark_keeps_one_set_of_self_model_fields_and_passes_them_to_every_cell(tmp_path, monkeypatch):
    from aquafish import recovery

    lean = {"lineages": 1, "estimation_generations": 2}
    merge_manifest(tmp_path, check_spec("smoke", ["left_pectoral_half"], [0]))
    manifest = json.loads((tmp_path / MANIFEST_FILE).read_text())
    assert manifest["self_model_fields"] == {}
    del manifest["self_model_fields"]  # a manifest written before the fields existed: none
    (tmp_path / MANIFEST_FILE).write_text(json.dumps(manifest))
    assert merge_manifest(tmp_path, check_spec("smoke", ["sampled:3"], [0])).self_model_fields == {}
    with pytest.raises(MismatchError, match=r'self_model_fields: "\{\}" -> "\{\\"estimation_generations'):
        merge_manifest(tmp_path, check_spec("smoke", ["left_pectoral_half"], [0], self_model_fields=lean))
    other = tmp_path / "lean"
    other.mkdir()
    assert merge_manifest(other, check_spec("smoke", ["left_pectoral_half"], [0], self_model_fields=lean)) \
        .self_model_fields == lean
    assert summary_so_far(other)["settings"]["self_model_fields"] == lean
    assert ("Every cell's self-model has settings of its own: `estimation_generations = 2`, `lineages = 1`."
            in recovery.render_summary(summary_so_far(other)))
    calls = []
    monkeypatch.setattr("aquafish.case_study.run_case_study", lambda *args, **kwargs: calls.append(kwargs) or {})
    recovery._run_cell("smoke", "left_pectoral_half", 0, str(other / "cell"), str(other / "shared"), 20.0, 1, False,
                       self_model_fields=lean)
    assert calls[0]["self_model_fields"] == lean


@pytest.mark.parametrize("argv, message", [
    (["--damages", "nope,left_pectoral_half"], "unknown damage(s) ['nope']"),
    (["--damages", "none"], "unknown damage(s) ['none']"),
    (["--damages", 'left_pectoral_half,{"gains":[1, 0.5, 1]},left_pectoral_half'], "damages given more than once"),
    (["--damages", "left_pectoral_half", "--seeds", "1,1"], "seeds given more than once: 1"),
    (["--damages", "left_pectoral_half", "--seeds", "0,-2"], "argument --seeds: must be an int >= 0"),
    (["--damages", '{"gains": [1, 2]}'], "gains"),
    (["--damages", "left_pectoral_half", "--self-model-fields", '{"seed": 1}'], "self_model_fields may not set 'seed'"),
    (["--damages", "left_pectoral_half", "--self-model-fields", '{"lineages": 0}'],
     "self_model_fields: EEAConfig.lineages must be an int >= 1, got 0"),
])
def test_bad_settings_fail_in_one_line_creating_nothing(tmp_path, capsys, argv, message):
    out = tmp_path / "new" / "bench"
    with pytest.raises(SystemExit) as exc:
        main(["recovery", "--preset", "smoke", "--out", str(out), *argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "new").exists()


def test_two_cells_share_the_healthy_and_robust_rows_and_a_rerun_is_a_no_op(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("aquafish.case_study._rl_available", lambda: False)  # no PPO rows: faster
    out = tmp_path / "bench"
    argv = ["recovery", "--preset", "smoke", "--damages", "left_pectoral_half,reversed_left_pectoral", "--seeds", "0",
            "--workers", "1", "--no-progress", "--all-rows", "--out", str(out)]
    assert main(argv) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert [(c["damage"], c["seed"]) for c in summary["cells"]] == [("left_pectoral_half", 0),
                                                                    ("reversed_left_pectoral", 0)]
    assert summary["settings"] == {"preset": "smoke", "episode_duration_s": 20.0, "self_model_fields": {},
                                   "damages": ["left_pectoral_half", "reversed_left_pectoral"], "seeds": [0]}
    # the damage-independent rows were trained once, in shared/seed0, and every cell used them
    shared = out / "shared" / "seed0"
    assert (shared / "gait_healthy" / "run.json").is_file() and (shared / "gait_robust" / "run.json").is_file()
    assert not list((out / "cells").rglob("gait_healthy*")) and not list((out / "cells").rglob("gait_robust*"))
    reports = [json.loads((cell_dir(out, d, 0) / "report.json").read_text())
               for d in ("left_pectoral_half", "reversed_left_pectoral")]
    assert {r["shared_dir"] for r in reports} == {str(shared)}
    # one healthy gait: the same distances on its native (healthy) robot in both cells
    assert reports[0]["controllers"]["healthy"]["native_distances"] == \
        reports[1]["controllers"]["healthy"]["native_distances"]
    assert {k: v for k, v in summary.items() if k in ("cells", "totals")} == json.loads(json.dumps(summarize(reports)))
    md = (out / "summary.md").read_text()
    assert md == render_summary(summary) and md in capsys.readouterr().out
    assert f"cells that break: `plain_eea` {summary['totals']['rows']['plain_eea']['recovers']}/" in md

    # a rerun is a no-op: the cells are read back, the summary is the same
    stamps = [(cell_dir(out, d, 0) / "report.json").stat().st_mtime_ns for d in ("left_pectoral_half",
                                                                                 "reversed_left_pectoral")]
    assert main(argv) == 0
    assert json.loads((out / "summary.json").read_text()) == summary
    assert [(cell_dir(out, d, 0) / "report.json").stat().st_mtime_ns
            for d in ("left_pectoral_half", "reversed_left_pectoral")] == stamps

    # a cell whose self-model was checked by an earlier procedure runs again: today's check on the
    # same experiments (the same self-model here), the other cell is left alone
    from eea.fault_check import FAULT_CHECK_PROCEDURE

    cell = cell_dir(out, "reversed_left_pectoral", 0)
    path = cell / "report.json"
    assert not check_stale(reports[0], cell) and not check_stale(reports[1], cell) and not check_stale(None, cell)
    assert reports[1]["models"]["self_model"]["fault_check"]["procedure"] == FAULT_CHECK_PROCEDURE
    del reports[1]["models"]["self_model"]["fault_check"]["procedure"]
    path.write_text(json.dumps(reports[1]))
    assert check_stale(reports[1], cell)
    assert not check_stale(reports[1], tmp_path)  # a copy of the report alone (published): read back as it is
    assert main(argv) == 0
    again = json.loads(path.read_text())
    assert again["models"]["self_model"]["fault_check"]["procedure"] == FAULT_CHECK_PROCEDURE
    assert again["models"]["self_model"]["servo_gains"] == reports[1]["models"]["self_model"]["servo_gains"]
    assert (cell_dir(out, "left_pectoral_half", 0) / "report.json").stat().st_mtime_ns == stamps[0]

    # another preset is refused naming the field, before any work
    with pytest.raises(SystemExit):
        main([*argv[:2], "quick", *argv[3:]])
    assert 'preset: "smoke" -> "quick"' in capsys.readouterr().err


def test_breaks_is_the_share_of_the_oracle_kept_by_the_healthy_gait():
    assert BREAKS_SHARE == 0.5
    assert breaks(5.0, 10.0) and breaks(-3.0, 10.0)          # 50 % and less of the oracle's distance
    assert not breaks(5.01, 10.0) and not breaks(12.0, 10.0)
    assert not breaks(-2.0, -1.0) and not breaks(0.0, 0.0)   # the oracle does not swim forward
    assert verdict({"healthy": {"target_distance": 5.01}, "plain_eea": {"target_distance": 1},
                    "self_model": {"target_distance": 1}, "true_damaged": {"target_distance": 10}})["breaks"] is False


def test_a_cell_whose_damage_does_not_break_the_healthy_gait_stops_at_its_triage_and_all_rows_completes_it(
        tmp_path, monkeypatch):
    monkeypatch.setattr("aquafish.case_study._rl_available", lambda: False)  # no PPO rows: faster
    monkeypatch.setattr("aquafish.case_study.breaks", lambda healthy, oracle: False)
    out = tmp_path / "bench"
    argv = ["recovery", "--preset", "smoke", "--damages", "reversed_left_pectoral", "--seeds", "0", "--workers", "1",
            "--no-progress", "--out", str(out)]
    assert main(argv) == 0
    cell = cell_dir(out, "reversed_left_pectoral", 0)
    report = json.loads((cell / "report.json").read_text())
    assert report["triaged"] is True and report["models"] == {}
    assert set(report["controllers"]) == {"healthy", "true_damaged"}
    assert not [p.name for p in cell.iterdir() if p.is_dir()]  # no EEA run, no other gait: the oracle is the damage's
    oracle_runs = oracle_dir(out, "reversed_left_pectoral")
    assert sorted(p.name for p in oracle_runs.iterdir()) == [f"gait_oracle_run{i}" for i in range(3)]
    assert set(report["stage_seconds"]) == {"gaits", "transfer"}   # the gaits evolve as one stage
    summary = json.loads((out / "summary.json").read_text())
    assert summary["totals"]["breaking"] == 0 and summary["cells"][0]["shares"].keys() == {"healthy"}
    healthy_share = report["controllers"]["healthy"]["target_distance"] / report["controllers"]["true_damaged"]["target_distance"]
    assert summary["cells"][0]["shares"]["healthy"] == pytest.approx(healthy_share, rel=1e-12)

    # a rerun without --all-rows keeps the triaged cell; with it, the cell gets every row, its two gaits reused
    stamp = (oracle_runs / "gait_oracle_run0" / "run.json").stat().st_mtime_ns
    assert main(argv) == 0
    assert json.loads((cell / "report.json").read_text())["triaged"] is True
    assert main([*argv, "--all-rows"]) == 0
    full = json.loads((cell / "report.json").read_text())
    assert "triaged" not in full and {"plain_eea", "self_model"} <= set(full["models"])
    assert full["controllers"]["true_damaged"] == report["controllers"]["true_damaged"]
    assert (oracle_runs / "gait_oracle_run0" / "run.json").stat().st_mtime_ns == stamp
    assert {"eea_self_model", "gaits", "transfer"} <= set(full["stage_seconds"])


def test_the_summary_so_far_reads_the_finished_cells_lists_the_rest_and_writes_nothing(tmp_path, capsys):
    from aquafish.recovery import SUMMARY_JSON, summary_so_far

    with pytest.raises(ValueError, match="holds no recovery benchmark"):
        summary_so_far(tmp_path)
    merge_manifest(tmp_path, check_spec("smoke", ["left_pectoral_half", "sampled:3"], [0, 1]))
    done = _report("left_pectoral_half", 1, {"healthy": 2, "plain_eea": 5, "self_model": 9, "true_damaged": 10})
    cell_dir(tmp_path, "left_pectoral_half", 1).mkdir(parents=True)
    (cell_dir(tmp_path, "left_pectoral_half", 1) / "report.json").write_text(json.dumps(done))
    before = sorted(p.name for p in tmp_path.rglob("*"))
    summary = summary_so_far(tmp_path)
    assert [(c["damage"], c["seed"]) for c in summary["cells"]] == [("left_pectoral_half", 1)]
    assert summary["cells"][0]["shares"]["self_model"] == pytest.approx(0.9)
    assert summary["missing"] == [{"damage": "left_pectoral_half", "seed": 0}, {"damage": "sampled:3", "seed": 0},
                                  {"damage": "sampled:3", "seed": 1}]
    assert main(["recovery", "--out", str(tmp_path), "--summary-only"]) == 0
    out = capsys.readouterr().out
    assert "| `left_pectoral_half` | 1 | yes | 20% |" in out and "1 cells finished, 3 to run (nothing written)" in out
    assert sorted(p.name for p in tmp_path.rglob("*")) == before and not (tmp_path / SUMMARY_JSON).exists()


def test_every_cell_is_triaged_before_any_cell_runs_its_other_rows_and_a_broken_cell_left_at_triage_is_missing(
        tmp_path, monkeypatch, capsys):
    from aquafish.recovery import run_recovery, summary_so_far

    calls = []
    broken = {"reversed_left_pectoral", "sampled:5"}  # the fake triage's verdicts
    stop_at = {"sampled:5"}  # its rows fail once: the run is interrupted between the passes

    def fake_cell(preset, damage, seed, cell, shared, duration, workers, progress, all_rows, triage_only,
                  self_model_fields=None, oracle=None, recheck=False):
        calls.append(("triage" if triage_only else "rows", damage))
        path = Path(cell)
        path.mkdir(parents=True, exist_ok=True)
        healthy = 2.0 if damage in broken else 9.0
        if triage_only:
            report = _report(damage, seed, {"healthy": healthy, "plain_eea": 0, "self_model": 0, "true_damaged": 10})
            del report["controllers"]["plain_eea"], report["controllers"]["self_model"]
            report.update(models={}, triaged=True, wall_seconds=1.0, verdict={"breaks": healthy <= 5, "recovering": []})
        else:
            if damage in stop_at:
                stop_at.discard(damage)
                raise RuntimeError("interrupted")
            assert json.loads((path / "report.json").read_text())["triaged"] is True  # goes on from its triage
            report = _report(damage, seed, {"healthy": healthy, "plain_eea": 3, "self_model": 9, "true_damaged": 10})
        (path / "report.json").write_text(json.dumps(report))
        return report

    monkeypatch.setattr("aquafish.recovery._run_cell", fake_cell)
    monkeypatch.setattr("aquafish.recovery._train_shared", lambda preset, seed, *rest: seed)
    monkeypatch.setattr("aquafish.recovery._train_oracle", lambda preset, damage, *rest: damage)
    damages = ["left_pectoral_half", "reversed_left_pectoral", "caudal_half", "sampled:5"]
    with pytest.raises(RuntimeError, match="interrupted"):
        run_recovery(tmp_path, preset="smoke", damages=damages, seeds=[0], progress=False)
    # the four triages first, then the rows of the two broken cells only
    assert calls == [("triage", d) for d in damages] + [("rows", "reversed_left_pectoral"), ("rows", "sampled:5")]
    summary = summary_so_far(tmp_path)
    assert [m["damage"] for m in summary["missing"]] == ["sampled:5"]  # broken, rows not run: not finished
    by_damage = {c["damage"]: c for c in summary["cells"]}
    assert by_damage["sampled:5"]["breaks"] and by_damage["sampled:5"]["shares"] == {"healthy": pytest.approx(0.2)}
    assert summary["totals"]["rows"]["self_model"] == {"recovers": 1, "of": 1, "rate": 1.0}
    assert main(["recovery", "--out", str(tmp_path), "--summary-only"]) == 0
    assert "3 cells finished, 1 to run (1 of them triaged, their other rows to run)" in capsys.readouterr().out

    calls.clear()  # a second seed: its triages, then the rows seed by seed (seed 0's unfinished cell first)
    summary = run_recovery(tmp_path, preset="smoke", damages=damages, seeds=[0, 1], progress=False)
    assert calls == [("triage", d) for d in damages] + [("rows", "sampled:5"), ("rows", "reversed_left_pectoral"),
                                                        ("rows", "sampled:5")]
    assert summary["missing"] == [] and summary["totals"]["breaking"] == 4
    assert summary["totals"]["rows"]["self_model"]["of"] == 4
    calls.clear()
    run_recovery(tmp_path, preset="smoke", damages=damages, seeds=[0], progress=False, all_rows=True)
    assert calls == [("rows", "left_pectoral_half"), ("rows", "caudal_half")]  # all_rows completes the triaged


def test_a_case_study_that_goes_on_from_its_triage_counts_the_triages_seconds(tmp_path):
    from aquafish.case_study import _triage_seconds

    assert _triage_seconds(tmp_path) == 0.0  # no report
    (tmp_path / "report.json").write_text(json.dumps({"triaged": True, "wall_seconds": 55.5}))
    assert _triage_seconds(tmp_path) == 55.5
    (tmp_path / "report.json").write_text(json.dumps({"wall_seconds": 900.0}))  # a finished case study's
    assert _triage_seconds(tmp_path) == 0.0
    (tmp_path / "report.json").write_text("{not json")
    assert _triage_seconds(tmp_path) == 0.0


def test_rows_to_run_and_triage_only_needs_all_rows_off(tmp_path):
    from aquafish.case_study import run_case_study
    from aquafish.recovery import rows_to_run

    triaged = {"triaged": True, "verdict": {"breaks": True}}
    assert rows_to_run(triaged) and rows_to_run({**triaged, "verdict": {"breaks": False}}, all_rows=True)
    assert not rows_to_run({**triaged, "verdict": {"breaks": False}}) and not rows_to_run(None)
    assert not rows_to_run({"verdict": {"breaks": True}})  # a finished cell
    with pytest.raises(ValueError, match="triage_only=True needs all_rows=False"):
        run_case_study("smoke", "reversed_left_pectoral", 0, tmp_path / "cs", triage_only=True)
    assert not (tmp_path / "cs").exists()


def test_a_triage_that_finds_the_damage_breaks_the_healthy_gait_says_so_and_that_the_rest_is_to_run(tmp_path):
    from aquafish.case_study import _write_triaged, preset_settings
    from aquafish_gym import get_damage

    def scored(native, target):
        return {"native_distance": native, "target_distance": target, "native_distances": [native],
                "target_distances": [target]}

    damage = get_damage("reversed_left_pectoral")
    transfers = {"healthy": scored(12.0, -1.5), "true_damaged": scored(10.0, 10.0)}
    report = _write_triaged(tmp_path, "smoke", preset_settings("smoke"), damage.name, damage.apply(), 0,
                            "profile_lineages", "morphology+servos", transfers, {}, 2.5, None)
    assert report["triaged"] is True and report["verdict"]["breaks"] is True
    assert report["verdict"]["healthy_share"] == pytest.approx(-0.15)
    assert "breaks the healthy gait (it keeps -15% of" in report["verdict"]["line"]
    assert "still to run" in (tmp_path / "report.md").read_text()
    transfers["healthy"] = scored(12.0, 6.0)  # 60 % of the oracle: not broken
    assert _write_triaged(tmp_path, "smoke", preset_settings("smoke"), damage.name, damage.apply(), 0,
                          "profile_lineages", "morphology+servos", transfers, {}, 2.5, None)["verdict"]["breaks"] is False
