"""``aquafish COMMAND --config FILE``: a flat TOML file of a command's flags, which the flags
given override (:mod:`aquafish.config_file`).

Nothing runs: the tests read the parsed namespace (or the ``EEAConfig`` and study spec a command
builds, with its runner replaced), the one-line errors, and the record a finished run writes.
"""

from __future__ import annotations

import argparse
import importlib
import json
from pathlib import Path

import pytest

from aquafish.cli import build_parser, main
from aquafish.config_file import RECORD_FILE, config_keys, parse_command_line
from eea.cli import config_fields, config_flag_names, config_from_args
from eea.config import EEAConfig

ROOT = Path(__file__).parents[2]
#: Commands that take a config file: every long-running one (they have --no-progress) but ``gait``,
#: whose ``--config`` is NEAT's INI file.
WITH_CONFIG = {"eea", "study", "case-study", "recovery", "mission", "damages", "baselines", "gait", "rl"}


def _parse(argv: list[str]) -> tuple[argparse.Namespace, object]:
    return parse_command_line(build_parser(), [str(a) for a in argv])


def _flags(argv: list[str]) -> dict:
    """What the same command line gives without a config file (the file's path aside)."""
    return {k: v for k, v in vars(build_parser().parse_args([str(a) for a in argv])).items() if k != "config_file"}


def _vars(args: argparse.Namespace) -> dict:
    return {k: v for k, v in vars(args).items() if k != "config_file"}


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _error(argv, capsys) -> str:
    """The one line ``aquafish ARGV`` fails with (exit status 2)."""
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    assert exc.value.code == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"aquafish {argv[0]}: error: "), lines
    return lines[0]


def _command(name: str) -> argparse.ArgumentParser:
    return next(a for a in build_parser()._actions if a.dest == "command").choices[name]


def test_the_long_running_commands_take_a_config_file():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    have = {name for name, parser in sub.choices.items()
            if any(a.dest == "config_file" for a in parser._actions)}
    assert have == WITH_CONFIG
    long_running = {name for name, parser in sub.choices.items() if "--no-progress" in parser._option_string_actions}
    assert have == long_running
    assert _command("gait")._option_string_actions["--neat-config"].dest == "neat_config"   # NEAT's INI file


def test_gait_takes_neat_ini_as_neat_config_and_refuses_it_as_a_run_config(tmp_path, capsys):
    ini = tmp_path / "neat.ini"
    ini.write_text("[NEAT]\npop_size = 4\n")
    args, _ = _parse(["gait", "--neat-config", ini, "--generations", "2"])
    assert (args.neat_config, args.generations, args.config_file) == (ini, 2, None)
    config = _write(tmp_path / "gait.toml", 'generations = 3\nseed = 2\nepisode_duration_s = 5\n')
    args, _ = _parse(["gait", "--config", config, "--seed", "4"])
    assert (args.generations, args.seed, args.episode_duration_s) == (3, 4, 5.0)   # the flag given wins
    line = _error(["gait", "--config", ini], capsys)   # the old meaning of gait --config
    assert "an INI file" in line and "--neat-config" in line


def test_a_json_flag_takes_its_json_as_a_string(tmp_path):
    config = _write(tmp_path / "cs.toml", 'self_model_fields = \'{"lineages": 1, "profile_refine": 0}\'\n')
    args, _ = _parse(["case-study", "--config", config])
    assert args.self_model_fields == {"lineages": 1, "profile_refine": 0}


def test_keys_are_the_canonical_long_flags():
    keys = config_keys(_command("case-study"))
    assert list(keys) == ["budget", "method", "model_space", "behaviour_summary", "episode_duration_s", "video",
                          "damage", "seed", "out", "self_model_fields", "workers", "no_progress"]   # no preset, config, debug
    assert "duration_s" in config_keys(_command("eea")) and "duration" not in config_keys(_command("eea"))
    assert "methods" in config_keys(_command("study"))                         # the flag's name, not its dest


