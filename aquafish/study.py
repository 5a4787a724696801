"""Studies: many independent, resumable EEA runs, and the paper's Figures 5-10.

A study is conditions (inference strategies) x experiment durations x replicate seeds
(paper section 4, DESIGN.md section 8). Each (condition, duration, replicate) is one
:func:`eea.run` in ``OUT/<condition>/<duration>s/seed<k>``; a run whose ``rounds.csv``
already holds every round is skipped, and an interrupted one resumes from its last
finished round. Runs execute in a local process pool (one process per core, each run
serial) or, with ``backend="ray"``, as Ray tasks on a cluster (the ``[cluster]`` extra).
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Iterable

import numpy as np
from tqdm.auto import tqdm

from eea.config import EEAConfig

BACKENDS = ("local", "ray")


@dataclasses.dataclass(frozen=True)
class StudySpec:
    """What to run.

    Attributes:
        conditions: inference strategy names (e.g. ``("known", "none", "in_band", "out_of_band")``).
        durations_s: experiment durations in seconds (paper: 1.28, 2.56, 5.12, 10.24).
        replicates: seeds ``0 .. replicates-1`` per (condition, duration); paper: 25.
        base: every other EEA setting (population sizes, generations, rounds, damage).

    Raises:
        ValueError: empty lists, duplicate entries, ``replicates < 1`` or an invalid
            condition/duration (checked by building each run's :class:`EEAConfig`).
    """

    conditions: tuple[str, ...]
    durations_s: tuple[float, ...]
    replicates: int
    base: EEAConfig = dataclasses.field(default_factory=lambda: EEAConfig(workers=1))

    def __post_init__(self) -> None:
        object.__setattr__(self, "conditions", tuple(self.conditions))
        object.__setattr__(self, "durations_s", tuple(float(d) for d in self.durations_s))
        if not self.conditions or len(set(self.conditions)) != len(self.conditions):
            raise ValueError(f"conditions must be a non-empty list without repeats, got {self.conditions}")
        if not self.durations_s or len(set(self.durations_s)) != len(self.durations_s):
            raise ValueError(f"durations must be a non-empty list without repeats, got {self.durations_s}")
        if isinstance(self.replicates, bool) or not isinstance(self.replicates, int) or self.replicates < 1:
            raise ValueError(f"replicates must be a positive integer, got {self.replicates!r}")
        self.runs(Path("."))  # validates every run's config

    def runs(self, out_dir: Path) -> list[tuple[EEAConfig, Path]]:
        """Every run of the study: ``(config, run directory)``, in a fixed order."""
        out = []
        for condition in self.conditions:
            for duration in self.durations_s:
                for seed in range(self.replicates):
                    config = self.base.replace(inference=condition, duration_s=duration, seed=seed)
                    out.append((config, Path(out_dir) / condition / f"{duration:g}s" / f"seed{seed}"))
        return out


def rounds_done(run_dir: Path) -> int:
    """Number of finished rounds recorded in ``run_dir/rounds.csv`` (0 if none)."""
    path = Path(run_dir) / "rounds.csv"
    if not path.exists():
        return 0
    with path.open(newline="") as f:
        return sum(1 for _ in csv.DictReader(f))


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
        out_dir: study directory; ``study.json`` records the spec.
        backend: ``"local"`` (a process pool over ``processes`` cores, default all) or
            ``"ray"`` (Ray tasks; ``address`` as for ``ray.init``, e.g. ``"auto"`` or
            ``"ray://head:10001"``; ``None`` starts a local Ray instance).
        processes: local pool size (default ``os.cpu_count()``).
        progress: show a tqdm bar over runs.

    Raises:
        ValueError: unknown backend, or ``study.json`` exists with a different spec.
        ModuleNotFoundError: ``backend="ray"`` without the ``[cluster]`` extra.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    _write_spec(spec, out_dir)
    runs = spec.runs(out_dir)
    todo = [(c, d) for c, d in runs if rounds_done(d) < c.rounds]
    bar = tqdm(total=len(runs), initial=len(runs) - len(todo), desc="study runs", unit="run", disable=not progress)
    if backend == "local":
        with ProcessPoolExecutor(max_workers=processes or os.cpu_count()) as pool:
            futures = [pool.submit(_run_one, c.to_dict(), str(d)) for c, d in todo]
            for future in as_completed(futures):
                future.result()
                bar.update()
    else:
        import ray

        if not ray.is_initialized():
            ray.init(address=address, include_dashboard=False, log_to_driver=False)
        remote = ray.remote(num_cpus=1)(_run_one)
        pending = [remote.remote(c.to_dict(), str(d)) for c, d in todo]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            ray.get(done)
            bar.update(len(done))
    bar.close()
    return [d for _, d in runs]


def _write_spec(spec: StudySpec, out_dir: Path) -> None:
    data = {"conditions": list(spec.conditions), "durations_s": list(spec.durations_s),
            "replicates": spec.replicates, "base": spec.base.to_dict()}
    data["base"].pop("workers", None)
    path = out_dir / "study.json"
    if path.exists():
        old = json.loads(path.read_text())
        old["base"].pop("workers", None)
        if old != data:
            raise ValueError(f"{path} describes a different study; use another --out or delete it")
        return
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=2))
    tmp.replace(path)


# -- results --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class RunCurve:
    """Objective fitness per round of one finished or partial run."""

    inference: str
    duration_s: float
    seed: int
    objective_fitness: np.ndarray  # (rounds,)


def find_runs(paths: Iterable) -> list[RunCurve]:
    """All EEA run directories (``config.json`` + ``rounds.csv``) under ``paths``, recursively.

    Raises:
        ValueError: a path that does not exist, or no run found.
    """
    curves = []
    for root in paths:
        root = Path(root)
        if not root.exists():
            raise ValueError(f"{root} does not exist")
        for cfg in sorted(root.rglob("config.json")):
            csv_path = cfg.with_name("rounds.csv")
            if not csv_path.exists():
                continue
            config = json.loads(cfg.read_text())
            with csv_path.open(newline="") as f:
                fitness = np.array([float(row["objective_fitness"]) for row in csv.DictReader(f)])
            if fitness.size:
                curves.append(RunCurve(config["inference"], float(config["duration_s"]), int(config["seed"]), fitness))
    if not curves:
        raise ValueError(f"no EEA runs (config.json + rounds.csv) found under {[str(p) for p in paths]}")
    return curves


def summarise(curves: list[RunCurve]) -> dict[tuple[str, float], dict]:
    """Mean and standard deviation of objective fitness per round, per (inference, duration).

    Runs of different lengths are truncated to the shortest in their group.
    Returns ``{(inference, duration_s): {"mean": (R,), "std": (R,), "n": replicates}}``.
    """
    groups: dict[tuple[str, float], list[np.ndarray]] = {}
    for c in curves:
        groups.setdefault((c.inference, c.duration_s), []).append(c.objective_fitness)
    out = {}
    for key, series in sorted(groups.items()):
        rounds = min(len(s) for s in series)
        arr = np.stack([s[:rounds] for s in series])
        out[key] = {"mean": arr.mean(axis=0), "std": arr.std(axis=0), "n": len(series)}
    return out


def plot_study(summary: dict, path: Path) -> Path:
    """Figures 5-10: per condition, mean objective fitness (solid) and its standard
    deviation (dashed) against EEA round, one colour per experiment duration. Writes a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conditions = sorted({k[0] for k in summary}, key=_condition_order)
    fig, axes = plt.subplots(1, len(conditions), figsize=(4.2 * len(conditions), 3.6), squeeze=False, sharey=True)
    for ax, condition in zip(axes[0], conditions):
        for i, ((cond, duration), s) in enumerate((k, v) for k, v in summary.items() if k[0] == condition):
            rounds = np.arange(1, len(s["mean"]) + 1)
            color = f"C{i}"
            ax.plot(rounds, s["mean"], "-", color=color, label=f"{duration:g} s (n={s['n']})")
            ax.plot(rounds, s["std"], "--", color=color)
        ax.set_title(condition)
        ax.set_xlabel("EEA round")
        ax.set_ylim(0, 1.02)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="center right")
    axes[0, 0].set_ylabel("objective fitness (solid: mean, dashed: std)")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.png")
    fig.savefig(tmp, dpi=120)
    plt.close(fig)
    tmp.replace(path)
    return path


def _condition_order(name: str) -> tuple[int, str]:
    order = ["known", "none", "in_band", "out_of_band"]
    return (order.index(name) if name in order else len(order), name)


def final_round_table(summary: dict) -> str:
    """Plain-text table of final-round mean and std objective fitness per (condition, duration)."""
    lines = [f"{'condition':<14} {'duration_s':>10} {'runs':>5} {'rounds':>6} {'mean':>7} {'std':>7}"]
    for (condition, duration), s in sorted(summary.items(), key=lambda kv: (_condition_order(kv[0][0]), kv[0][1])):
        lines.append(f"{condition:<14} {duration:>10g} {s['n']:>5} {len(s['mean']):>6} {s['mean'][-1]:>7.3f} {s['std'][-1]:>7.3f}")
    return "\n".join(lines)
