"""One self-model from several independent runs on the same target (not the paper's; issue 14).

N independent runs on the same target, each with its own experiments, vote: every
run's final model gets its own initial angles fitted for every experiment of every run,
equally hard for all (:meth:`eea.inference.profile.Profile.fit` from random starts, then
:meth:`~eea.inference.profile.Profile.scan_angles` and :meth:`~eea.inference.profile.Profile.polish_angles`),
and the model with the highest MOD_FIT (eq. 3) over the pooled experiments is the
ensemble's model. No oracle is used: the selection sees only models and responses.

Cost: N runs (N times one run's simulations and N times its target experiments: with N
runs side by side, each round performs N experiments on the target), plus the selection,
about ``225 N E_total`` simulations (``E_total`` the pooled experiments), some 1% of two
10-round runs. Why and what it measured: docs/studies.md, "Ensembles of two runs".
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Sequence

import numpy as np

from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, MismatchError, check_fingerprint, check_output_file, read_json, run_lock
from eea.evaluation import Evaluator
from eea.experiment import FLIPPERS, Experiment
from eea.record import RunResult, read_csv, write_csv
from eea.replay import replay_run
from eea.inference.selection import Selection, select_model

__all__ = ["SELECTION_COLUMNS", "Selection", "ensemble_groups", "select_model", "select_runs", "select_study"]


def select_runs(run_dirs: Sequence[str | os.PathLike], *, rounds: int | None = None, seed: int = 0,
                generations: int = 30, scan_cycles: int = 2,
                workers: int = 1) -> tuple[Selection, list[RunResult], list[Experiment]]:
    """:func:`select_model` over finished runs' final models and their pooled experiments.

    The experiments are rebuilt from each run's ``rounds.csv`` (:mod:`eea.replay`), so
    ``docs/results`` is enough.

    Args:
        run_dirs: two or more run directories on the same damage and experiment length.
        rounds: optional R: each run as it stood after round R (round R's model, the first R
            experiments; :func:`eea.replay.replay_run`). Two runs stopped at round 5 have
            performed as many target experiments as one run at round 10.
        seed: seed of the fit's random numbers.
        generations, scan_cycles: as in :func:`select_model`.
        workers: simulation processes.

    Returns:
        ``(selection, results, experiments)``: the :class:`Selection` (row i is run i's
        final model), the loaded runs and the pooled experiments (run by run, in order).

    Raises:
        ValueError: if fewer than two runs are given, a directory is not a run with a
            finished round (or fewer than ``rounds``), or the runs differ in damage, steps or
            model space.
    """
    if len(run_dirs) < 2:
        raise ValueError(f"an ensemble needs at least two runs, got {len(run_dirs)}")
    replays = [replay_run(d, rounds) for d in run_dirs]
    results = [r for r, _ in replays]
    for field in ("damage", "steps", "model_space"):
        values = {getattr(r.config, field) for r in results}
        if len(values) > 1:
            raise ValueError(f"the runs differ in {field}: {sorted(map(str, values))}; an ensemble needs one target")
    experiments = [e for _, exps in replays for e in exps]
    models = np.stack([r.best_model for r in results])
    config = results[0].config
    with Evaluator(config.steps, workers=workers,
                   params=config.sim_params, model_space=config.model_space) as evaluator:
        selection = select_model(models, experiments, evaluator, np.random.default_rng(seed),
                                 generations=generations, scan_cycles=scan_cycles)
    return selection, results, experiments


def ensemble_groups(seeds: Sequence[int], size: int) -> tuple[list[tuple[int, ...]], list[int]]:
    """Split a study's seeds into ensembles of ``size`` consecutive seeds (sorted).

    Returns:
        ``(groups, left_out)``: e.g. seeds 0-9 and size 3 give (0, 1, 2), (3, 4, 5),
        (6, 7, 8) and leave out [9].

    Raises:
        ValueError: if ``size < 2``, a seed repeats or there are fewer seeds than ``size``.
    """
    if size < 2:
        raise ValueError(f"an ensemble has at least 2 runs, got size {size}")
    seeds = sorted(seeds)
    if len(set(seeds)) != len(seeds):
        raise ValueError(f"seeds repeat: {seeds}")
    if len(seeds) < size:
        raise ValueError(f"{len(seeds)} seeds cannot make an ensemble of {size}")
    n = len(seeds) // size * size
    return [tuple(seeds[i : i + size]) for i in range(0, n, size)], seeds[n:]


#: Columns of the file :func:`select_study` writes, one row per run of each ensemble.
SELECTION_COLUMNS = ("ensemble", "seed", "objective_fitness", "model_fitness", "chosen", "error_left_deg",
                     "error_right_deg", "error_caudal_deg")


def select_study(runs: Sequence[RunResult], size: int, out_csv: str | os.PathLike | None = None, *,
                 rounds: int | None = None, seed: int = 0, generations: int = 30, scan_cycles: int = 2,
                 workers: int = 1, progress=None) -> list[dict]:
    """:func:`select_runs` on every ensemble of ``size`` consecutive seeds of one study.

    Args:
        runs: one variant's runs, one per seed (:func:`eea.analysis.plot.find_runs`), finished or at
            least ``rounds`` rounds long.
        size: runs per ensemble (>= 2); the last ``len(runs) % size`` seeds are left out.
        out_csv: optional file of :data:`SELECTION_COLUMNS` rows, rewritten atomically after
            each ensemble; ensembles already in it are not selected again (an interrupted
            study loses at most the ensemble under way).
        rounds, seed, generations, scan_cycles, workers: as in :func:`select_runs`.
        progress: optional callable ``progress(rows_of_one_ensemble)`` after each one.

    Returns:
        The rows, one dict per run (``ensemble`` numbers the ensembles from 0; ``chosen`` is
        1 for the run whose model the selection picked, else 0; OBJ_FIT is eq. 4 of the
        run's model (its final one, or round ``rounds``'), and ``error_<flipper>_deg`` the
        median error of its fitted angles over the pooled experiments
        (:meth:`Selection.angle_errors_deg`): oracles the selection does not see).

    ``out_csv`` has a manifest next to it, ``OUT_CSV.json``: the settings that define its rows
    (:func:`selection_fingerprint`). An existing file is extended only if the manifest matches
    and every row's OBJ_FIT is the one its run has now (a file made from another variant, or
    from runs that have changed since, is refused). The file is locked while it is written.

    Raises:
        ValueError: as :func:`ensemble_groups` and :func:`select_runs`, or if ``out_csv``
            cannot be written (checked before any work), holds ensembles of other seeds, was
            made with other settings or from other runs (:class:`~aquafish_gym.rundir.MismatchError`),
            is corrupt (:class:`~aquafish_gym.rundir.FileError`) or is being written by another
            process (:class:`~aquafish_gym.rundir.BusyError`).
    """
    by_seed = {r.config.seed: r for r in runs}
    if len(by_seed) != len(runs):
        raise ValueError("one run per seed, please: the runs repeat seeds (several variants in one directory?)")
    groups, _ = ensemble_groups(list(by_seed), size)
    if out_csv is None:
        return _select(by_seed, groups, None, rounds, seed, generations, scan_cycles, workers, progress)
    out_csv = check_output_file(out_csv, "--out")
    fingerprint = selection_fingerprint(by_seed, size, rounds, seed, generations, scan_cycles)
    with run_lock(out_csv.parent, "--out", name=f".{out_csv.name}.lock"):
        manifest = Path(f"{out_csv}.json")
        if out_csv.exists():
            if not manifest.is_file():
                raise MismatchError(f"{out_csv} has no manifest {manifest.name} (written by another version, or by "
                                    "hand): its settings are unknown; delete it or use another --out")
            check_fingerprint(out_csv, read_json(manifest), fingerprint,
                              "use another --out, or the settings and runs it was made with")
        atomic_write(manifest, (json.dumps(fingerprint, indent=1) + "\n").encode())
        return _select(by_seed, groups, out_csv, rounds, seed, generations, scan_cycles, workers, progress)


def selection_fingerprint(by_seed: dict, size: int, rounds: int | None, seed: int, generations: int,
                          scan_cycles: int) -> dict:
    """The settings that define a selection file's rows: the selection's own and the variant's
    (the config of its runs, seed and result-neutral fields aside)."""
    from eea.config import RESULT_NEUTRAL_FIELDS

    first = by_seed[min(by_seed)].config.to_dict()
    variant = {k: v for k, v in first.items() if k not in RESULT_NEUTRAL_FIELDS and k != "seed"}
    return {"size": size, "rounds": rounds, "seed": seed, "generations": generations, "scan_cycles": scan_cycles,
            "variant": variant}


def _select(by_seed: dict, groups, out_csv: Path | None, rounds, seed, generations, scan_cycles, workers,
            progress) -> list[dict]:
    """The body of :func:`select_study` (under the lock of ``out_csv``)."""
    rows = _read_rows(out_csv) if out_csv is not None and out_csv.exists() else []
    for row in rows:  # a row must describe the run of its seed as it is now
        run = by_seed.get(row["seed"])
        if run is None:
            raise MismatchError(f"{out_csv}: seed {row['seed']} is not among the runs given; use the runs it was made "
                                "from, or another --out")
        if len(run.rounds) < (rounds or len(run.rounds)) or not run.rounds:
            continue  # left out below
        now = run.rounds[(rounds or len(run.rounds)) - 1]["objective_fitness"]
        if now != row["objective_fitness"]:
            raise MismatchError(f"{out_csv}: seed {row['seed']} has OBJ_FIT {row['objective_fitness']!r} there but "
                                f"{now!r} in {run.out_dir}: it was made from other runs (or these changed since); "
                                "use another --out")
    done = {}
    for row in rows:
        done.setdefault(row["ensemble"], []).append(row["seed"])
    for k, group in enumerate(groups):
        if k in done:
            if tuple(done[k]) != group:
                raise ValueError(f"{out_csv}: ensemble {k} holds seeds {done[k]}, this study's is {list(group)}")
            continue
        selection, results, experiments = select_runs([by_seed[s].out_dir for s in group], rounds=rounds,
                                                      seed=seed, generations=generations,
                                                      scan_cycles=scan_cycles, workers=workers)
        errors = selection.angle_errors_deg(experiments)
        new = [{"ensemble": k, "seed": s, "objective_fitness": float(results[i].rounds[-1]["objective_fitness"]),
                "model_fitness": float(selection.model_fitness[i]), "chosen": int(i == selection.index),
                **{f"error_{f}_deg": float(errors[i, j]) for j, f in enumerate(FLIPPERS)}}
               for i, s in enumerate(group)]
        rows += new
        if out_csv is not None:
            write_csv(out_csv, SELECTION_COLUMNS, rows)
        if progress is not None:
            progress(new)
    return rows


def _read_rows(path) -> list[dict]:
    columns, rows = read_csv(path, ("ensemble", "seed", "chosen"))
    if columns != SELECTION_COLUMNS:
        raise FileError(path, f"has columns {list(columns)}, expected {list(SELECTION_COLUMNS)}")
    bad = [i + 2 for i, row in enumerate(rows) if not all(np.isfinite(v) for v in row.values())]
    if bad:
        raise FileError(path, f"line {bad[0]} has a non-finite value")
    return rows