def test_a_files_values_arrive_typed_like_flags(tmp_path):
    config = _write(tmp_path / "run.toml", 'budget = "smoke"\ndamage = "caudal_half"\nseed = 3\n'
                    '"episode-duration-s" = 5\nvideo = false\nno_progress = true\nworkers = 2\nout = "cs"\n')
    args, loaded = _parse(["case-study", "--config", config])
    assert _vars(args) == _flags(["case-study", "--budget", "smoke", "--damage", "caudal_half", "--seed", "3",
                                  "--episode-duration-s", "5", "--no-video", "--no-progress", "--workers", "2",
                                  "--out", "cs"])
    assert (args.seed, args.episode_duration_s, args.out, args.config_file) == (3, 5.0, Path("cs"), config)
    assert loaded.values["seed"] == 3 and loaded.given == ("--config", str(config))
    # lists go to comma-separated flags, a JSON fault's commas included; a text list works too
    config = _write(tmp_path / "rec.toml", 'damages = ["reversed_left_pectoral", \'{"gains": [1, -0.5, 1]}\', '
                                           '"sampled:3"]\nseeds = [0, 1]\nall_rows = true\nout = "rec"\n')
    args, _ = _parse(["recovery", "--config", config])
    assert args.damages == ("reversed_left_pectoral", '{"gains": [1, -0.5, 1]}', "sampled:3")
    assert (args.seeds, args.all_rows) == ((0, 1), True)
    config = _write(tmp_path / "study.toml", 'methods = "known,none"\ndurations = [1.28, 2.56]\nout = "s"\n')
    args, _ = _parse(["study", "--config", config])
    assert (args.conditions, args.durations) == (("known", "none"), (1.28, 2.56))


def test_a_flag_given_overrides_the_file_before_or_after_config(tmp_path):
    config = _write(tmp_path / "run.toml", 'seed = 3\nbudget = "smoke"\nout = "cs"\nno_progress = true\n')
    for argv in (["--config", config, "--seed", "7"], ["--seed", "7", "--config", config]):
        args, _ = _parse(["case-study", *argv])
        assert (args.seed, args.budget, args.out, args.no_progress) == (7, "smoke", Path("cs"), True)
    args, _ = _parse(["case-study", "--config", config, "--out", "other", "--budget", "paper"])
    assert (args.out, args.budget) == (Path("other"), "paper")


def test_without_config_the_command_line_parses_as_before():
    args, loaded = _parse(["case-study", "--seed", "2"])
    assert loaded is None and args.config_file is None and _vars(args) == _flags(["case-study", "--seed", "2"])


def test_eea_values_from_a_file_count_as_given(tmp_path, monkeypatch):
    """A file's value is a flag given: it overrides the budget and the method (``waterline =
    "deep"`` is deep water, None, as ``--waterline deep``), and a field it leaves out keeps theirs."""
    config = _write(tmp_path / "eea.toml", 'method = "profile_lineages"\nbudget = "reduced"\nwaterline = "deep"\n'
                                           'estimation_generations = 15\nout = "e"\n')
    args, _ = _parse(["eea", "--config", config, "--rounds", "3"])
    fields = config_fields(args, config_flag_names())
    assert fields == config_fields(build_parser().parse_args(
        ["eea", "--method", "profile_lineages", "--budget", "reduced", "--waterline", "deep",
         "--estimation-generations", "15", "--rounds", "3", "--out", "e"]), config_flag_names())
    assert config_from_args(args, config_flag_names()) == EEAConfig.from_method(
        "profile_lineages", "reduced", waterline=None, estimation_generations=15, rounds=3)
    # the command builds that config, and a study holds the file's fields fixed over its methods' fields
    configs, specs = [], []
    monkeypatch.setattr(importlib.import_module("eea.run"), "run", lambda c, out, progress: configs.append(c) or
                        type("R", (), {"rounds": [dict(objective_fitness=1, model_fitness=1, simulations=0)],
                                       "fault_check": None})())
    monkeypatch.setattr(importlib.import_module("aquafish.study"), "run_study",
                        lambda spec, out, **kw: specs.append(spec) or [])
    assert main(["eea", "--config", str(config), "--out", str(tmp_path / "e")]) == 0
    assert configs[0].waterline is None and configs[0].estimation.generations == 15
    study = _write(tmp_path / "study.toml", 'methods = ["profile_lineages"]\ndurations = [1.28]\nlineages = 1\n'
                                             'waterline = "deep"\n')
    assert main(["study", "--config", str(study), "--out", str(tmp_path / "s")]) == 0
    assert specs[0].fixed == ("lineages",) and specs[0].base["waterline"] is None  # fixed: the methods' fields given
    assert specs[0].runs(tmp_path)[0][0].estimation.lineages == 1   # over profile_lineages' 2


