"""Evolve a swimming gait with NEAT (neat-python 2.x), paper section 5.

``evolve_gait`` runs ``neat.Population`` on the config in ``gait/neat_config.ini`` with
a ``Checkpointer``, a :class:`HistoryReporter` (fitness per generation, best controller), a
progress display over generations (:class:`gait.neat_progress.GenerationBar`) and, with
``verbose``, NEAT's ``StdOutReporter``. A generation is evaluated at once on the batched
vector env (:class:`gait.batch_fitness.BatchEvaluator`: every genome and start a robot of
one PyBullet world, whole worlds dealt to ``workers`` processes); ``batched=False`` scores
genome by genome with :func:`evaluate_genome` (a single env per episode, on a process pool,
:class:`gait.neat_progress.PoolEvaluator`, or in-process for one worker), the reference
the batched fitness equals to the vector env's round-off (about 1e-13 units; the same
genomes evolve).

Fitness: :func:`gait.rollout.rollout`'s forward distance (units) in 20 s of swimming on the
given robot. Every genome of the run is evaluated with the same initial flipper angles:
``initial_angles`` if given, else the angles ``AquaFish-v0``'s ``reset(seed=seed)`` draws.
Fitness is therefore a deterministic function of the genome (batched, also of its place in
the generation, by round-off of 1e-13 units; an elite keeps the fitness it was given); with
elitism, the best fitness per generation never decreases, and serial and parallel runs with
one seed agree (genome for genome: :class:`_GenomeConfig` works around a neat-python 2.0.0
pickling side effect; batched, whole worlds go to each process).
A gait evolved from one start may rely on it (the servos have no position feedback, so the
start is unknown on the real robot): ``episodes_per_genome = K`` scores each genome as the
mean over the starts of seeds ``seed ... seed + K - 1`` instead, at K times the cost.

Seeding: ``seed`` seeds Python's ``random`` (all of NEAT's randomness, in the main
process) and NumPy's global generator; the simulator needs no seed beyond the angles.
A run resumed from a checkpoint continues the checkpoint's ``random`` state.
"""

from __future__ import annotations

import configparser
import dataclasses
import functools
import inspect
import itertools
import json
import os
import random
import re
import time
from pathlib import Path
from typing import Any

import neat
import numpy as np

from aquafish_gym.checks import check_int, check_seconds
from aquafish_gym.files import atomic_write, read_input
from aquafish_gym.rundir import (FileError, MismatchError, check_fingerprint, check_memory, check_output_dir,
                                 make_subdir, read_json, read_pickle, run_lock)
from gait.clock import CLOCK_DIM, CLOCK_PERIOD_S, check_clock_period
from gait.controller import NEAT_CONTROLLER_FILE, NEATController, load_controller
from gait.batch_fitness import BatchEvaluator
from gait.neat_progress import GenerationBar, PoolEvaluator, QuietCheckpointer
from gait.plots import plot_fitness_history
from gait.population_file import POPULATION_FILE, load_population, save_population
from gait.rehearsal import TopGenomes
from gait.robots import Robot, as_robot
from gait.fitness_task import FitnessTask, evaluate_genome
from gait.envs import DEFAULT_ENV_ID, EPISODE_DURATION_S, make_env
from gait.rollout import Rollout
from gait.shared_pool import SharedPool

#: The documented NEAT config kept next to this module.
DEFAULT_CONFIG = Path(__file__).with_name("neat_config.ini")
HISTORY_FILE = "fitness_history.json"
HISTORY_PLOT = "fitness_history.png"
CHECKPOINT_DIR = "checkpoints"
CHECKPOINT_PREFIX = "neat-checkpoint-"
SETTINGS_FILE = "fitness_settings.json"
#: Written last by :func:`evolve_gait`: its presence marks a finished run.
RUN_FILE = "run.json"
#: The attribute of a run's ``neat.Config`` that carries its fingerprint (fitness settings and
#: population size) into every checkpoint; ``fitness_settings.json`` holds the same dict.
FINGERPRINT_ATTR = "aquafish_fingerprint"
#: Rough memory per NEAT genome (bytes; Python objects of its nodes and connections), and per
#: simulated 0.01 s step of an episode (trajectory and logs): the up-front memory estimate.
GENOME_BYTES, STEP_BYTES = 50_000, 200


class _GenomeConfig(neat.genome.DefaultGenomeConfig):
    """neat-python's genome config, pickled without skipping a node id.

    neat-python 2.0.0's ``DefaultGenomeConfig.__getstate__`` calls ``next()`` on the
    counter that hands out new node ids. Every pickle of the config (a checkpoint, a saved
    controller, a genome batch sent to a worker) therefore skips an id, and the genomes a
    run evolves depended on how often it was pickled: a run on two workers, or one with an
    ``out_dir``, diverged from the same run serial and in memory after a few generations.
    This pickles the same state and leaves the counter where it was.
    """

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        if state.get("_node_indexer_next_value") is not None:  # a private key of neat-python 2.0.0
            self.node_indexer = itertools.count(state["_node_indexer_next_value"])
        return state


