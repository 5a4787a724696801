"""eea.analysis.diagnosis: MOD_FIT of the final and the true morphology under inferred and true angles."""

from pathlib import Path

import pytest

from aquafish.cli import main
from eea.analysis.diagnosis import RunDiagnosis, diagnose_run
from eea.run import run


@pytest.mark.parametrize("inference, summary", [("known", "dft"), ("none", "dft"), ("known", "signed_dft"),
                                                ("known", "gyro_dft")])
def test_truth_reproduces_the_target_exactly_under_true_angles(tmp_path, tiny_config, inference, summary):
    # the diagnosis simulates the models with the run's own behaviour summary (a signed run's
    # target summaries keep the zero-frequency term's sign: scored against plain DFT
    # magnitudes, the truth would fall below 1.0)
    result = run(tiny_config(inference=inference, behaviour_summary=summary), tmp_path, progress=False)
    d = diagnose_run(tmp_path)
    assert d.experiments == 2 and d.inference == inference
    assert d.true_true_angles == 1.0                  # the damaged robot is an exact model genome
    # the final model's fitness under the inferred angles is what the run recorded as MOD_FIT
    # when the final model is that round's best (it is: one GA, best of the last generation)
    assert d.final_inferred == pytest.approx(result.rounds[-1]["model_fitness"], abs=1e-12)
    # own fitted angles, started from the inferred ones: never worse than those
    assert d.final_profiled >= d.final_inferred and d.true_profiled >= d.true_inferred
    # the models the run scored: its final model among them, none better than it counted wrongly
    from eea.checkpoint import load_state
    from eea.evaluation import Evaluator
    from eea.encoding import decode_models
    from eea.fitness import objective_fitness
    ev = Evaluator(tiny_config().steps)
    ev.load_state_dict(load_state(tmp_path).evaluator)
    genomes, _ = ev.scored_models()
    objective = objective_fitness(decode_models(genomes), result.target_morphology.to_array())
    final = result.rounds[-1]["objective_fitness"]
    assert d.seen == len(genomes) >= tiny_config().estimation.population
    assert d.closest_seen == objective.max() >= final
    assert d.better_seen == (objective > final + 1e-12).sum()
    assert d.found == (final == 1.0) and (d.verdict == "found") == d.found
    if inference == "known":                          # inferred = true angles
        assert d.true_inferred == 1.0 and d.final_true_angles == d.final_inferred
        assert d.true_profiled == 1.0
    else:                                             # zero state: the truth no longer fits exactly
        assert d.true_inferred < 1.0


def test_verdict_names_the_failure():
    def diagnosis(inference, final_inferred, true_inferred, final_profiled, true_profiled):
        return RunDiagnosis(Path("r"), inference, 10, final_inferred, true_inferred, final_true_angles=0.976,
                            true_true_angles=1.0, final_profiled=final_profiled, true_profiled=true_profiled,
                            per_model=inference == "profile")

    assert diagnosis("known", 0.988, 1.0, 0.99, 1.0).verdict == "search"
    assert diagnosis("out_of_band", 0.985, 0.976, 0.986, 0.996).verdict == "inference"        # a trap
    assert diagnosis("out_of_band", 0.985, 0.976, 0.990, 0.989).verdict == "identifiability"
    # profile gives every model its own angles: the truth under the final model's angles does not count
    assert diagnosis("profile", 0.985, 0.96, 0.986, 0.996).verdict == "search"
    # a run that ended at the truth did not fail, although the truth then fits no better than the final model
    ended_at_truth = RunDiagnosis(Path("r"), "profile", 10, 0.9998, 0.9998, final_true_angles=1.0, true_true_angles=1.0,
                                  final_profiled=0.9998, true_profiled=0.9998, per_model=True, found=True)
    assert ended_at_truth.verdict == "found"
    assert diagnosis("profile", 0.985, 0.96, 0.986, 0.980).verdict == "identifiability"


