"""Batched NEAT fitness: a generation on the vector env scores every genome as the single env does."""

import random
import re

import neat
import numpy as np
import pytest
from gait_helpers import SHORT_S

from gait import evolve_gait
from gait.batch_fitness import BatchEvaluator, batch_fitness, genomes_per_world
from gait.fitness_task import FitnessTask, evaluate_genome
from gait.neat_evolution import load_neat_config, set_num_inputs
from gait.robots import as_robot
from gait.shared_pool import SharedPool
import gait.batch_fitness as batch_fitness_module


def _genomes(n: int, seed: int = 11, num_inputs: int = 14):
    state = random.getstate()
    try:
        config = load_neat_config(population_size=n)
        set_num_inputs(config, num_inputs)
        population = neat.Population(config, seed=seed)
    finally:
        random.setstate(state)
    return [population.population[k] for k in sorted(population.population)], config


def _single(genomes, config, task):
    return np.array([evaluate_genome(g, config, task=task) for g in genomes])


@pytest.mark.parametrize("robot, episodes, angles", [
    (as_robot("healthy"), 2, None),                         # the case study's K starts, drawn from seed, seed + 1
    (as_robot("reversed_left_pectoral"), 1, (0.3, -1.2, 0.1)),   # a damaged robot, fixed initial angles
    (as_robot("healthy", damage="random"), 2, None),        # a damage drawn per start from its seed
])
def test_every_genome_scores_as_evaluate_genome(robot, episodes, angles):
    genomes, config = _genomes(6)
    task = FitnessTask(robot, 3, angles, SHORT_S, episodes=episodes)
    batched = batch_fitness(genomes, config, task, max_world_robots=4)   # 2 or 3 worlds: slots beyond the origin
    np.testing.assert_allclose(batched, _single(genomes, config, task), rtol=0, atol=1e-9)
    assert len(set(batched.tolist())) == len(genomes)   # distinct genomes, distinct fitnesses (not one copied)


def test_a_robot_at_its_worlds_origin_is_exact():
    """With one robot per world, every sub-env is the single env's robot at the origin: bit-equal
    fitness, which checks that start k of genome j is seeded seed + k and driven by genome j."""
    genomes, config = _genomes(4)
    task = FitnessTask(as_robot("healthy"), 5, None, SHORT_S, episodes=2)
    np.testing.assert_array_equal(batch_fitness(genomes, config, task, max_world_robots=1),
                                  _single(genomes, config, task))


def test_another_task_scores_its_return():
    genomes, config = _genomes(3, num_inputs=16)
    task = FitnessTask(as_robot("healthy"), 2, None, SHORT_S, episodes=2, env_id="AquaFishHeading-v0")
    np.testing.assert_allclose(batch_fitness(genomes, config, task), _single(genomes, config, task),
                               rtol=0, atol=1e-9)


def test_fitness_does_not_depend_on_how_the_generation_is_split_over_workers(monkeypatch):
    genomes, config = _genomes(7)
    task = FitnessTask(as_robot("healthy"), 1, None, 1.0, episodes=2)
    pairs = list(enumerate(genomes))
    with BatchEvaluator(task, workers=1, max_world_robots=4) as serial:
        serial(pairs, config)
    in_process = [g.fitness for g in genomes]
    with BatchEvaluator(task, workers=3, max_world_robots=4) as pool:
        assert pool.chunks(7) == [slice(0, 2), slice(2, 4), slice(4, 7)]   # whole worlds of 2 genomes
        for g in genomes:
            g.fitness = None
        pool(pairs, config)
    assert [g.fitness for g in genomes] == in_process
    with SharedPool(2) as shared, BatchEvaluator(task, max_world_robots=4, shared=shared) as evaluate:
        assert evaluate.workers == 2 and evaluate.chunks(7) == [slice(0, 4), slice(4, 7)]
        for g in genomes:
            g.fitness = None
        evaluate(pairs, config)
        assert [g.fitness for g in genomes] == in_process
        genomes[6].fitness = None
        monkeypatch.setattr(batch_fitness_module, "batch_fitness", None)   # nothing scored in this process
        evaluate(pairs, config)                           # one world left to score: it goes to the pool too
        assert [g.fitness for g in genomes] == in_process


def test_genomes_with_a_fitness_keep_it_as_neats_elites_do():
    genomes, config = _genomes(3)
    task = FitnessTask(as_robot("healthy"), 0, None, 1.0)
    genomes[1].fitness = 123.0                         # an elite, scored in the generation before
    BatchEvaluator(task)(list(enumerate(genomes)), config)
    assert genomes[1].fitness == 123.0
    expected = batch_fitness([genomes[0], genomes[2]], config, task)
    assert [genomes[0].fitness, genomes[2].fitness] == expected.tolist()
    BatchEvaluator(task, keep_fitness=False)(list(enumerate(genomes)), config)
    assert genomes[1].fitness == pytest.approx(evaluate_genome(genomes[1], config, task=task), abs=1e-9)


