"""Studies: many independent, resumable EEA runs, and the paper's Figures 5-10.

A study is conditions (named methods, :mod:`eea.methods`) x experiment durations x replicate
seeds (paper section 4; docs/self_modeling.md). Each (condition, duration, replicate) is one
:func:`eea.run` in ``OUT/<condition>/<duration>s/seed<k>``; a run whose ``rounds.csv``
already holds every round is skipped, and an interrupted one resumes from its last
finished round. Runs execute in a local process pool (one process per core, each run
serial) or, with ``backend="ray"``, as Ray tasks on a cluster (the ``[cluster]`` extra;
:func:`aquafish.backends.connect_ray` fails in about a second, with one line, without Ray, without a cluster at
the address or without the token a token-authenticated cluster asks for). On Ray a run works in
a temporary directory on its node and its finished files come back to this process, which
writes them into ``OUT`` (:mod:`aquafish.shipping`): no shared file system is needed, and which
runs are finished is decided here, as on the local pool. A finished ``morphology+servos`` run
whose check against fault hypotheses is missing or was made by an earlier procedure
(:mod:`eea.fault_check`) is run again for its check only (:func:`run_pending`).
The results are read back and plotted by :mod:`eea.analysis.plot` (``aquafish plot``).
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

from aquafish import backends
from aquafish.shipping import DirTask, run_dir_tasks
from aquafish_gym.checks import check_int
from aquafish_gym.files import atomic_write
from aquafish_gym.progress import progress_bar
from aquafish_gym.rundir import FileError, check_output_dir, make_subdir, read_json, run_lock
from eea.checkpoint import STATE_FILE
from eea.compat import upgrade_flat_fields
from eea.config import FLAT_DEFAULTS, EEAConfig, nest_flat
from eea.encoding import get_model_space
from eea.methods import METHODS, method_fields
from eea.record import load_result, read_rounds



@dataclasses.dataclass(frozen=True)
class StudySpec:
    """What to run.

    Attributes:
        conditions: method names (:data:`eea.methods.METHODS`, e.g. ``("out_of_band",
            "profile_lineages")``); each run is ``base`` with the method's fields, except those
            named in ``fixed``, by :meth:`eea.config.EEAConfig.from_flat` (a run keeps the fields
            of ``base`` that its strategy and search use). A name that is no method but an
            inference strategy (``"profile"``, in studies written before methods had names) sets
            ``inference`` alone.
        durations_s: experiment durations in seconds (paper: 1.28, 2.56, 5.12, 10.24).
        replicates: seeds ``first_seed .. first_seed + replicates - 1`` per (condition,
            duration); paper: 25.
        base: every other EEA setting by flat name (:data:`eea.config.FLAT_FIELDS`: the flags'
            vocabulary; population sizes, generations, rounds, damage, and the settings of every
            strategy and search, e.g. a budget's ``oob_period`` for the out-of-band runs), or an
            :class:`~eea.config.EEAConfig` (its :meth:`~eea.config.EEAConfig.to_flat`). Held as
            every flat field, a name left out at its default (``workers`` 1); ``study.json``
            records it so.
        first_seed: the first seed (default 0): a study's seeds can be run in shards, e.g.
            seeds 0-9 on one machine and ``first_seed=10`` on another, into one directory.
        fixed: fields ``base`` holds that no method overrides (``aquafish study``: the flags
            given explicitly, e.g. ``--lineages 1`` beside ``--methods profile_lineages``). One at
            another value than its default must be used by some run (``--oob-period 5`` needs an
            out-of-band condition); only the fields some method sets are kept.

    Raises:
        ValueError: empty lists, duplicate entries, ``replicates < 1``, ``first_seed < 0`` or
            an invalid condition/duration (checked by building each run's :class:`EEAConfig`), an
            unknown field in ``base`` or ``fixed``, or a field of ``fixed`` at another value than
            its default that no run uses.
    """

    conditions: tuple[str, ...]
    durations_s: tuple[float, ...]
    replicates: int
    base: dict | EEAConfig = dataclasses.field(default_factory=lambda: {"workers": 1})
    first_seed: int = 0
    fixed: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        base = self.base.to_flat() if isinstance(self.base, EEAConfig) else dict(self.base)
        nest_flat(base)  # unknown names fail here
        base = {**FLAT_DEFAULTS, "workers": 1, **base}
        # canonical values (the damage's text) of the fields a config holds; the others as given
        object.__setattr__(self, "base", {**base, **EEAConfig.from_flat({}, optional=base).to_flat()})
        unknown = sorted(set(self.fixed) - set(FLAT_DEFAULTS))
        if unknown:
            raise ValueError(f"fixed names unknown EEAConfig fields {unknown}")
        given = tuple(self.fixed)
        # only a field some method sets can be overridden: the rest is dropped, so a study
        # started before methods had names (no "fixed" in its study.json) resumes with --damage D
        method_keys = {k for m in METHODS.values() for k in m.fields}
        object.__setattr__(self, "fixed", tuple(sorted(set(self.fixed) & method_keys)))
        object.__setattr__(self, "conditions", tuple(self.conditions))
        object.__setattr__(self, "durations_s", tuple(float(d) for d in self.durations_s))
        if not self.conditions or len(set(self.conditions)) != len(self.conditions):
            raise ValueError(f"conditions must be a non-empty list without repeats, got {self.conditions}")
        if not self.durations_s or len(set(self.durations_s)) != len(self.durations_s):
            raise ValueError(f"durations must be a non-empty list without repeats, got {self.durations_s}")
        check_int("replicates", self.replicates, 1)
        check_int("first_seed", self.first_seed, 0)
        used = {k for config, _ in self.runs(Path(".")) for k in config.to_flat()}  # validates every run's config
        unused = [k for k in given if k not in used and self.base[k] != FLAT_DEFAULTS[k]]
        if unused:
            raise ValueError(f"no run of the study uses {', '.join(f'EEAConfig.{k} = {self.base[k]!r}' for k in unused)} "
                             f"(a setting of a strategy or search none of its methods runs)")

    @property
    def seeds(self) -> range:
        """The study's seeds: ``first_seed .. first_seed + replicates - 1``."""
        return range(self.first_seed, self.first_seed + self.replicates)

    def _method_fields(self, condition: str) -> dict:
        """The fields the method ``condition`` sets, except those in ``fixed``; a legacy
        inference name sets ``inference``."""
        if condition not in METHODS:
            return {"inference": condition}
        return {k: v for k, v in method_fields(condition).items() if k not in self.fixed}

    def runs(self, out_dir: Path) -> list[tuple[EEAConfig, Path]]:
        """Every run of the study: ``(config, run directory)``, replicate by replicate.

        The first seed of every (condition, duration) comes first, then the next, ...: a study
        that is stopped early (or looked at while running) has the same replicates of every
        condition.
        """
        out = []
        for seed in self.seeds:
            for condition in self.conditions:
                for duration in self.durations_s:
                    config = EEAConfig.from_flat({"duration_s": duration, "seed": seed},
                                                 optional={**self.base, **self._method_fields(condition)})
                    out.append((config, Path(out_dir) / condition / f"{duration:g}s" / f"seed{seed}"))
        return out


def rounds_done(run_dir: Path) -> int:
    """Number of finished rounds recorded in ``run_dir/rounds.csv`` (0 if none)."""
    return len(read_rounds(run_dir))


def run_pending(config: EEAConfig, run_dir: Path) -> bool:
    """Whether a study's run has work left: rounds to run, or, for a finished
    ``morphology+servos`` run with its checkpoint, its check against fault hypotheses to make
    (none yet, or one of another round or an earlier procedure:
    :attr:`eea.record.RunResult.fault_check` is None), which :func:`eea.run` then makes from
    the checkpoint's experiments without running a round. A finished run without a checkpoint
    (a published one) has nothing left that can be done.

    Raises:
        ValueError: a corrupt record in ``run_dir`` (:class:`~aquafish_gym.rundir.FileError`).
    """
    if rounds_done(run_dir) < config.rounds:
        return True
    return (get_model_space(config.model_space).servos and (run_dir / STATE_FILE).is_file()
            and load_result(run_dir).fault_check is None)


def _run_one(config_dict: dict, run_dir: str) -> str:
    """Run (or resume) one EEA run; top-level so process pools and Ray can ship it."""
    import eea

    eea.run(EEAConfig.from_dict(config_dict), Path(run_dir), progress=False)
    return run_dir


def run_study(spec: StudySpec, out_dir, *, backend: str = "local", address: str | None = None,
              processes: int | None = None, progress: bool = True) -> list[Path]:
    """Run every unfinished run of ``spec`` under ``out_dir``; return all run directories.

    Args:
        spec: the study.
        out_dir: study directory; ``study.json`` records the spec and every seed run into it.
        backend: ``"local"`` (a process pool over ``processes`` cores, default all) or
            ``"ray"`` (Ray tasks; ``address`` as for ``ray.init``, e.g. ``"auto"`` or
            ``"ray://head:10001"``; ``None`` starts a local Ray instance). On Ray each run's
            directory is written here from the files its task sends back (no shared file
            system); a run whose worker is lost is retried and logged.
        processes: local pool size (default ``os.cpu_count()``).
        progress: show progress over runs (a tqdm bar on a terminal, else one line per run),
            with the best final objective fitness per condition among the runs finished so far.

    Raises:
        ValueError: unknown backend, an ``address`` without ``backend="ray"``, ``processes`` < 1,
            ``out_dir`` cannot be written (checked before anything is created), another process
            is running a study there (:class:`~aquafish_gym.rundir.BusyError`), a file in it is corrupt, or
            ``study.json`` exists with a different spec (other seeds of the same spec are the
            same study: new seeds extend it, and ``study.json`` records the union of its seeds).
        aquafish.backends.ClusterError: ``backend="ray"`` without the ``[cluster]`` extra, or a cluster that
            cannot be reached or refuses this client (:func:`aquafish.backends.connect_ray`); before anything is
            created.
        ValueError: a run raised one (e.g. a corrupt file in its directory): the run's own
            error, also from a Ray task (not Ray's ``RayTaskError`` around it).
    """
    backends.check_backend(backend, address)
    if processes is not None:
        check_int("--processes", processes, 1)
    out_dir = check_output_dir(out_dir)
    from eea.run import check_run_memory

    for config, _ in spec.runs(out_dir):
        check_run_memory(config)
    if backend == "ray":
        backends.connect_ray(address)
    with run_lock(out_dir, command="study"):
        return _run_study_locked(spec, out_dir, backend, address, processes, progress)


def _run_study_locked(spec: StudySpec, out_dir: Path, backend: str, address: str | None, processes: int | None,
                      progress: bool) -> list[Path]:
    _write_spec(spec, out_dir)
    runs = spec.runs(out_dir)
    todo = [(c, d) for c, d in runs if run_pending(c, d)]
    bar = progress_bar(len(runs), initial=len(runs) - len(todo), desc="study runs", unit="run", disable=not progress)
    best = {}

    def finished(run_dir: str) -> None:
        rows = read_rounds(Path(run_dir))
        if rows:  # the best final objective fitness so far, per condition
            condition = Path(run_dir).parts[-3]
            best[condition] = max(best.get(condition, 0.0), float(rows[-1]["objective_fitness"]))
            bar.set_postfix_str(", ".join(f"{c} {v:.3f}" for c, v in best.items()))
        bar.update()

    for _, d in todo:  # the runs' directories, made here: never through a link planted in the study's
        make_subdir(out_dir, *d.relative_to(out_dir).parts)
    tasks = [DirTask(_run_one, (c.to_dict(), str(d)), outputs=(1,), label=f"run {d.relative_to(out_dir)}")
             for c, d in todo]
    for run_dir in run_dir_tasks(tasks, backend=backend, processes=processes or os.cpu_count() or 1, address=address):
        finished(run_dir)
    bar.close()
    return [d for _, d in runs]


def _study_seeds(study: dict) -> list[int]:
    """The seeds a ``study.json`` records: its ``seeds``, or ``0 .. replicates - 1`` in a file
    written before studies could start at another seed."""
    return sorted(study["seeds"]) if "seeds" in study else list(range(study["replicates"]))


def _write_spec(spec: StudySpec, out_dir: Path) -> None:
    data = {"conditions": list(spec.conditions), "durations_s": list(spec.durations_s),
            "seeds": list(spec.seeds), "base": dict(spec.base)}
    if spec.fixed:  # only when set: a study.json written before still describes its study
        data["fixed"] = list(spec.fixed)
    data["base"].pop("workers", None)
    path = out_dir / "study.json"
    if path.exists():
        old = read_json(path)
        try:
            # a spec written before a field was added gets its default (eea.compat: deep water before the
            # surface swimmer, retired fields dropped); canonical values as StudySpec holds them
            old["base"] = dataclasses.replace(spec, base=upgrade_flat_fields(old["base"])).base
            old["base"].pop("workers", None)
            old_seeds = _study_seeds(old)
        except (KeyError, TypeError, ValueError) as err:
            raise FileError(path, f"is not a study.json ({type(err).__name__}: {err})") from None
        if {k: v for k, v in old.items() if k not in ("seeds", "replicates")} \
                != {k: v for k, v in data.items() if k != "seeds"}:
            diff = [k for k in data if k not in ("seeds", "base") and old.get(k) != data[k]]
            diff += [f"base.{k}" for k in data["base"] if old.get("base", {}).get(k) != data["base"][k]]
            raise ValueError(f"{path} describes a different study (differs in {', '.join(diff) or 'its keys'}); "
                             "use another --out or delete it")
        if set(data["seeds"]) <= set(old_seeds):  # a subset of its seeds: nothing to record
            return
        # other seeds of the same study: it grows, its finished seeds are kept
        data["seeds"] = sorted(set(old_seeds) | set(data["seeds"]))
    atomic_write(path, json.dumps(data, indent=2).encode())
