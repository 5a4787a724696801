"""Which damages a gait must adapt to: the damage table (``aquafish damages``).

For every damage preset, in 20 s episodes from the same fresh starts (initial flipper
angles drawn from seeds ``eval_seed, eval_seed + 1, ...``, none of them a training start):

* the **healthy gait** (NEAT, evolved on the healthy robot) on the healthy and on the
  damaged robot, and
* the **oracle gait** (NEAT, evolved on the true damaged robot, servo faults included) on
  the damaged robot: what recovery could reach at best.

``recovery_needed = healthy gait on the damaged robot / oracle gait on the damaged robot``
(``None`` when the oracle gait does not swim forward, the robot cannot recover);
a damage *qualifies* for the damage-recovery case study (paper section 5) when it is at most
:data:`QUALIFY_RATIO` and the oracle gait on the damaged robot reaches at least
:data:`QUALIFY_RATIO` of the healthy gait on the healthy robot: the damage breaks the healthy
gait, and a gait made for the damaged body swims well again. ``qualifies`` judges the
paper's 20 s episodes; the same gaits are also scored over :data:`LONG_EPISODE_S` (60 s),
where a robot that veers loses more of its distance (the ``*_long`` fields,
``qualifies_long``).

Every gait is evolved once into ``OUT/gaits/<robot>/`` and reused when the command is
repeated (:func:`gait.evolve_or_load_gait`; an interrupted gait run resumes from its last
checkpoint); the table is written
to ``OUT/damage_table.json`` and ``.md`` through :func:`aquafish_gym.files.atomic_write`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from aquafish_gym.checks import check_int
from aquafish_gym import DAMAGES, get_damage
from aquafish_gym.faults import SAMPLED_PREFIX, sampled_fault
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import run_lock
from gait.neat_evolution import evolve_or_load_gait
from gait.rollout import rollout

#: A damage qualifies for the case study when the healthy gait keeps at most this share of
#: what the oracle gait reaches on the damaged robot (issue "a robot that swims", item 4).
QUALIFY_RATIO = 0.5
#: The longer episode of the table's second set of columns (s).
LONG_EPISODE_S = 60.0


@dataclasses.dataclass(frozen=True)
class GaitBudget:
    """NEAT budget of every gait in the table.

    Attributes:
        generations: NEAT generations.
        population_size: genomes per generation.
        episodes_per_genome: training starts per genome (seeds ``seed ... seed + K - 1``).
        seed: NEAT seed and first training start.
        workers: evaluation processes.
    """

    generations: int = 30
    population_size: int = 50
    episodes_per_genome: int = 2
    seed: int = 0
    workers: int = 1


def _gait(robot: str, budget: GaitBudget, out_dir: Path, verbose: bool, progress: bool = True):
    return evolve_or_load_gait(robot, out_dir, generations=budget.generations, population_size=budget.population_size,
                               seed=budget.seed, workers=budget.workers,
                               episodes_per_genome=budget.episodes_per_genome, verbose=verbose, progress=progress)


def distances(controller, robot: str, eval_seed: int, starts: int, duration_s: float = 20.0) -> np.ndarray:
    """``(starts,)`` forward distances (units, in ``duration_s`` seconds) of ``controller`` on ``robot`` from
    seeds ``eval_seed + k``."""
    return np.array([rollout(controller, robot, seed=eval_seed + k, episode_duration_s=duration_s).distance
                     for k in range(starts)])


def _ratio(healthy: np.ndarray, oracle: np.ndarray) -> float | None:
    """Healthy gait over oracle gait on the damaged robot (None when the oracle does not swim forward)."""
    return float(healthy.mean() / oracle.mean()) if oracle.mean() > 0 else None


def qualifies(recovery_needed: float | None, oracle_on_damaged: float, healthy_on_healthy: float) -> bool:
    """Whether a damage qualifies for the case study (module docstring): the healthy gait keeps at most
    :data:`QUALIFY_RATIO` of the oracle's distance on the damaged robot, and the oracle reaches at least
    :data:`QUALIFY_RATIO` of the healthy gait's distance on the healthy robot (mean distances, units)."""
    return bool(recovery_needed is not None and recovery_needed <= QUALIFY_RATIO
                and oracle_on_damaged >= QUALIFY_RATIO * healthy_on_healthy)


