"""The damage-recovery case study end to end, on the smoke preset (paper section 5)."""

import json

import pytest

import eea
import gait
from aquafish import case_study
from aquafish.case_study import CONTROLLER_KEYS, PRESETS, model_robot, render_report, run_case_study, verdict
from aquafish.cli import main
from aquafish_gym import MORPHOLOGY_FIELDS, get_damage
from eea.methods import BUDGETS


@pytest.mark.slow
def test_smoke_case_study_writes_report_and_figures(tmp_path):
    report = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["controllers"] == report["controllers"]
    target = get_damage("left_pectoral_half").apply().to_array()
    assert [saved["target_morphology"][f] for f in MORPHOLOGY_FIELDS] == pytest.approx(target.tolist())
    assert {k: (m["method"], m["inference"], m["model_space"]) for k, m in report["models"].items()} == {
        "plain_eea": ("none", "none", "morphology"), "self_model": ("profile_lineages", "profile", "morphology+servos"),
        "out_of_band": ("out_of_band", "out_of_band", "morphology")}
    for model in report["models"].values():
        assert 0.0 <= model["objective_fitness"] <= 1.0
        assert model["target_experiments"] == BUDGETS["smoke"]["rounds"]
    assert {"healthy", "plain_eea", "self_model", "true_damaged", "robust"} <= set(report["controllers"]) <= set(CONTROLLER_KEYS)
    for c in report["controllers"].values():
        assert c["target_distance"] == pytest.approx(sum(c["target_distances"]) / len(c["target_distances"]))
    assert report["verdict"] == verdict(report["controllers"]) and report["verdict"]["line"] in (tmp_path / "report.md").read_text()
    for name in report["figures"].values():
        assert (tmp_path / name).stat().st_size > 5000
    md = (tmp_path / "report.md").read_text()
    assert md == render_report(saved) and "| the healthy robot (`healthy`) |" in md
    # a finished case study is reused, not recomputed
    again = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False)
    assert again["controllers"] == report["controllers"]


def test_a_case_study_without_the_rl_extra_says_its_ppo_rows_are_left_out(tmp_path, monkeypatch, caplog):
    monkeypatch.setattr("aquafish.case_study._rl_available", lambda: False)
    report = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False, video=False)
    assert not {"ppo", "robust_ppo"} & set(report["controllers"])
    # the oracle is independent: seeds no other row's episodes meet, at least 3x the budget, best of 3 runs
    oracle, rows = report["controllers"]["true_damaged"], report["controllers"]
    starts = PRESETS["smoke"].gait_episodes
    oracle_episodes = {s + k for s in oracle["seeds"] for k in range(oracle["budget"]["starts"])}
    for key, row in rows.items():
        if key != "true_damaged":
            assert row["seeds"] == [0] and row["budget"]["starts"] == starts
            assert not oracle_episodes & {s + k for s in row["seeds"] for k in range(starts)}, key
            assert oracle["budget"]["episodes"] >= 3 * row["budget"]["episodes"], key
    assert oracle["budget"]["runs"] >= 3 and len(oracle["seeds"]) == oracle["budget"]["runs"]
    assert oracle["chosen"] == max(range(3), key=lambda i: (oracle["selection"]["distances"][i], -i))
    assert report["left_out"] and "aquafish[rl]" in report["left_out"][0]
    assert f"Left out: {report['left_out'][0]}." in (tmp_path / "report.md").read_text()
    assert "PPO rows are left out" in caplog.text
    # a self-model gait trained on another model (its EEA run or check made again since) is
    # moved aside and trained again on the model the run holds now; the other gaits are reused
    gait_dir = tmp_path / "gait_self_model"
    settings = json.loads((gait_dir / "fitness_settings.json").read_text())
    now = settings["robot"]
    settings["robot"] = {**now, "faults": {**now["faults"], "speed_scale": [-1.0, 1.0, 1.0]}}
    (gait_dir / "fitness_settings.json").write_text(json.dumps(settings))
    healthy_run = (tmp_path / "gait_plain_eea" / "run.json").read_text()
    caplog.clear()
    again = run_case_study("smoke", "left_pectoral_half", 0, tmp_path, workers=1, progress=False, video=False)
    replaced = tmp_path / ("gait_self_model" + case_study.REPLACED_SUFFIX)
    assert json.loads((replaced / "fitness_settings.json").read_text())["robot"]["faults"]["speed_scale"] == [-1, 1, 1]
    assert json.loads((gait_dir / "fitness_settings.json").read_text())["robot"] == now
    assert (tmp_path / "gait_plain_eea" / "run.json").read_text() == healthy_run
    assert "trained on another self-model" in caplog.text and again["controllers"] == report["controllers"]