def test_cli_prints_one_line_per_run(tmp_path, tiny_config, capsys):
    for seed in (0, 1):
        run(tiny_config(inference="none", seed=seed), tmp_path / f"seed{seed}", progress=False)
    assert main(["diagnose", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[0].split()[:3] == ["run", "inference", "E"]
    assert all(line.split()[1:3] == ["none", "2"] and line.split()[6] == "1.0000" for line in lines[1:])


def test_no_finished_round_raises(tmp_path):
    with pytest.raises(ValueError, match="not an EEA run directory"):
        diagnose_run(tmp_path)


def test_a_run_that_found_the_truth_gets_one_fit_for_both(tmp_path, tiny_config, monkeypatch):
    from aquafish_gym import get_damage
    from eea.record import RunResult

    config = tiny_config(inference="none")
    run(config, tmp_path, progress=False)
    truth = get_damage(config.damage).apply()
    monkeypatch.setattr(RunResult, "best_morphology", property(lambda self: truth))
    d = diagnose_run(tmp_path)
    assert d.final_inferred == d.true_inferred and d.final_true_angles == d.true_true_angles == 1.0
    assert d.final_profiled == d.true_profiled >= d.true_inferred


def test_profile_run_scores_the_truth_under_the_angles_it_would_start_from(tmp_path, tiny_config):
    import numpy as np

    from aquafish_gym import get_damage
    from eea.checkpoint import load_state
    from eea.encoding import MODEL_BITS, encode_models, genomes_from_keys
    from eea.evaluation import Evaluator
    from eea.experiment import Experiment
    from eea.fitness import model_fitness_from_similarities

    config = tiny_config(inference="profile")
    run(config, tmp_path, progress=False)
    d = diagnose_run(tmp_path)
    state = load_state(tmp_path)
    experiments = [Experiment.from_state_dict(e) for e in state.experiments]
    truth = encode_models(get_damage(config.damage).apply().to_array()[None])
    memory = state.inference["memory"]
    keys = list(memory)
    remembered = genomes_from_keys(keys, MODEL_BITS)
    nearest = keys[int(np.argmin((remembered != truth).sum(axis=1)))]  # the truth is not remembered here
    assert truth[0].tobytes() not in memory
    with Evaluator(config.steps, params=config.sim_params) as ev:
        expected = model_fitness_from_similarities(ev.similarities(truth, experiments, memory[nearest][0][None]))[0]
    assert d.true_proposed == pytest.approx(float(expected), abs=1e-12)
    assert d.true_proposed < d.true_true_angles == 1.0
    assert d.per_model and d.true_refined is None
    # contender refinement starts from those angles and keeps only improvements
    refined = diagnose_run(tmp_path, refine=20).true_refined
    assert d.true_proposed < refined <= 1.0
    with pytest.raises(ValueError, match="refine must be >= 0"):
        diagnose_run(tmp_path, refine=-1)


def test_shared_angle_runs_have_no_proposed_truth(tmp_path, tiny_config):
    run(tiny_config(inference="known"), tmp_path, progress=False)
    d = diagnose_run(tmp_path, refine=5)
    assert d.true_proposed is None and d.true_refined is None


def test_median_error_by_hand():
    import numpy as np

    from eea.analysis.diagnosis import median_error_deg

    true = np.zeros((3, 3))
    angles = np.array([[0.1, 6.2, 0.05], [0.3, 0.0, -0.1], [3.0, 0.2, 0.2]])
    # left |0.1|, |0.3|, |3.0| -> median 0.3; right 6.2 is 0.083 the short way, 0, 0.2 -> 0.083;
    # caudal on the line: 0.05, 0.1, 0.2 -> 0.1
    np.testing.assert_allclose(median_error_deg(angles, true),
                               np.degrees([0.3, 2 * np.pi - 6.2, 0.1]), atol=1e-12)
    with pytest.raises(ValueError, match=r"\(E, 3\)"):
        median_error_deg(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"\(E, 3\)"):
        median_error_deg(np.zeros((0, 3)), np.zeros((0, 3)))


@pytest.mark.parametrize("inference", ["known", "profile"])
def test_angle_errors_of_the_run_and_of_the_truths_own_fit(tmp_path, tiny_config, inference):
    import numpy as np

    from aquafish_gym import get_damage
    from eea.checkpoint import load_state
    from eea.analysis.diagnosis import median_error_deg
    from eea.encoding import encode_models
    from eea.evaluation import Evaluator
    from eea.experiment import Experiment
    from eea.fitness import model_fitness_from_similarities

    config = tiny_config(inference=inference)
    run(config, tmp_path, progress=False)
    d = diagnose_run(tmp_path)
    experiments = [Experiment.from_state_dict(e) for e in load_state(tmp_path).experiments]
    true = np.stack([e.true_angles for e in experiments])
    inferred = np.stack([e.context.estimate() for e in experiments])
    np.testing.assert_array_equal(d.run_error_deg, median_error_deg(inferred, true))
    assert d.true_fitted_angles.shape == (len(experiments), 3)
    np.testing.assert_array_equal(d.floor_error_deg, median_error_deg(d.true_fitted_angles, true))
    # the reported angles are the ones the truth's MOD_FIT was fitted under
    truth = encode_models(get_damage(config.damage).apply().to_array()[None])
    with Evaluator(config.steps, params=config.sim_params) as ev:
        sims = ev.similarities(truth, experiments, d.true_fitted_angles[None])
    assert float(model_fitness_from_similarities(sims)[0]) == pytest.approx(d.true_profiled, abs=1e-12)
    if inference == "known":  # the inferred angles are the true ones, and the truth's fit starts there
        assert (d.run_error_deg == 0).all() and (d.floor_error_deg == 0).all() and d.true_profiled == 1.0
    else:
        assert (d.run_error_deg > 0).any()
