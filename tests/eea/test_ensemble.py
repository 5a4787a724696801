"""eea.analysis.ensemble: one self-model chosen from several runs by an equal, hard angle fit."""

import numpy as np
import pytest

from aquafish.cli import main
from aquafish_gym import get_damage
from eea.encoding import decode_models, encode_models
from eea.analysis.ensemble import SELECTION_COLUMNS, ensemble_groups, select_model, select_runs, select_study
from eea.evaluation import Evaluator
from eea.fitness import model_fitness_from_similarities
from eea.analysis.plot import find_runs
from eea.run import run


@pytest.fixture
def experiments(lph_experiments):
    return lph_experiments


def test_the_truth_wins_over_the_healthy_robot_and_a_repeated_model_scores_the_same(experiments):
    # the candidates as a run would hold them: decoded from genomes (the truth is on the grid)
    truth = decode_models(encode_models(get_damage("left_pectoral_half").apply().to_array()[None]))[0]
    healthy = decode_models(encode_models(get_damage("none").apply().to_array()[None]))[0]
    models = np.stack([healthy, truth, healthy])
    evaluator = Evaluator(64)
    selection = select_model(models, experiments, evaluator, np.random.default_rng(0), generations=3, scan_cycles=1)
    assert selection.index == 1 and np.array_equal(selection.model, truth)
    assert selection.model_fitness[0] == selection.model_fitness[2] < selection.model_fitness[1]
    assert selection.angles.shape == (3, 2, 3)
    # MOD_FIT is eq. 3 (the mean of eq. 2 over the experiments) at the returned angles
    again = evaluator.similarities(encode_models(models), experiments, selection.angles)
    np.testing.assert_allclose(selection.model_fitness, model_fitness_from_similarities(again))
    # the truth scores near 1 under its fitted angles (exactly 1 at its true ones), the healthy robot below
    assert selection.model_fitness[1] > 0.99 > selection.model_fitness[0]
    # the angle errors are the median over experiments of each model's fitted angles' distance
    errors = selection.angle_errors_deg(experiments)
    true = np.stack([e.true_angles for e in experiments])
    by_hand = [np.median([np.degrees(np.abs((selection.angles[i, j, f] - true[j, f] + np.pi) % (2 * np.pi) - np.pi))
                          for j in range(2)]) for i in range(3) for f in range(2)]
    np.testing.assert_allclose(errors[:, :2].ravel(), by_hand, atol=1e-9)
    caudal = np.degrees(np.abs(selection.angles[:, :, 2] - true[:, 2]))
    np.testing.assert_allclose(errors[:, 2], np.median(caudal, axis=1))
    with pytest.raises(ValueError, match="fitted on 2 experiments, got 1"):
        selection.angle_errors_deg(experiments[:1])


def test_select_model_rejects_bad_input(experiments):
    evaluator, rng = Evaluator(64), np.random.default_rng(0)
    good = get_damage("none").apply().to_array()[None]
    with pytest.raises(ValueError, match=r"models must be \(N >= 1, 9\)"):
        select_model(np.zeros((2, 8)), experiments, evaluator, rng)
    with pytest.raises(ValueError, match=r"models must be \(N >= 1, 9\)"):
        select_model(np.zeros((0, 9)), experiments, evaluator, rng)
    with pytest.raises(ValueError, match="at least one experiment"):
        select_model(good, [], evaluator, rng)
    with pytest.raises(ValueError, match="generations must be >= 1, got 0"):
        select_model(good, experiments, evaluator, rng, generations=0)
    with pytest.raises(ValueError, match="scan_cycles must be >= 0, got -1"):
        select_model(good, experiments, evaluator, rng, scan_cycles=-1)


def test_ensembles_are_consecutive_seeds_and_the_rest_is_left_out():
    assert ensemble_groups([9, 0, 1, 2, 3, 4, 5, 6, 7, 8], 3) == ([(0, 1, 2), (3, 4, 5), (6, 7, 8)], [9])
    assert ensemble_groups([10, 11], 2) == ([(10, 11)], [])
    with pytest.raises(ValueError, match="at least 2 runs, got size 1"):
        ensemble_groups([0, 1], 1)
    with pytest.raises(ValueError, match="seeds repeat"):
        ensemble_groups([0, 0, 1], 2)
    with pytest.raises(ValueError, match="2 seeds cannot make an ensemble of 3"):
        ensemble_groups([0, 1], 3)


def test_select_study_chooses_the_highest_mod_fit_and_resumes_from_its_file(tmp_path, tiny_config, capsys):
    for seed in (0, 1):
        run(tiny_config(inference="profile", seed=seed), tmp_path / f"seed{seed}", progress=False)
    runs = find_runs([tmp_path])
    out = tmp_path / "select.csv"
    shown = []
    rows = select_study(runs, 2, out, generations=1, scan_cycles=0, progress=shown.append)
    assert [r["seed"] for r in rows] == [0, 1] and len(shown) == 1
    assert sum(r["chosen"] for r in rows) == 1
    chosen = next(r for r in rows if r["chosen"])
    assert chosen["model_fitness"] == max(r["model_fitness"] for r in rows)
    by_seed = {x.config.seed: x for x in runs}
    for r in rows:  # OBJ_FIT is each run's own final one (eq. 4), not recomputed
        assert r["objective_fitness"] == by_seed[r["seed"]].rounds[-1]["objective_fitness"]
    assert out.read_text().splitlines()[0] == ",".join(SELECTION_COLUMNS)
    assert all(0.0 <= r["error_caudal_deg"] <= 60.0 and 0.0 <= r["error_left_deg"] <= 180.0 for r in rows)
    # a second call finds the ensemble in the file and selects nothing again
    assert select_study(runs, 2, out, generations=1, scan_cycles=0, progress=shown.append) == rows and len(shown) == 1
    # the command line prints each ensemble and the summary from the same file (made with the same settings)
    assert main(["select", str(tmp_path), "--out", str(out), "--generations", "1", "--scan-cycles", "0"]) == 0
    summary = capsys.readouterr().out.splitlines()[-2]
    assert summary.startswith(f"1 ensembles of 2: chosen OBJ_FIT {chosen['objective_fitness']:.3f} ± 0.000;")
    # at round 1: each run's round-1 model and its one experiment
    early = select_study(runs, 2, rounds=1, generations=1, scan_cycles=0)
    for r in early:
        assert r["objective_fitness"] == by_seed[r["seed"]].rounds[0]["objective_fitness"]
    # other settings are refused, naming the fields, and the file is left as it was
    before = out.read_text()
    with pytest.raises(ValueError, match="generations: 1 -> 30; scan_cycles: 0 -> 2"):
        select_study(runs, 2, out)
    assert out.read_text() == before
    # the file of another study's seeds is refused, not overwritten
    out.write_text(out.read_text().replace("\n0,1,", "\n0,7,"))
    with pytest.raises(ValueError, match="seed 7 is not among the runs given"):
        select_study(runs, 2, out, generations=1, scan_cycles=0)


def test_select_runs_needs_two_runs_of_one_target(tmp_path, tiny_config):
    run(tiny_config(inference="profile"), tmp_path / "a", progress=False)
    run(tiny_config(inference="profile", damage="caudal_half"), tmp_path / "b", progress=False)
    with pytest.raises(ValueError, match="at least two runs, got 1"):
        select_runs([tmp_path / "a"])
    with pytest.raises(ValueError, match="the runs differ in damage"):
        select_runs([tmp_path / "a", tmp_path / "b"])
