"""The registry of held-out sets and spending a sealed set (aquafish.heldout): no simulation,
the runners replaced by fakes."""

import subprocess
import tomllib
from pathlib import Path

import pytest
import tomli_w

from aquafish import heldout
from aquafish.cli import main

ROOT = Path(__file__).parents[2]
REGISTRY = ROOT / "benchmarks" / "heldout.toml"
#: The sets that were looked at while the method was developed: never again held out.
VALIDATION = {"rlp_identification_5000", "sampled_servo_faults_2000", "benchmark_sampled_1000",
              "missions_heldout_5000"}


def _recovery_set(**over):
    return {"kind": "recovery", "description": "a test set", "status": "sealed", "reality_gap": "none",
            "damages": ["caudal_half", "sampled:3"], "seeds": [1, 2],
            "settings": {"preset": "smoke", "episode_duration_s": 20.0}, **over}


def _registry(tmp_path, sets) -> Path:
    path = tmp_path / "heldout.toml"
    path.write_text("# the rules\n# of the registry\n\n" + tomli_w.dumps({"sets": sets}))
    return path


def _git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), "-c", "user.name=t", "-c", "user.email=t@example.org", *args],
                          capture_output=True, text=True, check=True).stdout.strip()


@pytest.fixture
def checkout(tmp_path):
    """A git checkout with a committed method (aquafish/__init__.py)."""
    repo = tmp_path / "repo"
    (repo / "aquafish").mkdir(parents=True)
    (repo / "aquafish" / "__init__.py").write_text("x = 1\n")
    _git(repo, "init", "-q")
    _git(repo, "add", "aquafish/__init__.py")
    _git(repo, "commit", "-q", "-m", "the method")
    return repo


@pytest.fixture
def fake_runs(monkeypatch):
    """The recovery runner replaced: records each call and the registry as it stood when it ran."""
    calls = []

    def run(entry, out, **kwargs):
        calls.append({"entry": entry, "out": out, **kwargs})
        return "3 of 4 cells break the healthy gait; recovers in them: self_model 2/3"

    monkeypatch.setattr(heldout, "run_recovery_set", run)
    return calls


def test_the_committed_registry_validates_and_names_every_looked_at_set_validation():
    sets = heldout.load_registry(REGISTRY)
    assert VALIDATION <= set(sets)
    for name in VALIDATION:
        assert sets[name]["status"] == "validation" and sets[name]["note"], name
    for name, entry in sets.items():
        assert entry["reality_gap"] == "none", name
        heldout.check_runnable(entry)  # every set's settings are ones its runner takes
    fresh = {"benchmark_20s", "benchmark_60s", "missions_development_damages", "missions_fresh_faults"}
    assert fresh <= set(sets) and all(sets[n]["status"] in ("sealed", "spent") for n in fresh)
    for name, entry in sets.items():
        if entry["status"] == "spent":   # spent once, at a named commit, into a named directory
            assert len(entry["commit"]) == 40 and entry["out"] and entry["result"], name


def test_the_committed_registry_holds_the_sets_as_stated():
    sets = heldout.load_registry(REGISTRY)
    b20, b60 = sets["benchmark_20s"], sets["benchmark_60s"]
    presets = {"left_pectoral_half", "right_pectoral_half", "left_pectoral_missing", "caudal_half", "caudal_missing",
               "seized_left_pectoral", "weak_right_pectoral", "reversed_left_pectoral"}
    assert set(b20["damages"]) == presets | {f"sampled:{i}" for i in range(3000, 3008)}
    assert (b20["damages"], b20["seeds"]) == (b60["damages"], b60["seeds"]) and b20["seeds"] == [7000, 7001, 7002]
    assert (b20["settings"]["episode_duration_s"], b60["settings"]["episode_duration_s"]) == (20.0, 60.0)
    development, fresh = (heldout.missions_of(sets[n]) for n in ("missions_development_damages", "missions_fresh_faults"))
    assert len(set(development + fresh)) == len(development) + len(fresh) == 24
    assert {d for d, _ in development} == {"reversed_left_pectoral", "sampled:5", "sampled:13", "sampled:67"}
    assert {s for _, s in development} == {7100, 7101, 7102} and {s for _, s in fresh} == {7200, 7201, 7202}
    assert {d for d, _ in fresh} == {f"sampled:{i}" for i in range(3100, 3104)}
    for name in ("missions_development_damages", "missions_fresh_faults"):
        assert sets[name]["settings"] == {"preset": "quick", "onset_s": 30.0, "duration_s": 300.0}


