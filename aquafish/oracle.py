"""The independent oracle gait: the yardstick every share of a recovered gait is taken against.

A share of the oracle says how close a recovery comes to what it could reach at best. It can
only say so if the oracle cannot be equalled by construction: an oracle evolved with the same
budget and the same seed as the self-model gait *is* the self-model gait whenever the
self-model is the true fault, and the share is then exactly 1.000 whatever the gait is worth.
So the oracle here

* is evolved on the true damaged target (its faults included),
* with :data:`ORACLE_BUDGET_FACTOR` times the procedure's NEAT generations (population and
  starts per genome the same, so generations x population x starts is that factor larger),
* in :data:`ORACLE_RUNS` independent runs whose seeds (:func:`oracle_seeds`) are disjoint from
  every seed a procedure may use (:data:`PROCEDURE_SEED_LIMIT`; a run of seed ``s`` with ``K``
  starts per genome draws its starts from seeds ``s .. s + K - 1``),
* and the best run is the oracle, chosen by its mean distance on the target over
  :data:`SELECTION_EPISODES` starts of its own (seeds from :data:`SELECTION_SEED`), disjoint
  from the procedure's and the runs' seeds too.

The oracle does not depend on the procedure's seed, so the oracle of one damage, duration and
preset is one yardstick for every seed (the recovery benchmark trains it once per damage:
:func:`train_oracle`). A share of exactly 1.000 against it is a symptom, not a success.

Every controller of a report records its ``budget`` (:func:`neat_budget`, :func:`ppo_budget`)
and ``seeds``; the oracle's record (:meth:`OracleGait.record`) adds its runs' selection
distances and which run was chosen.
"""

from __future__ import annotations

import dataclasses
import functools
import os
from pathlib import Path

import numpy as np

import gait
from aquafish_gym.checks import check_int
from gait.robots import Robot
from gait.shared_pool import SharedPool

__all__ = ["ORACLE_BUDGET_FACTOR", "ORACLE_RUNS", "ORACLE_SEED_BASE", "ORACLE_SEED_STRIDE", "PROCEDURE_SEED_LIMIT",
           "SELECTION_EPISODES", "SELECTION_SEED", "OracleGait", "check_procedure_seed", "evolve_oracle",
           "neat_budget", "oracle_jobs", "oracle_run_dir", "oracle_seeds", "ppo_budget", "select_oracle"]

#: Independent runs of the oracle; the best of them is the oracle.
ORACLE_RUNS = 3
#: The oracle's NEAT generations over the procedure's (population and starts per genome alike),
#: so its budget (generations x population x starts) is this factor over each procedure gait's.
ORACLE_BUDGET_FACTOR = 3
#: Seeds a procedure (case study, benchmark cell, mission) may use: ``0 .. PROCEDURE_SEED_LIMIT - 1``;
#: with the starts and evaluation episodes it derives (``seed + k``, k below 1,000) they stay
#: below the oracle's.
PROCEDURE_SEED_LIMIT = 1_000_000
#: The first oracle run's seed; run ``i`` uses ``ORACLE_SEED_BASE + i * ORACLE_SEED_STRIDE``.
#: Below 2**32, since NumPy's global generator is seeded with it.
ORACLE_SEED_BASE, ORACLE_SEED_STRIDE = 3_000_000_000, 100
#: The first seed of the starts the best run is chosen on, and how many starts.
SELECTION_SEED, SELECTION_EPISODES = ORACLE_SEED_BASE + 10_000, 5


def check_procedure_seed(seed) -> int:
    """``seed`` as an int, checked to lie below :data:`PROCEDURE_SEED_LIMIT`, so that no seed the
    procedure derives from it meets an oracle's.

    Raises:
        ValueError: not an integer in ``[0, PROCEDURE_SEED_LIMIT)``.
    """
    return check_int("seed", seed, 0, PROCEDURE_SEED_LIMIT - 1)


def oracle_seeds(runs: int = ORACLE_RUNS) -> list[int]:
    """The seeds of the oracle's ``runs`` runs: ``ORACLE_SEED_BASE + i * ORACLE_SEED_STRIDE``."""
    return [ORACLE_SEED_BASE + i * ORACLE_SEED_STRIDE for i in range(check_int("runs", runs, 1))]


def neat_budget(generations: int, population: int, starts: int) -> dict:
    """A NEAT gait's budget for a report: ``generations``, ``population``, ``starts`` (episodes
    per genome evaluation) and their product ``episodes`` (genome-episodes simulated)."""
    return {"generations": int(generations), "population": int(population), "starts": int(starts),
            "episodes": int(generations) * int(population) * int(starts)}


def ppo_budget(timesteps: int) -> dict:
    """A PPO policy's budget for a report: its training env ``timesteps`` (0.1 s control steps)."""
    return {"timesteps": int(timesteps)}


def oracle_run_dir(run: int, duration_s: float) -> str:
    """``gait_oracle_run<i>`` for 20 s episodes, ``gait_oracle_run<i>_<N>s`` for others."""
    return f"gait_oracle_run{run}" + ("" if duration_s == 20.0 else f"_{duration_s:g}s")