def test_retire_if_other_robot_moves_only_a_run_of_another_robot(tmp_path):
    from gait.robots import Robot
    from aquafish_gym import Morphology, ServoFaults
    model = Robot(Morphology.healthy(), "none", "self_model", ServoFaults(speed_scale=(-1.0, 1.0, 1.0)))
    other = Robot(Morphology.healthy(), "none", "self_model")
    assert not case_study.retire_if_other_robot(tmp_path / "missing", model)
    for name, record in (("neat", "fitness_settings.json"), ("ppo", "model.json")):
        run_dir = tmp_path / name
        run_dir.mkdir()
        (run_dir / record).write_text(json.dumps({"robot": model.to_dict(), "seed": 0}))
        assert not case_study.retire_if_other_robot(run_dir, model) and run_dir.is_dir()
        assert case_study.retire_if_other_robot(run_dir, other) and not run_dir.exists()
        replaced = tmp_path / (name + case_study.REPLACED_SUFFIX)
        assert json.loads((replaced / record).read_text())["robot"] == model.to_dict()
        # a second replacement deletes the first one
        run_dir.mkdir()
        (run_dir / record).write_text(json.dumps({"robot": other.to_dict()}))
        assert case_study.retire_if_other_robot(run_dir, model)
        assert json.loads((replaced / record).read_text())["robot"] == other.to_dict()


def test_tiny_case_study_new_rows_servo_gains_and_video(tmp_path, capsys):
    """The whole command on the smoke preset with 2 s episodes: the self-model in morphology+servos,
    its gains on its gait's robot, the damage-robust rows (NEAT, and PPO with the ``[rl]`` extra),
    the verdict and the video."""
    out = tmp_path / "cs"
    assert main(["case-study", "--preset", "smoke", "--damage", "reversed_left_pectoral", "--episode-duration", "2",
                 "--workers", "1", "--out", str(out),
                 "--self-model-fields", '{"lineages": 1, "estimation_generations": 2}']) == 0
    report = json.loads((out / "report.json").read_text())
    assert report["episode_duration_s"] == 2.0 and report["model_space"] == "morphology+servos"
    # the self-model's own settings reached its run only, over the method's 2 lineages and smoke's 3 generations
    assert report["self_model_fields"] == {"lineages": 1, "estimation_generations": 2}
    configs = {key: json.loads((out / d / "config.json").read_text())["estimation"] for key, d in
               (("self_model", "eea_profile_lineages_servos_signed"), ("plain_eea", "eea_none"))}
    assert (configs["self_model"]["lineages"], configs["self_model"]["generations"]) == (1, 2)
    assert configs["plain_eea"]["generations"] == BUDGETS["smoke"]["estimation_generations"] == 3
    assert "`estimation_generations = 2`, `lineages = 1`" in (out / "report.md").read_text()
    assert {k: m["behaviour_summary"] for k, m in report["models"].items()} == {
        "plain_eea": "dft", "self_model": "signed_dft", "out_of_band": "dft"}
    assert (out / "eea_profile_lineages_servos_signed" / "rounds.csv").exists()
    saved = json.loads((out / "eea_profile_lineages_servos_signed" / "config.json").read_text())
    assert saved["estimation"]["search"]["flip_gains"] == 1 and saved["estimation"]["search"]["name"] == "cma"
    assert set(report["models"]) == {"plain_eea", "self_model", "out_of_band"}
    assert report["models"]["plain_eea"]["servo_gains"] is None
    gains = report["models"]["self_model"]["servo_gains"]
    assert set(gains) == set(case_study.GAIN_NAMES) and -1 <= gains["left_pectoral_gain"] <= 1
    assert report["target_servo_gains"] == {"left_pectoral_gain": -1.0, "right_pectoral_gain": 1.0, "caudal_gain": 1.0}
    # the self-model is what the run's check against fault hypotheses kept
    run = eea.load_result(out / "eea_profile_lineages_servos_signed")
    assert [gains[k] for k in case_study.GAIN_NAMES] == run.fault_check.model[9:].tolist()
    assert report["models"]["self_model"]["fault_check"]["replaced"] == (run.fault_check.index != 0)
    assert report["models"]["self_model"]["objective_fitness"] == run.self_model_objective_fitness
    assert report["models"]["plain_eea"]["fault_check"] is None
    assert report["models"]["self_model"]["search_simulations"] == run.rounds[-1]["simulations"] > 0
    # the model's gains reached the robot its gait was evolved on, and the 2 s runs have their own directories
    robot = json.loads((out / "gait_self_model_2s" / "run.json").read_text())["robot"]
    assert robot["faults"]["speed_scale"] == pytest.approx([gains[k] for k in case_study.GAIN_NAMES])
    assert json.loads((out / "gait_robust_2s" / "run.json").read_text())["robot"]["damage"] == "random"
    rows = {"healthy", "plain_eea", "self_model", "out_of_band", "true_damaged", "robust"}
    if case_study._rl_available():  # both PPO rows, for one gait's env steps (6 x 2 x 2 x 20)
        rows |= {"ppo", "robust_ppo"}
        assert report["settings"]["rl_timesteps"] == 480
        meta = {key: json.loads((out / f"rl_ppo_{key}_2s" / "model.json").read_text())
                for key in ("self_model", "random_damage")}
        assert meta["random_damage"]["robot"]["damage"] == "random" and meta["self_model"]["robot"]["damage"] == "none"
        assert {m["timesteps_requested"] for m in meta.values()} == {480}
        assert "(`robust_ppo`)" in (out / "report.md").read_text()
    assert set(report["controllers"]) == rows
    v = report["verdict"]
    assert v == verdict(report["controllers"]) and set(v["recovering"]) <= set(report["controllers"]) - {"healthy", "true_damaged"}
    assert v["robust_share"] == pytest.approx(report["controllers"]["robust"]["target_distance"]
                                              / report["controllers"]["true_damaged"]["target_distance"])
    md = (out / "report.md").read_text()
    assert v["line"] in md and "(`robust`)" in md and "Forward distance in 2 s" in md and "left pectoral gain" in md
    video = out / report["video"]
    assert video.suffix in (".mp4", ".gif") and video.stat().st_size > 1000 and report["video"] in md
    assert "recovery" in capsys.readouterr().out


