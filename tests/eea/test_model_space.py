"""The ``morphology+servos`` model space: servo gains in the self-model.

The encoding of the gains, their exactness for every damage preset, OBJ_FIT over 12 values,
the evaluator simulating each model with its own gains (the truth reproduces a reversed
servo's target exactly), tiny runs with both searches, and the config's field.
"""

import argparse
import csv
import json

import numpy as np
import pytest

import eea
from test_golden_rounds import _without_wall_seconds
from aquafish_gym import DAMAGES, MORPHOLOGY_BOUNDS, Morphology, ServoFaults, SimParams, simulate_batch
from eea.behaviour import behaviour_summary
from eea.cli import add_config_flags, config_fields, config_flag_names
from eea.search.cma import CMAModelSearch, genomes_to_unit, unit_to_genomes
from eea.config import EEAConfig
from eea.diversity import model_distance
from eea.encoding import (MODEL_BITS, SERVO_GAIN_BOUNDS, decode_gains, decode_models, encode_gains, encode_models,
                          get_model_space, model_space_of, servo_gains)
from eea.evaluation import Evaluator
from eea.experiment import Context, Experiment
from eea.fitness import objective_fitness
from eea.search import ModelGA, model_search_from_state
from eea.record import (GAIN_COLUMNS, ROUND_COLUMNS, TRUE_GAIN_COLUMNS, check_rounds, load_result, read_rounds,
                        round_columns)
from eea.target import Target

SERVOS = get_model_space("morphology+servos")
PECTORAL_LEVELS = [-1.0] + [k / 8 - 1 for k in range(2, 17)]           # eighths of [-1, 1] without -0.875
CAUDAL_LEVELS = [0.0] + [k / 16 for k in range(2, 17)]                  # sixteenths of [0, 1] without 0.0625


def _code_genomes():
    """(16, 12) gain genomes: row c holds code c in all three fields."""
    return np.array([[int(b) for b in f"{c:04b}" * 3] for c in range(16)], dtype=np.uint8)


# -- encoding -----------------------------------------------------------------------------------

def test_gain_levels_are_the_grid_of_sixteenths_without_the_second_level():
    gains = decode_gains(_code_genomes())
    assert gains[:, 0].tolist() == PECTORAL_LEVELS and gains[:, 1].tolist() == PECTORAL_LEVELS
    assert gains[:, 2].tolist() == CAUDAL_LEVELS
    assert decode_gains(np.ones(12, np.uint8)).tolist() == [1.0, 1.0, 1.0]   # all ones: healthy


def test_gains_round_trip_and_encode_to_the_nearest_level():
    genomes = _code_genomes()
    np.testing.assert_array_equal(encode_gains(decode_gains(genomes)), genomes)
    # -0.9 is nearer -1 than -0.75; -0.8 nearer -0.75; the caudal's 0.03 nearer 0, 0.1 nearer 0.125
    assert decode_gains(encode_gains([-0.9, -0.8, 0.03])).tolist() == [-1.0, -0.75, 0.0]
    assert decode_gains(encode_gains([0.06, 0.49, 0.1])).tolist() == [0.0, 0.5, 0.125]
    with pytest.raises(ValueError, match="outside its range"):
        encode_gains([0.0, 0.0, -0.5])                 # a caudal gain is in [0, 1]
    with pytest.raises(ValueError, match="outside its range"):
        encode_gains([1.5, 0.0, 0.5])
    with pytest.raises(ValueError, match="12"):
        decode_gains(np.zeros(11, np.uint8))


@pytest.mark.parametrize("damage", sorted(DAMAGES))
def test_every_damage_preset_is_an_exact_model_genome(damage):
    truth = SERVOS.truth(damage)
    assert truth.shape == (12,)
    np.testing.assert_array_equal(SERVOS.decode(SERVOS.encode(truth)), truth)   # exact, not nearest
    np.testing.assert_array_equal(truth[:9], DAMAGES[damage].apply().to_array())


