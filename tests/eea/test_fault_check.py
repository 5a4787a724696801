"""eea.fault_check: a morphology+servos run ends with its final model checked against fault hypotheses."""

import json

import numpy as np
import pytest

import eea
from aquafish_gym import Morphology
from aquafish_gym.rundir import FileError
from eea.fault_check import (FAULT_CHECK_FILE, FAULT_CHECK_PROCEDURE, FAULT_CHECK_PROCEDURE_GIVEN_SCREEN, FaultCheck,
                             read_fault_check)
from eea.fitness import objective_fitness
from eea.inference.selection import fault_hypotheses


@pytest.fixture(scope="module")
def servo_run(tmp_path_factory, session_tiny_config):
    """A tiny finished morphology+servos run on a reversed left servo."""
    config = session_tiny_config(model_space="morphology+servos", damage="reversed_left_pectoral",
                                 behaviour_summary="signed_dft", rounds=1)
    return eea.run(config, tmp_path_factory.mktemp("servo_run"), progress=False)


def test_a_finished_servo_run_keeps_the_best_of_its_final_model_and_the_hypotheses(servo_run):
    check = servo_run.fault_check
    assert check is not None and (servo_run.out_dir / FAULT_CHECK_FILE).is_file()
    n = len(check.models)  # the final model, the 97 hypotheses, and the polished models that moved (0-2)
    assert check.round == 1 and 98 <= n <= 100 and check.models.shape == (n, 12) and check.model_fitness.shape == (n,)
    assert check.procedure == FAULT_CHECK_PROCEDURE and check.polished == (check.index >= 98)
    np.testing.assert_array_equal(check.final_model, servo_run.best_model)
    np.testing.assert_array_equal(check.models[1:98], fault_hypotheses(Morphology.healthy().to_array()))
    assert check.index == int(np.argmax(check.model_fitness)) and check.simulations > 0
    np.testing.assert_array_equal(servo_run.self_model, check.models[check.index])
    # the self-model's OBJ_FIT is eq. 4 of the kept model; the round's column stays the search's
    truth = np.concatenate([Morphology.healthy().to_array(), [-1.0, 1.0, 1.0]])
    assert servo_run.self_model_objective_fitness == pytest.approx(
        objective_fitness(check.model, truth, servo_run.model_space.bounds))
    assert servo_run.rounds[-1]["objective_fitness"] == pytest.approx(
        objective_fitness(servo_run.best_model, truth, servo_run.model_space.bounds))


def test_the_record_round_trips_and_a_stale_one_is_ignored(servo_run, tmp_path):
    check = read_fault_check(servo_run.out_dir)
    again = FaultCheck.from_dict(json.loads(json.dumps(check.to_dict())))
    np.testing.assert_array_equal(again.models, check.models)
    assert (again.index, again.round, again.simulations) == (check.index, check.round, check.simulations)
    stale = eea.RunResult(tmp_path, servo_run.config, servo_run.rounds)
    (tmp_path / FAULT_CHECK_FILE).write_text(json.dumps({**check.to_dict(), "round": 7}))
    assert stale.fault_check is None  # a record of another round: the run was extended since
    record = check.to_dict()
    (tmp_path / FAULT_CHECK_FILE).write_text(json.dumps(record))
    assert stale.fault_check is not None  # the same record as the run's own: current
    older = {**record, "models": record["models"][:46], "model_fitness": record["model_fitness"][:46], "index": 0}
    (tmp_path / FAULT_CHECK_FILE).write_text(json.dumps(older))
    assert stale.fault_check is None  # a record against fewer hypotheses (before the caudal faults): checked again
    (tmp_path / FAULT_CHECK_FILE).write_text(json.dumps({k: v for k, v in record.items() if k != "procedure"}))
    assert read_fault_check(tmp_path).procedure == "" and stale.fault_check is None  # before the gain polish
    np.testing.assert_array_equal(stale.self_model, servo_run.best_model)


def test_a_paper_space_run_has_no_check(tmp_path, tiny_config):
    result = eea.run(tiny_config(rounds=1), tmp_path, progress=False)
    assert result.fault_check is None and not (tmp_path / FAULT_CHECK_FILE).exists()
    np.testing.assert_array_equal(result.self_model, result.best_model)


@pytest.mark.parametrize("content, match", [("{", "not valid JSON"), ('{"round": 1}', "not a fault-check record"),
                                            ('{"round": 1, "index": 3, "models": [[0]], "model_fitness": [1],'
                                             ' "simulations": 0, "wall_seconds": 0}', "do not agree")])
def test_a_corrupt_record_is_named(tmp_path, content, match):
    (tmp_path / FAULT_CHECK_FILE).write_text(content)
    with pytest.raises(FileError, match=match) as err:
        read_fault_check(tmp_path)
    assert FAULT_CHECK_FILE in str(err.value)