def _summary(values: np.ndarray) -> dict[str, Any]:
    return {"mean": float(values.mean()), "min": float(values.min()), "max": float(values.max()),
            "distances": values.tolist()}


def check_damages(damages=None) -> list[str]:
    """The table's damages as canonical text (:func:`aquafish_gym.get_damage`'s ``name``; a file is read here).

    Args:
        damages: None (every preset but ``"none"``) or a sequence of damages (preset names,
            JSON faults inline or as ``.json`` files, ``sampled:SEED``).

    Raises:
        ValueError: an unknown name, ``"none"`` or a fault that changes nothing (no damage to
            adapt to), or an invalid fault (its one-line message).
    """
    if damages is None:
        return sorted(d for d in DAMAGES if d != "none")
    names, unknown = [], []
    for d in damages:
        try:
            name = get_damage(d).name
        except ValueError as err:
            if not str(err).startswith("unknown damage"):
                raise
            unknown.append(d)
            continue
        if name in ("none", "{}"):
            unknown.append(d)
        else:
            names.append(name)
    if unknown:
        raise ValueError(f"unknown damage(s) {unknown}; valid: {', '.join(sorted(d for d in DAMAGES if d != 'none'))}, "
                         f"a JSON fault (inline or FILE.json) or sampled:SEED")
    return names


def gait_dir_name(damage: str) -> str:
    """The directory under ``gaits/`` of the gait evolved on ``damage`` (canonical text): a
    preset's name, ``sampled_SEED``, or ``fault_`` and 12 hex digits of the JSON's SHA-256."""
    if damage in DAMAGES:
        return damage
    if damage.startswith(SAMPLED_PREFIX):
        return "sampled_" + damage[len(SAMPLED_PREFIX):]
    return "fault_" + hashlib.sha256(damage.encode()).hexdigest()[:12]


def damage_list_lines(seeds=range(10)) -> list[str]:
    """What ``aquafish damages --list`` prints: each preset (name and description), then for each
    seed what ``sampled:SEED`` gives (its canonical JSON and a one-sentence description)."""
    lines = ["presets (a --damage or --damages value):"]
    width = max(map(len, DAMAGES))
    lines += [f"  {name:<{width}}  {DAMAGES[name].description}" for name in sorted(DAMAGES)]
    lines += ["", "sampled faults (sampled:SEED; the distribution: docs/simulator.md, Damage):"]
    for seed in seeds:
        fault = sampled_fault(seed)
        lines.append(f"  sampled:{seed:<3} {fault.to_json()}  {fault.describe()}")
    lines += ["", "a fault written out: --damages '{\"gains\": [1, -0.5, 1]}' or FILE.json (keys scale, seized, gains)"]
    return lines


def damage_table(out, *, damages=None, budget: GaitBudget = GaitBudget(), starts: int = 10,
                 eval_seed: int = 1000, verbose: bool = False, progress: bool = True) -> list[dict[str, Any]]:
    """Evolve the gaits and measure the table; write ``damage_table.json`` and ``.md`` to ``out``.

    Args:
        out: output directory.
        damages: damages (default: every preset but ``"none"``): preset names, JSON faults
            (inline or ``.json`` files) or ``sampled:SEED`` (:func:`aquafish_gym.get_damage`);
            a row's ``damage`` is the canonical text, its gait in ``gaits/``:func:`gait_dir_name`.
        budget: NEAT budget of every gait.
        starts: fresh starts per (gait, robot) pair.
        eval_seed: seed of the first fresh start (keep it away from the training seeds).
        verbose: NEAT's per-generation report.
        progress: progress over each gait's generations.

    Returns:
        One row per damage (the JSON's content).

    Raises:
        ValueError: an unknown damage name, ``"none"`` or a fault that is no damage, an invalid
            fault (:func:`~aquafish_gym.get_damage`'s message) or ``starts`` < 1.
    """
    with run_lock(out, command="damages"):  # the library call holds its directory as the command does
        return _damage_table_locked(out, damages=damages, budget=budget, starts=starts, eval_seed=eval_seed,
                                    verbose=verbose, progress=progress)


