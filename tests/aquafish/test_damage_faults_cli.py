"""Faults as data on the command line: every ``--damage`` / ``--damages`` takes a preset name,
a JSON fault (inline or FILE.json) or sampled:SEED; a bad fault fails in one line and creates
nothing; ``aquafish damages --list``; an EEA run records the fault itself and resumes."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from aquafish.cli import main
from aquafish_gym import DAMAGES
from aquafish_gym.faults import sampled_fault
from test_fail_safe import TINY_EEA, TINY_GAIT, TINY_STUDY, fails_safe

BAD_GAINS = '{"gains":[2,1,1]}'


@pytest.mark.parametrize("command", ["eea", "study", "case-study", "gait", "swim", "damages"])
@pytest.mark.parametrize("fault, names", [
    (BAD_GAINS, ["damage fault: gains[0] must be in [-1, 1], got 2"]),
    ('{"gain":[1,1,1]}', ["unknown key 'gain'; allowed: scale, seized, gains"]),
    ('{"scale":{"tail_y":0.5}}', ["scale: unknown morphology field 'tail_y'; fields: left_pectoral_x"]),
    ("sampled:-3", ["sampled:SEED needs an int SEED >= 0"]),
    ("nowhere.json", ["cannot read nowhere.json"]),
])
def test_a_bad_fault_fails_in_one_line_and_creates_nothing(command, fault, names, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "X"
    argv = {
        "eea": ["eea", "--damage", fault, *TINY_EEA, "--workers", "1", "--out", out],
        "study": ["study", *TINY_STUDY, "--damage", fault, "--out", out],
        "case-study": ["case-study", "--preset", "smoke", "--damage", fault, "--no-progress", "--out", out],
        "gait": ["gait", *TINY_GAIT, "--damage", fault, "--out", out],
        "swim": ["swim", "--duration", "0.1", "--damages", f"none,{fault}", "--out", out],
        "damages": ["damages", "--damages", fault, "--out", out],
    }[command]
    fails_safe(argv, capsys, *names)
    assert list(tmp_path.iterdir()) == []


def test_damages_list_prints_presets_and_sampled_faults_and_writes_nothing(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["damages", "--list"]) == 0
    out = capsys.readouterr().out
    for name, damage in DAMAGES.items():
        assert any(line.split()[:1] == [name] and damage.description in line for line in out.splitlines()), name
    sampled = [line.split(None, 2) for line in out.splitlines() if line.strip().startswith("sampled:")]
    assert [s[0] for s in sampled] == [f"sampled:{seed}" for seed in range(10)]
    for seed, (_, text, description) in enumerate(sampled):
        assert text == sampled_fault(seed).to_json() and description == sampled_fault(seed).describe()
        assert description[0].isupper() and description.endswith(".") and ". " not in description  # one sentence
    assert list(tmp_path.iterdir()) == []


def test_damages_without_out_or_list_fails_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    fails_safe(["damages"], capsys, "--out is required", "--list")
    assert list(tmp_path.iterdir()) == []


def _rounds(run: Path) -> int:
    with open(run / "rounds.csv", newline="") as f:
        return len(list(csv.DictReader(f)))


def test_an_eea_run_records_the_fault_itself_and_resumes(tmp_path, capsys):
    fault = tmp_path / "fault.json"
    fault.write_text(json.dumps({"seized": [False, False, False], "gains": [1, -0.5, 1],
                                 "scale": {"left_pectoral_y": 0.5}}, indent=2))
    canonical = '{"gains":[1.0,-0.5,1.0],"scale":{"left_pectoral_y":0.5}}'
    run = tmp_path / "run"
    flags = [*TINY_EEA, "--inference", "known", "--workers", "1", "--out", str(run)]
    assert main(["eea", "--damage", str(fault), *flags]) == 0
    assert json.loads((run / "config.json").read_text())["damage"] == canonical
    assert _rounds(run) == 2
    fault.unlink()                                   # the run no longer needs the file
    respelt = '{"scale": {"left_pectoral_y": 0.50}, "gains": [1, -0.5, 1.0]}'
    assert main(["eea", "--damage", respelt, *flags, "--rounds", "3"]) == 0   # resumes: the same fault
    assert _rounds(run) == 3
    assert json.loads((run / "config.json").read_text())["damage"] == canonical
    fails_safe(["eea", "--damage", "sampled:1", *flags, "--rounds", "3"], capsys, "damage")   # another fault


def test_the_damage_table_takes_faults(tmp_path):
    from aquafish.damage_table import GaitBudget, check_damages, damage_table, gait_dir_name

    fault = tmp_path / "fault.json"
    fault.write_text('{"gains": [1, 1, 0.5]}')
    assert check_damages(["caudal_half", str(fault), "sampled:8", '{"gains":[-1,1,1]}']) == \
        ["caudal_half", '{"gains":[1.0,1.0,0.5]}', "sampled:8", '{"gains":[-1.0,1.0,1.0]}']
    assert [gait_dir_name(d) for d in ("caudal_half", "sampled:8")] == ["caudal_half", "sampled_8"]
    assert gait_dir_name('{"gains":[1.0,1.0,0.5]}').startswith("fault_") and "/" not in gait_dir_name("{}")
    for nothing in ("none", '{"gains": [1, 1, 1]}', "broken_fin"):
        with pytest.raises(ValueError, match="unknown damage"):
            check_damages([nothing])
    tiny = GaitBudget(generations=1, population_size=2, episodes_per_genome=1, seed=0, workers=1)
    (row,) = damage_table(tmp_path / "table", damages=["sampled:8"], budget=tiny, starts=1, eval_seed=100)
    assert row["damage"] == "sampled:8" and row["description"] == "Caudal servo dead (gain 0)."
    assert (tmp_path / "table" / "gaits" / "sampled_8" / "best_controller.json").is_file()