def test_case_study_rejects_bad_duration_and_model_space(tmp_path):
    with pytest.raises(ValueError, match="episode_duration_s"):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, episode_duration_s=0)
    with pytest.raises(ValueError, match="model_space"):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, model_space="servos")
    assert not any(tmp_path.iterdir())


def test_self_model_fields_are_refused_by_name_before_anything_is_written(tmp_path, capsys):
    with pytest.raises(ValueError, match="may not set 'seed'.*--seed"):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, self_model_fields={"seed": 3})
    with pytest.raises(ValueError, match="self_model_fields: unknown EEAConfig keys .'lineagez'."):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, self_model_fields={"lineagez": 1})
    with pytest.raises(ValueError, match="self_model_fields: EEAConfig.lineages must be an int >= 1, got 0"):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, self_model_fields={"lineages": 0})
    with pytest.raises(ValueError, match="must map"):
        run_case_study("smoke", "left_pectoral_half", 0, tmp_path, self_model_fields=[("lineages", 1)])
    assert not any(tmp_path.iterdir())
    with pytest.raises(SystemExit):
        main(["case-study", "--self-model-fields", "[1]", "--out", str(tmp_path / "x")])
    assert "--self-model-fields: must be a JSON object" in capsys.readouterr().err


def test_the_quick_self_model_ranks_the_fault_hypotheses_under_the_callers_fields():
    from aquafish.case_study import HYPOTHESES_SELF_MODEL_FIELDS, LEAN_SELF_MODEL_FIELDS, own_self_model_fields
    from aquafish.recovery import check_spec
    from eea import EEAConfig
    from eea.search.hypotheses import HypothesisSettings

    quick, ranked, lean = PRESETS["quick"], dict(HYPOTHESES_SELF_MODEL_FIELDS), dict(LEAN_SELF_MODEL_FIELDS)
    assert own_self_model_fields(quick, None) == ranked
    assert own_self_model_fields(PRESETS["medium"], None) == ranked
    assert own_self_model_fields(quick, {"estimation_generations": 30}) == {**ranked, "estimation_generations": 30}
    assert own_self_model_fields(quick, None, method="out_of_band", model_space="morphology",
                                 behaviour_summary="dft") == {}  # the preset's are the default method's
    # no servo gains in the model space, no fault hypotheses about them: the lean search instead
    assert own_self_model_fields(quick, None, model_space="morphology") == lean
    assert own_self_model_fields(PRESETS["smoke"], None) == {}
    with pytest.raises(ValueError, match="may not set 'seed'"):
        own_self_model_fields(quick, {"seed": 3})
    # one lineage, 3 generations of the ranked hypotheses, 2 angle sets per action, the best-ranked
    # hypotheses as the exploration's candidates, no profile refinement or library, no gain flips
    fields = case_study.model_fields(own=own_self_model_fields(quick, None))
    assert "cma_flip_gains" not in fields
    config = EEAConfig.from_method(case_study.DEFAULT_METHOD, "quick", **fields)
    assert isinstance(config.estimation.search, HypothesisSettings)
    assert (config.estimation.lineages, config.estimation.generations, config.exploration.angles,
            config.exploration.diversity, config.inference.refine, config.inference.library) == (1, 3, 2, 0, 0, 0)
    # a recovery benchmark's cells record them, and its spec holds them
    assert check_spec("quick", ["sampled:3"], [0]).self_model_fields == ranked


