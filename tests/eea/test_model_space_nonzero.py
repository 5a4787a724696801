"""The ``morphology_nonzero`` model space: the paper's genome on a grid one level up (no
zero-size flipper), a variant of the paper's methods under measurement."""

import numpy as np
import pytest

from aquafish_gym import DAMAGES, MORPHOLOGY_BOUNDS, get_damage
from eea.analysis.diagnosis import diagnose_run
from eea.config import EEAConfig
from eea.encoding import MODEL_FIELD_BITS, decode_models, get_model_space
from eea.fitness import objective_fitness
from eea.record import MODEL_COLUMNS, load_result
from eea.run import run
from eea.search import ModelGA, model_search_from_state

NONZERO = get_model_space("morphology_nonzero")
STEP = MORPHOLOGY_BOUNDS[:, 1] / 2.0 ** np.array(MODEL_FIELD_BITS)    # one level of each field


def test_the_grid_is_the_papers_one_level_up():
    """Code k decodes to (k + 1) levels: all-zeros is one level (no 0), all-ones the top of the
    range; the paper's code k + 1 is this space's code k (every nonzero level kept)."""
    assert NONZERO.n_bits == 45 and not NONZERO.servos
    np.testing.assert_array_equal(NONZERO.decode(np.zeros(45, np.uint8)), STEP)
    np.testing.assert_array_equal(NONZERO.decode(np.ones((1, 45), np.uint8)), MORPHOLOGY_BOUNDS[:, 1][None])
    rng = np.random.default_rng(0)
    paper = rng.integers(0, 2, (200, 45), dtype=np.uint8)
    values = decode_models(paper)
    nonzero = values[np.all(values > 0, axis=1)]          # the paper's models with no zero dimension
    assert len(nonzero) > 20
    np.testing.assert_array_equal(NONZERO.decode(NONZERO.encode(nonzero)), nonzero)
    np.testing.assert_array_equal(NONZERO.decode(NONZERO.encode(nonzero)) - STEP, decode_models(
        NONZERO.encode(nonzero)))                         # the same code, one level apart


@pytest.mark.parametrize("damage", sorted(d for d in DAMAGES if np.all(get_damage(d).apply().to_array() > 0)))
def test_every_damage_that_keeps_its_flippers_is_an_exact_model(damage):
    truth = NONZERO.truth(damage)
    np.testing.assert_array_equal(NONZERO.decode(NONZERO.encode(truth)), truth)


def test_a_zero_size_flipper_is_refused_by_name():
    lost = get_damage("left_pectoral_missing").apply().to_array()
    with pytest.raises(ValueError, match="morphology_nonzero has no level below 0.03125 for left_pectoral_x"):
        NONZERO.encode(lost)
    too_long = NONZERO.truth("left_pectoral_half")
    too_long[1] = 2.01                                   # left pectoral length above its range's top, 2
    with pytest.raises(ValueError, match="left_pectoral_y = 2.01 is above its range's top 2.0"):
        NONZERO.encode(too_long)


def test_the_space_runs_only_with_the_papers_search():
    with pytest.raises(ValueError, match="morphology_nonzero.*estimation_search='ga' and lineages=1"):
        EEAConfig.from_flat({"model_space": "morphology_nonzero", "estimation_search": "cma"})
    with pytest.raises(ValueError, match="morphology_nonzero.*lineages=1"):
        EEAConfig.from_flat({"model_space": "morphology_nonzero", "lineages": 2})


def test_a_model_ga_keeps_its_space_through_its_state():
    ga = ModelGA(6, np.random.default_rng(0), model_space="morphology_nonzero")
    back = model_search_from_state(ga.state_dict(), np.random.default_rng(1))
    assert back.model_space is NONZERO
    old = {k: v for k, v in ModelGA(6, np.random.default_rng(0)).state_dict().items() if k != "model_space"}
    assert model_search_from_state(old, np.random.default_rng(1)).model_space.name == "morphology"  # by width


@pytest.mark.parametrize("inference", ["known", "out_of_band"])
def test_a_run_scores_and_records_models_of_the_nonzero_grid(tmp_path, tiny_config, inference):
    """A tiny run: rounds.csv holds the nonzero grid's values and their OBJ_FIT against the
    truth; the truth's genome, simulated by the run's evaluator, reproduces the target (MOD_FIT 1
    under the true angles: decoded on the paper's grid it would be one level off)."""
    config = tiny_config(model_space="morphology_nonzero", inference=inference)
    result = run(config, tmp_path, progress=False)
    assert load_result(tmp_path).config.model_space == "morphology_nonzero"
    best = np.array([[row[c] for c in MODEL_COLUMNS] for row in result.rounds])
    assert np.all(best >= STEP - 1e-12)
    np.testing.assert_array_equal(NONZERO.decode(NONZERO.encode(best)), best)   # values on the nonzero grid
    truth = NONZERO.truth(config.damage)
    np.testing.assert_allclose([row["objective_fitness"] for row in result.rounds],
                               objective_fitness(best, truth, NONZERO.bounds), rtol=0, atol=1e-12)
    d = diagnose_run(tmp_path)
    assert d.true_true_angles == 1.0