def _pickle_safe(config: neat.Config) -> neat.Config:
    """Give ``config`` the :class:`_GenomeConfig` pickling (in place; no state is added)."""
    if type(config.genome_config) is neat.genome.DefaultGenomeConfig:
        config.genome_config.__class__ = _GenomeConfig
    return config


def load_neat_config(path=None, *, population_size: int | None = None) -> neat.Config:
    """Load a NEAT config (default :data:`DEFAULT_CONFIG`).

    Args:
        path: INI file in neat-python's format.
        population_size: overrides ``[NEAT] pop_size`` (>= 2).

    Raises:
        ValueError: missing file, unknown or missing keys (also in ``[DefaultGenome]``,
            which neat-python does not check), or a bad population size.
    """
    path = Path(path) if path is not None else DEFAULT_CONFIG
    if not path.is_file():
        raise ValueError(f"no NEAT config file {path}")
    read_input(path)  # a regular file of a bounded size (refused, naming it, before neat-python reads it)
    try:
        config = neat.Config(neat.DefaultGenome, neat.DefaultReproduction, neat.DefaultSpeciesSet,
                             neat.DefaultStagnation, str(path))
    except (NameError, RuntimeError, KeyError, ValueError, configparser.Error) as err:
        raise ValueError(f"NEAT config {path}: {err}") from None
    parser = configparser.ConfigParser()
    parser.read(path)
    known = {p.name for p in config.genome_config._params}
    unknown = sorted(set(parser["DefaultGenome"]) - known)
    if unknown:
        raise ValueError(f"NEAT config {path}: unknown [DefaultGenome] key(s) {unknown}")
    if population_size is not None:
        check_int("population_size", population_size, 2)
        config.pop_size = population_size
    return _pickle_safe(config)


def set_num_inputs(config: neat.Config, num_inputs: int) -> None:
    """Give ``config``'s genomes ``num_inputs`` input nodes (keys -1 .. -num_inputs), in place.

    The INI file is written for AquaFish-v0 (12 observation entries + 2 clock = 14); a
    task with a larger observation needs more inputs.
    """
    genome_config = config.genome_config
    genome_config.num_inputs = int(num_inputs)
    genome_config.input_keys = [-i - 1 for i in range(int(num_inputs))]


class HistoryReporter(neat.reporting.BaseReporter):
    """Records fitness per generation and keeps the best controller, saving both as it goes.

    Args:
        task: the fitness task (to build controllers).
        out_dir: directory for ``fitness_history.json`` and ``best_controller.json``, or None.
        history: entries of earlier generations (when resuming).
        best: best controller of earlier generations (when resuming), or None.
    """

    def __init__(self, task: FitnessTask, out_dir: Path | None, history: list[dict] | None = None,
                 best: NEATController | None = None, best_fitness: float = -np.inf):
        self.task = task
        self.out_dir = out_dir
        self.history = list(history or [])
        self.best_controller = best
        self.best_fitness = best_fitness
        self._generation = 0
        self._start = time.perf_counter()
        self._elapsed_before = self.history[-1]["wall_time_s"] if self.history else 0.0
        self._evaluations = self.history[-1]["evaluations"] if self.history else 0

    def start_generation(self, generation: int) -> None:
        self._generation = generation

    def post_evaluate(self, config, population, species, best_genome) -> None:
        fitness = np.array([g.fitness for g in population.values()])
        if best_genome.fitness > self.best_fitness:
            self.best_fitness = float(best_genome.fitness)
            self.best_controller = self.task.controller(best_genome, config)
            if self.out_dir is not None:
                self.best_controller.save(self.out_dir / NEAT_CONTROLLER_FILE)
        self._evaluations += len(fitness)
        self.history.append({
            "generation": int(self._generation),
            "best_fitness": float(best_genome.fitness),
            "mean_fitness": float(fitness.mean()),
            "std_fitness": float(fitness.std()),
            "best_so_far": self.best_fitness,
            "n_species": len(species.species),
            "best_nodes": len(best_genome.nodes),
            "best_connections": sum(c.enabled for c in best_genome.connections.values()),
            "evaluations": self._evaluations,
            "wall_time_s": self._elapsed_before + time.perf_counter() - self._start,
        })
        if self.out_dir is not None:
            atomic_write(self.out_dir / HISTORY_FILE, json.dumps(self.history, indent=1).encode())


