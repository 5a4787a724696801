"""eea.search.cma: CMA-ES over the nine morphology dimensions with the BitGA ask/tell interface."""

import pickle

import numpy as np
import pytest

from eea.search.cma import CMAModelSearch, carried_shape, genomes_to_unit, unit_to_genomes
from eea.config import EEAConfig
from aquafish_gym import MORPHOLOGY_BOUNDS as MODEL_BOUNDS
from eea.encoding import decode_models, encode_models
from eea.estimation import Estimation
from eea.ga import BitGA
from eea.inference import make_inference


def test_unit_to_genomes_picks_the_half_open_grid_cell():
    x = np.zeros((3, 9))
    x[1] = 1.0                       # the top end belongs to the top level
    x[2] = [0.5, 0.25, 0.2499, 0, 0, 0, 0, 0, 0.999]
    dims = decode_models(unit_to_genomes(x))
    np.testing.assert_array_equal(dims[0], MODEL_BOUNDS[:, 0])
    np.testing.assert_array_equal(dims[1], MODEL_BOUNDS[:, 1] * (1 - 1 / 2.0 ** np.array([5, 6, 4] * 3)))
    # lp_x 5 bits: floor(0.5 * 32) = 16 -> 0.5; lp_y 6 bits: 16 of 64 -> 0.5;
    # lp_z 4 bits: floor(0.2499 * 16) = 3 -> 0.5 * 3 / 16; c_z: floor(0.999 * 16) = 15 -> 15 / 16
    np.testing.assert_array_equal(dims[2], [0.5, 0.5, 0.09375, 0, 0, 0, 0, 0, 0.9375])


@pytest.mark.parametrize("x, match", [(np.zeros(9), "shape"), (np.full((1, 9), 1.01), "unit cube"),
                                      (np.full((1, 9), np.nan), "unit cube")])
def test_unit_to_genomes_rejects_bad_points(x, match):
    with pytest.raises(ValueError, match=match):
        unit_to_genomes(x)


def _ridge_fitness(target_dims):
    """An ill-conditioned diagonal ridge peaking at ``target_dims`` (normalised units)."""
    span = MODEL_BOUNDS[:, 1] - MODEL_BOUNDS[:, 0]
    u = np.ones(9) / 3.0

    def fitness(genomes):
        d = (decode_models(genomes) - target_dims) / span
        along = d @ u
        return -(np.sum(d**2, axis=1) + 100.0 * (np.sum(d**2, axis=1) - along**2))
    return fitness


def test_finds_the_exact_grid_optimum_of_a_diagonal_ridge():
    target = np.array([0.25, 0.5, 0.0625, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375])  # damaged robot
    fitness = _ridge_fitness(target)
    search = CMAModelSearch(25, np.random.default_rng(0))
    for _ in range(150):
        search.tell(fitness(search.ask()))
    np.testing.assert_array_equal(search.best_genome, encode_models(target))
    assert search.best_fitness == 0.0 and search.generation == 150


def test_elitism_carries_the_best_point_into_the_next_population():
    fitness = _ridge_fitness(np.full(9, 0.25))
    search = CMAModelSearch(10, np.random.default_rng(1))
    for _ in range(5):
        genomes = search.ask()
        np.testing.assert_array_equal(search.population, genomes)      # reading does not resample
        with pytest.raises(RuntimeError, match="ask\\(\\) called twice"):
            search.ask()
        search.tell(fitness(genomes))
        assert any((g == search.best_genome).all() for g in search.population)


def test_same_seed_same_search_and_state_round_trip_continues_identically():
    fitness = _ridge_fitness(np.full(9, 0.25))

    def trajectory(resume_at=None):
        search, out = CMAModelSearch(12, np.random.default_rng(7)), []
        for generation in range(12):
            if generation == resume_at:
                search = CMAModelSearch.from_state_dict(pickle.loads(pickle.dumps(search.state_dict())))
            genomes = search.ask()
            search.tell(fitness(genomes))
            out.append(genomes)
        return np.array(out)

    straight = trajectory()
    np.testing.assert_array_equal(trajectory(resume_at=5), straight)
    other = CMAModelSearch(12, np.random.default_rng(8)).ask()
    assert not np.array_equal(other, straight[0])