def test_the_committed_registry_is_as_the_command_writes_it(tmp_path):
    # a spend rewrites the file: in this form its diff is the spent set's lines only
    text = REGISTRY.read_text()
    assert text.startswith("# ") and "run once" in text.split("[sets.", 1)[0]
    copy = tmp_path / "heldout.toml"
    copy.write_text(text)
    heldout.write_registry(copy, heldout.load_registry(copy))
    assert copy.read_text() == text


def test_spend_marks_the_set_spent_before_running_and_records_the_result(tmp_path, checkout, monkeypatch):
    path = _registry(tmp_path, {"fresh": _recovery_set(), "other": _recovery_set()})
    commit = _git(checkout, "rev-parse", "HEAD")

    def run(entry, out, **kwargs):
        during = tomllib.loads(path.read_text())["sets"]["fresh"]
        assert (during["status"], during["commit"], during["result"]) == ("spent", commit, "running")
        assert "records" not in during
        return "the result"

    monkeypatch.setattr(heldout, "run_recovery_set", run)
    out = checkout / "records" / "fresh"
    entry = heldout.spend("fresh", out, path, checkout=checkout, workers=1)
    after = heldout.load_registry(path)
    assert after["fresh"] == entry
    assert entry["status"] == "spent" and entry["commit"] == commit
    assert entry["result"] == "the result" and entry["records"] == entry["out"] == "records/fresh"
    assert after["other"]["status"] == "sealed"
    assert path.read_text().startswith("# the rules\n# of the registry\n\n[sets.fresh]")  # the rules are kept


def test_spend_passes_the_settings_to_the_runner(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set()})
    heldout.spend("fresh", tmp_path / "out", path, checkout=checkout, processes=2, workers=1, progress=False)
    (call,) = fake_runs
    assert call["out"] == tmp_path / "out" and (call["processes"], call["workers"], call["progress"]) == (2, 1, False)
    assert call["entry"]["damages"] == ["caudal_half", "sampled:3"]
    # outside the checkout, out is recorded as an absolute path
    assert heldout.load_registry(path)["fresh"]["records"] == (tmp_path / "out").resolve().as_posix()


def test_a_spent_set_is_never_run_again(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set()})
    heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    commit = _git(checkout, "rev-parse", "HEAD")
    for out in (tmp_path / "out", tmp_path / "again"):
        with pytest.raises(ValueError, match=rf"spent at commit {commit}.*never run again"):
            heldout.spend("fresh", out, path, checkout=checkout)
    assert len(fake_runs) == 1


def test_a_validation_set_is_refused_as_not_held_out(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"looked_at": _recovery_set(status="validation", note="tuned on")})
    with pytest.raises(ValueError, match="validation set, not held out.*tuned on"):
        heldout.spend("looked_at", tmp_path / "out", path, checkout=checkout)
    assert not fake_runs and heldout.load_registry(path)["looked_at"]["status"] == "validation"


def test_an_unknown_set_is_refused_naming_the_sets(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set()})
    with pytest.raises(ValueError, match="no set 'nope'.*fresh"):
        heldout.spend("nope", tmp_path / "out", path, checkout=checkout)