@dataclasses.dataclass
class GaitResult:
    """Outcome of :func:`evolve_gait`.

    Attributes:
        best_controller: the best controller found (over all generations).
        best_fitness: its forward distance (units) under the run's fitness episode.
        history: one dict per generation (see :class:`HistoryReporter`).
        best_rollout: the best controller's first fitness episode on the single env (seed
            ``seed``; trajectory ``(T + 1, 2)``); its distance is ``best_fitness`` when
            ``episodes_per_genome`` is 1 (batched: to the vector env's round-off, ~1e-13 units).
            With ``spread_headings`` it starts turned and its ``distance`` is along +y, the
            env's; ``run.json``'s ``best_rollout_distance`` is then its score along its heading.
        robot: the robot evolved for.
        seed: the run seed (also the episode seed unless ``initial_angles``).
        initial_angles: ``(3,)`` rad used for every evaluation.
        generations: generations evaluated in total (including before a resume).
        wall_time_s: wall time of the run (including before a resume).
        out_dir: where files were written, or None.
        candidates: the fittest controllers of every generation
            (:func:`evolve_from_population`'s ``keep_top``; empty otherwise).
        candidate_generations: for each of ``candidates``, the generation it was first kept in,
            counted from 0 (the restored population's first evaluation).
    """

    best_controller: NEATController
    best_fitness: float
    history: list[dict]
    best_rollout: Rollout
    robot: Robot
    seed: int
    initial_angles: np.ndarray
    generations: int
    wall_time_s: float
    out_dir: Path | None
    candidates: list[NEATController] = dataclasses.field(default_factory=list)
    candidate_generations: list[int] = dataclasses.field(default_factory=list)


def latest_checkpoint(out_dir) -> Path:
    """The checkpoint of ``out_dir`` with the highest generation.

    Raises:
        ValueError: no checkpoint there.
    """
    found = sorted((Path(out_dir) / CHECKPOINT_DIR).glob(CHECKPOINT_PREFIX + "*"),
                   key=lambda p: int(re.sub(r"\D", "", p.name) or -1))
    if not found:
        raise ValueError(f"no NEAT checkpoint in {Path(out_dir) / CHECKPOINT_DIR}")
    return found[-1]


def _restore(resume, population_size: int | None, settings: dict[str, Any]) -> neat.Population:
    """The population of the checkpoint ``resume``, checked against the run's fitness ``settings``.

    A NEAT checkpoint is a pickle (neat-python's format), and unpickling runs code: it is read
    only from ``RUN/checkpoints/`` of a run directory whose manifest (``fitness_settings.json``)
    records ``settings`` (and ``population_size``, if given), checked before anything is unpickled.
    A run directory is trusted like code.

    Raises:
        ValueError: no such file, or a checkpoint outside a run directory with a manifest;
            :class:`~aquafish_gym.rundir.FileError` if it is truncated or not a NEAT checkpoint;
            :class:`~aquafish_gym.rundir.MismatchError` if the manifest (or the checkpoint's
            fingerprint) records other fitness settings or another population size.
    """
    path = Path(resume)
    if not path.is_file():
        raise ValueError(f"no NEAT checkpoint {path}")
    manifest = path.parent.parent / SETTINGS_FILE
    if path.parent.name != CHECKPOINT_DIR or not manifest.is_file():
        raise ValueError(f"cannot resume from {path}: a checkpoint is only read from {CHECKPOINT_DIR}/ of a gait run "
                         f"directory with its {SETTINGS_FILE} (checkpoints are pickles, which run code when loaded: "
                         "resume only runs you trust)")
    recorded = read_json(manifest)
    check_fingerprint(path, {k: v for k, v in recorded.items() if k != "population_size"}, settings,
                      f"cannot resume: the checkpoint belongs to another run (as its {manifest} records; it was "
                      "not read); give the settings it was made with, or start a new run in another --out")
    if population_size is not None and recorded.get("population_size", population_size) != population_size:
        raise MismatchError(f"cannot resume: --population-size {population_size} differs from the run's "
                            f"{recorded['population_size']} ({manifest})")
    data = read_pickle(path, gzipped=True, what="NEAT checkpoint",
                       fix="delete it to resume from the checkpoint before it, or restore it from a copy")
    if not (isinstance(data, tuple) and len(data) == 5 and isinstance(data[1], neat.Config)):
        raise FileError(path, "is not a NEAT checkpoint")
    recorded = getattr(data[1], FINGERPRINT_ATTR, None)
    if recorded is not None:  # checkpoints written before fingerprints were recorded have none
        check_fingerprint(path, {k: v for k, v in recorded.items() if k != "population_size"}, settings,
                          "cannot resume: the checkpoint belongs to another run; give the settings it was made "
                          "with, or start a new run in another --out")
    population = neat.Checkpointer.restore_checkpoint(str(path))
    _pickle_safe(population.config)
    if population_size is not None and population_size != population.config.pop_size:
        raise MismatchError(f"cannot resume: --population-size {population_size} differs from the checkpoint's "
                            f"{population.config.pop_size} ({path})")
    return population


