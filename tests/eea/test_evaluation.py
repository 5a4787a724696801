"""Evaluator: one batched simulator call per evaluation, caching, identical results for any workers."""

import numpy as np
import pytest

from aquafish_gym import simulate_batch
from eea.behaviour import angular_rates, behaviour_summary, similarity, summarise
from eea.encoding import decode_actions, decode_models
from eea.evaluation import Evaluator
from eea.experiment import quantise_angles


def _genomes(n, seed=0, bits=45):
    return np.random.default_rng(seed).integers(0, 2, (n, bits), dtype=np.uint8)


def test_similarities_are_eq2_against_each_experiments_target(simulator_spy, make_experiment):
    exps = [make_experiment(0), make_experiment(1, action=(-0.4, 0.1, 0.3))]
    genomes = _genomes(3)
    angles = np.random.default_rng(1).uniform(0, 0.5, (3, 2, 3))
    with Evaluator(16) as ev:
        sims = ev.similarities(genomes, exps, angles)
    assert sims.shape == (3, 2)
    assert len(simulator_spy.calls) == 1 and simulator_spy.robots == 6   # one batched call for the population
    for p in range(3):
        for e in range(2):
            snapped = quantise_angles(angles[p, e][None])[1]
            log = simulate_batch(decode_models(genomes[p])[None], exps[e].action[None], snapped, 16)
            assert sims[p, e] == similarity(behaviour_summary(log[0]), exps[e].summary)


def test_a_target_summarised_otherwise_than_the_models_is_refused(make_experiment):
    import dataclasses

    x = make_experiment(0)
    log = x.imu_log - 10.0                                    # a negative mean: signed and plain DFT differ
    plain = dataclasses.replace(x, imu_log=log, summary=behaviour_summary(log))
    signed = dataclasses.replace(x, imu_log=log, summary=behaviour_summary(log, signed=True))
    assert signed.summary[2, 0] < 0 < plain.summary[2, 0]
    angles = np.zeros((1, 1, 3))
    for summary, right, wrong in (("dft", plain, signed), ("signed_dft", signed, plain)):
        with Evaluator(16, summary=summary) as ev:
            assert ev.similarities(_genomes(1), [right], angles).shape == (1, 1)
        with Evaluator(16, summary=summary) as ev:
            with pytest.raises(ValueError, match=f"experiment 0's summary is not the '{summary}' behaviour summary"):
                ev.similarities(_genomes(1), [wrong], angles)


def test_a_gyro_evaluator_scores_eq2_of_the_rates_at_max_1000(make_experiment):
    """With ``summary="gyro_dft"`` a model is scored by eq. 2 at MAX 1000 between the DFTs of its
    angular rates and the target's (checked against the hand-built summaries)."""
    import dataclasses

    x = make_experiment(0)
    target = dataclasses.replace(x, summary=summarise(x.imu_log, "gyro_dft"))
    genomes = _genomes(2)
    with Evaluator(16, summary="gyro_dft") as ev:
        assert ev.max_coefficient == 1000.0
        sims = ev.similarities(genomes, [target], np.zeros((2, 1, 3)))
    with Evaluator(16, summary="gyro_dft") as ev:
        with pytest.raises(ValueError, match="not the 'gyro_dft' behaviour summary"):
            ev.similarities(genomes, [x], np.zeros((2, 1, 3)))        # the paper's summary of the same log
    log = simulate_batch(decode_models(genomes), np.repeat(x.action[None], 2, axis=0), np.zeros((2, 3)), 16)
    expected = similarity(behaviour_summary(angular_rates(log)), target.summary, 1000.0)
    np.testing.assert_array_equal(sims[:, 0], expected)
    assert not np.allclose(expected, similarity(behaviour_summary(angular_rates(log)), target.summary))  # MAX matters


