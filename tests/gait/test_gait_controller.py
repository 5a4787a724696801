"""Controllers clip what their network or policy outputs to the action range [-1, 1]."""

import copy

import gymnasium as gym
import neat
import numpy as np
import pytest

from gait import NEATController, SB3PolicyController, with_clock


def test_neat_controller_clips_the_raw_network_output(controller):
    """Outputs 0 and 1 made identity nodes with biases 3 and -2.5 and no inputs: raw values outside [-1, 1]."""
    genome = copy.deepcopy(controller.genome)
    out_keys = controller.config.genome_config.output_keys
    for key, bias in zip(out_keys, (3.0, -2.5, 0.25)):
        node = genome.nodes[key]
        node.activation, node.aggregation, node.bias, node.response = "identity", "sum", bias, 1.0
    for conn in genome.connections.values():
        if conn.key[1] in out_keys[:2]:
            conn.weight = 0.0
    c = NEATController(genome, controller.config)
    obs = np.random.default_rng(0).normal(size=12)
    inputs = with_clock(obs, 0.3, c.clock_period_s).tolist()
    raw = np.array(neat.nn.FeedForwardNetwork.create(genome, controller.config).activate(inputs))
    assert raw[0] == 3.0 and raw[1] == -2.5
    np.testing.assert_array_equal(c.act(obs, 0.3), [1.0, -1.0, np.clip(raw[2], -1.0, 1.0)])


class _StubModel:
    """Stands in for an SB3 model: a fixed action, and a record of what ``predict`` saw."""

    observation_space = gym.spaces.Box(-np.inf, np.inf, (14,))

    def __init__(self, action):
        self.action = np.asarray(action, dtype=np.float32)
        self.seen = []

    def predict(self, obs, state=None, episode_start=None, deterministic=False):  # SB3's signature
        self.seen.append((np.array(obs), deterministic, state, np.array(episode_start)))
        return self.action, len(self.seen)  # a recurrent model returns its next hidden state


def test_sb3_controller_clips_the_policy_action_and_feeds_the_clock():
    model = _StubModel([2.0, -1.5, 0.5])
    c = SB3PolicyController(model, clock_period_s=2.0)
    obs = np.random.default_rng(1).normal(size=12)
    action = c.act(obs, 0.5)
    assert action.dtype == np.float64
    np.testing.assert_array_equal(action, [1.0, -1.0, 0.5])
    (seen, deterministic, _, _), = model.seen
    np.testing.assert_array_equal(seen, with_clock(obs, 0.5, 2.0))
    assert deterministic is True


def test_sb3_controller_carries_the_policy_state_through_an_episode_and_clears_it_at_reset():
    model = _StubModel([0.0, 0.0, 0.0])
    c = SB3PolicyController(model)
    for _ in range(3):
        c.act(np.zeros(12), 0.0)
    c.reset()
    c.act(np.zeros(12), 0.0)
    states = [state for _, _, state, _ in model.seen]
    starts = [start.tolist() for _, _, _, start in model.seen]
    assert states == [None, 1, 2, None]  # each call gets the state the last one returned
    assert starts == [[True], [False], [False], [True]]


def test_heading_hold_eases_the_paddle_on_the_side_it_must_turn_to():
    import math

    from gait import HeadingHoldController

    c = HeadingHoldController(base=(-1.0, -1.0, 1.0), gain=2.0)
    obs = np.zeros(12)
    obs[3:6] = 1.0                                                  # level, on the initial heading
    np.testing.assert_array_equal(c.act(obs, 0.0), [-1.0, -1.0, 1.0])
    yaw = math.radians(15)                                          # turned left: steer right
    obs[2], obs[5] = math.sin(yaw), math.cos(yaw)
    np.testing.assert_allclose(c.act(obs, 0.0), [-1.0, -1.0 + 2.0 * yaw, 1.0])
    obs[2] = -obs[2]                                                # turned right: steer left
    np.testing.assert_allclose(c.act(obs, 0.0), [-1.0 + 2.0 * yaw, -1.0, 1.0])
    with pytest.raises(ValueError, match="gain"):
        HeadingHoldController(gain=-1.0)


