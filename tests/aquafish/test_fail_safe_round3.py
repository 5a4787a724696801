"""Fail safe, round 3: manifests used unchecked, mission tables and missions that overwrite,
settings refused late, missions without a size guard, records of the wrong shape, nested run
directories, one fault under two names. One test, or parametrised family, per cause of the
issue; each failed before its fix. The conventions of ``test_fail_safe.py`` (its ``fails_safe``
helper): in-process through :func:`aquafish.cli.main`, nothing evolved (the heavy functions are
replaced by ones that fail loudly, so a command that would start work fails the test at once).
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import aquafish.case_study
import aquafish.mission
import aquafish.recovery
from aquafish.cli import build_parser, main
from aquafish.recovery import MANIFEST_FILE, cell_dir, check_spec
from aquafish_gym.rundir import COMMAND_FILE, run_lock
from test_fail_safe import TINY_EEA, fails_safe
from test_mission_table import _report

#: ``sampled:3`` written out (``aquafish damages --list``): one fault under two texts.
SAMPLED_3 = '{"gains":[1.0,0.55,1.0]}'


def _main(argv) -> int:
    return main([str(a) for a in argv])


def _no_work(*args, **kwargs):
    raise AssertionError("the command started work it should have refused")


@pytest.fixture
def no_cells(monkeypatch):
    """A recovery benchmark that would run anything fails the test."""
    monkeypatch.setattr(aquafish.recovery, "_run_tasks", _no_work)


def _tree(root: Path) -> dict:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _manifest(out: Path, **fields) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    (out / COMMAND_FILE).write_text("recovery\n")
    manifest = {"preset": "smoke", "episode_duration_s": 20.0, "self_model_fields": {},
                "damages": ["reversed_left_pectoral"], "seeds": [0], **fields}
    (out / MANIFEST_FILE).write_text(json.dumps(manifest))
    return out / MANIFEST_FILE


# -- 3. recovery.json is validated before use ---------------------------------------------------------

@pytest.mark.parametrize("field, value", [
    ("damages", "abc"),                                 # a string where a list belongs: one-letter "damages"
    ("damages", ["sampled:../../../outside"]),          # a cell path outside --out
    ("damages", ["sampled:03"]),                        # not the canonical text (sampled:3)
    ("damages", [7]),
    ("damages", ["reversed_left_pectoral", "reversed_left_pectoral"]),
    ("damages", ["sampled:3", SAMPLED_3]),              # one fault under two texts
    ("seeds", "0"),
    ("seeds", [0.5]),
    ("seeds", [2**40]),
    ("preset", "nope"),
    ("episode_duration_s", float("nan")),
    ("self_model_fields", ["lineages"]),
])
def test_a_recovery_manifest_is_refused_naming_the_field(field, value, tmp_path, capsys, no_cells):
    out = tmp_path / "bench"
    manifest = _manifest(out, **{field: value})
    outside = tmp_path / "outside" / "seed0"  # a report planted where a crafted damage text leads
    outside.mkdir(parents=True)
    (outside / "report.json").write_text("{}")
    fails_safe(["recovery", "--summary-only", "--out", out], capsys, MANIFEST_FILE, field)
    before = manifest.read_bytes()
    fails_safe(["recovery", "--budget", "smoke", "--damages", "caudal_half", "--out", out, "--no-progress"], capsys,
               MANIFEST_FILE, field)
    assert manifest.read_bytes() == before  # nothing merged into it


def test_a_cell_report_with_a_nan_distance_is_refused_not_counted(tmp_path, capsys):
    out = tmp_path / "bench"
    _manifest(out)
    cell = cell_dir(out, "reversed_left_pectoral", 0)
    cell.mkdir(parents=True)
    (cell / "report.json").write_text(json.dumps({
        "damage": "reversed_left_pectoral", "seed": 0, "preset": "smoke", "episode_duration_s": 20.0,
        "controllers": {"healthy": {"target_distance": float("nan")}, "true_damaged": {"target_distance": 3.0}},
        "verdict": {"breaks": True, "recovering": []}, "models": {}, "wall_seconds": 1.0}))
    fails_safe(["recovery", "--summary-only", "--out", out], capsys, "report.json", "target_distance")


def test_the_published_benchmarks_manifests_still_read():
    for name in ("recovery_quick_20s_today", "recovery_quick_60s"):
        out = Path(__file__).resolve().parents[2] / "docs" / "results" / name
        recorded, spec = aquafish.recovery.read_manifest(out)
        assert list(spec.damages) == recorded["damages"] and list(spec.seeds) == recorded["seeds"]


# -- 5. mission-table --out is a directory of its own ------------------------------------------------------------

def _mission_dir(root: Path, **report) -> Path:
    d = root / f"mission_{len(list(root.glob('mission_*')))}"
    d.mkdir(parents=True)
    (d / "mission.json").write_text(json.dumps({**_report(), **report}))
    return d


@pytest.mark.parametrize("legacy", [False, True])
def test_mission_table_refuses_another_commands_directory(legacy, tmp_path, capsys):
    mission = _mission_dir(tmp_path)
    bench = tmp_path / "bench"
    bench.mkdir()
    if legacy:  # a benchmark written before the command marker: known by its manifest
        (bench / MANIFEST_FILE).write_text("{}")
    else:
        (bench / COMMAND_FILE).write_text("recovery\n")
    (bench / "summary.json").write_text("precious")
    (bench / "summary.md").write_text("precious")
    before = _tree(bench)
    fails_safe(["mission-table", mission, "--out", bench], capsys, "aquafish recovery", "--out")
    assert _tree(bench) == before


def test_mission_table_claims_its_out_and_writes_it_again(tmp_path, capsys):
    mission = _mission_dir(tmp_path)
    table = tmp_path / "table"
    assert _main(["mission-table", mission, "--out", table]) == 0
    assert (table / COMMAND_FILE).read_text() == "mission-table\n"
    assert _main(["mission-table", mission, "--out", table]) == 0  # a table is made again in its own directory
    assert json.loads((table / "summary.json").read_text())["totals"]["missions"] == 1
    fails_safe(["eea", *TINY_EEA, "--out", table], capsys, "aquafish mission-table")


# -- 6. a mission directory has a manifest -------------------------------------------------------------

_FAKE_REPORT = {"onset_s": 8.0, "alarm_s": None, "recovered_s": None, "target_experiments": 0, "compute_seconds": 0.0,
                "speed_before": None, "speed_damaged": None, "speed_after": None, "oracle_speed": None,
                "oracle_in_window": None, "files": {"timeline": "timeline.png", "trajectory": "trajectory.csv"}}


@pytest.fixture
def fake_mission(monkeypatch):
    """Missions that run nothing: the prior and the mission itself are recorded, not run."""
    runs = []
    monkeypatch.setattr(aquafish.mission, "prepare_prior", lambda *a, **k: "prior")
    monkeypatch.setattr(aquafish.mission, "_run", lambda *a, **k: runs.append(a) or dict(_FAKE_REPORT))
    return runs


def _mission(out, *flags, damage="reversed_left_pectoral", duration="30"):
    return ["mission", "--budget", "smoke", "--damage", damage, "--onset-s", "8", "--duration-s", duration,
            "--no-video", "--no-progress", *flags, "--out", out]


def test_a_mission_rerun_with_other_settings_is_refused_naming_them(tmp_path, capsys, fake_mission):
    out = tmp_path / "m"
    assert _main(_mission(out)) == 0
    settings = json.loads((out / aquafish.mission.SETTINGS_FILE).read_text())
    assert (settings["damage"], settings["seed"], settings["preset"], settings["prior_source"]) == \
        ("reversed_left_pectoral", 0, "smoke", "design")
    assert _main(_mission(out)) == 0 and len(fake_mission) == 2  # the same settings: run again
    fails_safe(_mission(out, damage="caudal_half"), capsys, "damage:", "caudal_half")
    fails_safe(_mission(out, "--cold-start", "--seed", "3"), capsys, "seed: 0 -> 3", "warm_start: true -> false")
    fails_safe(_mission(out, "--no-oracle"), capsys, "oracle: true -> false")
    fails_safe(_mission(out, "--self-model-fields", '{"lineages": 2}'), capsys, "self_model_fields")
    assert len(fake_mission) == 2


def test_a_mission_made_before_the_manifest_is_judged_by_its_report(tmp_path, capsys, fake_mission):
    out = tmp_path / "m"
    out.mkdir()
    (out / "mission.json").write_text(json.dumps({"damage": "reversed_left_pectoral", "seed": 0, "preset": "smoke",
                                                  "onset_s": 8.0, "duration_s": 30.0, "warm_start": True}))
    fails_safe(_mission(out, "--seed", "1"), capsys, "seed: 0 -> 1")
    assert not fake_mission


# -- 7. settings are refused before any write ------------------------------------------------------------

@pytest.mark.parametrize("duration", ["1e9", "0.01"])
def test_recovery_refuses_an_episode_length_before_writing_its_manifest(duration, tmp_path, capsys, no_cells):
    if duration == "0.01" and importlib.util.find_spec("stable_baselines3") is None:
        pytest.skip("without the [rl] extra no PPO row trains on such episodes")
    out = tmp_path / "bench"
    fails_safe(["recovery", "--budget", "smoke", "--damages", "caudal_half", "--episode-duration-s", duration,
                "--out", out, "--no-progress"], capsys, "--episode-duration-s")
    assert not out.exists()  # so the corrected command is not refused by a manifest of this one


HUGE_FIELDS = '{"estimation_population": 1000000000}'


@pytest.mark.parametrize("argv", [
    ["recovery", "--budget", "smoke", "--damages", "caudal_half", "--self-model-fields", HUGE_FIELDS],
    ["case-study", "--budget", "smoke", "--damage", "caudal_half", "--self-model-fields", HUGE_FIELDS],
    ["case-study", "--budget", "smoke", "--damage", "caudal_half", "--episode-duration-s", "1e9"],
])
def test_huge_self_model_fields_and_episodes_are_refused_up_front(argv, tmp_path, capsys, no_cells, monkeypatch):
    monkeypatch.setattr(aquafish.case_study, "_run_locked", _no_work)
    out = tmp_path / "out"
    line = fails_safe([*argv, "--no-progress", "--out", out], capsys, "memory")
    assert ("--self-model-fields" in line) == (HUGE_FIELDS in argv)
    assert not out.exists()


@pytest.mark.parametrize("command, flag, limit", [
    ("eea", "--seed", 2**32), ("study", "--first-seed", 2**32), ("gait", "--seed", 2**32),
    ("transfer", "--seed", 2**32), ("rl", "--seed", 2**32), ("damages", "--seed", 2**32),
    ("damages", "--eval-seed", 2**32), ("baselines", "--seed", 2**32), ("baselines", "--eval-seed", 2**32),
    ("case-study", "--seed", 10**6), ("mission", "--seed", 10**6), ("recovery", "--seeds", 10**6),
])
def test_out_of_range_seeds_are_refused_naming_the_flag(command, flag, limit, capsys):
    with pytest.raises(SystemExit) as exc:
        build_parser().parse_args([command, flag, f"0,{limit}" if flag == "--seeds" else str(limit)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {flag}" in err and f"must be an int >= 0 and <= {limit - 1}" in err and "Traceback" not in err


def test_the_procedure_seed_limit_is_the_oracles_and_the_library_refuses_it_too():
    from aquafish.oracle import PROCEDURE_SEED_LIMIT
    from aquafish.studies_cli import PROCEDURE_SEED_LIMIT as spelled_out

    assert spelled_out == PROCEDURE_SEED_LIMIT
    with pytest.raises(ValueError, match="seed"):
        check_spec("smoke", ["caudal_half"], [PROCEDURE_SEED_LIMIT])


# -- 8. missions have a size and memory guard ------------------------------------------------------------------

@pytest.mark.parametrize("argv, name", [
    (lambda out: _mission(out, duration="1e9"), "--duration-s"),
    (lambda out: _mission(out, "--self-model-fields", HUGE_FIELDS), "--self-model-fields"),
    (lambda out: _mission(out, "--prior", "eea", "--self-model-fields", HUGE_FIELDS), "--self-model-fields"),
])
def test_a_mission_too_large_for_memory_is_refused_before_any_work(argv, name, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(aquafish.mission, "prepare_prior", _no_work)
    monkeypatch.setattr(aquafish.mission, "_run", _no_work)
    out = tmp_path / "m"
    fails_safe(argv(out), capsys, name, "memory")
    assert not out.exists()


# -- 12. records of the wrong shape --------------------------------------------------------------------------------

@pytest.mark.parametrize("content, names", [
    ("[]", ["mission.json", "list"]),
    (json.dumps({**_report(), "speed_after": float("nan")}), ["mission.json", "speed_after", "NaN"]),
    (json.dumps({**_report(), "oracle_speed": "fast"}), ["oracle_speed", "fast"]),
    (json.dumps({**_report(), "self_model_after": {"left_pectoral_gain": "a", "right_pectoral_gain": 1.0,
                                                   "caudal_gain": 1.0}}), ["self_model_after", "left_pectoral_gain"]),
    (json.dumps({**_report(), "false_alarm": "no"}), ["false_alarm"]),
    (json.dumps({**_report(), "counterfactuals": {"keep_old": {"net_displacement": float("nan")}}}),
     ["counterfactuals.keep_old.", "net_displacement"]),
    (json.dumps({**_report(), "true_model": []}), ["true_model"]),
])
def test_mission_table_refuses_a_report_of_the_wrong_shape_naming_the_field(content, names, tmp_path, capsys):
    mission = tmp_path / "m"
    mission.mkdir()
    (mission / "mission.json").write_text(content)
    fails_safe(["mission-table", mission], capsys, *names)


def _prior(directory: Path, self_model: dict) -> Path:
    for part in ("gait/best_controller.json", "gait/run.json", "gait/final_population.json",
                 "monitor_calibration.json"):
        (directory / part).parent.mkdir(parents=True, exist_ok=True)
        (directory / part).write_text("{}")
    (directory / "self_model.json").write_text(json.dumps(self_model))
    return directory


_BITS = [0, 1] * 28 + [1]  # 57 bits: a morphology+servos genome


@pytest.mark.parametrize("self_model, field", [
    ({"genome": ["a"] * 57, "robot": {}}, "genome"),
    ({"genome": [0.5] * 57, "robot": {}}, "genome"),
    ({"genome": _BITS, "robot": "healthy"}, "robot"),
    ({"genome": _BITS, "robot": {"morphology": {"left_pectoral_x": "a"}}}, "robot"),
    ([], "JSON"),
])
def test_a_received_self_model_of_the_wrong_shape_is_refused_naming_the_file(self_model, field, tmp_path, capsys,
                                                                                 monkeypatch):
    monkeypatch.setattr(aquafish.mission, "_run", _no_work)
    prior = _prior(tmp_path / "prior", self_model)
    fails_safe(_mission(tmp_path / "m", "--self-model", prior), capsys, "self_model.json", field)


# -- 13. nested run directories ------------------------------------------------------------------------------

def test_a_run_inside_another_commands_run_directory_is_refused(tmp_path, capsys):
    mission = tmp_path / "m"
    mission.mkdir()
    (mission / COMMAND_FILE).write_text("mission\n")
    (mission / "mission.json").write_text("{}")
    fails_safe(["eea", *TINY_EEA, "--out", mission / "self_model"], capsys, "lies inside", "aquafish mission")
    fails_safe(["eea", *TINY_EEA, "--out", mission / "self_model" / "eea"], capsys, "lies inside")
    assert sorted(p.name for p in mission.iterdir()) == [COMMAND_FILE, "mission.json"]
    link = tmp_path / "link"
    link.symlink_to(mission, target_is_directory=True)  # a link does not hide the run directory
    fails_safe(["eea", *TINY_EEA, "--out", link / "self_model"], capsys, "lies inside")


_HOLD = textwrap.dedent("""
    import sys
    from aquafish_gym.rundir import run_lock
    with run_lock(sys.argv[1], command="recovery"):
        print("locked", flush=True)
        sys.stdin.read()
