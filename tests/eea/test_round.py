"""eea.round: one round as one function returning a frozen record; its rounds.csv row."""

import dataclasses

import numpy as np
import pytest

from eea.encoding import decode_actions
from eea.evaluation import Evaluator
from eea.fitness import objective_fitness
from eea.record import ROUND_COLUMNS, round_row
from eea.round import RoundParts, run_round


def test_run_round_returns_a_frozen_record_and_leaves_its_inputs_alone(tiny_config):
    config = tiny_config(inference="in_band")
    rng = np.random.default_rng(3)
    phases = []
    with Evaluator(config.steps) as evaluator:
        parts = RoundParts.from_config(config, rng, evaluator)
        first = run_round(1, (), parts, rng, lambda name, gens: phases.append((name, gens)))
        second = run_round(2, first.experiments, parts, rng)
    assert phases == [("exploration", config.exploration.generations), ("target", None),
                      ("estimation", config.estimation.generations)]
    assert [e.index for e in second.experiments] == [0, 1] and second.experiment is second.experiments[-1]
    assert second.experiments[0].imu_log is first.experiment.imu_log             # the round-1 experiment, passed on
    assert first.experiment.context.confidence == 1.0                            # in_band locks at the round's end
    np.testing.assert_array_equal(first.action, decode_actions(first.action_genome))
    assert 0 < first.exploration_simulations <= first.simulations < second.simulations
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.model_fitness = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        first.experiment.context = None
    with pytest.raises(ValueError, match="read-only"):
        first.experiment.imu_log[0, 0] = 1.0

    row = round_row(second, parts.target.morphology, wall_seconds=12.5)
    assert tuple(row) == ROUND_COLUMNS
    assert row["round"] == 2 and row["target_experiments"] == 2 and row["wall_seconds"] == 12.5
    dims = np.array([row[c] for c in ROUND_COLUMNS if c.startswith("model_") and c != "model_fitness"])
    assert row["objective_fitness"] == pytest.approx(objective_fitness(dims, parts.target.morphology.to_array()))
    assert row["inferred_left_rad"] == pytest.approx(second.experiment.context.estimate()[0])
    assert row["action_caudal_hz"] == second.action[2]