def _previous_run(out_dir: Path | None, generation: int) -> tuple[list[dict], NEATController | None, float]:
    """History before ``generation`` and the best controller saved in ``out_dir``."""
    if out_dir is None or not (out_dir / HISTORY_FILE).is_file():
        return [], None, -np.inf
    try:
        history = [h for h in read_json(out_dir / HISTORY_FILE, list) if h["generation"] < generation]
    except (KeyError, TypeError) as err:
        raise FileError(out_dir / HISTORY_FILE, f"is not a fitness history ({type(err).__name__}: {err})") from None
    if not history or not (out_dir / NEAT_CONTROLLER_FILE).is_file():
        return history, None, -np.inf
    return history, load_controller(out_dir / NEAT_CONTROLLER_FILE), history[-1]["best_so_far"]


def _settings(task: FitnessTask) -> dict[str, Any]:
    """What defines a run's fitness (a resumed run must not change it)."""
    settings = {"robot": task.robot.to_dict(), "seed": task.seed, "initial_angles": task.initial_angles,
                "episode_duration_s": task.episode_duration_s, "clock_period_s": task.clock_period_s,
                "episodes": task.episodes}
    if task.spread_headings:
        settings["spread_headings"] = True
    if task.start_yaws_deg is not None:
        settings["start_yaws_deg"] = list(task.start_yaws_deg)
    return settings if task.env_id == DEFAULT_ENV_ID else settings | {"env_id": task.env_id}


def _attach_reporters(population: neat.Population, task: FitnessTask, out_dir: Path | None, resuming: bool,
                      verbose: bool, checkpoint_every: int) -> tuple[HistoryReporter, neat.Checkpointer | None]:
    """Add StdOutReporter (if verbose), the HistoryReporter and a Checkpointer (if out_dir); write
    ``fitness_settings.json`` (the run's fingerprint)."""
    history, best, best_fitness = _previous_run(out_dir, population.generation) if resuming else ([], None, -np.inf)
    if out_dir is not None:
        make_subdir(out_dir, CHECKPOINT_DIR)  # never through a link planted in the run directory
        atomic_write(out_dir / SETTINGS_FILE,
                     json.dumps(getattr(population.config, FINGERPRINT_ATTR), indent=1).encode())
    recorder = HistoryReporter(task, out_dir, history, best, best_fitness)
    if verbose:
        population.add_reporter(neat.StdOutReporter(show_species_detail=False))
    population.add_reporter(recorder)
    if out_dir is None:
        return recorder, None
    checkpointer = QuietCheckpointer(checkpoint_every, None, str(out_dir / CHECKPOINT_DIR / CHECKPOINT_PREFIX),
                                     population_file=out_dir / POPULATION_FILE)
    checkpointer.last_generation_checkpoint = population.generation
    population.add_reporter(checkpointer)
    return recorder, checkpointer