def test_the_presets_servo_faults_become_their_gains():
    assert SERVOS.truth("none")[9:].tolist() == [1.0, 1.0, 1.0]
    assert SERVOS.truth("reversed_left_pectoral")[9:].tolist() == [-1.0, 1.0, 1.0]
    assert SERVOS.truth("seized_left_pectoral")[9:].tolist() == [0.0, 1.0, 1.0]       # seized -> gain 0
    assert SERVOS.truth("weak_right_pectoral")[9:].tolist() == [1.0, 0.5, 1.0]
    assert SERVOS.truth("left_pectoral_half")[9:].tolist() == [1.0, 1.0, 1.0]
    assert servo_gains(ServoFaults(seized=(False, False, True), speed_scale=(0.5, 1.0, 0.5))).tolist() == [0.5, 1.0, 0.0]


def test_the_servo_space_appends_twelve_bits_and_leaves_the_papers_space_alone():
    morphology = get_model_space("morphology")
    assert (morphology.n_bits, SERVOS.n_bits) == (MODEL_BITS, 57) == (45, 57)
    assert model_space_of(45) is morphology and model_space_of(57) is SERVOS
    with pytest.raises(ValueError, match="no model space has 50-bit"):
        model_space_of(50)
    genomes = np.random.default_rng(0).integers(0, 2, (20, 57), dtype=np.uint8)
    values = SERVOS.decode(genomes)
    np.testing.assert_array_equal(values[:, :9], decode_models(genomes[:, :45]))
    np.testing.assert_array_equal(values[:, 9:], decode_gains(genomes[:, 45:]))
    np.testing.assert_array_equal(SERVOS.encode(values), genomes)
    np.testing.assert_array_equal(morphology.decode(genomes[:, :45]), decode_models(genomes[:, :45]))
    np.testing.assert_array_equal(morphology.encode(values[:, :9]), encode_models(values[:, :9]))
    assert morphology.faults(values[:, :9]) is None
    assert SERVOS.faults(values[:2])[1] == ServoFaults(speed_scale=tuple(values[1, 9:]))
    np.testing.assert_array_equal(SERVOS.bounds, np.vstack([MORPHOLOGY_BOUNDS, SERVO_GAIN_BOUNDS]))


# -- the simulator: a seized servo is a gain of 0 -----------------------------------------------

@pytest.mark.parametrize("waterline", [None, 0.3])
def test_a_seized_servo_simulates_exactly_like_a_gain_of_zero(waterline):
    rng = np.random.default_rng(3)
    n = 4
    actions = np.column_stack([rng.uniform(-0.5, 0.5, n), rng.uniform(-0.5, 0.5, n), rng.uniform(0.2, 1, n)])
    angles = np.column_stack([rng.uniform(0, 2 * np.pi, (n, 2)), rng.uniform(-0.4, 0.4, n)])
    morphologies = np.repeat(Morphology.healthy().to_array()[None], n, axis=0)
    params = SimParams(waterline=waterline)
    healthy = simulate_batch(morphologies, actions, angles, 60, params=params)
    for servo in range(3):
        seized, gain = [False] * 3, [1.0] * 3
        seized[servo], gain[servo] = True, 0.0
        a = simulate_batch(morphologies, actions, angles, 60, faults=ServoFaults(seized=tuple(seized)), params=params)
        b = simulate_batch(morphologies, actions, angles, 60, faults=ServoFaults(speed_scale=tuple(gain)), params=params)
        np.testing.assert_array_equal(a, b)
        assert not np.array_equal(a, healthy)            # the fault does change the motion


# -- OBJ_FIT over 12 values -----------------------------------------------------------------------