def test_a_run_that_fails_leaves_the_set_spent_and_resumes_only_at_the_same_commit_and_out(tmp_path, checkout,
                                                                                          monkeypatch):
    path = _registry(tmp_path, {"fresh": _recovery_set()})

    def crash(entry, out, **kwargs):
        raise ValueError("a cell failed")

    monkeypatch.setattr(heldout, "run_recovery_set", crash)
    with pytest.raises(ValueError, match="a cell failed"):
        heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    entry = heldout.load_registry(path)["fresh"]
    assert (entry["status"], entry["result"]) == ("spent", "running")  # never back to sealed
    with pytest.raises(ValueError, match="still running.*same commit into the same --out"):
        heldout.spend("fresh", tmp_path / "elsewhere", path, checkout=checkout)
    (checkout / "aquafish" / "more.py").write_text("y = 2\n")
    _git(checkout, "add", "aquafish/more.py")
    _git(checkout, "commit", "-q", "-m", "a change to the method")
    with pytest.raises(ValueError, match=f"spent at commit {entry['commit']}"):
        heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    _git(checkout, "reset", "-q", "--hard", entry["commit"])
    monkeypatch.setattr(heldout, "run_recovery_set", lambda entry, out, **kw: "resumed")
    resumed = heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    assert (resumed["commit"], resumed["result"]) == (entry["commit"], "resumed")


def test_a_method_with_uncommitted_changes_is_refused_and_the_set_stays_sealed(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set()})
    (checkout / "notes.txt").write_text("not the method\n")
    (checkout / "aquafish" / "untracked.py").write_text("")  # untracked files are not the method
    assert heldout.method_commit(checkout) == _git(checkout, "rev-parse", "HEAD")
    (checkout / "aquafish" / "__init__.py").write_text("x = 2\n")
    with pytest.raises(ValueError, match=r"not frozen at a commit.*aquafish/__init__\.py"):
        heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    assert heldout.load_registry(path)["fresh"]["status"] == "sealed" and not fake_runs
    _git(checkout, "add", "aquafish/__init__.py")  # staged is not committed either
    with pytest.raises(ValueError, match="not frozen at a commit"):
        heldout.method_commit(checkout)


def test_outside_a_git_checkout_spending_is_refused(tmp_path, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set()})
    (tmp_path / "plain").mkdir()
    with pytest.raises(ValueError, match="not a usable git checkout"):
        heldout.spend("fresh", tmp_path / "out", path, checkout=tmp_path / "plain")
    assert heldout.load_registry(path)["fresh"]["status"] == "sealed"


def test_settings_the_runner_refuses_are_refused_before_the_set_is_spent(tmp_path, checkout, fake_runs):
    path = _registry(tmp_path, {"fresh": _recovery_set(settings={"preset": "huge", "episode_duration_s": 20.0})})
    with pytest.raises(ValueError, match="huge"):
        heldout.spend("fresh", tmp_path / "out", path, checkout=checkout)
    assert heldout.load_registry(path)["fresh"]["status"] == "sealed" and not fake_runs


@pytest.mark.parametrize("over, field, words", [
    ({"status": "opened"}, "status", "allowed: sealed, spent, validation"),
    ({"kind": "case_studies"}, "kind", "allowed: recovery, missions"),
    ({"reality_gap": "some"}, "reality_gap", "allowed: none"),
    ({"colour": "blue"}, "colour", "unknown key"),
    ({"damages": ["none"]}, "damages", "not a damage"),
    ({"damages": ["sampled:01"]}, "damages", "not a damage"),
    ({"damages": ["caudal_half", "caudal_half"]}, "damages", "listed twice"),
    ({"seeds": [1, -1]}, "seeds", "not a seed"),
    ({"seeds": []}, "seeds", "non-empty"),
    ({"settings": {"preset": "quick"}}, "settings.episode_duration_s", "missing"),
    ({"settings": {"preset": "quick", "episode_duration_s": 0}}, "settings.episode_duration_s", "> 0"),
    ({"settings": {"preset": "quick", "episode_duration_s": 20, "onset_s": 3}}, "settings.onset_s", "unknown"),
    ({"missions": [["caudal_half", 1]]}, "missions", "only a missions set"),
    ({"status": "validation"}, "note", "missing"),
    ({"status": "spent", "commit": "a" * 40, "out": "o"}, "result", "missing"),
    ({"status": "spent", "commit": "a" * 40, "out": "o", "result": "done"}, "records", "missing"),
    ({"status": "spent", "commit": "abc", "out": "o", "result": "running"}, "commit", "40 lowercase hex"),
    ({"commit": "a" * 40}, "commit", "sealed set was never run"),
])
def test_a_malformed_set_is_refused_naming_the_set_and_the_field(tmp_path, over, field, words):
    path = _registry(tmp_path, {"bad_set": _recovery_set(**over)})
    with pytest.raises(ValueError, match=rf"{path}: set 'bad_set', field '{field}': .*{words}"):
        heldout.load_registry(path)


