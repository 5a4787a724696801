"""NEAT gait evolution: config, monotone best fitness, outputs, checkpoint resume."""

import json
import pickle
import shutil

import numpy as np
import pytest

from gait import evolve_gait, evolve_or_load_gait, latest_checkpoint, load_controller, load_neat_config, rollout
from gait.neat_evolution import DEFAULT_CONFIG

TINY = dict(population_size=6, seed=3, workers=1, episode_duration_s=1.0, checkpoint_every=1, verbose=False)


def _strip_time(history):
    return [{k: v for k, v in h.items() if k != "wall_time_s"} for h in history]


def test_default_config():
    config = load_neat_config()
    assert (config.genome_config.num_inputs, config.genome_config.num_outputs) == (14, 3)
    assert config.pop_size == 50 and config.no_fitness_termination
    assert config.reproduction_config.elitism >= 1
    assert load_neat_config(population_size=7).pop_size == 7


def test_pickling_the_config_does_not_skip_node_ids():
    """neat-python 2.0.0's genome config advanced its node-id counter on every pickle, so a
    checkpoint, a saved controller or a batch sent to a worker changed the genomes that
    followed (a parallel run drifted from the serial one after ~6 generations)."""
    config = load_neat_config()
    nodes = {0: None, 1: None, 2: None}
    assert config.genome_config.get_new_node_key(nodes) == 3
    copy = pickle.loads(pickle.dumps(config))
    pickle.dumps(config)
    assert config.genome_config.get_new_node_key(nodes) == 4
    assert copy.genome_config.get_new_node_key(nodes) == 4
    assert pickle.loads(pickle.dumps(copy)).genome_config.get_new_node_key(nodes) == 5


@pytest.mark.parametrize("section, line, match", [
    ("[DefaultGenome]", "weight_mutate_rat = 0.5", "unknown \\[DefaultGenome\\] key"),
    ("[NEAT]", "pop_sise = 5", "Unknown .*pop_sise"),
])
def test_config_unknown_keys_raise(tmp_path, section, line, match):
    text = DEFAULT_CONFIG.read_text().replace(f"\n{section}\n", f"\n{section}\n{line}\n", 1)
    path = tmp_path / "bad.ini"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        load_neat_config(path)


def test_config_errors(tmp_path):
    with pytest.raises(ValueError, match="no NEAT config"):
        load_neat_config(tmp_path / "missing.ini")
    with pytest.raises(ValueError, match="population_size"):
        load_neat_config(population_size=1)


def test_evolution_never_loses_the_best_and_writes_outputs(tmp_path):
    out = tmp_path / "run"
    result = evolve_gait(None, generations=4, out_dir=out, **TINY)
    best = [h["best_fitness"] for h in result.history]
    assert [h["generation"] for h in result.history] == [0, 1, 2, 3]
    assert all(b2 >= b1 for b1, b2 in zip(best, best[1:])), best  # elitism + deterministic fitness
    assert result.best_fitness == max(best) == result.history[-1]["best_so_far"]
    # the fitness comes from the batched vector env: equal to the single env's episode to round-off
    assert result.best_rollout.distance == pytest.approx(result.best_fitness, rel=0, abs=1e-9)
    assert result.history[-1]["evaluations"] == 4 * 6
    for name in ("best_controller.json", "best_genome.txt", "fitness_history.json", "fitness_history.png",
                 "run.json", "neat_config.ini"):
        assert (out / name).is_file(), name
    assert json.loads((out / "fitness_history.json").read_text()) == result.history
    summary = json.loads((out / "run.json").read_text())
    assert summary["population_size"] == 6 and summary["generations"] == 4
    loaded = load_controller(out)
    again = rollout(loaded, seed=TINY["seed"], episode_duration_s=TINY["episode_duration_s"])
    assert again.distance == pytest.approx(result.best_fitness, rel=0, abs=1e-9)
    np.testing.assert_array_equal(again.initial_angles, result.initial_angles)


def test_checkpoint_resume_continues_the_same_run(tmp_path):
    full = evolve_gait(None, generations=4, out_dir=tmp_path / "a", **TINY)
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    checkpoint = tmp_path / "b" / "checkpoints" / "neat-checkpoint-2"
    resumed = evolve_gait(None, generations=4, out_dir=tmp_path / "b", resume=checkpoint, **TINY)
    assert _strip_time(resumed.history) == _strip_time(full.history)
    assert resumed.best_fitness == full.best_fitness and resumed.generations == 4
    assert latest_checkpoint(tmp_path / "b").name == "neat-checkpoint-4"
    with pytest.raises(ValueError, match="generations must exceed"):
        evolve_gait(None, generations=4, out_dir=tmp_path / "b", resume=latest_checkpoint(tmp_path / "b"), **TINY)
    with pytest.raises(ValueError, match="cannot resume"):  # other fitness settings in the same run directory
        evolve_gait(None, generations=5, out_dir=tmp_path / "b", resume=latest_checkpoint(tmp_path / "b"), **(TINY | dict(seed=4)))


def test_parallel_evaluation_matches_serial():
    kw = TINY | dict(population_size=4)
    serial = evolve_gait(None, generations=2, **kw)
    parallel = evolve_gait(None, generations=2, **(kw | dict(workers=2)))
    assert _strip_time(parallel.history) == _strip_time(serial.history)


@pytest.mark.parametrize("kwargs, match", [
    (dict(generations=0), "generations"),
    (dict(workers=0), "workers"),
    (dict(damage="nope"), "unknown damage"),
    (dict(resume="/nonexistent/ckpt"), "no NEAT checkpoint"),
])
def test_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        evolve_gait(None, **(TINY | dict(generations=1) | kwargs))


