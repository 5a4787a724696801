"""One EEA run: rounds of exploration, a target experiment and estimation (paper 3.2, 4).

:func:`run` composes the pieces::

    for each round:
        exploration   evolve the action the candidate models disagree on most (eq. 1)
        target        perform it on the damaged robot from random initial angles
        estimation    evolve models that reproduce all experiments (eq. 3), with the
                      inference strategy choosing the models' initial angles
        record        OBJ_FIT (eq. 4) of the best model, angles, counters -> rounds.csv

and writes ``DIR/config.json``, ``DIR/rounds.csv`` and the checkpoint ``DIR/state.pkl``
(see :mod:`eea.record`, :mod:`eea.checkpoint`). All randomness comes from one
``numpy.random.Generator`` seeded with ``config.seed``, so the same config gives the same
rounds. Resumable: running the same command again after an interruption continues from the
last finished round and ends with the same ``rounds.csv`` (``wall_seconds`` aside) as an
uninterrupted run.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from eea.behaviour import behaviour_summary
from eea.checkpoint import RunState, load_state, save_state
from eea.config import RESULT_NEUTRAL_FIELDS, EEAConfig
from eea.encoding import decode_models
from eea.estimation import Estimation
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.exploration import Exploration
from eea.fitness import objective_fitness
from eea.inference import make_inference
from eea.record import MODEL_COLUMNS, ACTION_COLUMNS, FLIPPERS, RunResult, read_config, write_config, write_rounds
from eea.target import Target

__all__ = ["run"]


def _check_config(out_dir: Path, config: EEAConfig) -> None:
    existing = read_config(out_dir)
    if existing is None or config.same_results_as(existing):
        return
    mine, theirs = config.to_dict(), existing.to_dict()
    diff = [f"{k}: {theirs[k]!r} -> {mine[k]!r}" for k in mine if k not in RESULT_NEUTRAL_FIELDS and mine[k] != theirs[k]]
    raise ValueError(f"{out_dir} holds a run with a different config ({'; '.join(diff)}); "
                     "use another directory or the same settings to resume it")


def _row(round_number, config, target, best_genome, best_fitness, action, action_fit, experiment,
         simulations, wall_seconds) -> dict:
    dims = decode_models(best_genome)
    row = {"round": round_number, "objective_fitness": objective_fitness(dims, target.morphology.to_array()),
           "model_fitness": float(best_fitness), "action_fitness": float(action_fit)}
    row.update(zip(MODEL_COLUMNS, dims.tolist()))
    row.update(zip(ACTION_COLUMNS, np.asarray(action, dtype=float).tolist()))
    row.update({f"true_{f}_rad": a for f, a in zip(FLIPPERS, experiment.true_angles.tolist())})
    row.update({f"inferred_{f}_rad": a for f, a in zip(FLIPPERS, experiment.context.estimate().tolist())})
    row.update({"target_experiments": experiment.index + 1, "simulations": int(simulations),
                "wall_seconds": float(wall_seconds)})
    return row


def run(config: EEAConfig, out_dir: str | os.PathLike, *, progress: bool = True) -> RunResult:
    """Run (or resume) the EEA with ``config``, writing into ``out_dir``.

    Args:
        config: the run's settings.
        out_dir: run directory (created if missing). If it holds a checkpoint of the same
            config, the run continues after its last finished round; a finished run is
            returned without simulating. ``rounds``, ``workers`` and ``max_batch_robots``
            may differ from the stored config (they do not change results; a larger
            ``rounds`` extends the run).
        progress: show a tqdm bar over rounds with the current phase as postfix.

    Returns:
        The :class:`~eea.record.RunResult` (all finished rounds).

    Raises:
        ValueError: if ``out_dir`` holds a run with a different config (the message lists
            the differing fields).
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    _check_config(out, config)
    write_config(out, config)
    rng = np.random.default_rng(config.seed)
    state = load_state(out)
    if state is not None:
        rng.bit_generator.state = state.rng_state
        estimation = Estimation.from_state_dict(state.estimation, rng)
        experiments = [Experiment.from_state_dict(e) for e in state.experiments]
    else:
        estimation = Estimation.from_config(config, rng)
        experiments = []
        state = RunState(config.to_dict(), 0, {}, {}, [], {}, 0.0, [])
    write_rounds(out, state.rows)  # repairs a kill between the checkpoint and the csv
    target = Target(config.damage, config.steps, rng)
    strategy = make_inference(config.inference, config)
    exploration = Exploration.from_config(config)
    bar = tqdm(total=config.rounds, initial=min(state.rounds_done, config.rounds), unit="round",
               desc=f"eea {config.inference} seed {config.seed}", disable=not progress)

    def phase(name: str, generations: int | None = None):
        def report(generation: int, best: float) -> None:
            bar.set_postfix_str(f"{name} {generation + 1}/{generations} best {best:.4f}")
        bar.set_postfix_str(name)
        return report

    with Evaluator(config.steps, workers=config.workers, max_batch_robots=config.max_batch_robots) as evaluator, bar:
        if state.evaluator:
            evaluator.load_state_dict(state.evaluator)
        for round_index in range(state.rounds_done, config.rounds):
            started = time.perf_counter()
            models = estimation.ranked_models(config.exploration_models)
            action_genome, action, action_fit = exploration.run(
                models, evaluator, rng, phase("exploration", config.exploration_generations))
            phase("target")
            imu_log, true_angles = target.perform(action)
            experiments.append(Experiment(len(experiments), action, imu_log, behaviour_summary(imu_log),
                                          true_angles, strategy.new_context(true_angles)))
            best_genome, best_fitness = estimation.run(
                experiments, strategy, evaluator, rng, config.estimation_generations,
                phase("estimation", config.estimation_generations))
            wall = state.wall_seconds + time.perf_counter() - started
            row = _row(round_index + 1, config, target, best_genome, best_fitness, action, action_fit,
                       experiments[-1], evaluator.simulations, wall)
            state = RunState(config.to_dict(), round_index + 1, rng.bit_generator.state, estimation.state_dict(),
                             [e.state_dict() for e in experiments], evaluator.state_dict(), wall, state.rows + [row])
            save_state(out, state)
            write_rounds(out, state.rows)
            bar.update(1)
            bar.set_postfix_str(f"obj {row['objective_fitness']:.3f}")
    return RunResult(out, config, list(state.rows))
