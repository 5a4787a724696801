"""What a worker needs to score one NEAT genome: the fitness task of a gait evolution.

:class:`FitnessTask` (the robot, the episodes' seeds or fixed angles, the duration, the task)
and :func:`evaluate_genome` (a genome's fitness on single envs, episode by episode) sit below
both ways of scoring a generation: genome by genome on a process pool
(:mod:`gait.neat_evolution`) and a generation at once on the vector env
(:mod:`gait.batch_fitness`), which must give the same numbers.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from gait.clock import CLOCK_PERIOD_S
from gait.controller import NEATController
from gait.robots import Robot
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, check_env_id, check_episodes
from gait.rollout import Rollout, rollout

__all__ = ["FitnessTask", "evaluate_genome"]


@dataclasses.dataclass(frozen=True)
class FitnessTask:
    """Everything a worker needs to score a genome (picklable).

    Attributes:
        robot: the robot the gait is evolved for.
        seed: episode seed (draws the initial angles unless ``initial_angles``).
        initial_angles: ``(3,)`` rad as a tuple, or None.
        episode_duration_s: simulated seconds per evaluation.
        clock_period_s: the controller's clock period (s).
        episodes: episodes per genome, with seeds ``seed, seed + 1, ...`` (different initial
            angles); the fitness is their mean distance. 1 (the default) is the paper's
            single 20 s trial; more episodes favour gaits that work from any start.
        env_id: the task (``aquafish_gym.ENV_IDS``). On ``"AquaFish-v0"`` (the paper's)
            the fitness is the forward distance, on the others the episode return.

    Raises:
        ValueError: ``episodes`` < 1, or > 1 with fixed ``initial_angles``; an unknown env id.
    """

    robot: Robot
    seed: int
    initial_angles: tuple[float, float, float] | None = None
    episode_duration_s: float = EPISODE_DURATION_S
    clock_period_s: float = CLOCK_PERIOD_S
    episodes: int = 1
    env_id: str = DEFAULT_ENV_ID

    def __post_init__(self) -> None:
        check_episodes(self.episodes, self.initial_angles)
        check_env_id(self.env_id)

    def controller(self, genome, config) -> NEATController:
        """The network of ``genome`` (a ``neat`` genome and its ``neat.Config``) with the task's clock."""
        return NEATController(genome, config, self.clock_period_s)

    def run(self, controller, episode: int = 0) -> Rollout:
        """Episode ``episode`` (seed ``seed + episode``) of ``controller``."""
        return rollout(controller, self.robot, seed=self.seed + episode, initial_angles=self.initial_angles,
                       episode_duration_s=self.episode_duration_s, env_id=self.env_id)

    def score(self, episode: Rollout) -> float:
        """An episode's fitness: forward distance (units) on AquaFish-v0, the return on other tasks."""
        return episode.distance if self.env_id == DEFAULT_ENV_ID else episode.episode_return

    def fitness(self, controller) -> float:
        """Mean score over the task's episodes."""
        return float(np.mean([self.score(self.run(controller, k)) for k in range(self.episodes)]))


def evaluate_genome(genome, config, *, task: FitnessTask) -> float:
    """Fitness of one genome: forward distance (units). Top level, so workers can unpickle it."""
    return task.fitness(task.controller(genome, config))