def test_several_episodes_per_genome_average_starts():
    result = evolve_gait(None, generations=1, episodes_per_genome=2, **(TINY | dict(population_size=4)))
    c, kw = result.best_controller, dict(episode_duration_s=TINY["episode_duration_s"])
    expected = np.mean([rollout(c, seed=TINY["seed"], **kw).distance, rollout(c, seed=TINY["seed"] + 1, **kw).distance])
    assert result.best_fitness == pytest.approx(expected, abs=1e-12)
    with pytest.raises(ValueError, match="episodes"):
        evolve_gait(None, generations=1, episodes_per_genome=2, initial_angles=[0.0, 0.0, 0.0], **TINY)


def test_evolve_or_load_gait_reuses_a_finished_run_and_resumes_an_interrupted_one(tmp_path):
    full = evolve_gait(None, generations=3, out_dir=tmp_path / "a", **TINY)
    # finished: loaded, not evolved again
    loaded = evolve_or_load_gait(None, tmp_path / "a", generations=3, **TINY)
    assert rollout(loaded, seed=3, episode_duration_s=1.0).distance == pytest.approx(full.best_fitness)
    # another budget is refused, naming the field (it must not be reused under the new budget's label)
    with pytest.raises(ValueError, match="generations: 3 -> 99"):
        evolve_or_load_gait(None, tmp_path / "a", generations=99, **TINY)
    # interrupted after generation 2 (no run.json, later checkpoints gone): resumed to the same result
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    (tmp_path / "b" / "run.json").unlink()
    (tmp_path / "b" / "checkpoints" / "neat-checkpoint-3").unlink()
    resumed = evolve_or_load_gait(None, tmp_path / "b", generations=3, **TINY)
    assert json.loads((tmp_path / "b" / "run.json").read_text())["best_fitness"] == full.best_fitness
    assert rollout(resumed, seed=3, episode_duration_s=1.0).distance == pytest.approx(full.best_fitness)


def test_neat_on_another_task_gets_its_inputs_and_scores_its_return(tmp_path):
    result = evolve_gait(None, generations=1, env_id="AquaFishHeading-v0", episodes_per_genome=2,
                         out_dir=tmp_path, **(TINY | dict(population_size=4)))
    c = result.best_controller
    assert c.config.genome_config.num_inputs == 16                     # 14 task observations + the clock
    kw = dict(episode_duration_s=TINY["episode_duration_s"], env_id="AquaFishHeading-v0")
    returns = [rollout(c, seed=TINY["seed"] + k, **kw).episode_return for k in range(2)]
    assert result.best_fitness == pytest.approx(np.mean(returns), abs=1e-12)   # the return, not the distance
    assert json.loads((tmp_path / "run.json").read_text())["env_id"] == "AquaFishHeading-v0"
    # the evolved network can be reloaded, and refuses an observation of another task
    loaded = load_controller(tmp_path / "best_controller.json")
    with pytest.raises(ValueError, match="takes 14 observation entries, got 12"):
        loaded.act(np.zeros(12), 0.0)
    with pytest.raises(ValueError, match="unknown env id"):
        evolve_gait(None, generations=1, env_id="CartPole-v1", **TINY)


def test_a_run_killed_after_its_final_checkpoint_is_finished_by_resuming(tmp_path, monkeypatch, capsys):
    """Issue: a kill -9 between the final checkpoint and run.json left a run that `--resume latest`
    (checkpoint already at `generations`), a plain rerun (a run is there) and evolve_or_load_gait
    (case-study, damages) all refused. Resuming now finishes it from the saved history and controller."""
    from aquafish.cli import main
    from gait import neat_evolution

    full = evolve_gait(None, generations=2, out_dir=tmp_path / "full", **TINY)

    def killed(*args, **kwargs):
        raise KeyboardInterrupt("killed after the final checkpoint")

    monkeypatch.setattr(neat_evolution, "_write_outputs", killed)
    for name in ("cli", "api"):
        with pytest.raises(KeyboardInterrupt):
            evolve_gait(None, generations=2, out_dir=tmp_path / name, **TINY)
        assert latest_checkpoint(tmp_path / name).name == "neat-checkpoint-2"
        assert not (tmp_path / name / "run.json").exists()
    monkeypatch.undo()

    # no new generation is run: evaluating a genome would fail
    monkeypatch.setattr(neat_evolution, "evaluate_genome", lambda *a, **k: pytest.fail("evaluated a genome"))
    monkeypatch.setattr(neat_evolution, "BatchEvaluator", lambda *a, **k: pytest.fail("evaluated a generation"))
    assert main(["gait", "--out", str(tmp_path / "cli"), "--resume", "latest", "--generations", "2",
                 "--population-size", "6", "--seed", "3", "--workers", "1", "--episode-duration-s", "1",
                 "--quiet"]) == 0
    loaded = evolve_or_load_gait(None, tmp_path / "api", generations=2, **TINY)
    for name in ("cli", "api"):
        run = json.loads((tmp_path / name / "run.json").read_text())
        assert run["best_fitness"] == full.best_fitness and run["generations"] == 2
        assert _strip_time(json.loads((tmp_path / name / "fitness_history.json").read_text())) == \
            _strip_time(full.history)
    assert rollout(loaded, seed=3, episode_duration_s=1.0).distance == pytest.approx(full.best_fitness, rel=0, abs=1e-9)
    # a checkpoint beyond the asked budget is refused naming the run directory
    (tmp_path / "api" / "run.json").unlink()
    with pytest.raises(ValueError, match=f"{tmp_path / 'api'}.*generation 2"):
        evolve_or_load_gait(None, tmp_path / "api", generations=1, **TINY)