def test_model_fields_flip_gains_only_for_a_cma_search_and_take_the_runs_own_fields_over_them():
    from eea import EEAConfig
    from eea.search.hypotheses import HypothesisSettings

    assert case_study.model_fields() == {"model_space": "morphology+servos", "behaviour_summary": "signed_dft",
                                         "cma_flip_gains": 1}
    assert "cma_flip_gains" not in case_study.model_fields("profile_lineages", "morphology", "dft")
    assert case_study.model_fields(own={"cma_flip_gains": 0})["cma_flip_gains"] == 0
    # another search named by the run's own fields: no CMA-ES restarts to flip, and the config builds
    ranked = case_study.model_fields(own={"estimation_search": "hypotheses", "exploration_diversity": 0})
    assert "cma_flip_gains" not in ranked and ranked["estimation_search"] == "hypotheses"
    config = EEAConfig.from_method(case_study.DEFAULT_METHOD, "quick", **ranked)
    assert isinstance(config.estimation.search, HypothesisSettings)
    assert case_study.check_self_model_fields({"estimation_search": "hypotheses"}, "quick") == \
        {"estimation_search": "hypotheses"}


def test_every_preset_pickles():
    # the PPO rows train in processes of their own, which are sent the preset
    import pickle

    for name, preset in PRESETS.items():
        assert pickle.loads(pickle.dumps(preset)) == preset, name


def test_unknown_preset_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["case-study", "--preset", "huge", "--out", str(tmp_path)])
    assert "invalid choice" in capsys.readouterr().err
    with pytest.raises(ValueError, match="valid"):
        run_case_study("huge", "left_pectoral_half", 0, tmp_path)


def _controllers(**target):
    return {key: {"target_distance": value} for key, value in target.items()}


def test_verdict_hand_computed():
    recovered = verdict(_controllers(healthy=1.0, plain_eea=2.0, self_model=3.5, true_damaged=4.0))
    assert recovered["breaks"] and recovered["recovers"] and recovered["plain_eea_below"]
    assert recovered["self_model_share"] == pytest.approx(0.875) and recovered["healthy_share"] == 0.25
    assert "breaks the healthy gait (it keeps 25% of the oracle gait's 4.00 units" in recovered["line"]
    assert "recovers: 88% of the oracle, 3.5x the healthy gait" in recovered["line"]
    # not broken: the healthy gait keeps 60%; the self-model gait has 88% of the oracle but 3.5 < 1.5 x 2.4
    kept = verdict(_controllers(healthy=2.4, plain_eea=3.9, self_model=3.5, true_damaged=4.0))
    assert not kept["breaks"] and not kept["recovers"] and not kept["plain_eea_below"]
    nothing = verdict(_controllers(healthy=0.1, plain_eea=0.0, self_model=0.0, true_damaged=-0.2))
    assert not nothing["breaks"] and nothing["self_model_share"] is None and "nothing to recover" in nothing["line"]