def test_cache_never_simulates_a_key_twice(simulator_spy, make_experiment):
    exps = [make_experiment(0), make_experiment(1)]
    genomes = _genomes(4)
    genomes[3] = genomes[0]                                          # a duplicate in the same population
    angles = np.zeros((4, 2, 3))
    with Evaluator(16) as ev:
        first = ev.similarities(genomes, exps, angles)
        assert ev.simulations == 6 and simulator_spy.robots == 6     # 3 distinct genomes x 2 experiments
        np.testing.assert_array_equal(first[3], first[0])
        again = ev.similarities(genomes, exps, angles + 1e-8)         # below the 1e-6 rad grid: same keys
        assert ev.simulations == 6 and len(simulator_spy.calls) == 1
        np.testing.assert_array_equal(again, first)
        ev.similarities(genomes[:1], exps, np.full((1, 2, 3), 0.25))  # other angles: simulated
        ev.similarities(genomes[:1], [make_experiment(2)], np.zeros((1, 1, 3)))  # other experiment index
        assert ev.simulations == 6 + 2 + 1 and ev.cache_size == 9
        state = ev.state_dict()
    with Evaluator(16) as fresh:                                      # a resumed run keeps the cache
        fresh.load_state_dict(state)
        np.testing.assert_array_equal(fresh.similarities(genomes, exps, angles), first)
        assert fresh.simulations == 9 and len(simulator_spy.calls) == 3


def test_scored_models_lists_every_genome_with_its_best_similarity_per_experiment(make_experiment):
    exps = [make_experiment(0), make_experiment(1)]
    genomes = _genomes(3)
    with Evaluator(16) as ev:
        assert [x.shape for x in ev.scored_models()] == [(0, 45), (0, 0)]
        a = ev.similarities(genomes, exps, np.zeros((3, 2, 3)))
        b = ev.similarities(genomes[:2], exps, np.full((2, 2, 3), 0.4))       # other angles for two of them
        c = ev.similarities(genomes[2:], [make_experiment(3)], np.zeros((1, 1, 3)))  # experiment index 3 only
        seen, sims = ev.scored_models()
    np.testing.assert_array_equal(seen, genomes)                                # first-scored order, exact bits
    assert sims.shape == (3, 4)
    np.testing.assert_array_equal(sims[:2, :2], np.maximum(a[:2], b))           # best over the angles tried
    np.testing.assert_array_equal(sims[2, :2], a[2])
    assert sims[2, 3] == c[0, 0] and np.isnan(sims[:, 2]).all() and np.isnan(sims[:2, 3]).all()


def test_angles_are_snapped_to_the_grid_before_simulating(simulator_spy, make_experiment):
    angles = np.array([[[2 * np.pi + 0.3000004, -0.1, 0.2]]])
    with Evaluator(16) as ev:
        ev.similarities(_genomes(1), [make_experiment(0)], angles)
    np.testing.assert_allclose(simulator_spy.calls[0]["initial_angles"], [[0.3, 2 * np.pi - 0.1, 0.2]], atol=1e-6)


def test_chunking_splits_one_batch_into_contiguous_calls(simulator_spy):
    genomes = _genomes(7)
    morph = decode_models(genomes)
    actions = decode_actions(_genomes(7, 1, 18))
    with Evaluator(16, max_batch_robots=3) as ev:
        chunked = ev.simulate(morph, actions, np.zeros((7, 3)))
    assert [len(c["morphologies"]) for c in simulator_spy.calls] == [2, 2, 3]
    np.testing.assert_array_equal(np.concatenate([c["morphologies"] for c in simulator_spy.calls]), morph)
    with Evaluator(16) as ev:
        whole = ev.simulate(morph, actions, np.zeros((7, 3)))
    np.testing.assert_array_equal(chunked, whole)                     # bit for bit


