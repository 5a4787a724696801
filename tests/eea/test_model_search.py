"""eea.search: every registered search honours the same ask/tell contract."""

import pickle
import types

import numpy as np
import pytest

from eea.encoding import MODEL_BITS
from eea.estimation import Estimation
from eea.ga import BitGA
from eea.search import (MODEL_SEARCHES, SEARCH_NAMES, ModelGA, check_model_search, make_model_search,
                              model_search_from_state)


#: The model space each search is built in (the hypotheses hold servo gains).
_SPACES = {"hypotheses": "morphology+servos"}


@pytest.fixture(params=SEARCH_NAMES)
def search(request, tiny_config):
    config = tiny_config(estimation_search=request.param, model_space=_SPACES.get(request.param, "morphology"))
    return make_model_search(config.estimation, config.ga, config.model_space, np.random.default_rng(0))


def test_registry_names_and_unknown_name(tiny_config):
    assert SEARCH_NAMES == ("ga", "cma", "hypotheses") and all(cls.name == name for name, cls in MODEL_SEARCHES.items())
    with pytest.raises(ValueError, match="valid names: ga, cma, hypotheses"):
        make_model_search(types.SimpleNamespace(search="annealing"), tiny_config().ga, "morphology",
                          np.random.default_rng(0))
    with pytest.raises(ValueError, match="valid names: ga, cma, hypotheses"):
        model_search_from_state({"search": "annealing"}, np.random.default_rng(0))


def test_contract_misuse_raises_and_names_it(search):
    check_model_search(search)
    with pytest.raises(RuntimeError, match="before the first tell"):
        search.best_genome
    with pytest.raises(RuntimeError, match="without a preceding ask"):
        search.tell(np.zeros(search.population_size))
    peek = search.population
    genomes = search.ask()
    assert genomes.shape == (search.population_size, search.n_bits) and genomes.dtype == np.uint8
    assert search.n_bits == (MODEL_BITS if search.name != "hypotheses" else 57)
    np.testing.assert_array_equal(genomes, peek)                 # population is what ask returns
    with pytest.raises(RuntimeError, match="called twice"):
        search.ask()
    fitness = genomes.sum(axis=1).astype(float)                   # onemax
    search.tell(fitness)
    np.testing.assert_array_equal(search.best_genome, genomes[np.argmax(fitness)])
    assert search.best_fitness == fitness.max()
    with pytest.raises(RuntimeError, match="without a preceding ask"):
        search.tell(fitness)                                      # tell twice


def test_state_round_trip_continues_identically(search):
    for _ in range(3):
        search.tell(search.ask().sum(axis=1).astype(float))
    state = pickle.loads(pickle.dumps(search.state_dict()))
    assert state["search"] == search.name
    restored = model_search_from_state(state, np.random.default_rng(5))
    assert type(restored) is type(search)
    np.testing.assert_array_equal(restored.ask(), search.ask())


def test_a_plain_bit_ga_state_restores_as_the_model_ga():
    ga = BitGA(MODEL_BITS, 6, np.random.default_rng(0))
    restored = model_search_from_state(ga.state_dict(), np.random.default_rng(0))   # checkpoints before the registry
    assert isinstance(restored, ModelGA)
    np.testing.assert_array_equal(restored.population, ga.population)
    with pytest.raises(ValueError, match="45-bit"):
        model_search_from_state(BitGA(18, 6, np.random.default_rng(0)).state_dict(), np.random.default_rng(0))


def test_estimation_refuses_an_object_that_is_not_a_search():
    with pytest.raises(ValueError, match="lacks .*restart"):
        Estimation(object())