def _damage_table_locked(out, *, damages=None, budget: GaitBudget = GaitBudget(), starts: int = 10,
                         eval_seed: int = 1000, verbose: bool = False, progress: bool = True) -> list[dict[str, Any]]:
    """The body of :func:`damage_table`, under the lock of ``out``."""
    names = check_damages(damages)
    check_int("starts", starts, 1)
    out = Path(out)
    healthy_gait = _gait("healthy", budget, out / "gaits" / "healthy", verbose, progress)
    on_healthy = distances(healthy_gait, "healthy", eval_seed, starts)
    on_healthy_long = distances(healthy_gait, "healthy", eval_seed, starts, LONG_EPISODE_S)
    rows = []
    for name in names:
        oracle = _gait(name, budget, out / "gaits" / gait_dir_name(name), verbose, progress)
        healthy_on_damaged = distances(healthy_gait, name, eval_seed, starts)
        oracle_on_damaged = distances(oracle, name, eval_seed, starts)
        healthy_long = distances(healthy_gait, name, eval_seed, starts, LONG_EPISODE_S)
        oracle_long = distances(oracle, name, eval_seed, starts, LONG_EPISODE_S)
        ratio, ratio_long = _ratio(healthy_on_damaged, oracle_on_damaged), _ratio(healthy_long, oracle_long)
        rows.append({
            "damage": name,
            "description": get_damage(name).description,
            "healthy_gait_on_healthy": _summary(on_healthy),
            "healthy_gait_on_damaged": _summary(healthy_on_damaged),
            "oracle_gait_on_damaged": _summary(oracle_on_damaged),
            "recovery_needed": ratio,
            "qualifies": qualifies(ratio, oracle_on_damaged.mean(), on_healthy.mean()),
            "healthy_gait_on_healthy_long": _summary(on_healthy_long),
            "healthy_gait_on_damaged_long": _summary(healthy_long),
            "oracle_gait_on_damaged_long": _summary(oracle_long),
            "recovery_needed_long": ratio_long,
            "qualifies_long": qualifies(ratio_long, oracle_long.mean(), on_healthy_long.mean()),
        })
    meta = {"budget": dataclasses.asdict(budget), "starts": starts, "eval_seed": eval_seed, "rows": rows}
    atomic_write(out / "damage_table.json", json.dumps(meta, indent=1).encode())
    atomic_write(out / "damage_table.md", format_table(rows, starts).encode())
    return rows


def format_table(rows: list[dict[str, Any]], starts: int) -> str:
    """Markdown table: mean (min to max) forward distance in 20 s per gait and robot."""

    def cell(s: dict[str, Any]) -> str:
        return f"{s['mean']:.2f} ({s['min']:.2f} to {s['max']:.2f})"

    def ratio(value) -> str:
        return "n/a" if value is None else f"{value:.2f}"

    long = all("healthy_gait_on_damaged_long" in r for r in rows)
    lines = [f"Forward distance (units, 1 unit = 8 cm), mean (min to max) over {starts} fresh starts; qualification "
             f"on the 20 s episodes.", "",
             "| damage | healthy gait on healthy | healthy gait on damaged | oracle gait on damaged | healthy / oracle | qualifies |"
             + (f" {LONG_EPISODE_S:.0f} s: healthy on healthy | healthy on damaged | oracle on damaged | healthy / oracle "
                f"| qualifies |" if long else ""),
             "|---|---|---|---|---|---|" + ("---|---|---|---|---|" if long else "")]
    for r in rows:
        line = (f"| `{r['damage']}` | {cell(r['healthy_gait_on_healthy'])} | {cell(r['healthy_gait_on_damaged'])} | "
                f"{cell(r['oracle_gait_on_damaged'])} | {ratio(r['recovery_needed'])} | {'yes' if r['qualifies'] else 'no'} |")
        if long:
            line += (f" {r['healthy_gait_on_healthy_long']['mean']:.2f} | {r['healthy_gait_on_damaged_long']['mean']:.2f} | "
                     f"{r['oracle_gait_on_damaged_long']['mean']:.2f} | {ratio(r['recovery_needed_long'])} | "
                     f"{'yes' if r['qualifies_long'] else 'no'} |")
        lines.append(line)
    return "\n".join(lines) + "\n"