def test_summaries_for_exploration_are_cached_within_a_phase(simulator_spy):
    models, acts = _genomes(3), _genomes(2, 1, 18)
    with Evaluator(16) as ev:
        s = ev.summaries(models, acts, decode_actions(acts), np.zeros(3))
        assert s.shape == (2, 3, 3, 9) and ev.simulations == 6
        np.testing.assert_array_equal(simulator_spy.calls[0]["initial_angles"], np.zeros((6, 3)))
        np.testing.assert_array_equal(ev.summaries(models[::-1], acts, decode_actions(acts), np.zeros(3)), s[:, ::-1])
        assert ev.simulations == 6
        ev.clear_summaries()
        ev.summaries(models, acts, decode_actions(acts), np.zeros(3))
        assert ev.simulations == 12
    log = simulate_batch(decode_models(models[1])[None], decode_actions(acts[0])[None], np.zeros((1, 3)), 16)
    np.testing.assert_array_equal(s[0, 1], behaviour_summary(log[0]))


def test_two_workers_give_identical_results(make_experiment):
    exps = [make_experiment(0, steps=32), make_experiment(1, steps=32, action=(0.5, 0.5, 1.0))]
    genomes = _genomes(9, 3)
    angles = np.random.default_rng(4).uniform(0, 0.5, (9, 2, 3))
    with Evaluator(32, workers=1) as one, Evaluator(32, workers=2) as two:
        np.testing.assert_array_equal(one.similarities(genomes, exps, angles), two.similarities(genomes, exps, angles))
        assert two._pool is not None
    assert two._pool is None                                          # closed with the context


def test_bad_arguments(make_experiment):
    with pytest.raises(ValueError, match="workers"):
        Evaluator(16, workers=0)
    with Evaluator(16) as ev, pytest.raises(ValueError, match="angles"):
        ev.similarities(_genomes(2), [make_experiment(0)], np.zeros((2, 2, 3)))


def test_for_config_takes_the_runs_settings_and_a_workers_override():
    from eea.config import EEAConfig
    config = EEAConfig().replace(duration_s=0.64, model_space="morphology+servos", behaviour_summary="gyro_dft",
                                 max_batch_robots=16, workers=2)
    ev = Evaluator.for_config(config)
    assert (ev.steps, ev.workers, ev.max_batch_robots, ev.summary) == (64, 2, 16, "gyro_dft")
    assert ev.model_space.name == "morphology+servos" and ev.params == config.sim_params
    assert Evaluator.for_config(config, workers=1).workers == 1
    assert Evaluator.for_config(config, model_space="morphology").model_space.name == "morphology"


def test_models_start_each_experiment_from_its_targets_start_motion(simulator_spy):
    """A target that started an experiment rolling and turning: the truth simulated from the
    recorded start motion reproduces it exactly (eq. 2's similarity 1), the truth from rest does not."""
    from aquafish_gym import BatchWorld
    from eea.experiment import Context, Experiment

    truth = decode_models(_genomes(1, seed=4))[0]
    world = BatchWorld(truth[None])
    world.reset(np.zeros((1, 3)), np.array([[0.4, -0.3, 0.9]]))
    world.advance(250)  # 2.5 s of swimming: the target is rolling and turning now
    motion = world.start_motion()
    action, angles = np.array([-0.2, 0.35, 0.4]), quantise_angles(np.array([[1.0, 2.0, 0.1]]))[1]
    log = simulate_batch(truth[None], action[None], angles, 32, start_motion=motion)[0]
    moving = Experiment(0, action, log, behaviour_summary(log), angles[0], Context.exact(angles[0]), motion[0])
    resting = Experiment(0, action, log, behaviour_summary(log), angles[0], Context.exact(angles[0]))
    assert not moving.at_rest and resting.at_rest
    genome = _genomes(1, seed=4)
    with Evaluator(32) as ev:
        assert ev.similarities(genome, [moving], angles[None])[0, 0] == 1.0
    np.testing.assert_array_equal(simulator_spy.calls[-1]["start_motion"], motion)
    with Evaluator(32) as ev:
        assert ev.similarities(genome, [resting], angles[None])[0, 0] < 0.999
    assert simulator_spy.calls[-1]["start_motion"] is None  # at rest: the plain reset
