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
