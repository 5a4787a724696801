"""gait.rehearsal: the candidates of a new gait's evolution, swum on the self-model from the robot's yaw."""

import copy
import types

import numpy as np
import pytest

from gait import evolve_from_population, evolve_gait, rollout
from gait.rehearsal import TopGenomes, rehearse
from gait.robots import as_robot

KW = dict(seed=3, episode_duration_s=0.5)


@pytest.fixture(scope="module")
def evolved(tmp_path_factory):
    """Two more generations of a 6-genome run on a damaged robot, keeping the best 2 of each."""
    run = tmp_path_factory.mktemp("rehearsal") / "run"
    evolve_gait(None, generations=1, population_size=6, workers=1, checkpoint_every=1, progress=False, out_dir=run, **KW)
    return evolve_from_population(as_robot("reversed_left_pectoral"), run, 2, keep_top=2, **KW)


def test_top_genomes_keeps_each_generations_fittest_once():
    def genome(key, fitness):
        return types.SimpleNamespace(key=key, fitness=fitness)

    top = TopGenomes(2)
    top.post_evaluate(None, {k: genome(k, f) for k, f in [(1, 0.5), (2, 2.0), (3, 1.0)]}, None, None)
    top.post_evaluate(None, {k: genome(k, f) for k, f in [(2, 2.0), (4, 3.0), (5, -1.0)]}, None, None)
    assert list(top.kept) == [2, 3, 4]  # first evaluation: 2 and 3; second: 4 (2 is kept already)
    assert top.generations == {2: 0, 3: 0, 4: 1}  # each where it was first kept, the first generation 0
    with pytest.raises(ValueError, match="top"):
        TopGenomes(0)


def test_the_evolution_keeps_its_generations_fittest_as_candidates(evolved):
    keys = [c.genome.key for c in evolved.candidates]
    assert 2 <= len(keys) <= 4 and len(set(keys)) == len(keys)  # 2 a generation, each genome once
    assert evolved.best_controller.genome.key in keys
    # 3 evaluations (the restored population, then 2 generations), in order, the first one's 2 fittest first
    gens = evolved.candidate_generations
    assert len(gens) == len(keys) and gens[:2] == [0, 0] and gens == sorted(gens) and set(gens) <= {0, 1, 2}


def test_rehearse_keeps_the_candidate_that_swims_furthest_along_plus_y_from_the_yaw(evolved):
    """Each score is the mean +y displacement of the single-env swims from that heading, flipper
    angles drawn from seeds 7 and 8; the chosen candidate is the argmax."""
    robot = as_robot("reversed_left_pectoral")
    result = rehearse(evolved.candidates, robot, start_yaw_deg=-150.0, duration_s=0.6, seed=7, draws=2)
    expected = [np.mean([rollout(c, robot, seed=7 + k, episode_duration_s=0.6, initial_yaw_deg=-150.0).distance
                         for k in range(2)]) for c in evolved.candidates]
    np.testing.assert_allclose(result.scores, expected, rtol=0, atol=1e-9)
    assert result.index == int(np.argmax(expected)) and result.controller is evolved.candidates[result.index]


def test_rehearse_refuses_bad_input_naming_it(evolved):
    robot = as_robot("reversed_left_pectoral")
    kw = dict(start_yaw_deg=0.0, duration_s=0.5, seed=0)
    with pytest.raises(ValueError, match="at least one candidate"):
        rehearse([], robot, **kw)
    with pytest.raises(ValueError, match="duration_s"):
        rehearse(evolved.candidates, robot, **{**kw, "duration_s": 0.0})
    with pytest.raises(ValueError, match="draws"):
        rehearse(evolved.candidates, robot, draws=0, **kw)
    with pytest.raises(ValueError, match=r"start_yaws_deg must be a number of degrees in \[-180, 180\]"):
        rehearse(evolved.candidates, robot, **{**kw, "start_yaw_deg": 200.0})
    foreign = copy.copy(evolved.candidates[0])  # a controller of another config
    foreign.config = copy.copy(foreign.config)
    with pytest.raises(ValueError, match="one NEAT config"):
        rehearse([evolved.candidates[0], foreign], robot, **kw)