def test_heading_hold_keeps_a_half_left_pectoral_on_course_where_the_open_loop_command_veers():
    from gait import ConstantController, HeadingHoldController
    from gait.rollout import rollout

    # the surface swimmer's paddles turn a robot with a weaker left paddle left; over 40 s the
    # open-loop command loses its heading, the feedback keeps it
    hold = rollout(HeadingHoldController(), "left_pectoral_half", seed=3, episode_duration_s=40.0)
    open_loop = rollout(ConstantController((-1.0, -1.0, 1.0)), "left_pectoral_half", seed=3, episode_duration_s=40.0)
    assert hold.distance > 1.5 * open_loop.distance
    dx, dy = hold.trajectory[-1, :2] - hold.trajectory[0, :2]
    assert abs(dx) < dy                                             # within 45 deg of the initial heading


# -- no file a user may receive from someone else runs code when loaded -------------------------------------

class _Payload:
    """Pickles to a call that creates the directory ``marker`` when it is unpickled."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        import os
        return os.mkdir, (self.marker,)


def test_a_saved_neat_controller_is_json_and_loads_bit_for_bit(tmp_path, controller):
    import json

    from gait import evolve_gait, load_controller
    from gait.controller import NEAT_CONTROLLER_FILE

    evolved = evolve_gait(None, generations=3, population_size=6, seed=3, workers=1, episode_duration_s=1.0,
                          progress=False).best_controller
    rng = np.random.default_rng(0)
    for original in (controller, evolved):
        path = original.save(tmp_path / NEAT_CONTROLLER_FILE)
        data = json.loads(path.read_text())  # data, not a pickle
        assert NEAT_CONTROLLER_FILE == "best_controller.json"
        assert {"format", "version", "clock_period_s", "num_inputs", "neat_config", "genome"} <= set(data)
        assert {"key", "bias", "response", "activation", "aggregation"} <= set(data["genome"]["nodes"][0])
        assert {"key", "weight", "enabled"} <= set(data["genome"]["connections"][0])
        loaded = load_controller(path)
        assert repr(loaded) == repr(original)
        for _ in range(5):
            obs, t = rng.normal(size=12), float(rng.uniform(0, 5))
            assert loaded.act(obs, t).tobytes() == original.act(obs, t).tobytes()
        assert load_controller(tmp_path).act(obs, t).tobytes() == original.act(obs, t).tobytes()  # the run directory


def test_load_controller_refuses_a_pickle_without_unpickling_it(tmp_path, controller):
    import pickle

    from aquafish_gym.rundir import FileError
    from gait import load_controller

    marker = tmp_path / "ran"
    evil = tmp_path / "evil.pkl"
    evil.write_bytes(pickle.dumps(_Payload(marker)))
    with pytest.raises(ValueError, match="not loaded, because unpickling runs code.*best_controller.json") as err:
        load_controller(evil)
    assert "\n" not in str(err.value)
    (tmp_path / "run").mkdir()
    (tmp_path / "run" / "best_controller.pkl").write_bytes(pickle.dumps(_Payload(marker)))
    with pytest.raises(ValueError, match="runs code"):
        load_controller(tmp_path / "run")
    assert not marker.exists()
    pickle.loads(evil.read_bytes())  # the payload does run when unpickled
    assert marker.exists()
    # the documented one-off conversion of one's own pickle
    own = tmp_path / "own.pkl"
    own.write_bytes(pickle.dumps(controller))
    pickle.load(open(own, "rb")).save(tmp_path / "own.json")
    assert load_controller(tmp_path / "own.json").act(np.zeros(12), 0.3).tobytes() == \
        controller.act(np.zeros(12), 0.3).tobytes()
    (tmp_path / "bad.json").write_text('{"format": "something else"}')
    with pytest.raises(FileError, match="bad.json.*not a NEAT controller"):
        load_controller(tmp_path / "bad.json")


def test_a_neat_checkpoint_is_unpickled_only_in_a_run_directory_whose_manifest_matches(tmp_path):
    import gzip
    import pickle
    import shutil

    from gait import evolve_gait, latest_checkpoint

    kw = dict(population_size=4, seed=3, workers=1, episode_duration_s=0.5, checkpoint_every=1, progress=False)
    evolve_gait(None, generations=1, out_dir=tmp_path / "run", **kw)
    marker = tmp_path / "ran"
    checkpoint = latest_checkpoint(tmp_path / "run")
    with gzip.open(checkpoint, "wb") as f:
        pickle.dump(_Payload(marker), f)
    # other settings than the manifest's: refused before the checkpoint is read
    with pytest.raises(ValueError, match="neat-checkpoint-1.*seed: 3 -> 4.*fitness_settings.json"):
        evolve_gait(None, generations=2, out_dir=tmp_path / "run", resume=checkpoint, **(kw | dict(seed=4)))
    with pytest.raises(ValueError, match="population"):
        evolve_gait(None, generations=2, out_dir=tmp_path / "run", resume=checkpoint, **(kw | dict(population_size=5)))
    # a checkpoint outside a run directory, or in one without a manifest
    shutil.copy(checkpoint, tmp_path / "neat-checkpoint-1")
    with pytest.raises(ValueError, match="trust"):
        evolve_gait(None, generations=2, out_dir=tmp_path / "other", resume=tmp_path / "neat-checkpoint-1", **kw)
    (tmp_path / "run" / "fitness_settings.json").unlink()
    with pytest.raises(ValueError, match="fitness_settings.json"):
        evolve_gait(None, generations=2, out_dir=tmp_path / "run", resume=checkpoint, **kw)
    assert not marker.exists()


def test_evolve_from_population_continues_a_runs_final_population_on_another_robot(tmp_path):
    """The final population's generation count carries on (1 + 1 = 2), the fitness is the new robot's
    (every restored genome scored anew: the best fitness is the best controller's distance on
    the new robot, not a fitness it kept from the old one), nothing is written."""
    from gait import evolve_from_population, evolve_gait, rollout
    from gait.robots import as_robot

    kw = dict(seed=3, episode_duration_s=0.5)
    evolve_gait(None, generations=1, population_size=4, workers=1, checkpoint_every=1, progress=False,
                out_dir=tmp_path / "run", **kw)
    before = sorted(p.name for p in (tmp_path / "run").rglob("*"))
    damaged = as_robot("reversed_left_pectoral")
    result = evolve_from_population(damaged, tmp_path / "run", 1, **kw)
    assert result.generations == 2 and [h["generation"] for h in result.history] == [1]
    assert result.robot == damaged and result.out_dir is None
    again = rollout(result.best_controller, damaged, seed=3, episode_duration_s=0.5)
    assert again.distance == result.best_rollout.distance
    assert result.best_fitness == pytest.approx(again.distance, abs=1e-9)  # the batched path's round-off
    assert sorted(p.name for p in (tmp_path / "run").rglob("*")) == before
    with pytest.raises(ValueError, match="generations"):
        evolve_from_population(damaged, tmp_path / "run", 0, **kw)
    with pytest.raises(ValueError, match="final_population.json: does not exist"):  # read as data, never a checkpoint
        evolve_from_population(damaged, tmp_path / "empty", 1, **kw)


def test_evolve_from_population_from_given_headings_scores_along_plus_y(tmp_path):
    """A mission's new gait: episode k starts turned by ``start_yaws_deg[k]`` and the fitness
    is the mean distance along +y (the single-env rollouts from those headings give it)."""
    from gait import evolve_from_population, evolve_gait, rollout
    from gait.robots import as_robot

    kw = dict(seed=3, episode_duration_s=0.5)
    evolve_gait(None, generations=1, population_size=4, workers=1, checkpoint_every=1, progress=False,
                out_dir=tmp_path / "run", **kw)
    damaged = as_robot("reversed_left_pectoral")
    result = evolve_from_population(damaged, tmp_path / "run", 1, start_yaws_deg=(-120.0, 30.0),
                                    episodes_per_genome=2, **kw)
    turned = [rollout(result.best_controller, damaged, seed=3 + k, episode_duration_s=0.5, initial_yaw_deg=yaw)
              for k, yaw in enumerate((-120.0, 30.0))]
    assert result.best_fitness == pytest.approx(np.mean([r.distance for r in turned]), abs=1e-9)
    assert result.best_rollout.distance == turned[0].distance
    with pytest.raises(ValueError, match=r"start_yaws_deg must be a number of degrees in \[-180, 180\]"):
        evolve_from_population(damaged, tmp_path / "run", 1, start_yaws_deg=(float("inf"),), **kw)
