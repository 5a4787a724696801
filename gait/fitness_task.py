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

from aquafish_gym.checks import check_yaw_deg
from aquafish_gym.heading import along_heading as along_heading_rad
from gait.clock import CLOCK_PERIOD_S
from gait.controller import NEATController
from gait.robots import Robot
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, check_env_id, check_episodes
from gait.rollout import Rollout, rollout

__all__ = ["FitnessTask", "along_heading", "evaluate_genome"]


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
        spread_headings: start episode k of K turned by :meth:`start_yaw_deg` (evenly spread
            headings) and score it by its displacement along its own start heading, so the
            gait is selected to swim alike whichever way it points (its observation holds
            the absolute yaw; AquaFish-v0 only). False (the default): every start heads +y.
        start_yaws_deg: episode k starts turned by ``start_yaws_deg[k % n]`` degrees
            counter-clockwise from +y and is scored, as by default, by its forward distance
            along +y: the gait is selected to turn to +y and swim along it from those headings
            (a mission's new gait holds the mission's heading this way). None (the default):
            every start heads +y.

    Raises:
        ValueError: ``episodes`` < 1, or > 1 with fixed ``initial_angles``; an unknown env id;
            ``spread_headings`` or ``start_yaws_deg`` on another task than AquaFish-v0; both
            at once; ``start_yaws_deg`` empty or holding a value that is not a number in
            [-180, 180].
    """

    robot: Robot
    seed: int
    initial_angles: tuple[float, float, float] | None = None
    episode_duration_s: float = EPISODE_DURATION_S
    clock_period_s: float = CLOCK_PERIOD_S
    episodes: int = 1
    env_id: str = DEFAULT_ENV_ID
    spread_headings: bool = False
    start_yaws_deg: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        check_episodes(self.episodes, self.initial_angles)
        check_env_id(self.env_id)
        for name, on in (("spread_headings", self.spread_headings), ("start_yaws_deg", self.start_yaws_deg is not None)):
            if on and self.env_id != DEFAULT_ENV_ID:
                raise ValueError(f"{name} needs the forward task {DEFAULT_ENV_ID!r} (the other tasks measure "
                                 f"their goals from +y), got {self.env_id!r}")
        if self.start_yaws_deg is not None:
            if isinstance(self.start_yaws_deg, (str, bytes)) or not hasattr(self.start_yaws_deg, "__len__") \
                    or len(self.start_yaws_deg) == 0:
                raise ValueError(f"start_yaws_deg must be a non-empty sequence of degrees in [-180, 180] or None, "
                                 f"got {self.start_yaws_deg!r}")
            yaws = tuple(check_yaw_deg("start_yaws_deg", y) for y in self.start_yaws_deg)
            if self.spread_headings:
                raise ValueError("give spread_headings or start_yaws_deg, not both: each sets the starts' headings")
            object.__setattr__(self, "start_yaws_deg", yaws)

    @property
    def turned(self) -> bool:
        """Whether the episodes start turned from +y (``spread_headings`` or ``start_yaws_deg``)."""
        return self.spread_headings or self.start_yaws_deg is not None

    def start_yaw_deg(self, episode: int) -> float:
        """Heading of episode ``episode``'s start, degrees counter-clockwise from +y: 0, with
        ``spread_headings`` ``-180 + 360 (k + 1/2) / K`` (K = ``episodes``: -90 and +90 for 2),
        with ``start_yaws_deg`` ``start_yaws_deg[episode % n]``."""
        if self.spread_headings:
            return -180.0 + 360.0 * (episode + 0.5) / self.episodes
        return 0.0 if self.start_yaws_deg is None else self.start_yaws_deg[episode % len(self.start_yaws_deg)]

    def controller(self, genome, config) -> NEATController:
        """The network of ``genome`` (a ``neat`` genome and its ``neat.Config``) with the task's clock."""
        return NEATController(genome, config, self.clock_period_s)

    def run(self, controller, episode: int = 0) -> Rollout:
        """Episode ``episode`` (seed ``seed + episode``, heading :meth:`start_yaw_deg`) of ``controller``."""
        return rollout(controller, self.robot, seed=self.seed + episode, initial_angles=self.initial_angles,
                       episode_duration_s=self.episode_duration_s, env_id=self.env_id,
                       initial_yaw_deg=self.start_yaw_deg(episode) if self.turned else None)

    def score(self, episode: Rollout, k: int = 0) -> float:
        """Episode ``k``'s fitness: forward distance (units) on AquaFish-v0 (with
        ``spread_headings``, the displacement along the episode's start heading,
        :func:`along_heading`), the return on other tasks."""
        if self.env_id != DEFAULT_ENV_ID:
            return episode.episode_return
        if self.spread_headings:
            return float(along_heading(episode.trajectory[-1] - episode.trajectory[0], self.start_yaw_deg(k)))
        return episode.distance

    def fitness(self, controller) -> float:
        """Mean score over the task's episodes."""
        return float(np.mean([self.score(self.run(controller, k), k) for k in range(self.episodes)]))


def along_heading(displacement, yaw_deg) -> np.ndarray:
    """Horizontal displacement along a heading given in degrees (the env's ``initial_yaw_deg``):
    :func:`aquafish_gym.heading.along_heading` of ``radians(yaw_deg)``.

    Args:
        displacement: ``(..., 2)`` x, y displacement (units, world frame).
        yaw_deg: heading(s) broadcasting with ``displacement[..., 0]``, degrees counter-clockwise
            from +y.

    Returns:
        ``(...)`` units; at 0 degrees the y displacement.
    """
    return along_heading_rad(displacement, np.radians(np.asarray(yaw_deg, dtype=np.float64)))


def evaluate_genome(genome, config, *, task: FitnessTask) -> float:
    """Fitness of one genome: forward distance (units). Top level, so workers can unpickle it."""
    return task.fitness(task.controller(genome, config))