def test_a_run_extended_by_a_round_is_checked_again(servo_run, tmp_path):
    import shutil

    shutil.copytree(servo_run.out_dir, tmp_path / "run")
    longer = eea.run(servo_run.config.replace(rounds=2), tmp_path / "run", progress=False)
    assert longer.fault_check.round == 2
    np.testing.assert_array_equal(longer.fault_check.final_model, longer.best_model)


def test_saved_experiments_come_back_equal_and_redo_the_runs_check(servo_run, tmp_path):
    from eea.checkpoint import load_state
    from eea.evaluation import Evaluator
    from eea.experiment import Experiment
    from eea.fault_check import check_final_model

    experiments = tuple(Experiment.from_state_dict(s) for s in load_state(servo_run.out_dir).experiments)
    eea.save_experiments(tmp_path / "experiments.npz", experiments)
    loaded = eea.load_experiments(tmp_path / "experiments.npz")
    assert len(loaded) == len(experiments) >= 1
    for a, b in zip(loaded, experiments):
        assert a.index == b.index and a.context == b.context
        for name in ("action", "imu_log", "summary", "true_angles", "start_motion"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    # the file is all an offline check needs: the same models' MOD_FITs, the same kept model
    config = servo_run.config
    with Evaluator(config.steps, workers=1, params=config.sim_params, model_space=config.model_space,
                   summary=config.behaviour_summary) as evaluator:
        again = check_final_model(servo_run.fault_check.final_model, loaded, evaluator, 1)
    np.testing.assert_array_equal(again.model_fitness, servo_run.fault_check.model_fitness)
    assert again.index == servo_run.fault_check.index


def test_start_motions_are_saved_and_a_file_without_them_starts_at_rest(tmp_path):
    from aquafish_gym.simulator import AT_REST
    from eea.experiment import Context, Experiment

    tilt = np.array([np.sin(0.05), 0.0, 0.0, np.cos(0.05), 0.01, -0.02, 0.03])  # rolled by 0.1 rad, turning
    experiments = [Experiment(i, np.zeros(3), np.zeros((8, 3)), np.zeros((3, 5)), np.zeros(3),
                              Context.exact(np.zeros(3)), motion) for i, motion in enumerate((tilt, AT_REST))]
    eea.save_experiments(tmp_path / "x.npz", experiments)
    loaded = eea.load_experiments(tmp_path / "x.npz")
    np.testing.assert_array_equal(loaded[0].start_motion, tilt)
    assert loaded[1].at_rest and not loaded[0].at_rest
    with np.load(tmp_path / "x.npz") as data:  # as a file written before start motions were kept
        np.savez(tmp_path / "old.npz", **{k: data[k] for k in data.files if k != "start_motion"})
    assert all(x.at_rest for x in eea.load_experiments(tmp_path / "old.npz"))
    with pytest.raises(ValueError, match="unit quaternions"):
        Experiment(0, np.zeros(3), np.zeros((8, 3)), np.zeros((3, 5)), np.zeros(3), Context.exact(np.zeros(3)),
                   np.zeros(7))


def test_an_experiments_file_that_is_not_one_is_named(tmp_path):
    with pytest.raises(FileError, match="does not exist"):
        eea.load_experiments(tmp_path / "missing.npz")
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(FileError, match="is not an experiments file"):
        eea.load_experiments(tmp_path / "bad.npz")
    np.savez(tmp_path / "other.npz", action=np.zeros((2, 3)))
    with pytest.raises(FileError, match="is not an experiments file"):
        eea.load_experiments(tmp_path / "other.npz")
    with pytest.raises(ValueError, match="no experiments"):
        eea.save_experiments(tmp_path / "empty.npz", [])


def test_a_hypotheses_run_screens_with_the_angles_its_search_fitted(tmp_path, session_tiny_config):
    """A run whose estimation ranks the fault hypotheses (``estimation_search="hypotheses"``, the
    profile strategy) hands the check the angles it fitted to every candidate: the check scores
    them as its screen (the procedure says so), one simulation per candidate and experiment where
    the fitted screen spends many, and its screen's MOD_FITs are the strategy's own."""
    config = session_tiny_config(model_space="morphology+servos", damage="reversed_left_pectoral",
                                 behaviour_summary="signed_dft", rounds=1, inference="profile",
                                 estimation_search="hypotheses")
    result = eea.run(config, tmp_path / "given", progress=False)
    given = result.fault_check
    assert given is not None and given.procedure == FAULT_CHECK_PROCEDURE_GIVEN_SCREEN
    assert given.is_current(1)
    np.testing.assert_array_equal(given.models[1:98], fault_hypotheses(Morphology.healthy().to_array()))
    fitted = eea.run(config.replace(estimation_search="ga", estimation_population=5), tmp_path / "fitted",
                     progress=False).fault_check
    assert fitted.procedure == FAULT_CHECK_PROCEDURE
    # the same later stages on about as many experiments; the given screen saves the fit (98 x E >> 98)
    assert given.simulations < fitted.simulations