def test_layout_and_bad_arguments():
    task = FitnessTask(as_robot("healthy"), 0, None, 1.0, episodes=3)
    assert genomes_per_world(task, 64) == 21 and genomes_per_world(task, 2) == 1
    assert BatchEvaluator(task, max_world_robots=6).chunks(5) == [slice(0, 5)]        # one process
    assert BatchEvaluator(task, workers=2, max_world_robots=6).chunks(1) == [slice(0, 1)]
    # the default world: a `quick` generation (30 genomes x 2 starts) is two worlds (16 and 14 genomes),
    # one for each of two processes; the paper's (150 x 3) is 15 worlds of 10 genomes
    quick = FitnessTask(as_robot("healthy"), 0, None, 1.0, episodes=2)
    assert genomes_per_world(quick) == 16
    assert BatchEvaluator(quick, workers=2).chunks(30) == [slice(0, 16), slice(16, 30)]
    assert genomes_per_world(task) == 10 and BatchEvaluator(task, workers=2).chunks(150) == [slice(0, 80), slice(80, 150)]
    genomes, config = _genomes(2)
    with pytest.raises(ValueError, match="at least one genome"):
        batch_fitness([], config, task)
    with pytest.raises(ValueError, match="max_world_robots"):
        batch_fitness(genomes, config, task, max_world_robots=0)
    with pytest.raises(ValueError, match="workers"):
        BatchEvaluator(task, workers=0)


def test_batched_evolution_is_the_single_env_evolution():
    """Same seed: the same genomes every generation and the same fitnesses to round-off."""
    kw = dict(population_size=8, seed=4, workers=1, episode_duration_s=1.0, episodes_per_genome=2, progress=False)
    single = evolve_gait(None, generations=4, batched=False, **kw)
    batched = evolve_gait(None, generations=4, **kw)
    for a, b in zip(single.history, batched.history):
        assert {k: v for k, v in a.items() if "fitness" not in k and k not in ("wall_time_s", "best_so_far")} == \
            {k: v for k, v in b.items() if "fitness" not in k and k not in ("wall_time_s", "best_so_far")}
        for key in ("best_fitness", "mean_fitness", "std_fitness", "best_so_far"):
            assert b[key] == pytest.approx(a[key], rel=0, abs=1e-9)
    assert str(batched.best_controller.genome) == str(single.best_controller.genome)


# -- starts at spread headings --------------------------------------------------------------------

def test_spread_headings_are_evenly_spaced_and_only_on_the_forward_task():
    task = FitnessTask(as_robot("healthy"), 0, None, SHORT_S, episodes=4, spread_headings=True)
    assert [task.start_yaw_deg(k) for k in range(4)] == [-135.0, -45.0, 45.0, 135.0]
    assert FitnessTask(as_robot("healthy"), 0, None, SHORT_S, episodes=2).start_yaw_deg(1) == 0.0
    with pytest.raises(ValueError, match="spread_headings needs the forward task 'AquaFish-v0'"):
        FitnessTask(as_robot("healthy"), 0, None, SHORT_S, episodes=2, env_id="AquaFishHeading-v0",
                    spread_headings=True)


def test_along_heading_by_hand():
    from gait.fitness_task import along_heading
    # heading +90 degrees (counter-clockwise from +y) points along -x
    assert along_heading([-2.0, 0.5], 90.0) == pytest.approx(2.0)
    assert along_heading([3.0, 4.0], 0.0) == pytest.approx(4.0)
    assert along_heading([1.0, 1.0], -45.0) == pytest.approx(np.sqrt(2.0))


def test_a_start_turned_scores_along_its_own_heading_on_both_paths():
    genomes, config = _genomes(4)
    plain = FitnessTask(as_robot("healthy"), 3, None, SHORT_S, episodes=2)
    spread = FitnessTask(as_robot("healthy"), 3, None, SHORT_S, episodes=2, spread_headings=True)
    batched = batch_fitness(genomes, config, spread, max_world_robots=4)
    np.testing.assert_allclose(batched, _single(genomes, config, spread), rtol=0, atol=1e-9)
    # by hand for genome 0: each start's displacement projected on its start heading (-90, +90)
    controller = spread.controller(genomes[0], config)
    by_hand = []
    for k, yaw in enumerate((-90.0, 90.0)):
        run = spread.run(controller, k)
        assert run.trajectory.shape[1] == 2
        dx, dy = run.trajectory[-1] - run.trajectory[0]
        by_hand.append(dx if yaw == -90.0 else -dx)        # -90 degrees heads +x, +90 heads -x
    assert batched[0] == pytest.approx(np.mean(by_hand), abs=1e-9)
    assert not np.allclose(batched, batch_fitness(genomes, config, plain, max_world_robots=4))