@pytest.mark.parametrize("text, names", [
    ("behavior_summary = \"dft\"\n", ["unknown key 'behavior_summary'", "did you mean behaviour_summary"]),
    ("zzz = 1\n", ["unknown key 'zzz' for aquafish case-study", "valid keys: budget, method,", "no_progress"]),
    ("preset = \"smoke\"\n", ["key 'preset' is another name of 'budget'; write budget"]),
    ("no_video = true\n", ["key 'no_video' is another name of 'video'; write video = true or false"]),
    ("seed = -1\n", ["key 'seed': argument --seed: must be an int >= 0 and <= 999999, got '-1'"]),
    ("seed = 1.5\n", ["key 'seed': argument --seed: must be an int >= 0 and <= 999999, got '1.5'"]),
    ("budget = \"fastest\"\n", ["key 'budget': argument --budget: invalid choice: 'fastest'"]),
    ("seed = true\n", ["key 'seed': --seed takes a value, not true or false"]),
    ("no_progress = \"yes\"\n", ["key 'no_progress': --no-progress is a switch: give true or false, got a string "
                                "'yes'"]),
    ("video = 1\n", ["key 'video': --video is on or off: give true or false"]),
    ("damage = [\"a\", \"b\"]\n", ["key 'damage': --damage takes one value, not a list"]),
    ("[case-study]\nseed = 1\n", ["key 'case-study' holds a table", "the file is flat"]),
    ("config = \"other.toml\"\n", ["key 'config' is not allowed", "give --config on the command line"]),
    ("seed = 1\n\"se-ed\" = 2\n", ["unknown key 'se-ed'", "did you mean seed"]),
    ("model_space = \"morphology\"\n\"model-space\" = \"morphology\"\n", ["key 'model-space' is given twice"]),
    ("seed = 1\nout = \n", ["not valid TOML", "line 2"]),
])
def test_a_bad_file_is_one_line_naming_the_file_and_key(text, names, tmp_path, capsys):
    config = _write(tmp_path / "bad.toml", text)
    line = _error(["case-study", "--config", config], capsys)
    assert f"config file {config}: " in line
    for name in names:
        assert name in line, (name, line)


def test_an_unknown_key_of_a_command_with_many_flags_points_to_its_help(tmp_path, capsys):
    line = _error(["eea", "--config", _write(tmp_path / "bad.toml", "zzz = 1\n")], capsys)
    assert "unknown key 'zzz' for aquafish eea; valid keys: the long flags of 'aquafish eea --help'" in line


def test_a_missing_file_an_empty_path_and_an_abbreviated_flag(tmp_path, capsys):
    assert "config file nowhere.toml: cannot read it: No such file or directory" in _error(
        ["case-study", "--config", "nowhere.toml"], capsys)
    assert "argument --config: is empty" in _error(["case-study", "--config", ""], capsys)
    config = _write(tmp_path / "run.toml", 'out = "e"\n')
    assert "write --config in full to give a config file, not --conf" in _error(["eea", "--conf", config], capsys)