def evolve_gait(morphology=None, *, damage: str = "none", generations: int = 30, population_size: int | None = None,
                seed: int = 0, out_dir=None, workers: int | None = None, config_path=None, resume=None,
                initial_angles=None, episode_duration_s: float = EPISODE_DURATION_S,
                clock_period_s: float = CLOCK_PERIOD_S, episodes_per_genome: int = 1, checkpoint_every: int = 5,
                verbose: bool = False, progress: bool = True, env_id: str = DEFAULT_ENV_ID,
                batched: bool = True, spread_headings: bool = False, shared: SharedPool | None = None) -> GaitResult:
    """Evolve a NEAT controller that swims forward on a robot (or solves another AquaFish task).

    Args:
        morphology: the robot (``Morphology``, 9 numbers, a ``Robot`` or a robot string;
            default healthy).
        damage: damage name applied to ``morphology``.
        generations: total generations; when resuming, the run continues up to this count.
        population_size: genomes per generation (default: the config's ``pop_size``, 50).
        seed: seeds NEAT (Python ``random``), NumPy, and the fitness episode's initial angles.
        out_dir: writes ``best_controller.json``, ``best_genome.txt``, ``fitness_history.json``
            and ``.png``, ``run.json``, ``fitness_settings.json``, ``neat_config.ini``,
            ``checkpoints/`` and, with every checkpoint, ``final_population.json`` (its
            population as data, :mod:`gait.population_file`); None: no files.
        workers: evaluation processes (default ``os.cpu_count()``); 1 evaluates in-process.
            Batched, the generation's PyBullet worlds (at most
            :data:`gait.batch_fitness.GENERATION_WORLD_ROBOTS` robots each: genomes x
            ``episodes_per_genome``) are dealt to the processes; the same fitnesses, bit for bit.
        config_path: NEAT INI file (default ``gait/neat_config.ini``).
        resume: a checkpoint file to continue from (see :func:`latest_checkpoint`), in
            ``checkpoints/`` of a run directory whose ``fitness_settings.json`` matches the
            settings (checked before the checkpoint, a pickle, is read). A run whose
            latest checkpoint is already at ``generations`` but that has no ``run.json`` (killed
            after its final checkpoint) is finished: its outputs are written from the saved
            history and best controller, without a new generation.
        initial_angles: ``(3,)`` rad for every evaluation (default: drawn from ``seed``).
        episode_duration_s: simulated seconds per evaluation (paper: 20).
        clock_period_s: period of the controller's clock input (s).
        episodes_per_genome: episodes per evaluation, seeds ``seed, seed + 1, ...``; fitness is
            the mean distance (see :class:`FitnessTask`).
        spread_headings: start episode k of the K turned by ``-180 + 360 (k + 1/2) / K`` degrees
            and score it along its own start heading (:class:`FitnessTask`), so the gait swims
            alike whichever way it points; AquaFish-v0 only. Default False: every start heads +y.
        checkpoint_every: generations between checkpoints (needs ``out_dir``); the final
            generation is always checkpointed, so ``resume=latest_checkpoint(out_dir)`` extends a run.
        verbose: print NEAT's per-generation report (species, fitness statistics).
        progress: show progress over generations with the best and mean fitness (a tqdm bar on a
            terminal, else one line per generation).
        env_id: the task (default the paper's ``"AquaFish-v0"``); the network gets one
            input per observation entry of the task, plus the clock.
        batched: evaluate each generation at once on the vector env
            (:mod:`gait.batch_fitness`; default), else genome by genome on single envs
            (:func:`evaluate_genome`). The fitnesses agree to about 1e-13 units (positions'
            round-off), and do not depend on ``workers`` either way.
        shared: with ``batched``, a :class:`~gait.shared_pool.SharedPool` that evaluates the
            generations' worlds (``workers`` is then the pool's), e.g. beside other evolutions in
            :meth:`~gait.shared_pool.SharedPool.run_each`; the same result as without.

    Returns:
        :class:`GaitResult`.

    Raises:
        ValueError: invalid robot, counts, duration, config, checkpoint, or a checkpoint
            beyond ``generations`` (or at it, in a finished run; the message names the run directory); an ``out_dir`` that cannot be written
            (checked before anything is created), that another process is writing
            (:class:`~aquafish_gym.rundir.BusyError`), that holds a run with other settings, or
            (without ``resume``) any run with checkpoints (:class:`~aquafish_gym.rundir.MismatchError`);
            a truncated checkpoint (:class:`~aquafish_gym.rundir.FileError`); a population or
            episode that cannot fit in memory.
    """
    robot = as_robot(morphology if morphology is not None else "healthy", damage=damage)
    generations = check_int("generations", generations, 1)
    seed = check_int("seed", seed, 0)
    workers = check_int("workers", workers if workers is not None else (os.cpu_count() or 1), 1)
    checkpoint_every = check_int("checkpoint_every", checkpoint_every, 1)
    task = _make_task(robot, seed, initial_angles, episode_duration_s, clock_period_s, episodes_per_genome, env_id,
                      spread_headings)
    out_dir = check_output_dir(out_dir) if out_dir is not None else None
    with make_env(robot, env_id=env_id, episode_duration_s=task.episode_duration_s) as env:  # checks the duration
        num_inputs = env.observation_space.shape[0] + CLOCK_DIM
    config = None
    if resume is None:
        config = load_neat_config(config_path, population_size=population_size)
    _check_gait_memory(population_size or (config.pop_size if config is not None else 0), task, workers)

    random.seed(seed)
    np.random.seed(seed)
    if resume is not None:
        population = _restore(resume, population_size, _settings(task))
        config_text = None
    else:
        # as Path.read_text() reads it (universal newlines), within read_input's bounds
        config_text = read_input(Path(config_path or DEFAULT_CONFIG)).decode("utf-8").replace("\r\n", "\n") \
            .replace("\r", "\n")
        set_num_inputs(config, num_inputs)
        population = neat.Population(config, seed=seed)
    setattr(population.config, FINGERPRINT_ATTR, _settings(task) | {"population_size": population.config.pop_size})
    remaining = generations - population.generation
    if remaining == 0 and out_dir is not None and not (out_dir / RUN_FILE).is_file():
        # killed after the final checkpoint and before run.json: finish it, with no new generation
        with run_lock(out_dir):
            _check_run_dir(out_dir, getattr(population.config, FINGERPRINT_ATTR), True)
            history, best, best_fitness = _previous_run(out_dir, population.generation)
            if best is None or len(history) != population.generation:
                raise FileError(out_dir, f"has a checkpoint at generation {population.generation} but not the "
                                         f"history and {NEAT_CONTROLLER_FILE} of its generations, so it cannot be "
                                         "finished", "delete the directory and run again, or use another --out")
            return _finish(population, task, out_dir, HistoryReporter(task, out_dir, history, best, best_fitness))
    if remaining < 1:
        where = f"{out_dir} holds a finished gait run" if out_dir is not None else f"the checkpoint {resume} is"
        raise ValueError(f"{where} at generation {population.generation}; generations must exceed it to extend "
                         f"it, got {generations}")
    if out_dir is None:
        return _evolve(population, task, None, resume is not None, verbose, checkpoint_every, generations, workers,
                       progress, batched, shared)
    with run_lock(out_dir, command="gait"):
        _check_run_dir(out_dir, getattr(population.config, FINGERPRINT_ATTR), resume is not None)
        if config_text is not None:
            atomic_write(out_dir / "neat_config.ini", config_text.encode())
        return _evolve(population, task, out_dir, resume is not None, verbose, checkpoint_every, generations, workers,
                       progress, batched, shared)


