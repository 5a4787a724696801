"""A finished run's target experiments, rebuilt from its ``rounds.csv`` and ``config.json``.

``rounds.csv`` keeps each round's action and the target's true initial angles
(:mod:`eea.record`), and the target is the simulator itself under the run's damage, so
simulating it again gives the run's experiments bit for bit
(``tests/eea/test_replay.py`` checks them against a checkpoint). The published runs in
``docs/results`` keep no checkpoint; this is how to get their experiments back (to fit a
model to them, or to score another). On a physical robot the recorded
logs would take the place of the replay.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np

from aquafish_gym import get_damage, simulate_batch
from eea.behaviour import summarise
from eea.experiment import FLIPPERS, Context, Experiment
from eea.record import ACTION_COLUMNS, RunResult, load_result

__all__ = ["rebuild_experiments", "replay_run"]


def rebuild_experiments(result: RunResult) -> list[Experiment]:
    """The run's target experiments, one per finished round, in order.

    Args:
        result: a loaded run (:func:`eea.record.load_result`).

    Returns:
        E experiments (E = finished rounds): action ``(3,)`` (rev/s, rev/s, Hz), the
        target's ``(steps, 3)`` IMU log (degrees) and its behaviour summary, the true
        initial angles ``(3,)`` (rad). Their contexts are exact at 0 rad: what the run
        inferred is not replayed.

    Raises:
        ValueError: if the run has no finished round.
    """
    if not result.rounds:
        raise ValueError(f"{result.out_dir}: no rounds recorded yet")
    preset = get_damage(result.config.damage)
    truth = preset.apply().to_array()
    actions = np.array([[row[c] for c in ACTION_COLUMNS] for row in result.rounds])
    true = np.array([[row[f"true_{f}_rad"] for f in FLIPPERS] for row in result.rounds])
    logs = simulate_batch(np.repeat(truth[None], len(actions), axis=0), actions, true, result.config.steps,
                          faults=preset.faults, params=result.config.sim_params)
    summary = result.config.behaviour_summary
    return [Experiment(i, actions[i], logs[i], summarise(logs[i], summary), true[i], Context.exact(np.zeros(3)))
            for i in range(len(actions))]


def replay_run(out_dir: str | os.PathLike, rounds: int | None = None) -> tuple[RunResult, list[Experiment]]:
    """:func:`eea.record.load_result` and :func:`rebuild_experiments` of a run directory.

    Args:
        out_dir: the run directory.
        rounds: optional R >= 1: the run as it stood after round R (its first R rows of
            ``rounds.csv``, so its best model is round R's, and R experiments).

    Raises:
        ValueError: if ``out_dir`` is not a run directory, has no finished round, or has
            fewer than ``rounds`` rounds.
    """
    result = load_result(out_dir)
    if rounds is not None:
        if rounds < 1 or len(result.rounds) < rounds:
            raise ValueError(f"{out_dir}: rounds must be 1..{len(result.rounds)} (its finished rounds), got {rounds}")
        result = dataclasses.replace(result, rounds=result.rounds[:rounds])
    return result, rebuild_experiments(result)