def test_bad_calls_raise():
    search = CMAModelSearch(4, np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="before the first tell"):
        search.best_genome
    with pytest.raises(RuntimeError, match="without a preceding ask"):
        search.tell(np.zeros(4))
    search.ask()
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        search.tell(np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        search.tell([0.0, np.nan, 0.0, 0.0])
    for kwargs, match in (({"population_size": 1}, "population_size"), ({"sigma0": 0.0}, "sigma0"),
                          ({"elitism": 2}, "elitism")):
        args = {"population_size": 4, **kwargs}
        with pytest.raises(ValueError, match=match):
            CMAModelSearch(args.pop("population_size"), np.random.default_rng(0), **args)
    with pytest.raises(ValueError, match="not a CMAModelSearch"):
        CMAModelSearch.from_state_dict(BitGA(45, 4, np.random.default_rng(0)).state_dict())


def test_estimation_uses_the_configured_search_and_restores_it(tiny_config, make_experiment):
    def estimation(config):
        return Estimation.from_settings(config.estimation, config.ga, config.model_space, np.random.default_rng(0))

    assert isinstance(estimation(tiny_config()).search, BitGA)
    est = estimation(tiny_config(estimation_search="cma"))
    assert isinstance(est.search, CMAModelSearch) and est.search.population_size == tiny_config().estimation.population

    class OnesEvaluator:
        def similarities(self, genomes, experiments, angles):
            return np.repeat(genomes.sum(axis=1, keepdims=True) / 45.0, len(experiments), axis=1)

    exps = [make_experiment(0)]
    est.run(exps, make_inference("known"), OnesEvaluator(), np.random.default_rng(1), 2)
    restored = Estimation.from_state_dict(est.state_dict(), np.random.default_rng(2))
    assert isinstance(restored.search, CMAModelSearch)
    np.testing.assert_array_equal(restored.search.ask(), est.search.ask())
    np.testing.assert_array_equal(restored.ranked_models(), est.ranked_models())


@pytest.mark.parametrize("changes, match", [({"estimation_search": "annealing"}, "valid names: ga, cma"),
                                            ({"cma_sigma": 0.0}, "cma_sigma"), ({"cma_sigma": 1.5}, "cma_sigma")])
def test_config_rejects_bad_search_settings(changes, match):
    with pytest.raises(ValueError, match=match):
        EEAConfig.from_flat({"estimation_search": "cma", **changes})


def test_restart_reopens_the_distribution_around_the_best_point():
    fitness = _ridge_fitness(np.full(9, 0.25))
    search = CMAModelSearch(10, np.random.default_rng(3), sigma0=0.3)
    search.restart()                                                   # no-op before any tell
    for _ in range(60):
        search.tell(fitness(search.ask()))
    converged = {g.tobytes() for g in search.population}
    best = search.best_genome
    search.restart()
    reopened = search.ask()
    np.testing.assert_array_equal(reopened[0], best)                  # the best point is kept
    assert len({g.tobytes() for g in reopened}) > len(converged)      # and the spread is back


def test_genomes_to_unit_is_the_cell_centre_and_inverts_unit_to_genomes():
    genomes = np.random.default_rng(0).integers(0, 2, (20, 45), dtype=np.uint8)
    x = genomes_to_unit(genomes)
    np.testing.assert_array_equal(unit_to_genomes(x), genomes)
    levels = 2.0 ** np.array([5, 6, 4] * 3)
    np.testing.assert_allclose(genomes_to_unit(encode_models(MODEL_BOUNDS[None, :, 0]))[0], 0.5 / levels)

def test_a_global_share_samples_beside_the_local_search_and_pulls_it_to_a_better_point():
    fitness = _ridge_fitness(np.full(9, 0.25))
    search = CMAModelSearch(10, np.random.default_rng(3), global_share=4)
    for _ in range(30):
        search.tell(fitness(search.ask()))
    incumbent = search.best_genome
    for round_ in range(2):
        search.restart()                                               # every restart: local + global
        genomes = search.ask()
        assert genomes.shape == (10, 45)
        np.testing.assert_array_equal(genomes[0], incumbent)           # local: at the best point
        span = MODEL_BOUNDS[:, 1] - MODEL_BOUNDS[:, 0]
        global_mean = MODEL_BOUNDS[:, 0] + span * search._global_es.mean
        assert np.abs((global_mean - decode_models(incumbent[None])[0]) / span).max() > 0.1  # elsewhere
        assert search._es.popsize == 6 and search._global_es.popsize == 4
        f = fitness(genomes)
        f[8] = f.max() + 1.0                                           # a global point is the best
        search.tell(f)
        assert search.best_fitness == f[8]
        nxt = search.ask()
        assert (nxt[:6] == genomes[8]).all(axis=1).any()               # injected into the local distribution
        assert (nxt[6:] == genomes[8]).all(axis=1).any()               # and the global one's own best
        assert search._es.countiter == search._global_es.countiter == 1  # each told its own points once
        search.tell(fitness(nxt))
        incumbent = search.best_genome
    resumed = CMAModelSearch.from_state_dict(pickle.loads(pickle.dumps(search.state_dict())))
    np.testing.assert_array_equal(resumed.ask(), search.ask())


def test_a_kept_global_share_restarts_at_its_own_best_and_at_random_every_kth_round():
    fitness = _ridge_fitness(np.full(9, 0.25))
    search = CMAModelSearch(10, np.random.default_rng(3), global_share=4, global_keep=3, carry_condition=100.0)
    for _ in range(5):
        search.tell(fitness(search.ask()))
    random_start = []
    for round_ in range(2, 9):                                         # rounds 2 ... 8
        previous_best = None if search._global_es is None else search._global_best_x.copy()
        search.restart()
        genomes = search.ask()
        kept = previous_best is not None and np.abs(search._global_es.mean - previous_best).max() < 0.05  # pycma's bounds move it a little
        random_start.append(not kept)
        if kept:                                                       # its last best is its first point
            assert (genomes[6:] == unit_to_genomes(previous_best[None])[0]).all(axis=1).any()
        search.tell(fitness(genomes))
    assert random_start == [True, False, False, True, False, False, True]   # rounds 2, 5 and 8 at random
    resumed = CMAModelSearch.from_state_dict(pickle.loads(pickle.dumps(search.state_dict())))
    search.restart(), resumed.restart()
    np.testing.assert_array_equal(resumed.ask(), search.ask())
    with pytest.raises(ValueError, match="global_keep > 0 needs a global_share"):
        CMAModelSearch(10, np.random.default_rng(0), global_keep=2)
    with pytest.raises(ValueError, match="cma_global_keep > 0 needs cma_global_share"):
        EEAConfig.from_flat({"estimation_search": "cma", "cma_global_keep": 2})

def test_a_global_share_leaves_two_points_to_each_distribution():
    for share in (1, 9):
        with pytest.raises(ValueError, match=r"global_share must be 0 or in .* = \[2, 8\]"):
            CMAModelSearch(10, np.random.default_rng(0), global_share=share)
    with pytest.raises(ValueError, match="cma_global_share must be 0 or in"):
        EEAConfig.from_flat({"cma_global_share": 24, "estimation_search": "cma"})
    with pytest.raises(ValueError, match="needs estimation_search='cma'"):
        EEAConfig.from_flat({"cma_global_share": 8})
    config = EEAConfig.from_flat({"cma_global_share": 8, "estimation_search": "cma"})
    assert CMAModelSearch.from_settings(config.estimation, config.ga, config.model_space,
                                        np.random.default_rng(0)).global_share == 8


def test_carried_shape_keeps_the_axes_scales_the_longest_to_one_and_floors_the_rest():
    rng = np.random.default_rng(0)
    axes, _ = np.linalg.qr(rng.standard_normal((4, 4)))
    covariance = 3.0 * (axes * np.array([1e-8, 1e-3, 0.1, 1.0])) @ axes.T
    shape = carried_shape(covariance, 100.0)
    values, vectors = np.linalg.eigh(shape)
    np.testing.assert_allclose(values, [0.01, 0.01, 0.1, 1.0], atol=1e-9)   # / 3, floored at 1 / 100
    np.testing.assert_allclose(shape @ axes, axes * np.array([0.01, 0.01, 0.1, 1.0]), atol=1e-9)  # same axes
    np.testing.assert_allclose(carried_shape(covariance, 1.0), np.eye(4), atol=1e-9)  # c = 1: isotropic
    for bad, match in ((np.ones((2, 3)), "square"), (np.full((2, 2), np.nan), "finite"), (-np.eye(2), "positive")):
        with pytest.raises(ValueError, match=match):
            carried_shape(bad, 10.0)
    with pytest.raises(ValueError, match="condition"):
        carried_shape(np.eye(2), 0.5)


def test_a_restart_with_carry_condition_samples_along_the_learned_ridge():
    fitness = _ridge_fitness(np.full(9, 0.25))
    searches = {c: CMAModelSearch(25, np.random.default_rng(2), carry_condition=c) for c in (0.0, 10.0)}
    for search in searches.values():
        for _ in range(40):
            search.tell(fitness(search.ask()))
    learned = searches[10.0]._es.sm.C
    principal = np.linalg.eigh(learned)[1][:, -1]
    assert abs(principal @ np.ones(9) / 3.0) > 0.9                      # the ridge: the all-ones diagonal
    assert np.linalg.cond(learned) > 20                                  # elongated beyond the cap below
    for c, search in searches.items():
        search.restart()
        values, vectors = np.linalg.eigh(search._es.sm.C)
        if c:
            assert abs(vectors[:, -1] @ principal) > 0.999               # the same longest axis
            assert values[-1] / values[0] == pytest.approx(10.0, rel=1e-3)  # capped at c
            assert search._es.sigma == pytest.approx(0.3)
        else:
            np.testing.assert_allclose(values, 1.0, rtol=1e-3)          # isotropic, as before
    with pytest.raises(ValueError, match="carry_condition"):
        CMAModelSearch(10, np.random.default_rng(0), carry_condition=0.5)
    with pytest.raises(ValueError, match="cma_carry_condition"):
        EEAConfig.from_flat({"cma_carry_condition": float("nan"), "estimation_search": "cma"})
    with pytest.raises(ValueError, match="needs estimation_search='cma'"):
        EEAConfig.from_flat({"cma_carry_condition": 100})


def test_flip_gains_injects_the_best_model_with_each_pectoral_gain_mirrored_at_a_restart():
    from eea.encoding import get_model_space

    space = get_model_space("morphology+servos")
    search = CMAModelSearch(10, np.random.default_rng(3), model_space=space.name, flip_gains=1)
    genomes = search.ask()
    fitness = np.arange(10, dtype=float)
    search.tell(fitness)
    best = space.decode(genomes[9:10])[0]                       # 12 values: 9 dimensions, 3 gains
    search.restart()
    after = space.decode(search.ask())
    for flipped in ([9], [10], [9, 10]):                         # left, right, both pectoral gains negated
        want = best.copy()
        want[flipped] = -best[flipped]
        assert any(np.allclose(row, want, atol=0.13) for row in after), flipped   # one 4-bit level (0.125)
    plain = CMAModelSearch(10, np.random.default_rng(3), model_space=space.name)
    plain.ask(), plain.tell(fitness), plain.restart()
    assert "flip_gains" not in vars(plain)                       # off: pickles as before
    with pytest.raises(ValueError, match="flip_gains needs the morphology\\+servos model space"):
        CMAModelSearch(10, np.random.default_rng(3), flip_gains=1)
    with pytest.raises(ValueError, match="cma_flip_gains = 1 needs model_space='morphology\\+servos'"):
        EEAConfig.from_flat({"estimation_search": "cma", "cma_flip_gains": 1})