def test_verdict_names_the_rows_that_recover():
    v = verdict(_controllers(healthy=1.0, plain_eea=2.0, self_model=3.5, true_damaged=4.0, robust=3.3, out_of_band=1.2))
    assert v["recovering"] == ["self_model", "robust"] and v["robust_recovers"] and v["robust_share"] == pytest.approx(0.825)
    assert "The damage-robust gait reaches 82% of the oracle, 3.3x the healthy gait." in v["line"]
    assert "Rows that recover (at least 80% of the oracle and 1.5x the healthy gait): `self_model`, `robust`." in v["line"]
    none = verdict(_controllers(healthy=1.0, plain_eea=2.0, self_model=2.5, true_damaged=4.0))
    assert none["recovering"] == [] and none["robust_recovers"] is None and none["robust_share"] is None
    assert none["line"].endswith("the healthy gait): none.") and "damage-robust" not in none["line"]


def test_verdict_reports_the_robust_ppo_row():
    v = verdict(_controllers(healthy=-1.0, plain_eea=2.0, self_model=3.5, true_damaged=4.0, robust=-0.5, robust_ppo=1.0))
    assert v["robust_ppo_share"] == pytest.approx(0.25) and v["robust_ppo_recovers"] is False
    assert v["robust_share"] == pytest.approx(-0.125) and v["robust_recovers"] is False
    assert "The damage-robust PPO policy reaches 25% of the oracle" in v["line"] and v["recovering"] == ["self_model"]


def test_rl_budget_is_one_gaits_env_steps():
    """quick: 30 genomes x 12 generations x 2 starts x 200 control steps (20 s at 0.1 s) = 144,000."""
    assert PRESETS["quick"].rl_timesteps == 144_000
    assert PRESETS["medium"].rl_timesteps == 50 * 20 * 3 * 200
    import dataclasses
    assert dataclasses.replace(PRESETS["quick"], episode_duration_s=2.0).rl_timesteps == 30 * 12 * 2 * 20


def test_damage_recovery_example_runs_the_case_study_through_the_api(tmp_path, capsys):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / "damage_recovery.py"
    assert len(path.read_text().splitlines()) <= 60  # a short script, the independent oracle included
    spec = importlib.util.spec_from_file_location("damage_recovery", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    module.main(["--preset", "smoke", "--episode-duration", "1", "--workers", "1", "--out", str(tmp_path)])
    out = capsys.readouterr().out
    assert all(f"{key}:" in out for key in ("healthy", "robust", "plain_eea", "self_model", "true_damaged"))
    assert "Rows that recover" in out or "nothing to recover" in out
    robot = json.loads((tmp_path / "gait_self_model_1s" / "run.json").read_text())["robot"]
    assert robot["faults"]
    # the gait's robot is the self-model the check kept, as in the case study (not the search's final model)
    assert gait.Robot.from_dict(robot) == model_robot(eea.load_result(tmp_path / "eea_self_model"), robot["label"])
    assert any(p.stat().st_size > 1000 for p in tmp_path.glob("recovery.*"))


def test_the_gaits_evolved_at_once_are_those_evolved_one_after_the_other(tmp_path):
    def triage(workers):   # the healthy and oracle gaits only, no EEA run
        return run_case_study("smoke", "reversed_left_pectoral", 0, tmp_path / str(workers), workers=workers,
                              progress=False, video=False, all_rows=False, triage_only=True)

    alone, together = triage(1), triage(2)          # 2: both at once on one shared pool of 2
    assert set(together["controllers"]) == {"healthy", "true_damaged"}
    assert together["controllers"] == alone["controllers"]        # every distance, to the last digit
    assert set(together["stage_seconds"]) == {"gaits", "transfer"}


@pytest.mark.slow
def test_the_ppo_rows_trained_at_once_are_those_trained_one_after_the_other(tmp_path):
    import dataclasses

    pytest.importorskip("stable_baselines3")
    from gait import as_robot

    tiny = dataclasses.replace(PRESETS["smoke"], gait_population=2, gait_generations=1, episode_duration_s=2.0)
    distances = {}
    for processes in (1, 2):                      # 2: each row in its own process
        jobs = {"ppo": (as_robot("reversed_left_pectoral"), tmp_path / str(processes) / "ppo"),
                "robust_ppo": (as_robot("healthy", damage="random"), tmp_path / str(processes) / "robust_ppo")}
        paths = case_study._train_ppo_rows(jobs, tiny, 0, False, processes)
        assert set(paths) == set(jobs)
        distances[processes] = [json.loads((run_dir / "model.json").read_text())["eval_distance"]
                                for _, run_dir in jobs.values()]
    assert distances[1] == distances[2]           # the same policies: the same seeds, one torch thread each
