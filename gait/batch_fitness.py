"""NEAT fitness of a whole generation at once, on the batched vector env.

:func:`batch_fitness` scores every genome of a list with every start of a
:class:`~gait.fitness_task.FitnessTask` in one ``gym.make_vec(task.env_id, ...)``
(:mod:`aquafish_gym.vector_env`): genome j's start k is sub-env ``j * K + k``
(K = ``task.episodes``), seeded ``task.seed + k``, so it starts from the initial angles
(and damage draw) of the single env's episode k. Each sub-env has its own network
(:meth:`~gait.controller.NEATController.network`, activated per control step on the
observation and the clock, outputs clipped), the same numbers as
:meth:`~gait.controller.NEATController.act` gives when :meth:`FitnessTask.run` drives the single env.

Equivalence with :func:`~gait.fitness_task.evaluate_genome`: observations, and so the
networks' actions, are equal to the last bit; the distance (and a return made of positions)
differs by the vector env's position round-off (measured at most 3.8e-13 units over 20 s,
tested to 1e-9; a robot's round-off depends on its place in its PyBullet world, the one at
the world's origin is exact).

Layout: worlds hold G = :func:`genomes_per_world` whole genomes (all K starts of a genome in
one world) and genome j of the list always sits at the same place, ``j % G``, of world
``j // G``. A genome's fitness therefore depends only on the genome and its position j in
the list (NEAT's order, fixed by the seed), never on how the list is split over processes:
:class:`BatchEvaluator` hands each worker whole worlds, so any number of workers gives the
same fitnesses, bit for bit.

Worlds hold at most :data:`GENERATION_WORLD_ROBOTS` (32) robots, half the vector env's default:
a `quick` generation (30 genomes x 2 starts) is two worlds, which two processes step at once
(6.2x the single-env path's generations per second against 3.6x in one process;
docs/performance.md), while in one process worlds of 30 and of 60 robots cost the same.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

import aquafish_gym  # registers the AquaFish tasks  # noqa: F401
from aquafish_gym.checks import check_int
from aquafish_gym.rundir import spawn_pool
from gait.clock import CLOCK_DIM, clock_features
from gait.fitness_task import FitnessTask, along_heading
from gait.shared_pool import SharedPool
from gait.envs import DEFAULT_ENV_ID

__all__ = ["BatchEvaluator", "GENERATION_WORLD_ROBOTS", "batch_fitness", "genomes_per_world"]

#: Most robots of one PyBullet world when a generation is scored (every ``max_world_robots``
#: default of this module): small enough that a `quick` generation spans two worlds, one for
#: each of two processes; large enough that a world's fixed cost stays small (module docstring).
GENERATION_WORLD_ROBOTS = 32


def genomes_per_world(task: FitnessTask, max_world_robots: int = GENERATION_WORLD_ROBOTS) -> int:
    """Genomes whose ``task.episodes`` starts share one PyBullet world: ``max(1, max_world_robots // K)``.

    Raises:
        ValueError: ``max_world_robots`` not an integer >= 1.
    """
    check_int("max_world_robots", max_world_robots, 1)
    return max(1, int(max_world_robots) // task.episodes)


def batch_fitness(genomes, config, task: FitnessTask, max_world_robots: int = GENERATION_WORLD_ROBOTS) -> np.ndarray:
    """Fitness of each genome: the mean score over ``task``'s starts, all genomes in one vector env.

    Args:
        genomes: a sequence of n ``neat.DefaultGenome`` (not modified).
        config: their ``neat.Config``.
        task: the :class:`~gait.fitness_task.FitnessTask` (robot, seed or fixed angles,
            duration, clock period, K = ``episodes``, env id).
        max_world_robots: most robots of one PyBullet world; a world holds
            :func:`genomes_per_world` whole genomes (the layout is in the module docstring).

    Returns:
        ``(n,)`` float64: forward distance (units; ``info["distance"]`` at the episode end) on
        AquaFish-v0, the episode return on other tasks, averaged over the K starts as
        :meth:`FitnessTask.fitness` does.

    Raises:
        ValueError: no genomes, a bad ``max_world_robots``, a config whose inputs do not
            match the task's observation, or a network action the env refuses.
    """
    genomes = list(genomes)
    if not genomes:
        raise ValueError("batch_fitness needs at least one genome")
    k = task.episodes
    world = genomes_per_world(task, max_world_robots) * k
    controllers = [task.controller(genome, config) for genome in genomes for _ in range(k)]
    seeds = [task.seed + episode for _ in genomes for episode in range(k)]
    envs = gym.make_vec(task.env_id, num_envs=len(controllers), vectorization_mode="vector_entry_point",
                        max_world_robots=world, **task.robot.env_kwargs(), initial_angles=task.initial_angles,
                        episode_duration_s=task.episode_duration_s)
    try:
        yaws = [task.start_yaw_deg(episode) for _ in genomes for episode in range(k)] if task.turned else None
        scores = _run_episodes(envs, controllers, seeds, task.env_id, yaws, task.spread_headings)
    finally:
        envs.close()
    return scores.reshape(len(genomes), k).mean(axis=1)


def _run_episodes(envs, controllers, seeds: list[int], env_id: str, yaws: list[float] | None = None,
                  along_start_heading: bool = False) -> np.ndarray:
    """One episode of every sub-env, sub-env i driven by ``controllers[i]``; ``(N,)`` scores
    (with ``yaws``, sub-env i starts turned by ``yaws[i]`` degrees; with ``along_start_heading``
    it scores its displacement along that heading, as :meth:`FitnessTask.score` with
    ``spread_headings``, else its forward distance along +y).

    Each step does what :meth:`~gait.controller.NEATController.act` does, for all sub-envs:
    the observation and the clock (:func:`gait.clock.with_clock`'s ``clock_features``), each
    network activated on its row, the outputs clipped to [-1, 1] (the same numbers, bit for bit).
    """
    networks = [controller.network() for controller in controllers]
    period = controllers[0].clock_period_s
    num_inputs = controllers[0].config.genome_config.num_inputs
    obs, info = envs.reset(seed=seeds, options=None if yaws is None else {"initial_yaw_deg": list(yaws)})
    start = None if yaws is None else np.column_stack([info["x_position"], info["y_position"]])
    if obs.shape[1] + CLOCK_DIM != num_inputs:
        raise ValueError(f"this network takes {num_inputs - CLOCK_DIM} observation entries, got {obs.shape[1]}")
    total = np.zeros(len(controllers))
    truncated = np.zeros(len(controllers), dtype=np.bool_)
    while not truncated.any():
        clock = np.array([clock_features(t, period) for t in info["time_s"]])
        rows = np.concatenate([obs, clock], axis=1).tolist()
        actions = np.clip(np.array([net.activate(row) for net, row in zip(networks, rows)], dtype=np.float64), -1.0, 1.0)
        obs, rewards, terminated, truncated, info = envs.step(actions)
        if terminated.any() or (truncated.any() and not truncated.all()):
            raise RuntimeError("the vector env ended some episodes and not others")  # it never does
        total += rewards
    if env_id != DEFAULT_ENV_ID:
        return total
    if along_start_heading:
        return along_heading(np.column_stack([info["x_position"], info["y_position"]]) - start, np.asarray(yaws))
    return np.array(info["distance"], dtype=np.float64)


def _chunk_fitness(genomes, config, task, max_world_robots: int) -> list[float]:
    """Worker side of :class:`BatchEvaluator` (top level, so it pickles)."""
    return batch_fitness(genomes, config, task, max_world_robots).tolist()


class BatchEvaluator:
    """NEAT's fitness function on the vector env: ``population.run(BatchEvaluator(task), n)``.

    Calling it with a generation's ``genomes`` (NEAT's list of ``(key, genome)``) and config
    sets every ``genome.fitness`` (:func:`batch_fitness` of the genomes without one, in
    NEAT's order). With ``workers`` > 1, the worlds
    of the generation (:func:`genomes_per_world` genomes each) are dealt to a process pool in
    contiguous chunks, one vector env per chunk: the fitnesses are the same, bit for bit, as
    in-process (the layout does not depend on the split). Use as a context manager; the
    pool ("spawn": PyBullet clients must not be forked) lives until exit and dies with the
    process that made it.

    A genome that already has a fitness keeps it (``keep_fitness``): NEAT carries its elites
    into the next generation unchanged, fitness included (also through a checkpoint), and the
    fitness is a deterministic function of the genome, so scoring them again would give the
    same value (the single-env path's, exactly) or, on the vector env, the same to round-off
    from another place in the world: kept, the best fitness per generation never decreases,
    exactly (and fewer robots swim).

    With ``shared`` (a :class:`~gait.shared_pool.SharedPool`), every world goes to that pool,
    one world too, and ``workers`` is the shared pool's: the jobs of
    :meth:`SharedPool.run_each <gait.shared_pool.SharedPool.run_each>` fill the cores together, with
    the same fitnesses.

    Args:
        task: the fitness task.
        workers: processes (>= 1; 1 evaluates in-process, no pool).
        max_world_robots: most robots of one PyBullet world.
        keep_fitness: score only genomes whose ``fitness`` is None (False: every genome).
        shared: a pool shared with other evaluations (None: this evaluator's own).

    Raises:
        ValueError: ``workers`` or ``max_world_robots`` not an integer >= 1.
    """

    def __init__(self, task: FitnessTask, workers: int = 1, max_world_robots: int = GENERATION_WORLD_ROBOTS,
                 keep_fitness: bool = True, shared: SharedPool | None = None):
        self.task = task
        self.keep_fitness = bool(keep_fitness)
        self.workers = shared.workers if shared is not None else check_int("workers", workers, 1)
        self.max_world_robots = check_int("max_world_robots", max_world_robots, 1)
        self.shared = shared
        self.pool = None
        if self.workers > 1 and shared is None:
            self.pool = spawn_pool(self.workers)

    def chunks(self, n: int) -> list[slice]:
        """The genomes of each worker out of ``n``: at most ``workers`` contiguous runs of whole
        worlds, each ending at the world boundary nearest an equal share of the genomes."""
        per_world = genomes_per_world(self.task, self.max_world_robots)
        parts = min(self.workers, -(-n // per_world))
        bounds = sorted({min(n, round(n * w / parts / per_world) * per_world) for w in range(parts)} | {n})
        return [slice(a, b) for a, b in zip(bounds, bounds[1:])]

    def __call__(self, genomes, config) -> None:
        genomes = [genome for _, genome in genomes if genome.fitness is None or not self.keep_fitness]
        if not genomes:
            return
        parts = self.chunks(len(genomes))
        if self.shared is None and (self.pool is None or len(parts) == 1):
            fitness = batch_fitness(genomes, config, self.task, self.max_world_robots).tolist()
        else:
            results = (self.shared or self.pool).map(_chunk_fitness, [genomes[s] for s in parts],
                                                     [config] * len(parts), [self.task] * len(parts),
                                                     [self.max_world_robots] * len(parts))
            fitness = [f for chunk in results for f in chunk]
        for genome, value in zip(genomes, fitness):
            genome.fitness = float(value)

    def __enter__(self) -> "BatchEvaluator":
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown()
