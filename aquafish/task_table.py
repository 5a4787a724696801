"""Baselines on every task of the env family: the task table (``aquafish baselines``).

For every registered task (``aquafish_gym.ENV_IDS``) and the healthy robot, the episode
return (and the forward distance) of

* a **random policy** (:class:`gait.RandomController`, uniform actions): "learned nothing";
* a **NEAT** controller (:func:`gait.evolve_or_load_gait` with the task's ``env_id``);
* a **PPO** policy (:func:`gait.train_rl`, the task's section of ``gait/rl_hyperparams.yml``;
  needs the ``[rl]`` extra; ``ppo_timesteps = 0`` leaves it out),

each over the same fresh starts (``reset(seed=eval_seed + k)``: initial flipper angles,
target heading or current drawn by the task), with the training wall time. Every learner
is trained once into ``OUT/<task>/<learner>/`` and reused when the command is repeated (an
interrupted NEAT run resumes from its last checkpoint). The table is written to
``OUT/task_table.json`` and ``.md`` through :func:`aquafish_gym.files.atomic_write`.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np

from aquafish_gym import ENV_IDS
from aquafish_gym.checks import check_int
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import read_json, run_lock
from gait.controller import RandomController, load_controller, require_rl, sb3_sidecar
from gait.neat_evolution import RUN_FILE, evolve_or_load_gait
from gait.rl import train_or_load_rl
from gait.envs import check_env_id
from gait.rollout import rollout


@dataclasses.dataclass(frozen=True)
class BaselineBudget:
    """Training budget of every learner in the table.

    Attributes:
        neat_generations, neat_population, neat_episodes: NEAT generations, genomes per
            generation and training starts per genome (seeds ``seed ... seed + K - 1``).
        ppo_timesteps: PPO env steps (0.1 s each); 0 leaves PPO out.
        seed: seeds NEAT, PPO and the training starts.
        workers: NEAT evaluation processes.
    """

    neat_generations: int = 10
    neat_population: int = 30
    neat_episodes: int = 3
    ppo_timesteps: int = 100_000
    seed: int = 0
    workers: int = 1

    def __post_init__(self) -> None:
        check_int("neat_generations", self.neat_generations, 1)
        check_int("neat_population", self.neat_population, 2)
        check_int("neat_episodes", self.neat_episodes, 1)
        check_int("ppo_timesteps", self.ppo_timesteps, 0)
        check_int("workers", self.workers, 1)


def check_ppo_extra(ppo_timesteps: int) -> None:
    """Refuse a PPO baseline (``ppo_timesteps`` > 0) when the ``[rl]`` extra is not installed.

    Raises:
        MissingExtraError: naming the extra, and ``--ppo-timesteps 0`` to leave PPO out.
    """
    if ppo_timesteps > 0:
        require_rl(f"the PPO baseline (--ppo-timesteps {ppo_timesteps})", training=True,
                   alternative=", or give --ppo-timesteps 0 to leave PPO out")


def _scores(controller, env_id: str, eval_seed: int, starts: int) -> dict[str, Any]:
    episodes = [rollout(controller, seed=eval_seed + k, env_id=env_id) for k in range(starts)]
    returns = np.array([e.episode_return for e in episodes])
    return {"return_mean": float(returns.mean()), "return_std": float(returns.std()),
            "returns": returns.tolist(), "distance_mean": float(np.mean([e.distance for e in episodes]))}


def _neat(env_id: str, budget: BaselineBudget, out: Path, progress: bool):
    controller = evolve_or_load_gait("healthy", out, generations=budget.neat_generations,
                                     population_size=budget.neat_population, seed=budget.seed, workers=budget.workers,
                                     episodes_per_genome=budget.neat_episodes, env_id=env_id, progress=progress)
    return controller, read_json(out / RUN_FILE).get("wall_time_s", 0.0)


def _ppo(env_id: str, budget: BaselineBudget, out: Path, progress: bool):
    path = train_or_load_rl("ppo", "healthy", budget.ppo_timesteps, budget.seed, out, env_id=env_id, num_threads=1,
                            progress=progress)
    return load_controller(path), read_json(sb3_sidecar(path)).get("wall_time_s", 0.0)


def task_table(out, *, env_ids=None, budget: BaselineBudget = BaselineBudget(), starts: int = 10,
               eval_seed: int = 1000, progress: bool = True) -> list[dict[str, Any]]:
    """Train the baselines and measure the table; write ``task_table.json`` and ``.md`` to ``out``.

    Args:
        out: output directory.
        env_ids: tasks (default: every registered one).
        budget: training budget.
        starts: fresh starts per (task, learner).
        eval_seed: seed of the first fresh start (away from the training seeds).
        progress: progress bars.

    Returns:
        One row per (task, learner): ``env_id``, ``learner``, ``return_mean``,
        ``return_std``, ``returns``, ``distance_mean`` (units in 20 s), ``train_wall_s``.

    Raises:
        ValueError: an unknown task or a bad count;
            :class:`~gait.controller.MissingExtraError` if ``ppo_timesteps`` > 0 without the
            ``[rl]`` extra (before anything is trained or written).
    """
    with run_lock(out, command="baselines"):  # the library call holds its directory as the command does
        return _task_table_locked(out, env_ids=env_ids, budget=budget, starts=starts, eval_seed=eval_seed,
                                  progress=progress)


def _task_table_locked(out, *, env_ids=None, budget: BaselineBudget = BaselineBudget(), starts: int = 10,
                       eval_seed: int = 1000, progress: bool = True) -> list[dict[str, Any]]:
    """The body of :func:`task_table`, under the lock of ``out``."""
    env_ids = list(ENV_IDS) if env_ids is None else [check_env_id(e) for e in env_ids]
    check_int("starts", starts, 1)
    out = Path(out)
    with_ppo = budget.ppo_timesteps > 0
    if with_ppo:
        check_ppo_extra(budget.ppo_timesteps)
    rows = []
    for env_id in env_ids:
        learners = {"random policy": (RandomController(budget.seed), 0.0),
                    "NEAT": _neat(env_id, budget, out / env_id / "neat", progress)}
        if with_ppo:
            learners["PPO"] = _ppo(env_id, budget, out / env_id / "ppo", progress)
        for learner, (controller, wall) in learners.items():
            rows.append({"env_id": env_id, "learner": learner, "train_wall_s": float(wall),
                         **_scores(controller, env_id, eval_seed, starts)})
        atomic_write(out / "task_table.json", json.dumps({"budget": dataclasses.asdict(budget), "starts": starts,
                                                          "eval_seed": eval_seed, "rows": rows}, indent=1).encode())
    atomic_write(out / "task_table.md", format_table(rows, starts).encode())
    return rows


def format_table(rows: list[dict[str, Any]], starts: int) -> str:
    """Markdown table: mean +- std episode return, mean forward distance and training wall time."""
    lines = [f"Healthy robot, 20 s episodes, {starts} fresh starts each (mean ± std of the return).", "",
             "| task | learner | return | forward distance (units) | training wall time |", "|---|---|---|---|---|"]
    for r in rows:
        wall = "-" if r["learner"] == "random policy" else f"{r['train_wall_s'] / 60:.1f} min"
        lines.append(f"| `{r['env_id']}` | {r['learner']} | {r['return_mean']:.2f} ± {r['return_std']:.2f} | "
                     f"{r['distance_mean']:.2f} | {wall} |")
    return "\n".join(lines) + "\n"
