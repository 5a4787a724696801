"""Readable logs: without a terminal, progress is one plain line per round, generation, run or
training chunk (no carriage returns); ``--no-progress`` on every long-running command silences it.

capsys's standard error is no terminal, so every test here sees what a log file would get.
"""

from __future__ import annotations

import json
import re

import pytest

from aquafish.cli import build_parser, main
from aquafish_gym.progress import LineProgress, progress_bar
from test_fail_safe import TINY_EEA, TINY_GAIT, TINY_PPO, TINY_STUDY

#: The tiny runs with their progress on (the TINY_* flags turn it off).
EEA = [f for f in TINY_EEA if f != "--no-progress"] + ["--inference", "known", "--workers", "1"]
GAIT = [f for f in TINY_GAIT if f != "--quiet"]

#: Every long-running command with the flags that make it parse.
COMMANDS = {
    "eea": ["--out", "x"],
    "gait": [],
    "rl": [],
    "case-study": [],
    "study": ["--out", "x"],
    "damages": ["--out", "x"],
    "baselines": ["--out", "x"],
}


def _lines(err: str) -> list[str]:
    assert "\r" not in err, repr(err[:300])
    return [line for line in err.splitlines() if line.strip()]


def test_line_progress_prints_one_line_per_update_and_nothing_else(capsys):
    bar = progress_bar(3, initial=1, desc="eea known seed 0", unit="round")
    assert isinstance(bar, LineProgress)
    bar.set_postfix_str("estimation 1/3 best 0.9")  # a phase inside a round: no line
    bar.set_postfix_str("obj 0.500")
    bar.update()
    bar.set_postfix(best="1.000", mean="0.250")
    bar.update()
    bar.close()
    lines = _lines(capsys.readouterr().err)
    assert len(lines) == 2
    assert lines[0].startswith("eea known seed 0: 2/3 round [") and lines[0].endswith(", obj 0.500]")
    assert lines[1].startswith("eea known seed 0: 3/3 round [") and lines[1].endswith(", best=1.000, mean=0.250]")


def test_eea_without_a_terminal_writes_one_line_per_round(tmp_path, capsys):
    assert main(["eea", *EEA, "--out", str(tmp_path / "run")]) == 0
    lines = _lines(capsys.readouterr().err)
    assert [line.split(" [")[0] for line in lines] == ["eea known seed 0: 1/2 round", "eea known seed 0: 2/2 round"]
    rows = (tmp_path / "run" / "rounds.csv").read_text().splitlines()
    assert all(re.search(r"obj \d\.\d{3}\]$", line) for line in lines) and len(rows) == 3


def test_gait_without_a_terminal_writes_one_line_per_generation(tmp_path, capsys):
    assert main(["gait", *GAIT, "--generations", "2", "--out", str(tmp_path / "gait")]) == 0
    lines = _lines(capsys.readouterr().err)
    assert [line.split(" [")[0] for line in lines] == ["NEAT gait on healthy: 1/2 gen", "NEAT gait on healthy: 2/2 gen"]
    assert all("best=" in line and "mean=" in line for line in lines)


def test_study_without_a_terminal_writes_one_line_per_run(tmp_path, capsys):
    argv = [*TINY_STUDY, "--replicates", "2"]
    assert main(["study", *argv, "--out", str(tmp_path / "study")]) == 0
    lines = _lines(capsys.readouterr().err)
    assert [line.split(" [")[0] for line in lines] == ["study runs: 1/2 run", "study runs: 2/2 run"]
    assert all(re.search(r"known \d\.\d{3}\]$", line) for line in lines)


@pytest.mark.rl
def test_ppo_counts_the_steps_it_trains_one_line_per_rollout(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    hp = tmp_path / "hp.json"
    hp.write_text(json.dumps(TINY_PPO))  # rollouts of 32 steps: 40 asked are 64 trained
    assert main(["rl", "--hyperparams", str(hp), "--episode-duration-s", "0.5", "--timesteps", "40",
                 "--out", str(tmp_path / "rl")]) == 0
    lines = _lines(capsys.readouterr().err)
    assert [line.split(" [")[0] for line in lines] == ["PPO on healthy: 32/64 step", "PPO on healthy: 64/64 step"]
    assert json.loads((tmp_path / "rl" / "model.json").read_text())["timesteps"] == 64


@pytest.mark.parametrize("command", COMMANDS)
def test_every_long_running_command_takes_no_progress(command):
    args = build_parser().parse_args([command, *COMMANDS[command], "--no-progress"])
    assert args.no_progress is True
    assert build_parser().parse_args([command, *COMMANDS[command]]).no_progress is False


def test_gait_quiet_is_still_no_progress():
    assert build_parser().parse_args(["gait", "--quiet"]).no_progress is True


@pytest.mark.parametrize("argv", [["eea", *EEA], ["gait", *GAIT], ["study", *TINY_STUDY]], ids=["eea", "gait", "study"])
def test_no_progress_writes_nothing_to_stderr(argv, tmp_path, capsys):
    assert main([*argv, "--no-progress", "--out", str(tmp_path / "out")]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.rl
def test_rl_no_progress_writes_nothing_to_stderr(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    hp = tmp_path / "hp.json"
    hp.write_text(json.dumps(TINY_PPO))
    assert main(["rl", "--hyperparams", str(hp), "--episode-duration-s", "0.5", "--timesteps", "32", "--no-progress",
                 "--out", str(tmp_path / "rl")]) == 0
    assert capsys.readouterr().err == ""


@pytest.mark.parametrize("command, target", [
    ("case-study", "aquafish.case_study.run_case_study"),
    ("damages", "aquafish.damage_table.damage_table"),
    ("baselines", "aquafish.task_table.task_table"),
])
def test_composite_commands_pass_no_progress_on(command, target, monkeypatch, tmp_path):
    """case-study, damages and baselines hand progress=False to the runs they make (each run's own
    progress is tested above)."""
    seen = {}

    class Stop(Exception):
        pass

    def record(*args, **kwargs):
        seen.update(kwargs)
        raise Stop

    monkeypatch.setattr(target, record)
    for flags, expected in (([], True), (["--no-progress"], False)):
        with pytest.raises(Stop):
            main([command, "--out", str(tmp_path / "out"), *flags])
        assert seen.pop("progress") is expected


def test_damage_table_passes_progress_to_every_gait(monkeypatch, tmp_path):
    import aquafish.damage_table as table

    seen = []

    def gait(robot, out_dir, **kwargs):
        seen.append(kwargs["progress"])
        raise StopIteration

    monkeypatch.setattr(table, "evolve_or_load_gait", gait)
    with pytest.raises(StopIteration):
        table.damage_table(tmp_path, damages=["reversed_left_pectoral"], progress=False)
    assert seen == [False]