@pytest.mark.parametrize("missing", heldout.REQUIRED_KEYS)
def test_a_set_missing_a_required_field_is_refused(tmp_path, missing):
    entry = _recovery_set()
    del entry[missing]
    with pytest.raises(ValueError, match=f"set 'bad_set', field '{missing}': missing"):
        heldout.load_registry(_registry(tmp_path, {"bad_set": entry}))


def test_a_registry_that_is_missing_or_not_toml_is_refused(tmp_path):
    with pytest.raises(ValueError, match="no registry of held-out sets"):
        heldout.load_registry(tmp_path / "none.toml")
    (tmp_path / "bad.toml").write_text("[sets.x\n")
    with pytest.raises(ValueError, match="not valid TOML"):
        heldout.load_registry(tmp_path / "bad.toml")
    (tmp_path / "top.toml").write_text("rules = 'x'\n")
    with pytest.raises(ValueError, match="unknown top-level key 'rules'"):
        heldout.load_registry(tmp_path / "top.toml")


def _missions_set(**over):
    return {"kind": "missions", "description": "missions", "status": "sealed", "reality_gap": "none",
            "damages": ["caudal_half", "sampled:3"], "seeds": [1, 2],
            "settings": {"preset": "smoke", "onset_s": 3, "duration_s": 30}, **over}


def test_a_missions_set_is_the_cross_product_unless_it_lists_its_missions(tmp_path):
    assert heldout.missions_of(_missions_set()) == [("caudal_half", 1), ("caudal_half", 2), ("sampled:3", 1),
                                                     ("sampled:3", 2)]
    listed = _missions_set(missions=[["sampled:3", 2], ["caudal_half", 1]])
    assert heldout.missions_of(heldout.check_set("x", listed)) == [("sampled:3", 2), ("caudal_half", 1)]
    for missions, words in (([["caudal_half", 1]], "'sampled:3' is in the set's damages or seeds but in none"),
                            ([["caudal_half", 3], ["sampled:3", 2]], "not a mission"),
                            ([["caudal_half", 1], ["sampled:3", 2], ["caudal_half", 1]], "listed twice")):
        with pytest.raises(ValueError, match=rf"set 'x', field 'missions': .*{words}"):
            heldout.check_set("x", _missions_set(missions=missions))
    with pytest.raises(ValueError, match="field 'settings.onset_s': 30 must come before"):
        heldout.check_set("x", _missions_set(settings={"preset": "smoke", "onset_s": 30, "duration_s": 30}))


