"""docs/studies/probes/: the study probes the docs quote run and compute what they say."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

PROBES = Path(__file__).resolve().parents[2] / "docs" / "studies" / "probes"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, PROBES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_local_maxima_are_periodic_and_sorted():
    landscape = _load("angle_landscape")
    x = np.linspace(-np.pi, np.pi, 12, endpoint=False)
    grid = np.cos(x)[:, None] + 0.5 * np.cos(2 * x)[None, :]   # peaks at (0, 0) and (0, pi = -pi, wrapped)
    assert landscape.local_maxima(grid) == [(6, 0), (6, 6)]    # x[6] = 0, x[0] = -pi; equal heights: row order
    grid[6, 6] += 0.1
    assert landscape.local_maxima(grid)[0] == (6, 6)


def test_angle_landscape_peaks_at_the_true_angles(tmp_path, tiny_config, capsys):
    from eea.run import run

    run(tiny_config(inference="none"), tmp_path, progress=False)
    _load("angle_landscape").main([str(tmp_path), "--experiment", "1", "--grid", "4"])
    out = capsys.readouterr().out
    assert "model: truth" in out
    peaks = out.splitlines()[-1]
    assert peaks.strip().startswith("(0, 0): 0.00000")          # the truth reproduces the target exactly there


def test_vestigial_flipper_splits_the_objective_error_by_flipper(tmp_path, tiny_config, capsys):
    from eea.fitness import objective_fitness
    from eea.run import run

    vestigial = _load("vestigial_flipper")
    truth = np.array([0.0, 0.0, 0.0, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375])   # left_pectoral_missing
    model = truth.copy()
    model[[0, 2]] = 0.5, 0.25                                   # span half its range, thickness half its range
    shares = vestigial.error_shares(model, truth)
    np.testing.assert_allclose(shares, [0.5 / 9, 0, 0.5 / 9, 0, 0, 0, 0, 0, 0])
    assert np.isclose(1 - shares.sum(), objective_fitness(model, truth))
    run(tiny_config(inference="none", damage="left_pectoral_missing"), tmp_path, progress=False)
    vestigial.main([str(tmp_path), "--actions", "2"])
    rows = capsys.readouterr().out.splitlines()
    obj, flipper, rest = map(float, rows[1].split()[1:4])
    assert np.isclose(obj, 1 - flipper - rest, atol=2e-3)       # the two parts are all of the error (3 decimals)
    assert rows[-1].startswith(f"mean error: {flipper:.3f} on the left_pectoral, {rest:.3f} on the rest")


def test_wrong_basins_flags_a_massless_flipper_only_where_the_target_has_volume(tmp_path, tiny_config, capsys):
    from aquafish_gym import MORPHOLOGY_FIELDS
    from eea.run import run

    basins = _load("wrong_basins")
    half = dict(zip(MORPHOLOGY_FIELDS, [0.25, 0.5, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375]))
    mimic = {**half, "left_pectoral_y": 1.8125, "left_pectoral_z": 0.0}
    assert basins.massless(mimic, half) == ["left_pectoral_z"]
    assert basins.massless({**mimic, "caudal_x": 0.0, "right_pectoral_y": 0.0}, half) == \
        ["left_pectoral_z", "right_pectoral_y", "caudal_x"]
    assert basins.massless(half, half) == []
    assert basins.massless(mimic, {**half, "left_pectoral_x": 0.0}) == []   # the target's flipper is massless too
    run(tiny_config(inference="none"), tmp_path, progress=False)
    basins.main([str(tmp_path)])
    lines = capsys.readouterr().out.splitlines()
    row, summary = lines[1].split(), lines[-1]
    from eea.record import load_result
    result = load_result(tmp_path)
    final = {f: float(result.rounds[-1][f"model_{f}"]) for f in MORPHOLOGY_FIELDS}
    trapped = bool(basins.massless(final, half))
    assert summary.startswith(f"{int(trapped)} of 1 runs end with a massless flipper")
    still = sum(float(r["action_caudal_hz"]) < 0.05 for r in result.rounds)
    assert row[-1] == f"{still}/{len(result.rounds)}" and float(row[1]) == round(float(result.rounds[-1]["objective_fitness"]), 3)


def test_lineage_choices_reports_each_lineage_and_the_chosen_one(tmp_path, tiny_config, capsys):
    from eea.analysis.lineage_report import lineage_objective_fitness
    from eea.run import run

    run(tiny_config(inference="profile", lineages=2), tmp_path / "lin", progress=False)
    run(tiny_config(inference="profile"), tmp_path / "plain", progress=False)   # skipped: one lineage
    _load("lineage_choices").main([str(tmp_path)])
    lines = capsys.readouterr().out.splitlines()
    objective, picks = lineage_objective_fitness(tmp_path / "lin")
    final, pick = objective[-1], picks[-1]
    assert len(lines) == 3 and lines[1].split()[1:4] == [f"{final[0]:.3f}", f"{final[1]:.3f}", str(pick)]
    assert lines[2].startswith(f"1 runs: chosen {final[pick]:.3f}")
    assert f"best lineage (oracle) {final.max():.3f}" in lines[2]
    with pytest.raises(SystemExit, match="no run with lineages >= 2"):
        _load("lineage_choices").main([str(tmp_path / "plain")])


def test_angle_sensitivity_is_zero_for_the_same_start_and_body_and_grows_with_the_model_error():
    probe = _load("angle_sensitivity")
    from aquafish_gym import SimParams, get_damage
    from eea.fitness import objective_fitness

    rng = np.random.default_rng(0)
    truth = get_damage("left_pectoral_half").apply().to_array()
    near = probe.near_models(truth, 0.1, 3, rng)
    assert all(objective_fitness(m, truth) >= 0.9 - 1e-12 for m in near)      # eq. 4: every dimension 10 % away
    far = probe.near_models(truth, 0.4, 3, rng)
    angles = np.array([[0.3, 2.0, 0.1], [4.0, 1.0, -0.2]])
    actions = np.array([[0.4, -0.3, 1.0], [-0.5, 0.5, 0.5]])
    model_other = np.tile(angles[:, None], (1, 3, 1))
    d = probe.dissimilarities(truth, truth, {"near": near, "random model": far}, actions, angles, angles.copy(),
                              model_other, 32, SimParams(waterline=None))
    assert np.all(d["other angles"] == 0) and np.all(d["design"] == 0)           # the same body from the same start
    np.testing.assert_array_equal(d["random model, other angles"], d["random model"])  # same starts: same responses
    assert np.all(d["random model"] > d["near"]) and np.all(d["near"] > 0)       # further bodies, further responses
    ramp = np.stack([np.arange(1, 5) * 0.5, np.zeros(4), -np.arange(1, 5) * 0.01], axis=-1)[None]   # (1, 4, 3) degrees
    np.testing.assert_allclose(probe.rates_log(ramp)[0], [[50.0, 0.0, -1.0]] * 4)  # degrees per 0.01 s step, from rest
    rates = probe.dissimilarities(truth, truth, {"near": near, "random model": far}, actions, angles, angles.copy(),
                                  model_other, 32, SimParams(waterline=None), rates=True, max_coefficient=1e6)
    assert np.all(rates["other angles"] == 0) and np.all(rates["random model"] > rates["near"])


def test_fault_check_and_identification_judge_a_servo_run(tmp_path, tiny_config, capsys):
    """fault_check on a tiny reversed-left-servo run: one JSON line; the chosen model is the run's final model or a
    hypothesis about the design, and its MOD_FIT is the best of the candidates listed."""
    import json

    from eea.run import run

    run(tiny_config(damage="reversed_left_pectoral", model_space="morphology+servos", behaviour_summary="signed_dft"),
        tmp_path, progress=False)
    _load("fault_check").main([str(tmp_path)])
    line = json.loads(capsys.readouterr().out.strip())
    assert line["damage"] == "reversed_left_pectoral" and line["true_gains"] == [-1.0, 1.0, 1.0]
    assert line["chosen_fit"] == max(fit for _, _, fit in line["top3"]) >= line["final_fit"]
    if line["chosen"] == "final":                       # ties go to the run's own model
        assert line["chosen_gains"] == line["final_gains"] and line["chosen_fit"] == line["final_fit"]
    else:
        assert line["chosen"] == "hypothesis" and line["chosen_fit"] > line["final_fit"]
    assert line["simulations"] > 0 and line["experiments"] == "checkpoint"
    # a published run keeps no checkpoint: its experiments are simulated again, the same check
    (tmp_path / "state.pkl").rename(tmp_path / "state.pkl.moved")
    _load("fault_check").main([str(tmp_path)])
    replayed = json.loads(capsys.readouterr().out.strip())
    assert replayed.pop("experiments") == "replayed" and replayed.pop("seconds") is not None
    assert replayed == {k: v for k, v in line.items() if k not in ("experiments", "seconds")}
    (tmp_path / "state.pkl.moved").rename(tmp_path / "state.pkl")
    # a bare screen (fit only) costs less and names the recorded check beside its own choice
    from eea.record import load_result

    _load("fault_check").main(["--bare-screen", str(tmp_path)])
    bare = json.loads(capsys.readouterr().out.strip())
    recorded = load_result(tmp_path).fault_check
    assert bare["screen"] == "bare" and bare["simulations"] < line["simulations"]
    assert bare["recorded_gains"] == recorded.model[9:].tolist() and bare["recorded_procedure"] == recorded.procedure
    assert bare["chosen_fit"] == max(fit for _, _, fit in bare["top3"])
    # identification (no simulation): the run's recorded self-model judged against its truth
    from eea.identification import servo_faults_named

    result = load_result(tmp_path)
    _load("identification").main([str(tmp_path)])
    line, counts = (json.loads(text) for text in capsys.readouterr().out.strip().splitlines())
    assert line["self_model_gains"] == result.self_model[9:].tolist() and line["checked"]
    assert line["self_model_named"] == servo_faults_named(result.self_model, result.true_model)
    assert line["self_model_named"] == (line["self_model_gains"][0] < 0)  # truth (-1, 1, 1): a negative left gain
    assert counts == {"runs": 1, "checked": 1,
                      **{name: {"judged": 1, "named": int(line[f"{name}_named"]),
                                "parts_named": int(line[f"{name}_parts_named"])} for name in ("final", "self_model")}}


def test_check_margin_keeps_a_row_that_is_not_a_hypothesis_only_beyond_the_margin():
    margin = _load("check_margin")
    # row 0 the search's model, rows 1-3 hypotheses, row 4 a polished row
    fitness = np.array([0.9960, 0.9950, 0.9940, 0.9900, 0.9958])
    assert margin.kept_with_margin(fitness, 3, 0.0, "all") == 0          # today's rule: the highest MOD_FIT
    assert margin.kept_with_margin(fitness, 3, 0.0009, "all") == 0       # 0.0010 ahead of row 1: beyond 0.0009
    assert margin.kept_with_margin(fitness, 3, 0.0009, "search") == 0
    assert margin.kept_with_margin(fitness, 3, 0.0012, "all") == 1       # neither row 0 nor 4 is 0.0012 ahead
    assert margin.kept_with_margin(fitness, 3, 0.0012, "search") == 4    # the polished row needs no margin
    with pytest.raises(ValueError, match="margin must be >= 0"):
        margin.kept_with_margin(fitness, 3, -0.001, "all")
    truth = np.r_[np.ones(9), -1.0, 1.0, 0.5]
    model = np.r_[np.ones(9), -1.0, 1.0, 0.5]
    model[2], model[10] = 1.25, 0.75
    assert margin.errors(model, truth) == (0.25, 0.25)
