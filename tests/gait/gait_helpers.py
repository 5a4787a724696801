"""Shared helpers of the gait tests (a uniquely named module, importable beside the tests)."""

import random

import neat

from gait import NEATController, load_neat_config

#: Short episodes keep the default test run fast; the gait fitness itself defaults to 20 s.
SHORT_S = 2.0


def random_controller(seed: int) -> NEATController:
    """The first genome of a fresh NEAT population seeded with ``seed``, as a controller."""
    state = random.getstate()
    try:
        config = load_neat_config(population_size=2)
        population = neat.Population(config, seed=seed)
        genome = population.population[min(population.population)]
    finally:
        random.setstate(state)
    return NEATController(genome, config)