def test_a_missions_set_runs_each_mission_once_into_its_directory(tmp_path, monkeypatch):
    import aquafish.mission
    import aquafish.mission_table

    calls = []

    def run_mission(damage, out_dir, **kwargs):
        calls.append((damage, Path(out_dir).name, kwargs))
        Path(out_dir).mkdir(parents=True)
        (Path(out_dir) / aquafish.mission.MISSION_FILE).write_text("{}")

    monkeypatch.setattr(aquafish.mission, "run_mission", run_mission)
    priors = []
    monkeypatch.setattr(aquafish.mission, "prepare_prior", lambda d, preset, seed, **kw: priors.append((Path(d).name, seed)))
    monkeypatch.setattr(aquafish.mission_table, "read_missions", lambda dirs: [{} for _ in dirs])
    monkeypatch.setattr(aquafish.mission_table, "format_table", lambda summary: "table\n")
    monkeypatch.setattr(aquafish.mission_table, "summarise_missions", lambda reports: {"totals": {
        "missions": len(reports), "alarm_in_time": 2, "false_alarms": 0, "recovered": 1, "judged": 2,
        "beats_keep_old": 1, "final_80": 2}})
    entry = heldout.check_set("x", _missions_set(missions=[["sampled:3", 2], ["caudal_half", 1]]))
    (tmp_path / "sampled_3_s2").mkdir()
    (tmp_path / "sampled_3_s2" / aquafish.mission.MISSION_FILE).write_text("{}")  # finished: not run again
    result = heldout.run_missions_set(entry, tmp_path, workers=1, progress=False)
    assert [(d, name) for d, name, _ in calls] == [("caudal_half", "caudal_half_s1")]
    assert calls[0][2] == {"onset_s": 3.0, "duration_s": 30.0, "preset": "smoke", "seed": 1, "workers": 1,
                           "video": False, "progress": False, "self_model": tmp_path / "priors" / "seed1",
                           "oracle_dir": tmp_path / "oracles" / "caudal_half"}   # a prior per seed, an oracle per damage
    assert priors == [("seed1", 1)]
    assert result.startswith("2 missions run") and (tmp_path / "summary.md").read_text() == "table\n"
    with pytest.raises(ValueError, match="--processes must be 1"):
        heldout.check_runnable(entry, processes=2)


def test_the_recovery_result_line_reads_the_summary_totals():
    totals = {"cells": 48, "breaking": 20, "rows": {"self_model": {"recovers": 15, "of": 20, "rate": 0.75},
                                                    "robust": {"recovers": 9, "of": 20, "rate": 0.45}},
              "identified": {"right": 18, "of": 20, "rate": 0.9}}
    assert heldout.recovery_result(totals) == ("20 of 48 cells break the healthy gait; recovers in them: "
                                               "self_model 15/20, robust 9/20; the self-model's signs right in 18/20")


def test_the_command_lists_shows_and_spends(tmp_path, checkout, fake_runs, monkeypatch, capsys):
    path = _registry(tmp_path, {"fresh": _recovery_set(), "old": _recovery_set(status="validation", note="seen")})
    assert main(["heldout", "list", "--registry", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["name", "kind", "status", "cells", "commit"]
    assert lines[1].split() == ["fresh", "recovery", "sealed", "4", "-"]
    assert main(["heldout", "show", "old", "--registry", str(path)]) == 0
    shown = capsys.readouterr().out
    assert "[sets.old]" in shown and "# 4 cells" in shown
    monkeypatch.setattr(heldout, "method_checkout", lambda: checkout)
    assert main(["heldout", "run", "fresh", "--out", str(tmp_path / "out"), "--registry", str(path),
                 "--no-progress"]) == 0
    assert "spent at commit" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["heldout", "run", "fresh", "--out", str(tmp_path / "out"), "--registry", str(path)])
    assert exc.value.code == 2 and "never run again" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["heldout", "list", "--registry", str(tmp_path / "missing.toml")])
    assert "no registry of held-out sets" in capsys.readouterr().err


def test_the_run_action_has_the_long_running_commands_flags():
    import argparse

    from aquafish.cli import build_parser

    command = next(a for a in build_parser()._actions if a.dest == "command").choices["heldout"]
    actions = next(a for a in command._actions if isinstance(a, argparse._SubParsersAction)).choices
    assert list(actions) == ["list", "show", "run"]
    flags = actions["run"]._option_string_actions
    assert {"--out", "--registry", "--workers", "--processes", "--no-progress", "--debug"} <= set(flags)
    assert flags["--registry"].default == heldout.REGISTRY_PATH
    args = build_parser().parse_args(["heldout", "run", "x", "--out", "o", "--debug"])
    assert args.debug_command and (args.processes, args.workers, args.no_progress) == (1, None, False)
    assert build_parser().parse_args(["heldout", "--debug", "list"]).debug_command
