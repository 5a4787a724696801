"""Tests of eea.ga.BitGA: the paper's generational GA with ask/tell (section 4)."""

import numpy as np
import pytest

from eea.ga import BitGA


def _run_onemax(ga, generations):
    best = []
    for _ in range(generations):
        genomes = ga.ask()
        ga.tell(genomes.sum(axis=1))
        best.append(ga.best_fitness)
    return best


def test_ask_shape_dtype_and_initial():
    ga = BitGA(45, 25, np.random.default_rng(0))
    x = ga.ask()
    assert x.shape == (25, 45) and x.dtype == np.uint8
    assert set(np.unique(x)) <= {0, 1}
    np.testing.assert_array_equal(ga.population, x)   # reading the population does not ask
    with pytest.raises(RuntimeError, match="ask\\(\\) called twice"):
        ga.ask()
    assert ga.generation == 0
    seed = np.ones((3, 45), np.uint8)
    ga = BitGA(45, 25, np.random.default_rng(0), initial=seed)
    np.testing.assert_array_equal(ga.ask()[:3], seed)


def test_deterministic_for_a_seed():
    runs = []
    for _ in range(2):
        ga = BitGA(18, 10, np.random.default_rng(42))
        _run_onemax(ga, 5)
        runs.append(ga.population)
    np.testing.assert_array_equal(runs[0], runs[1])
    other = BitGA(18, 10, np.random.default_rng(43))
    _run_onemax(other, 5)
    assert not np.array_equal(other.population, runs[0])

@pytest.mark.parametrize("seed", range(3))
def test_elitism_best_never_decreases_and_elite_is_first_row(seed):
    ga = BitGA(45, 25, np.random.default_rng(seed))
    previous = -1
    for _ in range(30):
        genomes = ga.ask()
        # The elite of the previous generation is carried unchanged as row 0.
        if ga.generation > 0:
            assert genomes[0].sum() == previous
        ga.tell(genomes.sum(axis=1))
        assert ga.best_fitness >= previous
        previous = ga.best_fitness
        np.testing.assert_array_equal(ga.best_genome, ga.population[0])


@pytest.mark.parametrize("seed", range(3))
def test_onemax_45_bits_population_25(seed):
    best = _run_onemax(BitGA(45, 25, np.random.default_rng(seed)), 100)
    assert best[-1] >= 40


@pytest.mark.parametrize("crossover", ["one_point", "uniform"])
def test_mutation_alone_flips_one_bit_per_genome_on_average(crossover):
    n_bits, pop = 45, 200
    start = np.zeros((pop, n_bits), np.uint8)
    ga = BitGA(n_bits, pop, np.random.default_rng(7), crossover=crossover,
               crossover_rate=0.0, elitism=0, initial=start)
    ga.ask()
    ga.tell(np.zeros(pop))             # all parents are all-zeros: children = mutations
    flipped = ga.ask().sum(axis=1)
    assert 0.8 < flipped.mean() < 1.2  # expected 1, std of the mean ~0.07
    assert flipped.var() > 0.5         # binomial(45, 1/45): variance ~0.98


def test_crossover_recombines_parents():
    pop, n_bits = 200, 20
    initial = np.zeros((pop, n_bits), np.uint8)
    initial[pop // 2:] = 1
    ga = BitGA(n_bits, pop, np.random.default_rng(8), crossover_rate=1.0, mutation_rate=0.0,
               elitism=0, tournament_size=1, initial=initial)
    ga.ask()
    ga.tell(np.zeros(pop))
    ones = ga.ask().sum(axis=1)
    mixed = (ones > 0) & (ones < n_bits)
    assert 0.3 < mixed.mean() < 0.7    # about half the pairs are 0/1 pairs, all crossed


def test_tournament_selection_prefers_fitter():
    pop = 100
    initial = np.zeros((pop, 1), np.uint8)
    initial[: pop // 2] = 1                    # half the genomes are "1"
    fitness = initial[:, 0].astype(float)      # and those are fitter
    ga = BitGA(1, pop, np.random.default_rng(9), mutation_rate=0.0, elitism=0,
               initial=initial)
    ga.ask()
    ga.tell(fitness)
    share = ga.ask().mean()
    assert 0.65 < share < 0.85                 # size-2 tournament: expected 1 - 0.5**2 = 0.75


def test_state_dict_round_trip_resumes_identically(tmp_path):
    rng = np.random.default_rng(1)
    ga = BitGA(18, 10, rng, elitism=2)
    _run_onemax(ga, 3)
    state = ga.state_dict()
    assert all(isinstance(v, (int, float, str, np.ndarray)) for v in state.values())
    rng_state = rng.bit_generator.state          # the caller checkpoints its rng too
    np.savez(tmp_path / "ga.npz", **state)
    with np.load(tmp_path / "ga.npz") as saved:
        loaded = {k: saved[k] for k in saved.files}
    resumed_rng = np.random.default_rng()
    resumed_rng.bit_generator.state = rng_state
    clone = BitGA.from_state_dict(loaded, resumed_rng)
    assert clone.generation == 3 and clone.best_fitness == ga.best_fitness
    np.testing.assert_array_equal(clone.best_genome, ga.best_genome)
    _run_onemax(ga, 2)
    _run_onemax(clone, 2)
    np.testing.assert_array_equal(clone.ask(), ga.ask())


def test_state_dict_before_tell_and_bad_keys():
    state = BitGA(5, 4, np.random.default_rng(0)).state_dict()
    clone = BitGA.from_state_dict(state, np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="before the first tell"):
        clone.best_genome
    with pytest.raises(ValueError, match="missing"):
        BitGA.from_state_dict({k: v for k, v in state.items() if k != "population"},
                              np.random.default_rng(0))


def test_misuse_raises():
    ga = BitGA(8, 4, np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="before the first tell"):
        ga.best_fitness
    with pytest.raises(RuntimeError, match="without a preceding ask"):
        ga.tell(np.zeros(4))
    ga.ask()
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        ga.tell(np.zeros(5))
    with pytest.raises(ValueError, match="NaN"):
        ga.tell(np.array([0.0, np.nan, 1.0, 2.0]))
    ga.tell(np.zeros(4))
    with pytest.raises(RuntimeError, match="without a preceding ask"):
        ga.tell(np.zeros(4))               # told twice


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"n_bits": 0}, "n_bits"),
        ({"population_size": 0}, "population_size"),
        ({"elitism": 5}, "elitism"),
        ({"tournament_size": 0}, "tournament_size"),
        ({"crossover_rate": 1.5}, "crossover_rate"),
        ({"mutation_rate": float("nan")}, "mutation_rate"),
        ({"crossover": "two_point"}, "crossover"),
        ({"initial": np.ones((5, 8))}, "initial"),
        ({"initial": np.full((2, 8), 2)}, "initial"),
        ({"rng": 0}, "rng"),
    ],
)
def test_bad_arguments_raise(kwargs, match):
    args = {"n_bits": 8, "population_size": 4, "rng": np.random.default_rng(0)} | kwargs
    with pytest.raises(ValueError, match=match):
        BitGA(**args)
