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
:data:`QUALIFY_RATIO` with the oracle gait swimming forward: the damage breaks the healthy
gait, and a gait made for the damaged body does much better.

Every gait is evolved once into ``OUT/gaits/<robot>/`` and reused when the command is
repeated (:func:`gait.evolve_or_load_gait`; an interrupted gait run resumes from its last
checkpoint); the table is written
to ``OUT/damage_table.json`` and ``.md`` through :func:`aquafish_gym.files.atomic_write`.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from aquafish_gym.checks import check_int
from aquafish_gym import DAMAGES
from aquafish_gym.files import atomic_write
from gait.neat_evolution import evolve_or_load_gait
from gait.rollout import rollout

#: A damage qualifies for the case study when the healthy gait keeps at most this share of
#: what the oracle gait reaches on the damaged robot (issue "a robot that swims", item 4).
QUALIFY_RATIO = 0.5


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


def _gait(robot: str, budget: GaitBudget, out_dir: Path, verbose: bool):
    return evolve_or_load_gait(robot, out_dir, generations=budget.generations, population_size=budget.population_size,
                               seed=budget.seed, workers=budget.workers,
                               episodes_per_genome=budget.episodes_per_genome, verbose=verbose)


def distances(controller, robot: str, eval_seed: int, starts: int) -> np.ndarray:
    """``(starts,)`` forward distances (units, 20 s) of ``controller`` on ``robot`` from seeds ``eval_seed + k``."""
    return np.array([rollout(controller, robot, seed=eval_seed + k).distance for k in range(starts)])


def _summary(values: np.ndarray) -> dict[str, Any]:
    return {"mean": float(values.mean()), "min": float(values.min()), "max": float(values.max()),
            "distances": values.tolist()}


def damage_table(out, *, damages=None, budget: GaitBudget = GaitBudget(), starts: int = 10,
                 eval_seed: int = 1000, verbose: bool = False) -> list[dict[str, Any]]:
    """Evolve the gaits and measure the table; write ``damage_table.json`` and ``.md`` to ``out``.

    Args:
        out: output directory.
        damages: damage names (default: every preset but ``"none"``).
        budget: NEAT budget of every gait.
        starts: fresh starts per (gait, robot) pair.
        eval_seed: seed of the first fresh start (keep it away from the training seeds).
        verbose: NEAT's per-generation report.

    Returns:
        One row per damage (the JSON's content).

    Raises:
        ValueError: an unknown damage name or ``starts`` < 1.
    """
    names = sorted(d for d in DAMAGES if d != "none") if damages is None else list(damages)
    unknown = [d for d in names if d not in DAMAGES or d == "none"]
    if unknown:
        raise ValueError(f"unknown damage(s) {unknown}; valid: {', '.join(sorted(d for d in DAMAGES if d != 'none'))}")
    check_int("starts", starts, 1)
    out = Path(out)
    healthy_gait = _gait("healthy", budget, out / "gaits" / "healthy", verbose)
    on_healthy = distances(healthy_gait, "healthy", eval_seed, starts)
    rows = []
    for name in names:
        oracle = _gait(name, budget, out / "gaits" / name, verbose)
        healthy_on_damaged = distances(healthy_gait, name, eval_seed, starts)
        oracle_on_damaged = distances(oracle, name, eval_seed, starts)
        oracle_swims = bool(oracle_on_damaged.mean() > 0)
        ratio = float(healthy_on_damaged.mean() / oracle_on_damaged.mean()) if oracle_swims else None
        rows.append({
            "damage": name,
            "description": DAMAGES[name].description,
            "healthy_gait_on_healthy": _summary(on_healthy),
            "healthy_gait_on_damaged": _summary(healthy_on_damaged),
            "oracle_gait_on_damaged": _summary(oracle_on_damaged),
            "recovery_needed": ratio,
            "qualifies": oracle_swims and ratio <= QUALIFY_RATIO,
        })
    meta = {"budget": dataclasses.asdict(budget), "starts": starts, "eval_seed": eval_seed, "rows": rows}
    atomic_write(out / "damage_table.json", json.dumps(meta, indent=1).encode())
    atomic_write(out / "damage_table.md", format_table(rows, starts).encode())
    return rows


def format_table(rows: list[dict[str, Any]], starts: int) -> str:
    """Markdown table: mean (min to max) forward distance in 20 s per gait and robot."""

    def cell(s: dict[str, Any]) -> str:
        return f"{s['mean']:.2f} ({s['min']:.2f} to {s['max']:.2f})"

    lines = [f"Forward distance in 20 s (units, 1 unit = 8 cm), mean (min to max) over {starts} fresh starts.", "",
             "| damage | healthy gait on healthy | healthy gait on damaged | oracle gait on damaged | healthy / oracle | qualifies |",
             "|---|---|---|---|---|---|"]
    for r in rows:
        ratio = "n/a" if r["recovery_needed"] is None else f"{r['recovery_needed']:.2f}"
        lines.append(f"| `{r['damage']}` | {cell(r['healthy_gait_on_healthy'])} | {cell(r['healthy_gait_on_damaged'])} | "
                     f"{cell(r['oracle_gait_on_damaged'])} | {ratio} | {'yes' if r['qualifies'] else 'no'} |")
    return "\n".join(lines) + "\n"
