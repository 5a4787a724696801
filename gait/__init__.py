"""gait: swimming controllers for the aquatic robot and their transfer (paper section 5).

NEAT (neat-python) evolves a network from the IMU and an oscillator clock to the three
servo commands, with fitness = forward distance in 20 s of swimming in ``AquaFish-v0``;
the best controller is then run on its native morphology and on a target (the damaged
robot) and the trajectories are compared as in the paper's Figure 12. stable-baselines3
PPO/SAC policies trained on the same env (the optional ``[rl]`` extra) are scored the same
way.

Public API:
    evolve_gait(morphology, *, damage, generations, population_size, seed, out_dir, workers,
                episodes_per_genome, batched) -> GaitResult: a generation scored at once on the
                vector env (batched, the default; gait.batch_fitness) or genome by genome
    evolve_from_population(robot, gait_dir, generations, *, seed, episode_duration_s, keep_top) -> GaitResult:
                more generations on another robot from a run's final population
    rehearse(candidates, robot, *, start_yaw_deg, duration_s, seed, draws) -> Rehearsal: the
                candidate gait that swims furthest along +y from a heading (gait.rehearsal)
    load_controller(path) -> Controller
    score_transfer(controller, native, target, *, seed, episodes, initial_angles) -> TransferResult:
                the K episodes on each robot at once on one vector env
    plot_transfer(results, path, titles=None) -> Path
    rollout(controller, robot, *, seed, initial_angles) -> Rollout
    batch_rollouts(controller, robot, seeds, *, initial_angles) -> list[Rollout]: one episode per
                seed, at once on one vector env (positions to round-off)
    train_rl(algo, morphology, timesteps, seed, out_dir) -> Path      (needs the [rl] extra)
    train_or_load_rl(...) -> Path: train_rl unless out_dir holds a finished run
    record_video(controllers, robot, path, *, seed, episode_duration_s) -> Path: controllers side
        by side from above, drawn from their recorded state at 1280 x 720 (gait.video_frames):
        flippers turning, flipper dials, paths (mp4, or GIF without imageio-ffmpeg)

A :class:`Robot` may carry ``faults`` (``ServoFaults``, e.g. a self-model's servo gains) and
``damage="random"`` (:data:`RANDOM_DAMAGE`: a damage preset drawn per episode).
"""

from importlib.metadata import PackageNotFoundError as _PackageNotFoundError
from importlib.metadata import version as _version

try:  # the installed distribution's version (pyproject.toml); the same in the four packages
    __version__: str = _version("aquafish")
except _PackageNotFoundError:  # run from a source tree that is not installed
    __version__ = "0+unknown"

from gait.clock import CLOCK_PERIOD_S, ClockObservation, clock_features, with_clock
from gait.controller import (ConstantController, Controller, HeadingHoldController, NEATController, RandomController,
                             SB3PolicyController, load_controller)
from gait.neat_evolution import (GaitResult, evolve_from_population, evolve_gait, evolve_or_load_gait, latest_checkpoint,
                                 load_neat_config)
from gait.plots import plot_fitness_history, plot_transfer
from gait.rehearsal import Rehearsal, rehearse
from gait.robots import RANDOM_DAMAGE, Robot, as_robot, parse_robot
from gait.envs import EPISODE_DURATION_S, make_env
from gait.rollout import Rollout, batch_rollouts, rollout
from gait.transfer import TransferResult, save_transfer, score_transfer
from gait.rl import train_or_load_rl, train_rl  # stable-baselines3 is imported only when training (the [rl] extra)
from gait.video import record_video  # imageio and matplotlib are imported only when recording


__all__ = [
    "CLOCK_PERIOD_S", "EPISODE_DURATION_S", "ClockObservation", "ConstantController", "Controller", "GaitResult",
    "HeadingHoldController", "NEATController", "RANDOM_DAMAGE", "RandomController", "Rehearsal", "Robot", "Rollout",
    "SB3PolicyController", "TransferResult", "as_robot", "batch_rollouts", "clock_features",
    "evolve_from_population", "evolve_gait", "evolve_or_load_gait", "latest_checkpoint", "load_controller", "load_neat_config", "make_env", "parse_robot", "plot_fitness_history",
    "plot_transfer", "record_video", "rehearse", "rollout", "save_transfer", "score_transfer", "train_or_load_rl", "train_rl", "with_clock",
]