def test_objective_fitness_over_twelve_values_by_hand():
    truth = SERVOS.truth("reversed_left_pectoral")
    assert objective_fitness(truth, truth, SERVOS.bounds) == 1.0
    model = truth.copy()
    model[9] = 1.0                                        # the reversed servo taken for a healthy one
    assert objective_fitness(model, truth, SERVOS.bounds) == pytest.approx(1 - (2 / 2) / 12)
    model[1] = 0.5                                        # and the left pectoral's y halved (range 2)
    model[11] = 0.25                                      # and the caudal gain at 0.25 (range 1)
    expected = 1 - (0.5 / 2 + 2 / 2 + 0.75 / 1) / 12
    assert objective_fitness(model, truth, SERVOS.bounds) == pytest.approx(expected)
    # model_distance is 1 - OBJ_FIT over the same 12 terms, on genomes
    assert model_distance(SERVOS.encode(model)[None], SERVOS.encode(truth))[0] == pytest.approx(1 - expected)
    # the paper's 9-dim OBJ_FIT (default bounds) sees only the y error
    assert objective_fitness(model[:9], truth[:9]) == pytest.approx(1 - (0.5 / 2) / 9)


# -- the evaluator ----------------------------------------------------------------------------------

def _target_experiments(damage, steps=32, n=3, seed=0):
    target = Target(damage, steps, np.random.default_rng(seed), SimParams(waterline=None))
    actions = [(0.5, 0.2, 0.6), (-0.4, 0.4, 0.0), (0.3, -0.3, 1.0)][:n]
    experiments = []
    for i, action in enumerate(actions):
        log, true = target.perform(np.array(action))
        experiments.append(Experiment(i, np.array(action), log, behaviour_summary(log), true, Context.exact(true)))
    return experiments


def test_the_truth_with_gain_minus_one_reproduces_the_reversed_target_exactly():
    experiments = _target_experiments("reversed_left_pectoral")
    true_angles = np.stack([e.true_angles for e in experiments])
    truth = SERVOS.truth("reversed_left_pectoral")
    healthy_servos = truth.copy()
    healthy_servos[9] = 1.0
    genomes = SERVOS.encode(np.stack([truth, healthy_servos]))
    with Evaluator(32, params=SimParams(waterline=None), model_space=SERVOS) as ev:
        sims = ev.similarities(genomes, experiments, np.repeat(true_angles[None], 2, axis=0))
    assert sims[0].tolist() == [1.0, 1.0, 1.0]           # MOD_FIT = 1: the model is the target
    assert sims[1].max() < 0.99                           # the same body with a healthy servo is not
    with Evaluator(32, params=SimParams(waterline=None)) as ev:   # the paper's space: no gain to get right
        paper = ev.similarities(encode_models(truth[:9])[None], experiments, true_angles[None])
    np.testing.assert_array_equal(paper, sims[1:])


def test_each_model_of_a_batch_gets_its_own_gains(simulator_spy, make_experiment):
    experiments = [make_experiment(0, steps=16)]
    values = np.tile(SERVOS.truth("none"), (3, 1))
    values[0, 9], values[2, 10:] = -1.0, [0.5, 0.0]
    with Evaluator(16, params=SimParams(waterline=None), model_space="morphology+servos") as ev:
        ev.similarities(SERVOS.encode(values), experiments, np.zeros((3, 1, 3)))
    (call,) = simulator_spy.calls
    assert [f.speed_scale for f in call["faults"]] == [(-1.0, 1.0, 1.0), (1.0, 1.0, 1.0), (1.0, 0.5, 0.0)]
    with Evaluator(16, model_space="morphology+servos") as ev, pytest.raises(ValueError, match=r"\(P, 57\)"):
        ev.similarities(np.zeros((1, 45), np.uint8), experiments, np.zeros((1, 1, 3)))


def test_scored_models_returns_57_bit_genomes():
    experiments = _target_experiments("weak_right_pectoral", steps=16, n=1)
    genomes = np.random.default_rng(2).integers(0, 2, (4, 57), dtype=np.uint8)
    with Evaluator(16, params=SimParams(waterline=None), model_space=SERVOS) as ev:
        ev.similarities(genomes, experiments, np.zeros((4, 1, 3)))
        scored, _ = ev.scored_models()
    np.testing.assert_array_equal(scored, genomes)