""")


def test_a_case_study_inside_a_running_benchmark_is_refused_as_busy(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(aquafish.case_study, "_run_locked", _no_work)
    bench = tmp_path / "bench"
    holder = subprocess.Popen([sys.executable, "-c", _HOLD, str(bench)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              text=True)
    try:
        assert holder.stdout.readline().strip() == "locked"
        cell = cell_dir(bench, "caudal_half", 0)
        fails_safe(["case-study", "--budget", "smoke", "--damage", "caudal_half", "--no-progress", "--out", cell],
                   capsys, "lies inside", f"pid {holder.pid}")
        assert not (bench / "cells").exists()
    finally:
        holder.communicate("")


def test_a_command_writes_its_own_sub_directories_in_process_and_in_its_workers(tmp_path):
    out = tmp_path / "bench"
    child = textwrap.dedent("""
        import sys
        from aquafish_gym.rundir import run_lock
        with run_lock(sys.argv[1], command="case-study"):
            pass
    """)
    with run_lock(out, command="recovery"):
        with run_lock(out / "cells" / "a" / "seed0", command="case-study"):  # in process
            pass
        subprocess.run([sys.executable, "-c", child, str(out / "cells" / "b" / "seed0")], check=True)  # a worker
    assert (out / "cells" / "b" / "seed0" / COMMAND_FILE).read_text() == "case-study\n"


# -- 18. one fault under two names is one cell ---------------------------------------------------------------

@pytest.mark.parametrize("damages, names", [
    (f"sampled:3,{SAMPLED_3}", ["sampled:3", SAMPLED_3]),
    ('reversed_left_pectoral,{"gains":[-1,1,1]}', ["reversed_left_pectoral", '{"gains":[-1.0,1.0,1.0]}']),
])
def test_one_fault_under_two_names_is_refused_naming_both(damages, names, tmp_path, capsys, no_cells):
    out = tmp_path / "bench"
    fails_safe(["recovery", "--budget", "smoke", "--damages", damages, "--out", out, "--no-progress"], capsys,
               "one fault", *names)
    assert not out.exists()


def test_a_rerun_naming_a_held_fault_otherwise_is_refused(tmp_path, capsys, no_cells):
    out = tmp_path / "bench"
    manifest = _manifest(out, damages=["sampled:3"])
    before = manifest.read_bytes()
    fails_safe(["recovery", "--budget", "smoke", "--damages", SAMPLED_3, "--out", out, "--no-progress"], capsys,
               "sampled:3", SAMPLED_3, MANIFEST_FILE)
    assert manifest.read_bytes() == before


def test_two_sampled_draws_of_one_fault_stay_two_cells():
    # sampled:2030 and sampled:2034 draw the same fault: two draws of the distribution (held-out sets hold both)
    assert aquafish.recovery.fault_key("sampled:2030") == aquafish.recovery.fault_key("sampled:2034")
    assert check_spec("smoke", ["sampled:2030", "sampled:2034"], [0]).damages == ("sampled:2030", "sampled:2034")
