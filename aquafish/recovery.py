"""The recovery benchmark (``aquafish recovery``): the damage-recovery case study over many faults.

A **cell** is one case study (:func:`aquafish.case_study.run_case_study`) of one damage and one
seed, in ``OUT/cells/<damage>/seed<S>`` (``<damage>``: a preset's name, ``sampled_SEED``, or
``fault_`` and a short hash of a JSON fault; :func:`aquafish.damage_table.gait_dir_name`). A
cell whose ``report.json`` exists is finished and read back, never run again, unless its
self-model was checked against fault hypotheses by an earlier procedure than today's and its
EEA runs' data are there (:func:`check_stale`): then its case study runs again, makes today's
check on the same experiments, read as data (no pickle of a finished cell is ever loaded), and
retrains only the gaits of a self-model that changed. An interrupted cell resumes from its
finished steps.

The rows that do not depend on the damage (:data:`aquafish.case_study.SHARED_KEYS`: the
healthy gait, the damage-robust gait and the damage-robust PPO policy) are trained once per
seed in ``OUT/shared/seed<S>`` (:func:`aquafish.case_study.train_shared_rows`) before that
seed's cells, which load them from there (``run_case_study(shared_dir=...)``).

The oracle of every damage (:mod:`aquafish.oracle`: the best of three gaits evolved on the
true damaged robot with three times the gait budget and seeds no cell uses) is trained once, in
``OUT/oracles/<damage>`` (:func:`oracle_dir`), before the cells, which load it from there (on
Ray, as the shared rows travel: each cell task carries a copy of its damage's oracle). It does
not depend on the cell's seed, so every seed of a damage is judged against the same yardstick.

The cells run in two passes: first every new cell's **triage** (the healthy and the oracle
gaits, scored on the damaged robot; ``run_case_study(triage_only=True)``), then the other
rows of the cells whose damage breaks the healthy gait (every triaged cell with
``all_rows``), so which cells break, and so what the rest will cost, is known early. The
second pass goes seed by seed (every breaking damage of the first seed, then of the next),
so a run stopped part-way has a cross-section of the damages. A triaged cell whose damage
breaks the healthy gait is not finished: the summary lists it as missing until its rows
have run.

``OUT/recovery.json`` is the run's manifest (preset, episode duration, damages, seeds): a
rerun with another preset or duration is refused naming the fields; one with other damages
or seeds extends it. At the end of every run, ``OUT/summary.json`` and ``OUT/summary.md`` are
rebuilt from the reports of every finished cell of the manifest (:func:`summarize`,
:func:`render_summary`).

Cells run one at a time in this process (each case study's evaluation on every core), on a
local process pool (``processes`` > 1; each case study's evaluation serial), both writing in
place, or as Ray tasks (``backend="ray"``, :func:`aquafish.backends.connect_ray`) that need no
file system shared with the driver (:mod:`aquafish.shipping`): each task runs in a node-local
temporary directory and sends its finished directory back with its value; the driver writes
it into ``OUT`` (atomically, a directory at a time) and decides here, as on the local backend,
what is finished. A task whose worker is lost is retried by Ray and logged in one line.

Shared rows without a shared file system: the cells of a seed need its shared rows, but a Ray
node cannot read them from the driver's ``OUT``. So the shared rows of every seed that has
unfinished cells are trained first, as tasks of their own (``shared/seed<S>`` sent back and
written on the driver), and every cell task then carries a copy of its seed's
``shared/seed<S>`` (an input directory: the cell loads the finished rows from it, and nothing
it writes there comes back). The shared rows are trained once per seed, as on the local
backend; the cost is sending a seed's shared rows (about 0.4 MB at ``smoke``; a cell's own
directory is about 1.3 MB) with each of its cells. The alternatives were worse: training the
shared rows inside every cell repeats the most expensive rows per damage, and keeping them in
Ray's object store would not survive the driver, while ``OUT/shared`` does and is reused by a
rerun.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Iterable, Iterator

from aquafish import backends
from aquafish.shipping import DirTask
from aquafish_gym.checks import check_int, short_json
from aquafish_gym.files import atomic_write
from aquafish_gym.progress import progress_bar
from aquafish_gym.rundir import (FileError, check_fingerprint, check_output_dir, make_subdir, read_json, refuse_pickles,
                                 run_lock)

#: The rows of the summary, in column order (``report.json`` controller keys; the oracle,
#: ``true_damaged``, is what every share is taken of).
ROWS = ("healthy", "plain_eea", "out_of_band", "self_model", "robust", "robust_ppo", "ppo")
#: The run's manifest: its settings, and the union of the damages and seeds run into it.
MANIFEST_FILE = "recovery.json"
#: The summary files, rebuilt at the end of every run.
SUMMARY_JSON, SUMMARY_MD = "summary.json", "summary.md"
#: The mark of a share whose row recovers, in ``summary.md``.
RECOVERS_MARK = "✓"


@dataclasses.dataclass(frozen=True)
class RecoverySpec:
    """What a recovery benchmark runs (checked by :func:`check_spec`).

    Attributes:
        preset: the case-study preset (:data:`aquafish.case_study.PRESETS`).
        episode_duration_s: simulated seconds of every episode (the preset's when not given).
        damages: damages as canonical text (:func:`aquafish_gym.get_damage`'s ``name``).
        seeds: the case-study seeds, ascending.
        self_model_fields: every cell's self-model settings of its own: the preset's
            (:attr:`aquafish.case_study.CaseStudyPreset.self_model_fields`) with the caller's
            over them (:func:`aquafish.case_study.own_self_model_fields`; ``{}``: none).
    """

    preset: str
    episode_duration_s: float
    damages: tuple[str, ...]
    seeds: tuple[int, ...]
    self_model_fields: dict = dataclasses.field(default_factory=dict)

    def cells(self) -> list[tuple[str, int]]:
        """Every ``(damage, seed)``, damage by damage."""
        return [(damage, seed) for damage in self.damages for seed in self.seeds]

    def settings(self) -> dict:
        """The fields a rerun must keep (other damages and seeds extend the run)."""
        return {"preset": self.preset, "episode_duration_s": self.episode_duration_s,
                "self_model_fields": dict(self.self_model_fields)}

    def to_dict(self) -> dict:
        """The manifest (``recovery.json``) and the summary's ``settings``."""
        return {**self.settings(), "damages": list(self.damages), "seeds": list(self.seeds)}


def check_spec(preset: str, damages: Iterable[str] | None, seeds: Iterable[int],
               episode_duration_s: float | None = None, self_model_fields: Mapping | None = None) -> RecoverySpec:
    """The benchmark's settings, checked; a JSON fault file is read here, once.

    Args:
        preset: a case-study preset name.
        damages: preset names, JSON faults (inline or ``.json`` files) or ``sampled:SEED``;
            None: every preset but ``none``.
        seeds: case-study seeds (ints >= 0).
        episode_duration_s: simulated seconds per episode (None: the preset's).
        self_model_fields: as ``run_case_study``'s (None: none); the spec holds them over the
            preset's.

    Raises:
        ValueError: an unknown preset, an unknown or empty damage (``none``), an invalid fault, a
            damage given twice (also under two texts of one fault, :func:`fault_key`: both named),
            no seeds, a seed that is no int in ``[0, PROCEDURE_SEED_LIMIT)``
            (:func:`aquafish.oracle.check_procedure_seed`) or is given twice, a bad duration, or
            self-model fields ``run_case_study`` refuses.
    """
    from aquafish.case_study import own_self_model_fields, preset_settings
    from aquafish.damage_table import check_damages
    from aquafish.oracle import check_procedure_seed

    settings = preset_settings(preset, episode_duration_s)
    own = own_self_model_fields(settings, self_model_fields)  # with the preset's own (quick: the ranked fault hypotheses)
    names = check_damages(None if damages is None else list(damages))
    _check_unique("damage", names)
    check_one_fault_one_cell(names)
    seeds = list(seeds)
    if not seeds:
        raise ValueError("give at least one seed")
    for seed in seeds:
        check_procedure_seed(seed)
    _check_unique("seed", seeds)
    return RecoverySpec(preset, settings.episode_duration_s, tuple(names), tuple(sorted(seeds)), own)


def fingerprint(recorded: dict, settings: dict) -> tuple[dict, dict]:
    """``(recorded, wanted)`` fingerprints of ``settings`` for :func:`~aquafish_gym.rundir.check_fingerprint`:
    the keys of ``settings`` that ``recorded`` (a manifest or a cell's report) holds, a record made
    before ``self_model_fields`` existed holding none (``{}``); the fields compared as one JSON
    text, so that a field one side lacks is a difference too."""
    def flat(values: dict) -> dict:
        return {k: json.dumps(v, sort_keys=True) if k == "self_model_fields" else v for k, v in values.items()}

    held = {k: recorded.get(k, {}) if k == "self_model_fields" else recorded[k] for k in settings
            if k in recorded or k == "self_model_fields"}
    return flat(held), flat(settings)


def fault_key(damage: str) -> tuple:
    """What a damage (canonical text) does to the robot: its damaged morphology and its servo
    faults. Every text of one fault has the same key (``sampled:3`` and the JSON it draws,
    ``reversed_left_pectoral`` and ``{"gains":[-1.0,1.0,1.0]}``)."""
    from aquafish_gym import get_damage

    resolved = get_damage(damage)
    return tuple(resolved.apply().to_array().tolist()), resolved.faults


def check_one_fault_one_cell(damages: Iterable[str], held: Iterable[str] = (), where: str | None = None) -> None:
    """Refuse one fault under two texts (``sampled:3`` and the JSON it draws, a preset and its
    JSON): it would be two cells, run twice and counted twice. Two ``sampled:SEED`` texts whose
    draws happen to be equal are two draws of the distribution, each a cell of its own.

    Args:
        damages: the damages asked for (canonical texts).
        held: the damages the benchmark holds already (its manifest's), each under its own text.
        where: the manifest that holds ``held`` (for the message).

    Raises:
        ValueError: two texts of one fault (:func:`fault_key`), not both draws, both named.
    """
    from aquafish_gym.faults import SAMPLED_PREFIX

    held = list(held)
    seen: dict[tuple, list[str]] = {}
    for damage in [*held, *damages]:
        texts = seen.setdefault(fault_key(damage), [])
        first = next((t for t in texts if t != damage
                      and not (t.startswith(SAMPLED_PREFIX) and damage.startswith(SAMPLED_PREFIX))), None)
        if first is not None and damage not in held:
            if first in held:
                raise ValueError(f"damage {damage} is the fault {first}, which {where} holds under that name; give it "
                                 f"as {first} (one fault is one cell)")
            raise ValueError(f"damages given more than once: {first} and {damage} are one fault (one fault is one "
                             "cell); give it once")
        if first is not None:
            raise ValueError(f"{first} and {damage} are one fault")
        texts.append(damage)


def _check_unique(what: str, values: list) -> None:
    """Raises: ValueError if a value of ``values`` repeats."""
    repeated = sorted({str(v) for v in values if values.count(v) > 1})
    if repeated:
        raise ValueError(f"{what}s given more than once: {', '.join(repeated)}")


def cell_dir(out: Path, damage: str, seed: int) -> Path:
    """``OUT/cells/<damage dir>/seed<S>``: the case study of ``damage`` (canonical text) and ``seed``."""
    from aquafish.damage_table import gait_dir_name

    return Path(out) / "cells" / gait_dir_name(damage) / f"seed{seed}"


def shared_dir(out: Path, seed: int) -> Path:
    """``OUT/shared/seed<S>``: the rows of ``seed`` that do not depend on the damage."""
    return Path(out) / "shared" / f"seed{seed}"


def oracle_dir(out: Path, damage: str) -> Path:
    """``OUT/oracles/<damage dir>``: the oracle of ``damage`` (:mod:`aquafish.oracle`), one for
    every seed's cell, since it depends on no procedure seed."""
    from aquafish.damage_table import gait_dir_name

    return Path(out) / "oracles" / gait_dir_name(damage)


def _check_subdir(out: Path, path: Path) -> None:
    """Make the parents of the task directory ``path`` below ``out`` and check ``path`` itself if
    it is there (:func:`aquafish_gym.rundir.make_subdir`: a symbolic link, or a component that
    leads outside ``out``, is refused naming it)."""
    parts = path.relative_to(out).parts
    make_subdir(out, *parts[:-1])
    if os.path.lexists(path):
        make_subdir(out, *parts)


def _shown(value) -> str:
    """A manifest's or report's value in a message (:func:`aquafish_gym.checks.short_json`)."""
    return short_json(value, 60)


def read_manifest(out: Path) -> tuple[dict, RecoverySpec]:
    """``OUT/recovery.json`` as recorded and as a :class:`RecoverySpec`, every field checked before
    any of it is used (a benchmark directory may come from anyone): ``preset`` a case-study
    preset, ``episode_duration_s`` a positive finite number, ``damages`` a list of damages each
    written as its canonical text (:func:`aquafish_gym.get_damage`'s ``name``: so no text names a
    file, or a directory outside ``OUT``), no fault twice, ``seeds`` a list of distinct ints in
    ``[0, PROCEDURE_SEED_LIMIT)``, ``self_model_fields`` (optional) a JSON object.

    Raises:
        FileError: (a ``ValueError``) the file is not such a manifest: one line naming it and the field.
    """
    from aquafish.case_study import PRESETS
    from aquafish.oracle import PROCEDURE_SEED_LIMIT
    from aquafish_gym import DAMAGES, get_damage
    from aquafish_gym.faults import SAMPLED_PREFIX

    path = Path(out) / MANIFEST_FILE
    recorded = read_json(path)

    def refuse(field: str, problem: str) -> FileError:
        return FileError(path, f"is not a recovery manifest: field {field!r} {problem}",
                         "restore it from a copy, or use another --out")

    preset = recorded.get("preset")
    if not isinstance(preset, str) or preset not in PRESETS:
        raise refuse("preset", f"must be one of {', '.join(sorted(PRESETS))}, got {_shown(preset)}")
    duration = recorded.get("episode_duration_s")
    if isinstance(duration, bool) or not isinstance(duration, (int, float)) or not math.isfinite(duration) \
            or duration <= 0:
        raise refuse("episode_duration_s", f"must be a positive number of seconds, got {_shown(duration)}")
    damages = recorded.get("damages")
    if not isinstance(damages, list) or not damages:
        raise refuse("damages", f"must be a non-empty list of damages, got {_shown(damages)}")
    for i, damage in enumerate(damages):
        if not isinstance(damage, str) or not (damage in DAMAGES or damage.startswith((SAMPLED_PREFIX, "{"))):
            raise refuse(f"damages[{i}]", f"must be a damage's canonical text (a preset name, sampled:SEED or a JSON "
                                          f"fault), got {_shown(damage)}")
        try:
            name = get_damage(damage).name
        except ValueError as err:
            raise refuse(f"damages[{i}]", f"is no damage ({str(err).splitlines()[0][:120]})") from None
        if name != damage or name in ("none", "{}"):
            raise refuse(f"damages[{i}]", f"must be a damage's canonical text ({_shown(name)}), got {_shown(damage)}")
    if len(set(damages)) != len(damages):
        raise refuse("damages", f"names {next(d for d in damages if damages.count(d) > 1)} twice")
    try:
        check_one_fault_one_cell(damages)
    except ValueError as err:
        raise refuse("damages", f"holds one fault twice ({err})") from None
    seeds = recorded.get("seeds")
    if not isinstance(seeds, list) or not seeds:
        raise refuse("seeds", f"must be a non-empty list of seeds, got {_shown(seeds)}")
    for i, seed in enumerate(seeds):
        if type(seed) is not int or not 0 <= seed < PROCEDURE_SEED_LIMIT:
            raise refuse(f"seeds[{i}]", f"must be an int in [0, {PROCEDURE_SEED_LIMIT - 1}], got {_shown(seed)}")
    if len(set(seeds)) != len(seeds):
        raise refuse("seeds", f"names {next(s for s in seeds if seeds.count(s) > 1)} twice")
    fields = recorded.get("self_model_fields", {})
    if not isinstance(fields, dict):
        raise refuse("self_model_fields", f"must be a JSON object, got {_shown(fields)}")
    return recorded, RecoverySpec(preset, float(duration), tuple(damages), tuple(seeds), dict(fields))


def merge_manifest(out: Path, spec: RecoverySpec) -> RecoverySpec:
    """``spec`` merged into ``OUT/recovery.json`` (the damages and seeds run so far, and these),
    written atomically; the merged spec.

    Raises:
        MismatchError: the manifest records another preset or duration (the fields named).
        FileError: the manifest is corrupt or not a recovery manifest (:func:`read_manifest`).
        ValueError: a damage of ``spec`` that the manifest holds under another text
            (:func:`check_one_fault_one_cell`).
    """
    path = Path(out) / MANIFEST_FILE
    merged = spec
    if path.is_file():
        recorded, held = read_manifest(out)
        check_fingerprint(out, *fingerprint(recorded, spec.settings()),
                          "use another --out, or the --budget, --episode-duration-s and --self-model-fields it was "
                          "run with")
        check_one_fault_one_cell(spec.damages, held.damages, str(path))
        damages = tuple(dict.fromkeys([*held.damages, *spec.damages]))
        seeds = tuple(sorted({*held.seeds, *spec.seeds}))
        merged = dataclasses.replace(spec, damages=damages, seeds=seeds)
    atomic_write(path, json.dumps(merged.to_dict(), indent=2).encode())
    return merged


def read_cell(out: Path, damage: str, seed: int, spec: RecoverySpec) -> dict | None:
    """The report of a finished cell (None when its ``report.json`` is missing).

    Raises:
        MismatchError: the report was made with another preset, duration, damage or seed.
        FileError: the report is corrupt.
    """
    path = cell_dir(out, damage, seed) / "report.json"
    if not path.is_file():
        return None
    report = read_json(path)
    wanted = {**spec.settings(), "damage": damage, "seed": seed}
    check_fingerprint(path.parent, *fingerprint(report, wanted),
                      "remove the cell's directory to run it again")
    _check_report(path, report)
    return report


def _check_report(path: Path, report: dict) -> None:
    """Refuse a cell's report that the summary cannot count: every row's ``target_distance`` a
    finite number (NaN is refused, not counted) and the fields :func:`cell_summary` reads.

    Raises:
        FileError: naming the file and what is wrong.
    """
    fix = "remove the cell's directory to run it again"
    controllers = report.get("controllers")
    if not isinstance(controllers, dict) or not isinstance(controllers.get("true_damaged"), dict):
        raise FileError(path, "is not a case-study report: field 'controllers' must be a JSON object with the "
                              "oracle's row 'true_damaged'", fix)
    for key, row in controllers.items():
        value = row.get("target_distance") if isinstance(row, dict) else None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise FileError(path, f"is not a case-study report: field 'controllers.{key}.target_distance' must be a "
                                  f"finite number, got {_shown(value)}", fix)
    try:
        cell_summary(report)
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as err:
        raise FileError(path, f"is not a case-study report ({type(err).__name__}: "
                              f"{str(err).splitlines()[0][:120] if str(err) else ''})", fix) from None


# -- the tasks (top-level, so that process pools and Ray can ship them) ------------------------------


def _train_shared(preset: str, seed: int, shared: str, episode_duration_s: float, workers: int | None,
                  progress: bool) -> int:
    """Train the shared rows of ``seed`` (:func:`aquafish.case_study.train_shared_rows`); return ``seed``."""
    from aquafish.case_study import train_shared_rows

    train_shared_rows(preset, seed, shared, episode_duration_s=episode_duration_s, workers=workers,
                      progress=progress)
    return seed


def _train_oracle(preset: str, damage: str, oracle: str, episode_duration_s: float, workers: int | None,
                  progress: bool) -> str:
    """Evolve (or find finished) the oracle of ``damage`` in ``oracle`` with the preset's gait
    settings (:func:`aquafish.oracle.evolve_oracle`); return ``damage``."""
    import gait
    from aquafish.case_study import preset_settings
    from aquafish.oracle import evolve_oracle

    settings = preset_settings(preset, episode_duration_s)
    evolve_oracle(gait.as_robot(damage), oracle, generations=settings.gait_generations,
                  population_size=settings.gait_population, episodes_per_genome=settings.gait_episodes,
                  episode_duration_s=settings.episode_duration_s, workers=workers, progress=progress)
    return damage


def _run_cell(preset: str, damage: str, seed: int, cell: str, shared: str, episode_duration_s: float,
              workers: int | None, progress: bool, all_rows: bool = False, triage_only: bool = False,
              self_model_fields: dict | None = None, oracle: str | None = None, recheck: bool = False) -> dict:
    """Run one cell's case study (no video) with the shared rows of its seed and the oracle of its
    damage; return its report (``all_rows`` False: the other rows only where the damage breaks
    the healthy gait; ``triage_only``: the healthy and oracle rows only, as ``run_case_study``).
    ``recheck``: the cell is finished and checked again (:func:`check_stale`); it is read as data,
    and any pickle it would load is refused unread (:func:`aquafish_gym.rundir.refuse_pickles`)."""
    from aquafish.case_study import run_case_study

    def run() -> dict:
        return run_case_study(preset, damage, seed, cell, episode_duration_s=episode_duration_s, video=False,
                              workers=workers, progress=progress, shared_dir=shared, all_rows=all_rows,
                              triage_only=triage_only, self_model_fields=self_model_fields, oracle_dir=oracle)

    if not recheck:
        return run()
    with refuse_pickles(f"the finished cell {cell} is checked again from its data"):
        return run()


def check_stale(report: dict | None, cell: str | os.PathLike) -> bool:
    """Whether a finished cell's self-model was checked against fault hypotheses by another
    procedure than today's (:data:`eea.fault_check.FAULT_CHECK_PROCEDURE`; a report made before
    checks named theirs counts as another) and every EEA run of the cell has its data
    (:data:`eea.checkpoint.RUN_DATA_FILE`), so that running the cell again makes today's check
    on the run's own experiments, read as data: a finished cell's checkpoints are never
    unpickled (:func:`_run_cell`'s ``recheck``), whoever made the benchmark directory. False
    without a report, without a check (a triaged cell, a ``morphology`` self-model), or without
    the data (a cell copied from published results, or made before the data file existed: it is
    read back as it is, and the summary names its check's procedure)."""
    from aquafish.case_study import eea_dir_name
    from eea.checkpoint import RUN_DATA_FILE
    from eea.fault_check import FAULT_CHECK_PROCEDURE

    models = (report or {}).get("models") or {}
    check = (models.get("self_model") or {}).get("fault_check")
    if check is None or check.get("procedure", "") == FAULT_CHECK_PROCEDURE:
        return False
    runs = [Path(cell) / eea_dir_name(m["method"], m["model_space"], m["behaviour_summary"]) for m in models.values()]
    return all((run / RUN_DATA_FILE).is_file() for run in runs)


def rows_to_run(report: dict | None, all_rows: bool = False) -> bool:
    """Whether a cell with this report (None: none yet) still has rows to run: a triaged cell
    whose damage breaks the healthy gait, or any triaged cell with ``all_rows``."""
    return report is not None and bool(report.get("triaged")) and (all_rows or bool(report["verdict"]["breaks"]))


# -- running tasks ----------------------------------------------------------------------------------


def _run_tasks(tasks: list, backend: str, processes: int, address: str | None) -> Iterator:
    """The values of ``tasks`` (:class:`aquafish.shipping.DirTask`), as they finish: in this
    process (local, ``processes == 1``, so that a cell's evaluation may use every core), else
    through :func:`aquafish.shipping.run_dir_tasks` (a local pool whose workers die with this
    process, writing in place, or Ray tasks whose directories come back to this process).

    Raises:
        ValueError: a task raised one (its own error, also from a Ray task).
        ClusterError: as :func:`aquafish.backends.connect_ray`.
    """
    if backend == "local" and processes == 1:
        for task in tasks:
            yield task.fn(*task.args)
        return
    from aquafish.shipping import run_dir_tasks

    yield from run_dir_tasks(tasks, backend=backend, processes=processes, address=address)


def run_recovery(out_dir, *, preset: str = "quick", damages: Iterable[str] | None = None, seeds: Iterable[int] = (0,),
                 episode_duration_s: float | None = None, processes: int = 1, workers: int | None = None,
                 backend: str = "local", address: str | None = None, progress: bool = True,
                 all_rows: bool = False, self_model_fields: Mapping | None = None) -> dict:
    """Run every unfinished cell (damage x seed) of the benchmark and write its summary; return it.

    Every new cell is first triaged: its healthy and oracle gaits are evolved and scored on the
    damaged robot (``run_case_study(triage_only=True)``). Then the cells whose damage breaks
    the healthy gait get the other rows (self-models, their gaits, PPO), since the benchmark's
    recovery rates count breaking cells only. ``all_rows=True`` runs every row on every cell,
    and completes cells an earlier run left at their triage.

    Args:
        out_dir: the benchmark's directory (finished cells and shared rows are reused).
        preset: the case-study preset.
        damages: as :func:`check_spec` (None: every preset but ``none``).
        seeds: the case-study seeds.
        episode_duration_s: simulated seconds per episode (None: the preset's).
        processes: cells at once on the local backend (1: in this process).
        workers: evaluation processes of each case study when cells run one at a time (default:
            all cores); cells that run at once (``processes`` > 1, Ray) evaluate serially.
        backend: ``"local"`` or ``"ray"`` (``address`` as for :func:`aquafish.backends.connect_ray`).
        progress: show progress (over cells; each case study's own bars when cells run one at a time).
        all_rows: every row on every cell, not only on the cells whose damage breaks the healthy gait.
        self_model_fields: every cell's self-model settings, as ``run_case_study``'s (None: none); a
            benchmark directory keeps one value (another is a :class:`~aquafish_gym.rundir.MismatchError`).

    Raises:
        ValueError: bad settings (:func:`check_spec`, ``processes``, ``workers``, ``backend``, an
            ``address`` without ``backend="ray"``) or an ``out_dir`` that cannot be written, checked
            before anything is created; another process writing ``out_dir``
            (:class:`~aquafish_gym.rundir.BusyError`); a manifest or a finished cell made with other
            settings (:class:`~aquafish_gym.rundir.MismatchError`, naming the fields); a cell's own
            error.
        aquafish.backends.ClusterError: ``backend="ray"`` without Ray or without a reachable cluster.
    """
    spec = check_spec(preset, damages, seeds, episode_duration_s, self_model_fields)
    backends.check_backend(backend, address)
    check_int("processes", processes, 1)
    if workers is not None:
        check_int("workers", workers, 1)
    _check_sizes(spec, workers if backend == "local" and processes == 1 else processes)
    out = check_output_dir(out_dir)
    if backend == "ray":
        backends.connect_ray(address)
    with run_lock(out, command="recovery"):
        return _run_locked(spec, out, processes, workers, backend, address, progress, all_rows)


def _check_sizes(spec: RecoverySpec, workers: int | None) -> None:
    """Refuse, before anything is written, a benchmark whose cells would fail or run out of memory
    part-way (:func:`aquafish.case_study.check_sizes`: episodes too short for PPO, gaits or the
    self-model's EEA run, with the spec's own self-model settings, that cannot fit)."""
    from aquafish.case_study import DEFAULT_METHOD, check_sizes, model_fields, preset_settings
    from eea import EEAConfig

    settings = preset_settings(spec.preset, spec.episode_duration_s)
    check_sizes(settings, {"self_model": EEAConfig.from_method(DEFAULT_METHOD, settings.budget,
                                                               **model_fields(own=spec.self_model_fields))}, workers)


def _run_locked(spec: RecoverySpec, out: Path, processes: int, workers: int | None, backend: str,
                address: str | None, progress: bool, all_rows: bool = False) -> dict:
    """The body of :func:`run_recovery`, under the lock of ``out``."""
    manifest = merge_manifest(out, spec)
    reports = {cell: read_cell(out, *cell, manifest) for cell in manifest.cells()}
    stale = {cell for cell in spec.cells() if check_stale(reports[cell], cell_dir(out, *cell))}
    todo = [cell for cell in spec.cells() if reports[cell] is None or rows_to_run(reports[cell], all_rows)
            or cell in stale]
    for damage, seed in todo:  # where the tasks write: never through a link planted in OUT, whichever backend
        for path in (shared_dir(out, seed), oracle_dir(out, damage), cell_dir(out, damage, seed)):
            _check_subdir(out, path)
    alone = backend == "local" and processes == 1  # one cell at a time, in this process
    cell_workers, inner_progress = (workers, progress) if alone else (1, False)
    duration = spec.episode_duration_s
    def run_stage(desc: str, unit: str, tasks: list) -> Iterator:
        """The values of ``tasks`` as they finish, counted on a progress bar."""
        bar = progress_bar(len(tasks), desc=desc, unit=unit, disable=not progress or not tasks)
        for value in _run_tasks(tasks, backend, processes, address):
            yield value
            bar.update()
        bar.close()

    seeds = sorted({seed for _, seed in todo})
    shared_tasks = [DirTask(_train_shared, (spec.preset, seed, str(shared_dir(out, seed)), duration, cell_workers,
                                            inner_progress), outputs=(2,), label=f"shared rows of seed {seed}")
                    for seed in seeds]
    for _ in run_stage("shared rows", "seed", shared_tasks):
        pass
    # the oracle of every damage with unfinished cells, once for all its seeds
    damages = list(dict.fromkeys(damage for damage, _ in todo))
    oracle_tasks = [DirTask(_train_oracle, (spec.preset, damage, str(oracle_dir(out, damage)), duration, cell_workers,
                                            inner_progress), outputs=(2,), label=f"oracle of {damage}")
                    for damage in damages]
    for _ in run_stage("oracles", "damage", oracle_tasks):
        pass

    def run_pass(stage: str, cells: list, triage_only: bool) -> None:
        tasks = [DirTask(_run_cell, (spec.preset, damage, seed, str(cell_dir(out, damage, seed)),
                                     str(shared_dir(out, seed)), duration, cell_workers, inner_progress,
                                     all_rows and not triage_only, triage_only, spec.self_model_fields,
                                     str(oracle_dir(out, damage)), (damage, seed) in stale and not triage_only),
                         outputs=(3,), inputs=(4, 11), label=f"{stage} of cell {damage} seed {seed}")
                 for damage, seed in cells]
        for report in run_stage(stage, "cell", tasks):
            reports[(report["damage"], report["seed"])] = report

    # 1. triage every new cell (the healthy and oracle rows); 2. the other rows where they are due,
    # seed by seed (every damage of a seed before the next seed): a run stopped part-way leaves a
    # cross-section of the breaking damages, not the first few complete
    run_pass("triage", [c for c in todo if reports[c] is None], True)
    due = [c for c in todo if rows_to_run(reports[c], all_rows) or c in stale]
    run_pass("recovery rows", sorted(due, key=lambda c: (spec.seeds.index(c[1]), spec.damages.index(c[0]))), False)
    summary = _summary(manifest, reports)
    atomic_write(out / SUMMARY_JSON, json.dumps(summary, indent=2).encode())
    atomic_write(out / SUMMARY_MD, render_summary(summary).encode())
    return summary


def _summary(manifest: RecoverySpec, reports: dict) -> dict:
    """``summary.json``: the settings, :func:`summarize` of the finished cells, the missing ones."""
    return {"settings": manifest.to_dict(), **summarize([r for r in reports.values() if r is not None]),
            "missing": [{"damage": d, "seed": s} for (d, s), r in reports.items() if r is None or rows_to_run(r)]}


def summary_so_far(out_dir) -> dict:
    """The summary of the cells finished so far in a benchmark directory, written nowhere.

    It reads only: a benchmark another process is running (or one that was stopped) can be
    looked at; its cells still to run are listed under ``missing``. :func:`render_summary`
    gives its Markdown.

    Raises:
        ValueError: ``out_dir`` holds no recovery benchmark (no ``recovery.json``), or a finished
            cell made with other settings (:class:`~aquafish_gym.rundir.MismatchError`).
        FileError: a corrupt manifest or report.
    """
    out = Path(out_dir)
    if not (out / MANIFEST_FILE).is_file():
        raise ValueError(f"{out} holds no recovery benchmark (no {MANIFEST_FILE}); give the --out of an "
                         "aquafish recovery run")
    manifest = read_manifest(out)[1]
    return _summary(manifest, {cell: read_cell(out, *cell, manifest) for cell in manifest.cells()})


# -- the summary ------------------------------------------------------------------------------------


def shares(controllers: dict) -> dict[str, float | None]:
    """Each row's mean distance on the damaged robot over the oracle's (``true_damaged``), for the
    rows of :data:`ROWS` present; None when the oracle does not swim forward (as
    :func:`aquafish.case_study.verdict`)."""
    oracle = float(controllers["true_damaged"]["target_distance"])
    return {key: float(controllers[key]["target_distance"]) / oracle if oracle > 0 else None
            for key in ROWS if key in controllers}


#: The servos' keys in a report's gains, in gain order.
_SERVO_GAINS = ("left_pectoral_gain", "right_pectoral_gain", "caudal_gain")


def signs_right(gains: dict, target_morphology: dict | None = None) -> bool | None:
    """Whether the self-model identified the pectoral servos: each of its pectoral gains on the
    target's side of 0 (:func:`eea.identification.pectoral_signs_right` on a report's dicts: a
    reversed servo needs a negative gain, a healthy or weak one a positive gain, a dead or
    seized one 0). A pectoral whose flipper the target has lost (length or width 0) is not
    judged: its servo moves nothing, so no experiment shows its gain.

    Args:
        gains: a cell's ``gains``: ``{"self_model": {...} or None, "target": {...}}``, each
            keyed ``left_pectoral_gain``, ``right_pectoral_gain``, ``caudal_gain``.
        target_morphology: the target's flipper dimensions keyed as
            ``aquafish_gym.MORPHOLOGY_FIELDS`` (a report's ``target_morphology``); None: every
            flipper is there.

    Returns:
        None when the cell has no self-model with servo gains (it did not run, or its model
        space holds none) or the target has lost both pectoral flippers, else the verdict.
    """
    from aquafish_gym import MORPHOLOGY_FIELDS, Morphology
    from eea.identification import pectoral_signs_right

    model, target = gains.get("self_model"), gains.get("target")
    if not model or not target or any(k not in model or k not in target for k in _SERVO_GAINS):
        return None
    design = dict(zip(MORPHOLOGY_FIELDS, Morphology.healthy().to_array().tolist()))
    return pectoral_signs_right(_model_values(design, model), _model_values(design | (target_morphology or {}), target))


def faults_named(report: dict) -> bool | None:
    """Whether a cell's self-model names every faulty servo of its target with the sign of its
    gain (:func:`eea.identification.servo_faults_named`: a reversed servo needs a
    negative gain, a weak one a gain in (0, 1), a dead or seized one 0; a servo whose flipper
    the target lost is not judged).

    Args:
        report: a case-study report (``models.self_model``'s ``morphology`` and
            ``servo_gains``, ``target_morphology``, ``target_servo_gains``).

    Returns:
        None when the cell has no self-model of servo gains or its target no judged faulty
        servo, else the verdict.
    """
    from eea.identification import servo_faults_named

    values = _self_model_and_truth(report)
    return None if values is None else servo_faults_named(*values)


def self_model_identification(report: dict) -> dict | None:
    """The strict judgement of a cell's self-model (:func:`eea.identification.identification`:
    every part's servo and flipper kinds the target's, so a healthy part held faulty is a miss;
    the servo of a flipper the target lost is not judged).

    Args:
        report: a case-study report (``models.self_model``'s ``morphology`` and
            ``servo_gains``, ``target_morphology``, ``target_servo_gains``).

    Returns:
        None when the cell has no self-model of servo gains (as :func:`faults_named`), else the
        identification dict (``strict``, ``gain_abs_error``, ``morphology_abs_error``, ``parts``).
    """
    from eea.identification import identification

    values = _self_model_and_truth(report)
    return None if values is None else identification(*values)


def _self_model_and_truth(report: dict) -> tuple[list[float], list[float]] | None:
    """A report's self-model and target as ``(12,)`` ``morphology+servos`` values (None when the
    report has no self-model of servo gains)."""
    model = report.get("models", {}).get("self_model") or {}
    parts = (model.get("morphology"), model.get("servo_gains"), report.get("target_morphology"),
             report.get("target_servo_gains"))
    if not all(parts):
        return None
    dims, gains, target_dims, target_gains = parts
    return _model_values(dims, gains), _model_values(target_dims, target_gains)


def _model_values(dims: dict, gains: dict) -> list[float]:
    """A report's flipper dimensions and servo gains (dicts keyed by field) as the ``(12,)``
    ``morphology+servos`` values :mod:`eea.identification` judges."""
    from aquafish_gym import MORPHOLOGY_FIELDS

    return [dims[f] for f in MORPHOLOGY_FIELDS] + [gains[k] for k in _SERVO_GAINS]


def cell_summary(report: dict) -> dict:
    """One cell of ``summary.json`` from its case study's report: ``damage``, ``seed``, ``breaks``,
    ``shares``, ``recovers`` (per row but ``healthy``: the verdict's test), ``gains`` (the
    self-model's and the target's servo gains), ``signs_right`` (:func:`signs_right`),
    ``faults_named`` (:func:`faults_named`, the lenient judgement), ``identification``
    (:func:`self_model_identification`, the strict one; None without a self-model of servo
    gains), ``check_procedure`` (the procedure of the check
    that made the self-model, :data:`eea.fault_check.FAULT_CHECK_PROCEDURE` when today's; ""
    for a report made before checks named theirs; None without a check), ``target_experiments``
    (per EEA model) and ``wall_seconds`` (of the case-study run that finished the cell).

    Raises:
        KeyError: the report lacks a field every case-study report has.
    """
    row_shares = shares(report["controllers"])
    recovering = set(report["verdict"]["recovering"])
    models = report["models"]
    gains = {"self_model": models.get("self_model", {}).get("servo_gains"), "target": report.get("target_servo_gains")}
    return {
        "damage": report["damage"], "seed": report["seed"], "breaks": bool(report["verdict"]["breaks"]),
        "shares": row_shares,
        "recovers": {key: key in recovering for key in row_shares if key != "healthy"},
        "gains": gains, "signs_right": signs_right(gains, report.get("target_morphology")),
        "faults_named": faults_named(report),
        "identification": self_model_identification(report),
        "check_procedure": _check_procedure(models.get("self_model")),
        "target_experiments": {key: m["target_experiments"] for key, m in models.items()},
        "wall_seconds": report["wall_seconds"],
    }


def _check_procedure(model: dict | None) -> str | None:
    """The procedure of the check that made a report's self-model ("" when the report predates
    named procedures; None without a check)."""
    check = (model or {}).get("fault_check")
    return None if check is None else check.get("procedure", "")


def summarize(reports: Iterable[dict]) -> dict:
    """``cells`` (:func:`cell_summary` of every report) and ``totals``: the number of ``cells``,
    of cells whose damage ``breaks`` the healthy gait, per row (but ``healthy``) how many of
    the breaking cells that have the row it recovers in (``recovers``, ``of``, ``rate``: None
    without such a cell), ``identified``: in how many of the cells whose self-model's signs
    are judged (:func:`signs_right` not None) they are right (``right``, ``of``, ``rate``),
    ``faults_named``: likewise for :func:`faults_named` (``named``, ``of``, ``rate``; the lenient
    judgement), ``strict_identification``: in how many of the cells with a self-model of servo
    gains it identifies the target strictly (:func:`self_model_identification`: ``strict``,
    ``of``, ``rate``), ``confusion``: their parts' classes, truth against model
    (:func:`eea.identification.identification_confusion`, every class of
    :data:`eea.identification.PART_CLASSES` in both), and ``check_procedures``: how many cells'
    self-models each check procedure made (a table gathered over changes of the check says so).

    Raises:
        KeyError: a report lacks a field every case-study report has.
    """
    from eea.identification import identification_confusion

    cells = [cell_summary(r) for r in reports]
    breaking = [c for c in cells if c["breaks"]]
    rows = {}
    for key in ROWS[1:]:
        having = [c for c in breaking if key in c["recovers"]]
        if any(key in c["recovers"] for c in cells):
            n = sum(c["recovers"][key] for c in having)
            rows[key] = {"recovers": n, "of": len(having), "rate": n / len(having) if having else None}
    judged = [c["signs_right"] for c in cells if c["signs_right"] is not None]
    identified = {"right": sum(judged), "of": len(judged), "rate": sum(judged) / len(judged) if judged else None}
    named = [c["faults_named"] for c in cells if c.get("faults_named") is not None]
    faults = {"named": sum(named), "of": len(named), "rate": sum(named) / len(named) if named else None}
    identifications = [c["identification"] for c in cells if c.get("identification") is not None]
    strict = sum(i["strict"] for i in identifications)
    strictly = {"strict": strict, "of": len(identifications),
                "rate": strict / len(identifications) if identifications else None}
    procedures = {}
    for c in cells:
        if c["check_procedure"] is not None:
            procedures[c["check_procedure"]] = procedures.get(c["check_procedure"], 0) + 1
    return {"cells": cells, "totals": {"cells": len(cells), "breaking": len(breaking), "rows": rows,
                                       "identified": identified, "faults_named": faults,
                                       "strict_identification": strictly,
                                       "confusion": identification_confusion(identifications),
                                       "check_procedures": procedures}}


def _share_text(cell: dict, key: str) -> str:
    """A row's share in ``summary.md`` (percent, marked where it recovers; empty without the row)."""
    if key not in cell["shares"]:
        return ""
    share = cell["shares"][key]
    text = "n/a" if share is None else f"{share:.0%}"
    return text + (f" {RECOVERS_MARK}" if cell["recovers"].get(key) else "")


def _gains_text(cell: dict) -> str:
    """The self-model's pectoral gains beside the truth's in ``summary.md`` (empty without them)."""
    right = cell.get("signs_right")
    if right is None:
        return ""
    model, target = cell["gains"]["self_model"], cell["gains"]["target"]
    pair = ", ".join(f"{model[k]:+g}" for k in _SERVO_GAINS[:2])
    truth = ", ".join(f"{target[k]:+g}" for k in _SERVO_GAINS[:2])
    return f"{pair} ({truth}){f' {RECOVERS_MARK}' if right else ''}"


def _confusion_table(confusion: dict) -> list[str]:
    """The lines of ``summary.md``'s confusion matrix (truth's class per row, the model's per
    column, ``servo kind/flipper kind``), only the classes that occur; none when no part counts."""
    rows = [r for r, cols in confusion.items() if any(cols.values())]
    columns = [c for c in dict.fromkeys(c for cols in confusion.values() for c in cols)
               if any(cols.get(c) for cols in confusion.values())]
    if not rows:
        return []
    return ["", "The self-models' parts (servo kind/flipper kind), the truth's per row and the model's per column "
                "(a lost flipper's servo is not judged: it counts as the truth's):", "",
            "| truth ↓, model → | " + " | ".join(f"`{c}`" for c in columns) + " |",
            "|---|" + "---|" * len(columns),
            *(f"| `{r}` | " + " | ".join(str(confusion[r].get(c, 0)) for c in columns) + " |" for r in rows)]


def render_summary(summary: dict) -> str:
    """``summary.md``: per damage and seed whether the damage breaks the healthy gait and each row's
    share of the oracle (marked where the row recovers), per damage on how many seeds it breaks
    the healthy gait, then each row's recoveries among the breaking cells, and how well the
    self-models identify the faults (the pectoral signs, the lenient and the strict judgement,
    the parts' confusion matrix)."""
    from aquafish.case_study import BREAKS_SHARE, RECOVERS_OVER_HEALTHY, RECOVERS_SHARE, format_self_model_fields

    s, totals = summary["settings"], summary["totals"]
    keys = [k for k in ROWS if any(k in c["shares"] for c in summary["cells"])]
    lines = [f"# Recovery benchmark: {s['preset']} preset, {s['episode_duration_s']:g} s episodes", "",
             f"Each row's mean distance on the damaged robot as a share of the oracle gait's (evolved on the "
             f"damaged robot); {RECOVERS_MARK}: the row recovers (at least {RECOVERS_SHARE:.0%} of the oracle and "
             f"{RECOVERS_OVER_HEALTHY:g}x the healthy gait). A damage breaks the healthy gait when it keeps at most "
             f"{BREAKS_SHARE:.0%} of the oracle; n/a: the oracle does not swim forward.", "",
             *([f"Every cell's self-model has settings of its own: "
                + format_self_model_fields(s["self_model_fields"]) + ".", ""]
               if s.get("self_model_fields") else []),
             f"The self-model's pectoral gains (left, right) are given beside the truth's; {RECOVERS_MARK}: each "
             f"on the truth's side of 0 (a pectoral whose flipper the target lost is not judged).", "",
             "| damage | seed | breaks | " + " | ".join(f"`{k}`" for k in keys) + " | self-model gains (truth) |",
             "|---|---|---|" + "---|" * len(keys) + "---|"]
    for cell in summary["cells"]:
        lines.append(f"| `{cell['damage']}` | {cell['seed']} | {'yes' if cell['breaks'] else 'no'} | "
                     + " | ".join(_share_text(cell, k) for k in keys) + f" | {_gains_text(cell)} |")
    damages = list(dict.fromkeys(c["damage"] for c in summary["cells"]))
    per_damage = [(d, [c["breaks"] for c in summary["cells"] if c["damage"] == d]) for d in damages]
    lines += ["", "Breaks the healthy gait (seeds): " + ", ".join(
        f"`{d}` {sum(b)}/{len(b)}" for d, b in per_damage) + "."]
    lines += ["", f"Recovers in the {totals['breaking']} of {totals['cells']} cells that break: "
              + (", ".join(f"`{k}` {r['recovers']}/{r['of']}" for k, r in totals["rows"].items()) or "no rows") + "."]
    identified = totals.get("identified")
    if identified and identified["of"]:
        lines += ["", f"Pectoral signs right: {identified['right']} of the {identified['of']} cells with a "
                      "self-model of servo gains."]
    named = totals.get("faults_named")
    if named and named["of"]:
        lines += ["", f"Faulty servos named, each with the sign of its gain: {named['named']} of the {named['of']} "
                      "cells whose target has a faulty servo on a flipper it still has (the lenient measure: a "
                      "healthy servo held faulty is not counted)."]
    strictly = totals.get("strict_identification")
    if strictly and strictly["of"]:
        lines += ["", "Identified strictly (every faulty part named with its kind, no healthy part held faulty): "
                      f"{strictly['strict']} of {strictly['of']} cells."]
        lines += _confusion_table(totals.get("confusion") or {})
    procedures = totals.get("check_procedures")
    if procedures:
        lines += ["", "Self-models checked against fault hypotheses by: " + "; ".join(
            f"{p or 'an earlier, unnamed procedure'} ({n} cells)" for p, n in procedures.items()) + "."]
    if summary.get("missing"):
        lines += ["", "Not finished (run the command again to finish them): "
                  + ", ".join(f"`{m['damage']}` seed {m['seed']}" for m in summary["missing"]) + "."]
    return "\n".join(lines) + "\n"