# -- the searches ----------------------------------------------------------------------------------

def test_cma_cube_maps_gain_coordinates_to_codes():
    x = np.full((1, 12), 0.5)
    x[0, 9:] = [0.0, 1.0, 0.49]                           # codes 0, 15 (top), floor(0.49 * 16) = 7
    genome = unit_to_genomes(x, SERVOS)
    assert genome.shape == (1, 57)
    assert decode_gains(genome[0, 45:]).tolist() == [-1.0, 1.0, 0.5]
    np.testing.assert_array_equal(genome[:, :45], unit_to_genomes(x[:, :9]))   # the 9 dims as before
    genomes = np.random.default_rng(1).integers(0, 2, (10, 57), dtype=np.uint8)
    np.testing.assert_array_equal(unit_to_genomes(genomes_to_unit(genomes, SERVOS), SERVOS), genomes)
    search = CMAModelSearch(6, np.random.default_rng(0), model_space="morphology+servos")
    assert search.n_bits == 57 and search.ask().shape == (6, 57)
    assert CMAModelSearch(6, np.random.default_rng(0)).n_bits == 45


@pytest.mark.parametrize("search", ["ga", "cma"])
def test_searches_of_the_servo_space_resume_from_their_state(search, tiny_config):
    config = tiny_config(model_space="morphology+servos", estimation_search=search)
    from eea.search import make_model_search
    s = make_model_search(config.estimation, config.ga, config.model_space, np.random.default_rng(4))
    assert s.n_bits == 57
    s.tell(s.ask().sum(axis=1).astype(float))
    restored = model_search_from_state(s.state_dict(), np.random.default_rng(5))
    assert restored.n_bits == 57
    np.testing.assert_array_equal(restored.ask(), s.ask())
    if search == "ga":
        assert s.mutation_rate == pytest.approx(1 / 57)
        assert isinstance(restored, ModelGA)


# -- runs ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("search", ["ga", "cma"])
def test_a_tiny_servo_run_records_gains_and_obj_fit_over_twelve(tmp_path, tiny_config, search):
    config = tiny_config(model_space="morphology+servos", damage="reversed_left_pectoral", inference="known",
                         estimation_search=search, seed=3)
    result = eea.run(config, tmp_path / "whole", progress=False)
    with open(tmp_path / "whole" / "rounds.csv", newline="") as f:
        header = next(csv.reader(f))
    assert tuple(header) == round_columns("morphology+servos")
    assert set(header) - set(ROUND_COLUMNS) == set(GAIN_COLUMNS) | set(TRUE_GAIN_COLUMNS)
    truth = SERVOS.truth("reversed_left_pectoral")
    assert np.array_equal(result.true_model, truth) and result.best_model.shape == (12,)
    for row in result.rounds:
        assert [row[c] for c in TRUE_GAIN_COLUMNS] == [-1.0, 1.0, 1.0]
        model = np.array([row[f"model_{name}"] for name in SERVOS.fields])
        assert np.array_equal(SERVOS.decode(SERVOS.encode(model)), model)   # a decoded genome
        assert row["objective_fitness"] == objective_fitness(model, truth, SERVOS.bounds)
        assert 0.0 <= row["model_fitness"] <= 1.0
    loaded = load_result(tmp_path / "whole")
    assert loaded.config.model_space == "morphology+servos" and loaded.rounds == result.rounds
    # resuming gives the same rounds
    eea.run(config.replace(rounds=1), tmp_path / "split", progress=False)
    eea.run(config, tmp_path / "split", progress=False)
    assert _without_wall_seconds(tmp_path / "split" / "rounds.csv") == \
        _without_wall_seconds(tmp_path / "whole" / "rounds.csv")
    # a servo run's rounds.csv is checked against its own columns
    assert read_rounds(tmp_path / "whole") == result.rounds
    with pytest.raises(ValueError, match="unknown columns .*model_left_pectoral_gain"):
        read_rounds(tmp_path / "whole", "morphology")    # a paper-space run does not read it
    with pytest.raises(ValueError, match="missing columns .*true_left_pectoral_gain"):
        check_rounds(tmp_path / "whole" / "rounds.csv", ROUND_COLUMNS, [], "morphology+servos")