def _make_task(robot: Robot, seed: int, initial_angles, episode_duration_s, clock_period_s, episodes_per_genome,
               env_id: str, spread_headings: bool = False,
               start_yaws_deg: tuple[float, ...] | None = None) -> FitnessTask:
    angles = None if initial_angles is None else tuple(float(a) for a in np.asarray(initial_angles, dtype=float).reshape(3))
    duration_s = check_seconds("episode_duration_s", episode_duration_s)
    if not isinstance(spread_headings, bool):
        raise ValueError(f"spread_headings must be True or False, got {spread_headings!r}")
    return FitnessTask(robot, seed, angles, duration_s, check_clock_period(clock_period_s),
                       check_int("episodes_per_genome", episodes_per_genome, 1), env_id, spread_headings,
                       start_yaws_deg)


def _check_gait_memory(population_size: int, task: FitnessTask, workers: int) -> None:
    """Refuse a population or an episode that cannot fit in memory (:func:`check_gait_memory`)."""
    check_gait_memory(population_size, task.episode_duration_s, workers)


def check_gait_memory(population_size: int, episode_duration_s: float, workers: int) -> None:
    """Refuse, up front, a gait evolution whose population or episodes cannot fit in memory
    (estimate: :data:`GENOME_BYTES` per genome, :data:`STEP_BYTES` per simulated step and
    worker); :func:`evolve_gait` checks its own, and a command that evolves gaits later (a case
    study, a recovery benchmark) checks them before it writes anything.

    Raises:
        ValueError: the estimate exceeds the available memory (the message gives both).
    """
    steps = episode_duration_s / 0.01
    check_memory(f"a population of {population_size} genomes and {episode_duration_s:g} s episodes on "
                 f"{workers} workers", GENOME_BYTES * population_size + STEP_BYTES * steps * workers,
                 "lower --population-size or --episode-duration-s")


def _check_run_dir(out_dir: Path, fingerprint: dict[str, Any], resuming: bool) -> None:
    """Refuse an ``out_dir`` that holds a gait run with other settings, or any run unless resuming.

    Raises:
        MismatchError: ``fitness_settings.json`` records other settings (the fields are named),
            or a new run would overwrite a run that has checkpoints or is finished.
    """
    settings_file = out_dir / SETTINGS_FILE
    if settings_file.is_file():
        recorded = read_json(settings_file)
        if not resuming:  # a new run may reuse a directory of the same settings that has nothing to resume
            check_fingerprint(out_dir, recorded, fingerprint, "use another --out, or the same settings")
        else:
            check_fingerprint(settings_file, {k: v for k, v in recorded.items() if k != "population_size"},
                              {k: v for k, v in fingerprint.items() if k != "population_size"},
                              "cannot resume: give the settings of the run in it, or use another --out")
    if not resuming:
        checkpoints = sorted((out_dir / CHECKPOINT_DIR).glob(CHECKPOINT_PREFIX + "*"))
        if checkpoints or (out_dir / RUN_FILE).is_file():
            raise MismatchError(f"{out_dir} already holds a gait run ({len(checkpoints)} checkpoints"
                                f"{', finished' if (out_dir / RUN_FILE).is_file() else ''}); continue it with "
                                "--resume latest, or use another --out")


def _evolve(population: neat.Population, task: FitnessTask, out_dir: Path | None, resuming: bool, verbose: bool,
            checkpoint_every: int, generations: int, workers: int, progress: bool, batched: bool,
            shared: SharedPool | None = None) -> GaitResult:
    """Run ``population`` up to ``generations`` and write the outputs (the body of :func:`evolve_gait`;
    ``shared``: the batched evaluation's worlds go to that pool)."""
    recorder, checkpointer = _attach_reporters(population, task, out_dir, resuming, verbose, checkpoint_every)
    remaining = generations - population.generation
    evaluate = functools.partial(evaluate_genome, task=task)
    bar = GenerationBar(generations, population.generation, desc=f"NEAT gait on {task.robot.label}",
                        disable=not progress)
    population.add_reporter(bar)
    try:
        if batched:
            with BatchEvaluator(task, workers, shared=shared) as evaluator:
                population.run(evaluator, remaining)
        elif workers == 1:
            def serial(genomes, config):
                for _, genome in genomes:
                    genome.fitness = evaluate(genome, config)

            population.run(serial, remaining)
        else:
            with PoolEvaluator(workers, evaluate) as evaluator:
                population.run(evaluator, remaining)
    finally:
        bar.close()

    if checkpointer is not None and checkpointer.last_generation_checkpoint != population.generation:
        # always leave a checkpoint of the final state, so a finished run can be extended
        checkpointer.save_checkpoint(population.config, population.population, population.species, population.generation)
    return _finish(population, task, out_dir, recorder)


