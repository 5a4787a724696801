"""One EEA run: rounds of exploration, a target experiment and estimation (paper 3.2, 4).

:func:`run` composes the pieces::

    for each round:
        exploration   evolve the action the candidate models disagree on most (eq. 1)
        target        perform it on the damaged robot from random initial angles
        estimation    evolve models that reproduce all experiments (eq. 3), with the
                      inference strategy choosing the models' initial angles
        record        OBJ_FIT (eq. 4) of the best model, angles, counters -> rounds.csv

and writes ``DIR/config.json``, ``DIR/rounds.csv`` and the checkpoint ``DIR/state.pkl``
(see :mod:`eea.record`, :mod:`eea.checkpoint`), and a run with lineages ``DIR/lineages.csv``
(:func:`eea.lineages.write_lineages`). The round itself is
:func:`eea.round.run_round`. All randomness comes from one
``numpy.random.Generator`` seeded with ``config.seed``, so the same config gives the same
rounds. Resumable: running the same command again after an interruption continues from the
last finished round and ends with the same ``rounds.csv`` (``wall_seconds`` aside) as an
uninterrupted run.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from eea.checkpoint import RunState, load_state, save_state
from eea.config import RESULT_NEUTRAL_FIELDS, EEAConfig
from eea.behaviour import SIMILARITIES
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.lineages import Lineages, estimation_from_state, write_lineages
from eea.record import RunResult, read_config, round_row, write_config, write_rounds
from eea.round import RoundParts, run_round

__all__ = ["run"]


def _check_config(out_dir: Path, config: EEAConfig) -> None:
    existing = read_config(out_dir)
    if existing is None or config.same_results_as(existing):
        return
    mine, theirs = config.to_dict(), existing.to_dict()
    diff = [f"{k}: {theirs[k]!r} -> {mine[k]!r}" for k in mine if k not in RESULT_NEUTRAL_FIELDS and mine[k] != theirs[k]]
    raise ValueError(f"{out_dir} holds a run with a different config ({'; '.join(diff)}); "
                     "use another directory or the same settings to resume it")


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
        estimation = estimation_from_state(state.estimation, rng)
        experiments = tuple(Experiment.from_state_dict(e) for e in state.experiments)
    else:
        estimation, experiments, state = None, (), RunState(config.to_dict())
    _write_records(out, state.rows, estimation)  # repairs a kill between the checkpoint and the csv
    bar = tqdm(total=config.rounds, initial=min(state.rounds_done, config.rounds), unit="round",
               desc=f"eea {config.inference} seed {config.seed}", disable=not progress)

    def on_phase(name: str, generations: int | None):
        bar.set_postfix_str(name)
        if generations is None:
            return None

        def report(generation: int, best: float) -> None:
            bar.set_postfix_str(f"{name} {generation + 1}/{generations} best {best:.4f}")
        return report

    with Evaluator(config.steps, workers=config.workers, max_batch_robots=config.max_batch_robots,
                   similarity_fn=SIMILARITIES[config.model_similarity], params=config.sim_params) as evaluator, bar:
        if state.evaluator:
            evaluator.load_state_dict(state.evaluator)
        parts = RoundParts.from_config(config, rng, evaluator, estimation)
        parts.strategy.load_state_dict(state.inference)
        for number in range(state.rounds_done + 1, config.rounds + 1):
            record = run_round(number, experiments, parts, rng, on_phase)
            experiments = record.experiments
            wall = state.wall_seconds + record.wall_s
            row = round_row(record, parts.target.morphology, wall)
            state = RunState(config=config.to_dict(), rounds_done=number, rng_state=rng.bit_generator.state,
                             estimation=parts.estimation.state_dict(),
                             experiments=tuple(e.state_dict() for e in experiments),
                             evaluator=evaluator.state_dict(), inference=parts.strategy.state_dict(),
                             wall_seconds=wall, rows=(*state.rows, row))
            save_state(out, state)
            _write_records(out, state.rows, parts.estimation)
            bar.update(1)
            bar.set_postfix_str(f"obj {row['objective_fitness']:.3f}")
    return RunResult(out, config, list(state.rows))


def _write_records(out: Path, rows, estimation) -> None:
    """``rounds.csv`` from the checkpoint's rows, and a lineage run's ``lineages.csv``."""
    write_rounds(out, rows)
    if isinstance(estimation, Lineages):
        write_lineages(out, estimation.history)