def test_the_example_config_file_parses_for_its_command():
    args, loaded = _parse(["case-study", "--config", ROOT / "examples" / "quick_case_study.toml"])
    assert _vars(args) == _flags(["case-study", "--budget", "quick", "--damage", "reversed_left_pectoral",
                                  "--seed", "0", "--method", "profile_lineages", "--model-space", "morphology+servos",
                                  "--episode-duration-s", "20", "--video", "--out", "runs/case_study_quick"])
    assert set(loaded.values) <= set(config_keys(_command("case-study")))


def _fake_case_study(calls):
    """A ``run_case_study`` that claims its directory and writes a report, as a finished one does."""
    from aquafish_gym.rundir import run_lock

    def run(preset, damage, seed, out, **kw):
        calls.append((preset, damage, seed, kw))
        with run_lock(out, command="case-study"):
            (Path(out) / "report.md").write_text("# report\n")
        return {"wall_seconds": 1.0, "video": None}

    return run


def test_a_finished_run_records_its_config_file_and_effective_flags(tmp_path, monkeypatch):
    calls = []
    monkeypatch.setattr(importlib.import_module("aquafish.case_study"), "run_case_study", _fake_case_study(calls))
    out = tmp_path / "cs"
    config = _write(tmp_path / "run.toml", f'budget = "smoke"\nseed = 3\nvideo = false\nout = "{out}"\n')
    assert main(["case-study", "--config", str(config), "--seed", "4", "--workers", "1"]) == 0
    assert calls == [("smoke", "left_pectoral_half", 4, dict(method="profile_lineages",
                      model_space="morphology+servos", behaviour_summary="signed_dft", episode_duration_s=None,
                      video=False, workers=1, progress=True, self_model_fields=None))]
    record = json.loads((out / RECORD_FILE).read_text())
    assert record["command"] == "case-study" and record["config_file"] == str(config)
    assert record["config"] == {"budget": "smoke", "seed": 3, "video": False, "out": str(out)}
    assert record["argv"] == ["--config", str(config), "--seed", "4", "--workers", "1"]
    assert record["flags"] == {"budget": "smoke", "method": "profile_lineages", "model_space": "morphology+servos",
                               "behaviour_summary": "signed_dft", "episode_duration_s": None, "video": False,
                               "damage": "left_pectoral_half", "seed": 4, "out": str(out),
                               "self_model_fields": None, "workers": 1, "no_progress": False}


def test_no_record_without_config_after_a_failure_or_in_another_commands_directory(tmp_path, monkeypatch, capsys):
    from aquafish_gym.rundir import run_lock

    monkeypatch.setattr(importlib.import_module("aquafish.case_study"), "run_case_study", _fake_case_study([]))
    assert main(["case-study", "--out", str(tmp_path / "plain")]) == 0
    assert not (tmp_path / "plain" / RECORD_FILE).exists()

    def refused(*args, **kwargs):
        raise ValueError("refused")

    monkeypatch.setattr(importlib.import_module("aquafish.recovery"), "run_recovery", refused)
    config = _write(tmp_path / "rec.toml", f'out = "{tmp_path / "rec"}"\n')
    assert _error(["recovery", "--config", config], capsys) == "aquafish recovery: error: refused"
    assert not (tmp_path / "rec").exists()
    # a directory that another command made gets no record (the command refuses it anyway)
    with run_lock(tmp_path / "eea", command="eea"):
        pass
    monkeypatch.setattr(importlib.import_module("aquafish.case_study"), "run_case_study",
                        lambda *a, **k: (tmp_path / "eea" / "report.md").write_text("x") and {"wall_seconds": 0})
    assert main(["case-study", "--config", str(_write(tmp_path / "cs.toml", f'out = "{tmp_path / "eea"}"\n'))]) == 0
    assert not (tmp_path / "eea" / RECORD_FILE).exists()