def test_evolve_gait_records_spread_headings(tmp_path):
    result = evolve_gait("healthy", generations=1, population_size=4, seed=0, out_dir=tmp_path / "g", workers=1,
                         episode_duration_s=SHORT_S, episodes_per_genome=2, spread_headings=True, progress=False)
    import json
    assert json.loads((tmp_path / "g" / "fitness_settings.json").read_text())["spread_headings"] is True
    assert json.loads((tmp_path / "g" / "run.json").read_text())["spread_headings"] is True
    from aquafish_gym.rundir import MismatchError
    with pytest.raises(MismatchError):
        evolve_gait("healthy", generations=2, population_size=4, seed=0, out_dir=tmp_path / "g", workers=1,
                    episode_duration_s=SHORT_S, episodes_per_genome=2, progress=False,
                    resume=str(sorted((tmp_path / "g" / "checkpoints").iterdir())[-1]))
    # the recorded best fitness is the spread task's score of the best controller (the single-env path)
    spread = FitnessTask(as_robot("healthy"), 0, None, SHORT_S, episodes=2, spread_headings=True)
    assert result.best_fitness == pytest.approx(spread.fitness(result.best_controller), abs=1e-9)
    first = spread.run(result.best_controller, 0)        # turned -90 degrees: scored along -90, not +y
    run_json = json.loads((tmp_path / "g" / "run.json").read_text())
    assert run_json["best_rollout_distance"] == pytest.approx(spread.score(first, 0), abs=1e-12)
    assert run_json["best_rollout_distance"] != pytest.approx(first.distance)


# -- starts turned by given headings, scored along +y (a mission's new gait) ------------------------

def test_starts_at_given_headings_score_along_plus_y_on_both_paths():
    genomes, config = _genomes(4)
    turned = FitnessTask(as_robot("reversed_left_pectoral"), 3, None, SHORT_S, episodes=3, start_yaws_deg=(60, -45))
    assert turned.start_yaws_deg == (60.0, -45.0)
    assert [turned.start_yaw_deg(k) for k in range(3)] == [60.0, -45.0, 60.0]  # cycled over the episodes
    batched = batch_fitness(genomes, config, turned, max_world_robots=4)
    np.testing.assert_allclose(batched, _single(genomes, config, turned), rtol=0, atol=1e-9)
    # by hand for genome 0: each start's displacement along +y, from starts turned 60, -45 and 60 degrees
    controller = turned.controller(genomes[0], config)
    runs = [turned.run(controller, k) for k in range(3)]
    assert batched[0] == pytest.approx(np.mean([r.trajectory[-1][1] - r.trajectory[0][1] for r in runs]), abs=1e-9)
    plain = FitnessTask(as_robot("reversed_left_pectoral"), 3, None, SHORT_S, episodes=2)
    assert not np.allclose(batched, batch_fitness(genomes, config, plain, max_world_robots=4))


@pytest.mark.parametrize("kwargs, message", [
    (dict(start_yaws_deg=(float("nan"),)), "start_yaws_deg must be a number of degrees in [-180, 180], got nan"),
    (dict(start_yaws_deg=("north",)), "start_yaws_deg must be a number of degrees in [-180, 180], got 'north'"),
    (dict(start_yaws_deg=(True,)), "start_yaws_deg must be a number of degrees in [-180, 180], got True"),
    (dict(start_yaws_deg=(0.0, 181.0)), "start_yaws_deg must be a number of degrees in [-180, 180], got 181.0"),
    (dict(start_yaws_deg=()), "start_yaws_deg must be a non-empty sequence of degrees in [-180, 180] or None, got ()"),
    (dict(start_yaws_deg=30.0), "start_yaws_deg must be a non-empty sequence of degrees in [-180, 180] or None, got 30.0"),
    (dict(start_yaws_deg=(30.0,), spread_headings=True), "give spread_headings or start_yaws_deg, not both"),
    (dict(start_yaws_deg=(30.0,), env_id="AquaFishHeading-v0"), "start_yaws_deg needs the forward task 'AquaFish-v0'"),
])
def test_a_bad_start_heading_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        FitnessTask(as_robot("healthy"), 0, None, SHORT_S, episodes=2, **kwargs)