def _finish(population: neat.Population, task: FitnessTask, out_dir: Path | None,
            recorder: HistoryReporter) -> GaitResult:
    """The result of a run whose generations are all evaluated: the best controller's rollout, and the
    outputs (``run.json`` last) in ``out_dir``. Also finishes a run killed after its final checkpoint."""
    best_rollout = task.run(recorder.best_controller)
    result = GaitResult(recorder.best_controller, recorder.best_fitness, recorder.history, best_rollout, task.robot,
                        task.seed, best_rollout.initial_angles, population.generation,
                        recorder.history[-1]["wall_time_s"], out_dir)
    if out_dir is not None:
        if not (out_dir / POPULATION_FILE).is_file():  # written with the final checkpoint; a run killed before it
            save_population(out_dir / POPULATION_FILE, population.config, population.population, population.species,
                            population.generation)
        _write_outputs(result, task, population.config)
    return result


def evolve_from_population(robot: Robot, gait_dir, generations: int, *, seed: int = 0, episode_duration_s: float,
                           episodes_per_genome: int = 1, workers: int | None = None,
                           progress: bool = False, start_yaws_deg: tuple[float, ...] | None = None,
                           keep_top: int = 0, shared: SharedPool | None = None) -> GaitResult:
    """Evolve a gait on ``robot`` for ``generations`` more generations, starting from the final
    NEAT population of the run in ``gait_dir`` (its ``final_population.json``,
    :mod:`gait.population_file`: genomes, species and innovation state carry over, as from its
    final checkpoint; every genome is evaluated anew on ``robot``). A damaged robot's new gait
    starts from what the healthy robot's evolution found (the mission's recovery) instead of
    from scratch. Nothing in ``gait_dir`` is unpickled: it may be a directory received from
    anyone.

    Args:
        robot: the robot the gait is evolved on (a :class:`~gait.robots.Robot`).
        gait_dir: a finished run directory of :func:`evolve_gait` (its population file; a run
            made before the file existed gets it from :func:`write_population_file`, in the
            directory that made it).
        generations: generations to run beyond the population's (>= 1).
        seed: the fitness task's seed, as :func:`evolve_gait`.
        episode_duration_s: simulated seconds of every episode, as :func:`evolve_gait`.
        episodes_per_genome: episodes a genome is scored on, as :func:`evolve_gait`.
        workers: evaluation processes (default 1).
        start_yaws_deg: episode k starts turned by ``start_yaws_deg[k % n]`` degrees
            counter-clockwise from +y and is scored by its distance along +y
            (:class:`~gait.fitness_task.FitnessTask`); None: every start heads +y.
        keep_top: the fittest genomes of every generation kept as the result's ``candidates``
            (:class:`gait.rehearsal.TopGenomes`; 0: none), e.g. for :func:`gait.rehearsal.rehearse`.
        shared: a :class:`~gait.shared_pool.SharedPool` that evaluates the generations' worlds
            (``workers`` is then the pool's), e.g. beside another evolution in
            :meth:`~gait.shared_pool.SharedPool.run_each`; the same result as without.

    Returns:
        The :class:`GaitResult`; nothing is written (``out_dir`` is None).

    Raises:
        ValueError: no population file in ``gait_dir``, or one that is not a population
            (:class:`~aquafish_gym.rundir.FileError`, naming it), ``generations`` < 1,
            ``keep_top`` < 0, or a bad task setting.
    """
    generations = check_int("generations", generations, 1)
    keep_top = check_int("keep_top", keep_top, 0)
    task = _make_task(as_robot(robot), seed, None, episode_duration_s, CLOCK_PERIOD_S, episodes_per_genome,
                      DEFAULT_ENV_ID, start_yaws_deg=start_yaws_deg)
    population = load_population(Path(gait_dir) / POPULATION_FILE)
    population.reporters = neat.reporting.ReporterSet()
    for genome in population.population.values():
        genome.fitness = None  # its fitness was on the old robot: the evaluator keeps a fitness it finds
    setattr(population.config, FINGERPRINT_ATTR, _settings(task) | {"population_size": population.config.pop_size})
    top = TopGenomes(keep_top) if keep_top else None
    if top is not None:
        population.add_reporter(top)
    random.seed(seed)
    np.random.seed(seed)
    result = _evolve(population, task, None, True, False, 1, population.generation + generations, workers or 1,
                     progress, True, shared)
    if top is not None:
        result.candidates = [task.controller(genome, population.config) for genome in top.kept.values()]
        result.candidate_generations = [top.generations[key] for key in top.kept]
    return result


