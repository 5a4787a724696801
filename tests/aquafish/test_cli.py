"""The ``aquafish`` parser: every sub-command registered, no optional dependency imported, study flags."""

import importlib.metadata
import subprocess
import sys
from pathlib import Path

import pytest

from aquafish.cli import build_parser, main

COMMANDS = ["swim", "envs", "bench", "eea", "gait", "transfer", "rl", "case-study", "study", "plot", "compare", "diagnose", "damages", "baselines", "recovery", "mission", "mission-table", "heldout", "tables", "doctor"]


def test_every_command_is_registered_in_help_order():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert list(sub.choices) == COMMANDS


def test_building_the_parser_imports_no_optional_dependency():
    code = ("import sys; from aquafish.cli import build_parser; build_parser(); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & {'stable_baselines3', 'torch', 'ray', 'pandas'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_version_is_the_installed_distributions(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.strip() == f"aquafish {importlib.metadata.version('aquafish')}"


def test_version_without_an_installed_distribution_is_unknown():
    code = ("import importlib.metadata as m\n"
            "def missing(name): raise m.PackageNotFoundError(name)\n"
            "m.version = missing\n"
            "import aquafish, aquafish_gym, eea, gait\n"
            "print({p.__version__ for p in (aquafish, aquafish_gym, eea, gait)})")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "{'0+unknown'}"


def test_bench_passes_the_rest_to_the_benchmark(capsys):
    args = build_parser().parse_args(["bench", "sim", "--steps", "2", "--sizes", "1"])
    assert (args.what, args.rest) == ("sim", ["--steps", "2", "--sizes", "1"])
    assert main(["bench", "sim", "--steps", "2", "--repeats", "1", "--sizes", "1"]) == 0
    table = capsys.readouterr().out.splitlines()
    assert table[1].split()[:2] == ["robots", "steps"] and table[2].split()[:2] == ["1", "2"]



@pytest.mark.parametrize("argv, message", [
    (["bench", "sim", "--bogus-flag"], "unrecognized arguments: --bogus-flag"),
    (["bench", "sim", "--steps", "many"], "argument --steps: invalid int value: 'many'"),
    (["bench", "eea_round", "--bogus-flag"], "unrecognized arguments: --bogus-flag"),
    (["bench", "gait_rollout", "--repeats"], "argument --repeats: expected one argument"),
])
def test_a_bad_benchmark_flag_is_one_usage_line(argv, message, capsys):
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    prog = f"aquafish bench {argv[1]}"
    assert err.splitlines() == [f"{prog}: error: {message} (see '{prog} --help')"] and out == ""


def test_a_benchmark_help_names_its_aquafish_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["bench", "sim", "--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    assert out.startswith("usage: aquafish bench sim [-h]") and "--steps" in out


def _flags(parser, command):
    sub = next(a for a in parser._actions if a.dest == "command").choices[command]
    return {a.dest: a for a in sub._actions if a.option_strings}


def test_study_has_every_eea_flag_but_the_per_run_ones():
    from eea.config import FLAT_FIELDS

    parser = build_parser()
    eea, study = _flags(parser, "eea"), _flags(parser, "study")
    fields = list(FLAT_FIELDS)
    per_run = {"inference", "duration_s", "seed", "workers"}
    assert per_run <= set(eea) and not per_run & set(study)
    for name in set(fields) - per_run:
        assert (study[name].option_strings, study[name].default, study[name].type, study[name].choices, study[name].help) \
            == (eea[name].option_strings, eea[name].default, eea[name].type, eea[name].choices, eea[name].help)


def test_study_command_line_of_the_readme(monkeypatch, tmp_path):
    import aquafish.study

    specs = []
    monkeypatch.setattr(aquafish.study, "run_study", lambda spec, out, **kw: specs.append((spec, out, kw)) or [])
    argv = ["study", "--methods", "known,none,in_band,out_of_band", "--durations", "1.28", "--replicates", "5",
            "--rounds", "10", "--estimation-generations", "30", "--exploration-generations", "10", "--oob-period", "10",
            "--estimation-search", "cma", "--cma-sigma", "0.2", "--first-seed", "10", "--out", str(tmp_path)]
    assert main(argv) == 0
    spec, out, kw = specs[0]
    assert (spec.conditions, spec.durations_s, spec.replicates, out) == (("known", "none", "in_band", "out_of_band"),
                                                                          (1.28,), 5, tmp_path)
    assert list(spec.seeds) == [10, 11, 12, 13, 14]
    from eea.config import FLAT_DEFAULTS

    assert spec.base == {**FLAT_DEFAULTS, "workers": 1, "rounds": 10, "estimation_generations": 30,
                         "exploration_generations": 10, "oob_period": 10, "estimation_search": "cma", "cma_sigma": 0.2}
    configs = {c.inference.name: c for c, _ in spec.runs(tmp_path)[:4]}
    assert configs["out_of_band"].inference.period == 10 and configs["known"].estimation.search.sigma == 0.2
    assert kw == {"backend": "local", "address": None, "processes": None, "progress": True}


def test_methods_and_budgets_on_the_command_line_and_flags_over_them(monkeypatch, tmp_path):
    import json

    import importlib

    import aquafish.study
    from eea.compat import upgrade_flat_fields
    from eea.config import EEAConfig

    specs = []
    monkeypatch.setattr(aquafish.study, "run_study", lambda spec, out, **kw: specs.append(spec) or [])
    argv = ["study", "--budget", "reduced", "--methods", "out_of_band,profile_lineages", "--durations", "1.28",
            "--damage", "caudal_half",
            "--profile-library", "4", "--out", str(tmp_path)]
    assert main(argv) == 0
    # the lineage studies of docs/self_modeling.md ran with the reduced budget and the best method (docs/results
    # keeps their study.json; they ran in deep water, before the surface swimmer became the default)
    published = json.loads((Path(__file__).parents[2] / "docs/results/lph_lin2/study.json").read_text())["base"]
    published.update(damage="caudal_half", profile_library=4, workers=1)        # the flags given beside the names
    (oob, _), (best, best_dir) = specs[0].runs(tmp_path)[:2]
    assert best == EEAConfig.from_flat({"inference": "profile", "seed": 0, "waterline": EEAConfig().waterline},
                                       optional=upgrade_flat_fields(published))
    assert best_dir == tmp_path / "profile_lineages" / "1.28s" / "seed0"
    assert (oob.inference.name, oob.estimation.search.name, oob.rounds) == ("out_of_band", "ga", 10)
    assert "profile_library" not in oob.to_flat()           # the out-of-band runs have no profile settings
    assert specs[0].fixed == ("profile_library",)           # only a method's field can be overridden
    main([*argv[:-1], str(tmp_path / "one"), "--lineages", "1"])   # a flag given wins, even at its default value
    assert specs[1].runs(tmp_path)[1][0] == best.replace(lineages=1)
    with pytest.raises(SystemExit):
        build_parser().parse_args(["study", "--out", str(tmp_path), "--methods", "out_of_band,profile_lineage"])
    # aquafish eea: the method's fields apply, a flag given wins over a method or budget
    configs = []
    monkeypatch.setattr(importlib.import_module("eea.run"), "run", lambda config, out, progress: configs.append(config) or
                        type("R", (), {"rounds": [dict(objective_fitness=1, model_fitness=1, simulations=0)],
                                       "fault_check": None})())
    assert main(["eea", "--method", "profile_lineages", "--budget", "reduced", "--rounds", "3", "--out",
                 str(tmp_path / "r")]) == 0
    assert configs[0] == EEAConfig.from_method("profile_lineages", "reduced", rounds=3)
    assert (configs[0].inference.name, configs[0].rounds, configs[0].estimation.generations) == ("profile", 3, 30)
    # a study's flag that none of its methods uses is an error; one that some use applies to those
    with pytest.raises(SystemExit):
        main(["study", "--methods", "known,none", "--durations", "1.28", "--oob-period", "5", "--out",
              str(tmp_path / "bad")])
    for bad in (["--budget", "fastest"], ["--method", "library"]):
        with pytest.raises(SystemExit):
            build_parser().parse_args(["eea", "--out", str(tmp_path), *bad])


@pytest.mark.parametrize("flag", ["--seed", "--inference", "--workers"])
def test_study_rejects_per_run_settings(flag, tmp_path):
    with pytest.raises(SystemExit):
        build_parser().parse_args(["study", "--out", str(tmp_path), flag, "1"])


def test_envs_lists_every_registered_task_once(capsys):
    from aquafish_gym import ENV_IDS

    assert main(["envs"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == list(ENV_IDS)
    heading = lines[list(ENV_IDS).index("AquaFishHeading-v0")].split()
    assert heading[1:5] == ["obs", "14", "act", "3"]