@dataclasses.dataclass(frozen=True)
class OracleGait:
    """The oracle: the best of :data:`ORACLE_RUNS` gaits evolved on the true damaged target.

    Attributes:
        controller: the chosen run's best controller.
        chosen: index of the chosen run.
        seeds: every run's seed (:func:`oracle_seeds`).
        budget: one run's budget (:func:`neat_budget`); ``runs`` of them were spent.
        selection_distances: ``(runs,)`` each run's mean distance (units) on the target over the
            selection starts.
        episode_duration_s: simulated seconds of every episode.
    """

    controller: object
    chosen: int
    seeds: tuple[int, ...]
    budget: dict
    selection_distances: tuple[float, ...]
    episode_duration_s: float

    def record(self) -> dict:
        """The oracle's entry in a report: ``budget`` (one run's, with ``runs``), ``seeds``,
        ``selection`` (the starts' first seed and count, each run's distance) and ``chosen``."""
        return {"budget": {**self.budget, "runs": len(self.seeds)}, "seeds": list(self.seeds),
                "selection": {"seed": SELECTION_SEED, "episodes": SELECTION_EPISODES,
                              "distances": [round(d, 6) for d in self.selection_distances]},
                "chosen": self.chosen}


def select_oracle(controllers, robot: Robot, episode_duration_s: float, *, generations: int, population: int,
                  starts: int) -> OracleGait:
    """The best of ``controllers`` (one per oracle run, in run order) on ``robot``, by mean distance
    over the selection starts (:data:`SELECTION_SEED`, :data:`SELECTION_EPISODES`); a tie goes to
    the first run.

    Args:
        controllers: each run's best controller (:func:`oracle_jobs`' results).
        robot: the true damaged target.
        episode_duration_s: simulated seconds of every selection episode.
        generations: the *procedure's* NEAT generations; the record's budget is the runs':
            :data:`ORACLE_BUDGET_FACTOR` times as many.
        population: NEAT's population of every run.
        starts: starts per genome evaluation of every run.

    Raises:
        ValueError: not one controller per :func:`oracle_seeds` run.
    """
    controllers = list(controllers)
    if len(controllers) != ORACLE_RUNS:
        raise ValueError(f"the oracle needs {ORACLE_RUNS} runs' controllers, got {len(controllers)}")
    distances = tuple(float(gait.score_transfer(c, robot, robot, seed=SELECTION_SEED, episodes=SELECTION_EPISODES,
                                                episode_duration_s=episode_duration_s).target_distance)
                      for c in controllers)
    chosen = int(np.argmax(distances))
    return OracleGait(controllers[chosen], chosen, tuple(oracle_seeds()),
                      neat_budget(ORACLE_BUDGET_FACTOR * generations, population, starts), distances,
                      episode_duration_s)


def oracle_jobs(robot: Robot, oracle_dir, *, generations: int, population_size: int, episodes_per_genome: int,
                episode_duration_s: float, workers: int | None = None, progress: bool = True) -> list:
    """One job per oracle run: a function of a :class:`~gait.shared_pool.SharedPool` (or None)
    that evolves the run in ``oracle_dir`` (or loads it when finished; resumes it when
    interrupted) and returns its best controller. A caller that evolves other gaits at once
    runs these beside its own on one pool (:meth:`~gait.shared_pool.SharedPool.run_each`), then
    chooses with :func:`select_oracle`. Arguments as :func:`evolve_oracle`.

    Raises:
        ValueError: ``generations`` not an integer >= 1.
    """
    oracle_dir = Path(oracle_dir)
    oracle_generations = ORACLE_BUDGET_FACTOR * check_int("generations", generations, 1)

    def run(i: int, seed: int, shared: SharedPool | None):
        return gait.evolve_or_load_gait(
            robot, oracle_dir / oracle_run_dir(i, episode_duration_s), generations=oracle_generations,
            population_size=population_size, seed=seed, workers=workers, episodes_per_genome=episodes_per_genome,
            episode_duration_s=episode_duration_s, progress=progress, shared=shared)

    return [functools.partial(run, i, seed) for i, seed in enumerate(oracle_seeds())]


def evolve_oracle(robot: Robot, oracle_dir, *, generations: int, population_size: int, episodes_per_genome: int,
                  episode_duration_s: float, workers: int | None = None, progress: bool = True) -> OracleGait:
    """Evolve (or load when finished; resume when interrupted) the oracle's runs in ``oracle_dir``
    and choose the best (:func:`select_oracle`).

    Args:
        robot: the true damaged target (``gait.as_robot(damage)``).
        oracle_dir: where the runs are kept (:func:`oracle_run_dir` each).
        generations: the *procedure's* NEAT generations; each run evolves
            :data:`ORACLE_BUDGET_FACTOR` times as many.
        population_size: NEAT's population, as the procedure's gaits'.
        episodes_per_genome: starts per genome evaluation, as the procedure's gaits'.
        episode_duration_s: simulated seconds of every episode.
        workers: evaluation processes (default: all cores); with more than one, the runs
            evolve at once on one :class:`~gait.shared_pool.SharedPool`.
        progress: NEAT's progress bars.

    Raises:
        ValueError: as :func:`gait.evolve_or_load_gait` (a finished run of other settings is a
            :class:`~aquafish_gym.rundir.MismatchError`).
    """
    processes = workers if workers is not None else (os.cpu_count() or 1)
    jobs = oracle_jobs(robot, oracle_dir, generations=generations, population_size=population_size,
                       episodes_per_genome=episodes_per_genome, episode_duration_s=episode_duration_s,
                       workers=workers, progress=progress)
    if processes == 1:
        controllers = [job(None) for job in jobs]
    else:
        with SharedPool(processes) as shared:
            controllers = shared.run_each([functools.partial(job, shared) for job in jobs])
    return select_oracle(controllers, robot, episode_duration_s, generations=generations,
                         population=population_size, starts=episodes_per_genome)
