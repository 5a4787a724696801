"""One EEA run: rounds of exploration, a target experiment and estimation (paper 3.2, 4).

:func:`run` composes the pieces::

    for each round:
        exploration   evolve the action the candidate models disagree on most (eq. 1)
        target        perform it on the damaged robot from random initial angles
        estimation    evolve models that reproduce all experiments (eq. 3), with the
                      inference strategy choosing the models' initial angles
        record        OBJ_FIT (eq. 4) of the best model, angles, counters -> rounds.csv
    and in the ``morphology+servos`` model space, after the last round:
        check         the final model against fault hypotheses about the design
                      (:mod:`eea.fault_check`) -> fault_check.json, the run's self-model

and writes ``DIR/config.json``, ``DIR/rounds.csv``, the checkpoint ``DIR/state.pkl`` and its
data ``DIR/run_data.npz`` (see :mod:`eea.record`, :mod:`eea.checkpoint`), a run with lineages
``DIR/lineages.csv`` (:func:`eea.record.write_lineages`) and a ``morphology+servos`` run
``DIR/fault_check.json``. Where pickles are refused (:func:`aquafish_gym.rundir.refuse_pickles`:
a finished benchmark cell checked again, a directory the command did not make), a finished run
is read from its data alone, its check against fault hypotheses made from it too.
The round itself is :func:`eea.round.run_round`. All randomness comes from one
``numpy.random.Generator`` seeded with ``config.seed``, so the same config gives the same
rounds. Resumable: running the same command again after an interruption continues from the
last finished round and ends with the same ``rounds.csv`` (``wall_seconds`` aside) as an
uninterrupted run.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from aquafish_gym.progress import progress_bar
from aquafish_gym.rundir import (FileError, MismatchError, check_fingerprint, check_memory, check_output_dir,
                                 differences, pickles_refused, run_lock)
from eea.checkpoint import STATE_FILE, RunState, load_run_data, load_state, save_run_data, save_state
from eea.config import FLAT_FIELDS, EEAConfig
from eea.evaluation import Evaluator
from eea.experiment import Experiment
from eea.fault_check import check_final_model, search_screen, write_fault_check
from eea.search.lineages import Lineages, estimation_from_state, make_strategy
from eea.record import (ROUNDS_FILE, RunResult, read_config, read_rounds, round_row, write_config, write_lineages,
                        write_rounds)
from eea.round import RoundParts, run_round

__all__ = ["check_run_memory", "run"]


def _check_manifest(out_dir: Path, config: EEAConfig, existing: EEAConfig | None) -> None:
    """Refuse a directory whose ``config.json`` holds another run (naming the fields by flat name)."""
    if existing is not None and not config.same_results_as(existing):
        mine, theirs = config.result_fields(), existing.result_fields()
        diff = [f"{k}: {theirs.get(k, '(none)')!r} -> {mine.get(k, '(none)')!r}"
                for k in FLAT_FIELDS if k in {*mine, *theirs} and mine.get(k) != theirs.get(k)]
        raise MismatchError(f"{out_dir} holds a run with a different config ({'; '.join(diff)}); {_FIX}")


def _check_checkpoint(out_dir: Path, config: EEAConfig, state: RunState | None) -> None:
    """Refuse a checkpoint that belongs to another run: it carries its run's config, so a
    copied-in or edited run is refused (naming the fields)."""
    if state is None:
        return
    # through from_dict: a checkpoint written before the sections holds a flat config (eea.compat)
    check_fingerprint(out_dir / STATE_FILE, EEAConfig.from_dict(state.config).result_fields(), config.result_fields(),
                      f"the checkpoint belongs to another run: {_FIX} (or delete {STATE_FILE} and "
                      f"{ROUNDS_FILE} to start this one over)")
    if len(state.rows) != state.rounds_done:
        raise FileError(out_dir / STATE_FILE, f"holds {len(state.rows)} rows for {state.rounds_done} rounds")


def _check_resumable(out_dir: Path, state: RunState | None) -> None:
    """Refuse a directory whose ``rounds.csv`` holds rounds but which has no checkpoint (a
    published run, or a copy without ``state.pkl``): starting it over would overwrite its
    rounds, and without its experiments it can be neither resumed nor checked."""
    if state is None and (rows := read_rounds(out_dir)):
        raise FileError(out_dir / ROUNDS_FILE,
                        f"holds {len(rows)} finished rounds but the run has no checkpoint ({STATE_FILE}) to resume "
                        "or check from (read it with eea.load_result, aquafish plot or compare)",
                        f"to run it again use another --out, or delete {ROUNDS_FILE} to start this one over")


_FIX = "use another --out, or the same settings to resume it"


def check_run_memory(config: EEAConfig) -> None:
    """Refuse, up front, a config whose simulation batches cannot fit in memory.

    The estimate is the largest batch of one round (every estimation genome on every
    experiment, or every exploration action on every candidate model), each robot with its
    joint log and behaviour summary (about 56 bytes per simulation step).

    Raises:
        ValueError: the estimate exceeds the available memory (the message gives both).
    """
    estimation, exploration = config.estimation, config.exploration
    robots = max(estimation.population * config.rounds * max(1, estimation.lineages),
                 exploration.population * exploration.models * max(1, exploration.angles))
    check_memory(f"estimation population {estimation.population} x {config.rounds} rounds x "
                 f"{config.steps} steps", 56.0 * robots * config.steps,
                 "lower the populations, the rounds or the duration")


def run(config: EEAConfig, out_dir: str | os.PathLike, *, progress: bool = True) -> RunResult:
    """Run (or resume) the EEA with ``config``, writing into ``out_dir``.

    Args:
        config: the run's settings.
        out_dir: run directory (created if missing). If it holds a checkpoint of the same
            config, the run continues after its last finished round; a finished run is
            returned without simulating (but for a ``morphology+servos`` run's check against
            fault hypotheses, :mod:`eea.fault_check`, when it has none yet).
            ``rounds``, ``workers`` and ``max_batch_robots`` may differ from the stored config
            (they do not change results; a larger ``rounds`` extends the run, a smaller one
            leaves ``config.json`` as it is).
        progress: show progress over rounds (:func:`aquafish_gym.progress.progress_bar`: a tqdm
            bar with the current phase on a terminal, else one line per round).

    Returns:
        The :class:`~eea.record.RunResult` (all finished rounds).

    Raises:
        ValueError: if ``out_dir`` cannot be written (checked before anything is created),
            holds a run with a different config, or a checkpoint of another run (the message
            lists the differing fields), or rounds without a checkpoint to resume from (a
            published run: :class:`~aquafish_gym.rundir.FileError`, nothing is written); if
            another process is writing it (:class:`~aquafish_gym.rundir.BusyError`); if a file
            in it is corrupt (:class:`~aquafish_gym.rundir.FileError`); or if the config cannot
            fit in memory.
    """
    out = check_output_dir(out_dir)
    check_run_memory(config)
    with run_lock(out, command="eea"):
        return _run_locked(config, out, progress)


def _finished_from_data(config: EEAConfig, out: Path, existing: EEAConfig | None) -> RunResult | None:
    """A run in ``out`` that is finished for ``config`` (no round to run), from its data alone
    (``run_data.npz``, ``rounds.csv``): its result, the check against fault hypotheses made
    first if it is due, with nothing unpickled (the same check, to the bit, as from the
    checkpoint: the data holds the checkpoint's experiments, estimation cache and inference
    state). None when the data does not show a finished run (no data file yet, a damaged one or
    another run's, rounds.csv out of step with it, more rounds asked): the checkpoint resumes,
    repairs, extends or refuses it then (and where pickles are refused, that is refused).
    """
    if existing is None:
        return None
    try:
        data = load_run_data(out)
        rows = read_rounds(out, config.model_space)
    except FileError:
        return None  # the checkpoint repairs them
    if data is None or data.rounds_done < config.rounds or len(rows) != data.rounds_done \
            or differences(EEAConfig.from_dict(data.config).result_fields(), config.result_fields()):
        return None  # unfinished, out of step, or another run's: the checkpoint's path (which names the fields)
    if config.rounds >= existing.rounds:
        write_config(out, config)
    else:  # fewer rounds asked than planned: the run's record keeps its plan
        config = config.replace(rounds=max(config.rounds, data.rounds_done))
    result = RunResult(out, config, rows)
    if result.model_space.servos and result.finished and result.fault_check is None:
        with Evaluator.for_config(config) as evaluator:
            if data.evaluator:
                evaluator.load_state_dict(data.evaluator)
            strategy = make_strategy(config.inference, config.ga, config.estimation.lineages)
            strategy.load_state_dict(data.inference)
            screen = search_screen(config, strategy, result.best_model, len(data.experiments))
            write_fault_check(out, check_final_model(result.best_model, data.experiments, evaluator, data.rounds_done,
                                                     screen_angles=screen))
    return result


def _run_locked(config: EEAConfig, out: Path, progress: bool) -> RunResult:
    existing = read_config(out)
    _check_manifest(out, config, existing)  # before the checkpoint is unpickled
    if pickles_refused():  # a directory this command did not make: its checkpoint is never unpickled
        finished = _finished_from_data(config, out, existing)
        if finished is not None:
            return finished
    state = load_state(out)
    _check_checkpoint(out, config, state)
    _check_resumable(out, state)
    if existing is None or config.rounds >= existing.rounds:
        write_config(out, config)
    else:  # fewer rounds asked than planned: the run's record keeps its plan
        config = config.replace(rounds=max(config.rounds, state.rounds_done if state is not None else 0))
    rng = np.random.default_rng(config.seed)
    if state is not None:
        rng.bit_generator.state = state.rng_state
        estimation = estimation_from_state(state.estimation, rng)
        experiments = tuple(Experiment.from_state_dict(e) for e in state.experiments)
    else:
        estimation, experiments, state = None, (), RunState(config.to_dict())
    _write_records(out, state.rows, estimation, config.model_space)  # repairs a kill between checkpoint and csv
    if state.rounds_done:  # and between the checkpoint and its data (or a run made before the data file)
        save_run_data(out, state)
    bar = progress_bar(config.rounds, initial=min(state.rounds_done, config.rounds), unit="round",
                       desc=f"eea {config.inference.name} seed {config.seed}", disable=not progress)

    def on_phase(name: str, generations: int | None):
        bar.set_postfix_str(name)
        if generations is None:
            return None

        def report(generation: int, best: float) -> None:
            bar.set_postfix_str(f"{name} {generation + 1}/{generations} best {best:.4f}")
        return report

    with Evaluator.for_config(config) as evaluator, bar:
        if state.evaluator:
            evaluator.load_state_dict(state.evaluator)
        parts = RoundParts.from_config(config, rng, evaluator, estimation)
        parts.strategy.load_state_dict(state.inference)
        for number in range(state.rounds_done + 1, config.rounds + 1):
            record = run_round(number, experiments, parts, rng, on_phase)
            experiments = record.experiments
            wall = state.wall_seconds + record.wall_s
            row = round_row(record, parts.target.morphology, wall, model_space=config.model_space,
                            target_faults=parts.target.faults)
            state = RunState(config=config.to_dict(), rounds_done=number, rng_state=rng.bit_generator.state,
                             estimation=parts.estimation.state_dict(),
                             experiments=tuple(e.state_dict() for e in experiments),
                             evaluator=evaluator.state_dict(), inference=parts.strategy.state_dict(),
                             wall_seconds=wall, rows=(*state.rows, row))
            save_state(out, state)
            _write_records(out, state.rows, parts.estimation, config.model_space)
            save_run_data(out, state)
            bar.set_postfix_str(f"obj {row['objective_fitness']:.3f}")
            bar.update(1)
        result = RunResult(out, config, list(state.rows))
        if result.model_space.servos and result.finished and result.fault_check is None:
            bar.set_postfix_str("fault check")
            screen = search_screen(config, parts.strategy, result.best_model, len(experiments))
            write_fault_check(out, check_final_model(result.best_model, experiments, evaluator, state.rounds_done,
                                                     screen_angles=screen))
    return result


def _write_records(out: Path, rows, estimation, model_space: str) -> None:
    """``rounds.csv`` from the checkpoint's rows, and a lineage run's ``lineages.csv``."""
    write_rounds(out, rows, model_space)
    if isinstance(estimation, Lineages):
        write_lineages(out, estimation.history)
