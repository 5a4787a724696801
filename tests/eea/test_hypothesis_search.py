"""eea.search.hypotheses: the design's fault hypotheses as the estimation's fixed candidates."""

import numpy as np
import pytest

from aquafish_gym import Morphology
from eea.diversity import model_distance
from eea.encoding import get_model_space
from eea.estimation import Estimation
from eea.inference.selection import fault_hypotheses
from eea.search import HypothesisSearch, make_model_search
from eea.search.hypotheses import hypothesis_genomes

SPACE = get_model_space("morphology+servos")


def test_the_population_is_every_distinct_hypothesis_healthy_first_then_farthest_first():
    genomes = hypothesis_genomes()
    expected = SPACE.encode(fault_hypotheses(Morphology.healthy().to_array()))
    assert genomes.shape == (97, 57)
    assert {g.tobytes() for g in genomes} == {g.tobytes() for g in expected}           # the same set, no duplicate
    np.testing.assert_allclose(SPACE.decode(genomes[:1])[0, 9:], [1.0, 1.0, 1.0])     # the healthy design first
    # each next one is the farthest (largest least distance) from those before it
    for k in (1, 2, 10):
        least = np.min([model_distance(genomes[k:], g) for g in genomes[:k]], axis=0)
        assert least[0] == pytest.approx(least.max())
    # the least distance to those before never grows along the order (greedy farthest-first)
    leasts = [np.min([model_distance(genomes[k], g) for g in genomes[:k]]) for k in range(1, 20)]
    assert all(a >= b - 1e-12 for a, b in zip(leasts, leasts[1:]))


def test_every_generation_offers_the_same_hypotheses_and_the_best_told_is_kept():
    search = HypothesisSearch()
    first = search.ask()
    fitness = np.linspace(0.0, 1.0, len(first))[::-1].copy()
    fitness[40] = 2.0
    search.tell(fitness)
    search.restart()                                    # a new round changes nothing
    np.testing.assert_array_equal(search.ask(), first)
    np.testing.assert_array_equal(search.best_genome, first[40])
    assert search.best_fitness == 2.0 and search.generation == 1


def test_bad_input_is_refused_with_what_was_wrong(tiny_config):
    with pytest.raises(ValueError, match=r"\(H >= 2, 57\) bits"):
        HypothesisSearch(np.zeros((3, 45), dtype=np.uint8))
    search = HypothesisSearch()
    search.ask()
    with pytest.raises(ValueError, match=r"\(97,\) finite"):
        search.tell(np.full(97, np.nan))
    config = tiny_config(estimation_search="hypotheses")           # the paper's 45-bit space
    with pytest.raises(ValueError, match="needs model_space='morphology\\+servos'"):
        make_model_search(config.estimation, config.ga, config.model_space, np.random.default_rng(0))


def test_the_estimation_ranks_the_hypotheses_and_hands_the_best_to_the_exploration(tiny_config):
    config = tiny_config(estimation_search="hypotheses", model_space="morphology+servos", inference="known")
    estimation = Estimation(make_model_search(config.estimation, config.ga, config.model_space,
                                              np.random.default_rng(0)))
    before = estimation.ranked_models(3)
    np.testing.assert_array_equal(before, hypothesis_genomes()[:3])    # before any ranking: the farthest-first order

    class Scores:       # an evaluator whose similarity is a fixed score per hypothesis
        simulations = 0
        score = {g.tobytes(): float(i % 7) / 10 for i, g in enumerate(hypothesis_genomes())}

        def similarities(self, genomes, experiments, angles):
            return np.array([[self.score[g.tobytes()]] * len(experiments) for g in genomes])

    from tests.eea.conftest import _make_experiment
    result = estimation.run([_make_experiment(0)], _Known(), Scores(), np.random.default_rng(0), 2)
    ranked = estimation.ranked_models(5)
    scores = [Scores.score[g.tobytes()] for g in ranked]
    assert scores == sorted(scores, reverse=True) and scores[0] == 0.6
    assert Scores.score[result.best_genome.tobytes()] == 0.6


class _Known:
    """A strategy that leaves the experiments alone and gives every model zero angles."""

    def begin_round(self, experiments):
        return experiments

    def before_generation(self, generation, ranked, experiments, evaluator, rng, genomes=None):
        return experiments

    def angles(self, experiments, genomes, rng):
        return np.zeros((len(genomes), len(experiments), 3))

    def after_generation(self, genomes, angles, fitness, experiments):
        return experiments

    def end_round(self, experiments):
        return experiments


def test_a_warm_start_puts_the_known_model_first_and_the_hypotheses_about_its_morphology_after():
    healthy = hypothesis_genomes()[0]
    search = HypothesisSearch()
    search.seed_at(healthy)
    np.testing.assert_array_equal(search.population, hypothesis_genomes())   # the healthy prior: the default
    shorter = SPACE.decode(healthy[None])[0]
    shorter[1] *= 0.5                                                          # a prior with a halved left flipper
    prior = SPACE.encode(shorter[None])[0]
    search.seed_at(prior)
    population = search.population
    np.testing.assert_array_equal(population[0], prior)
    assert len({g.tobytes() for g in population}) == len(population) == search.population_size
    expected = SPACE.encode(fault_hypotheses(SPACE.decode(prior[None])[0][:9]))
    assert {g.tobytes() for g in population} == {g.tobytes() for g in expected} | {prior.tobytes()}
    with pytest.raises(ValueError, match=r"\(57,\) genome"):
        search.seed_at(prior[:45])