@pytest.mark.parametrize("inference", ["none", "in_band", "out_of_band", "profile"])
def test_every_inference_strategy_runs_in_the_servo_space(tmp_path, tiny_config, inference):
    config = tiny_config(model_space="morphology+servos", damage="seized_left_pectoral", inference=inference,
                         rounds=1)
    result = eea.run(config, tmp_path, progress=False)
    assert len(result.rounds) == 1 and [result.rounds[0][c] for c in TRUE_GAIN_COLUMNS] == [0.0, 1.0, 1.0]


def test_the_lineages_method_runs_in_the_servo_space(tmp_path, tiny_config):
    from eea.methods import method_fields
    from eea.analysis.lineage_report import lineage_objective_fitness
    from eea.record import LINEAGES_FILE, lineage_columns

    config = tiny_config(**{**method_fields("profile_lineages"), "estimation_population": 10, "rounds": 1,
                            "model_space": "morphology+servos", "damage": "weak_right_pectoral"})
    result = eea.run(config, tmp_path, progress=False)
    with open(tmp_path / LINEAGES_FILE, newline="") as f:
        assert tuple(next(csv.reader(f))) == lineage_columns("morphology+servos")
    objective, chosen = lineage_objective_fitness(tmp_path)
    assert objective.shape == (1, 2)
    assert objective[0, chosen[0]] == result.rounds[0]["objective_fitness"]


# -- the config ------------------------------------------------------------------------------------

def test_model_space_config_round_trip_and_old_configs(tmp_path):
    config = EEAConfig(model_space="morphology+servos", damage="reversed_left_pectoral")
    assert EEAConfig.from_dict(json.loads(json.dumps(config.to_dict()))) == config
    old = EEAConfig().to_flat()
    del old["model_space"]                                # a (flat) config.json written before the field
    assert EEAConfig.from_dict(old).model_space == "morphology" == EEAConfig().model_space
    assert not config.same_results_as(config.replace(model_space="morphology"))
    with pytest.raises(ValueError, match="unknown model_space 'servos'; valid names: morphology, "
                                         "morphology\\+servos"):
        EEAConfig(model_space="servos")


def test_the_model_space_flag():
    parser = argparse.ArgumentParser()
    names = add_config_flags(parser)
    args = parser.parse_args(["--model-space", "morphology+servos", "--damage", "reversed_left_pectoral"])
    assert EEAConfig.from_flat(config_fields(args, names)).model_space == "morphology+servos"
    assert "model_space" not in config_fields(parser.parse_args([]), config_flag_names())
    with pytest.raises(SystemExit):
        parser.parse_args(["--model-space", "servos"])


def test_diagnosis_of_a_servo_run_scores_the_truth_with_its_gains(tmp_path, tiny_config):
    from eea.analysis.diagnosis import diagnose_run

    eea.run(tiny_config(model_space="morphology+servos", damage="reversed_left_pectoral", inference="known"),
            tmp_path / "servos", progress=False)
    d = diagnose_run(tmp_path / "servos", profile_generations=2)
    assert d.true_true_angles == 1.0                      # the truth with gain -1 is the target
    assert d.seen >= 1 and 0.0 < d.closest_seen <= 1.0
    eea.run(tiny_config(damage="reversed_left_pectoral", inference="known"), tmp_path / "paper", progress=False)
    assert diagnose_run(tmp_path / "paper", profile_generations=2).true_true_angles < 1.0   # no gain to model it