def write_population_file(out_dir) -> Path:
    """``out_dir/final_population.json`` of the finished gait run in ``out_dir``, written from its
    final checkpoint if the run was made before it wrote the file (:mod:`gait.population_file`).

    The checkpoint is a pickle: call this only on a run directory your own command made (a
    mission's ``self_model/gait``), never on one you received; it is read as a resume reads it
    (:func:`_restore`: only from ``checkpoints/`` beside the run's manifest).

    Raises:
        ValueError: no checkpoint or manifest in ``out_dir``; a damaged checkpoint
            (:class:`~aquafish_gym.rundir.FileError`).
    """
    out_dir = Path(out_dir)
    path = out_dir / POPULATION_FILE
    if path.is_file():
        return path
    with run_lock(out_dir, command="gait"):
        if not (out_dir / SETTINGS_FILE).is_file():
            raise ValueError(f"{out_dir} holds no gait run ({SETTINGS_FILE} is missing)")
        recorded = read_json(out_dir / SETTINGS_FILE)
        population = _restore(latest_checkpoint(out_dir), None,
                              {k: v for k, v in recorded.items() if k != "population_size"})
        save_population(path, population.config, population.population, population.species, population.generation)
    return path


def evolve_or_load_gait(morphology, out_dir, **kwargs) -> NEATController:
    """The best controller of a NEAT run in ``out_dir``, evolving it only if it is not finished.

    A finished run (its ``run.json`` written) is loaded, not repeated; a run interrupted after
    a checkpoint resumes from its latest one (one killed after its final checkpoint is only
    finished: see :func:`evolve_gait`); otherwise a new run starts. The case study and
    the damage table evolve every gait through this, so repeating a command reuses its gaits.

    Args:
        morphology: as :func:`evolve_gait`.
        out_dir: the run directory.
        **kwargs: further :func:`evolve_gait` arguments (not ``out_dir`` or ``resume``).

    Raises:
        ValueError: as :func:`evolve_gait`; :class:`~aquafish_gym.rundir.MismatchError` if the
            finished run was made with other settings or another budget (``generations``,
            ``population_size``), naming the fields.
    """
    out_dir = check_output_dir(out_dir)
    with run_lock(out_dir, command="gait"):
        if (out_dir / RUN_FILE).is_file():
            _check_finished(out_dir, morphology, kwargs)
            return load_controller(out_dir / NEAT_CONTROLLER_FILE)
        try:
            resume = latest_checkpoint(out_dir)
        except ValueError:
            resume = None
        return evolve_gait(morphology, out_dir=out_dir, resume=resume, **kwargs).best_controller


def _check_finished(out_dir: Path, morphology, kwargs: dict[str, Any]) -> None:
    """Refuse to reuse the finished run in ``out_dir`` if it was made with other settings than
    :func:`evolve_gait` would use with ``kwargs`` (its budget included)."""
    bound = inspect.signature(evolve_gait).bind(morphology, **kwargs)
    bound.apply_defaults()
    a = bound.arguments
    robot = as_robot(a["morphology"] if a["morphology"] is not None else "healthy", damage=a["damage"])
    task = _make_task(robot, check_int("seed", a["seed"], 0), a["initial_angles"], a["episode_duration_s"],
                      a["clock_period_s"], a["episodes_per_genome"], a["env_id"], a["spread_headings"])
    population_size = a["population_size"] or load_neat_config(a["config_path"]).pop_size
    run = read_json(out_dir / RUN_FILE)
    recorded = dict(read_json(out_dir / SETTINGS_FILE)) if (out_dir / SETTINGS_FILE).is_file() else {}
    recorded |= {"population_size": run.get("population_size"), "generations": run.get("generations")}
    check_fingerprint(out_dir, recorded, _settings(task) | {"population_size": population_size,
                                                            "generations": a["generations"]},
                      "use another --out for this budget, or the settings it was made with")


def _write_outputs(result: GaitResult, task: FitnessTask, config: neat.Config) -> None:
    out = result.out_dir
    atomic_write(out / "best_genome.txt",
                 f"{result.best_controller!r}\nfitness {result.best_fitness}\n\n{result.best_controller.genome}\n".encode())
    plot_fitness_history(result.history, out / HISTORY_PLOT, title=f"NEAT gait: {result.robot.label}, seed {result.seed}")
    summary: dict[str, Any] = {
        "robot": result.robot.to_dict(),
        "env_id": task.env_id,
        "seed": result.seed,
        "population_size": config.pop_size,
        "generations": result.generations,
        "episode_duration_s": task.episode_duration_s,
        "clock_period_s": task.clock_period_s,
        "initial_angles_rad": result.initial_angles.tolist(),
        "best_fitness": result.best_fitness,
        "episodes_per_genome": task.episodes,
        **({"spread_headings": True} if task.spread_headings else {}),
        "best_rollout_distance": task.score(result.best_rollout, 0) if task.spread_headings
        else result.best_rollout.distance,
        "evaluations": result.history[-1]["evaluations"],
        "wall_time_s": result.wall_time_s,
        "controller": NEAT_CONTROLLER_FILE,
    }
    atomic_write(out / RUN_FILE, json.dumps(summary, indent=1).encode())
