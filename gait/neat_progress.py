"""What a NEAT run shows while it runs: progress over generations, and a quiet pool.

neat-python's ``ParallelEvaluator`` draws a tqdm bar over the genomes of every generation
(one screen line per generation), its ``StdOutReporter`` prints a report per generation
and its ``Checkpointer`` a line per checkpoint. :func:`gait.evolve_gait` uses the classes
here instead, and adds ``StdOutReporter`` only when asked (``verbose``).
"""

from __future__ import annotations

import gzip
import io
import pickle
import random

import neat
import numpy as np

from aquafish_gym.files import atomic_write
from aquafish_gym.progress import progress_bar
from aquafish_gym.rundir import spawn_pool

__all__ = ["GenerationBar", "PoolEvaluator", "QuietCheckpointer"]


class GenerationBar(neat.reporting.BaseReporter):
    """Progress over generations (:func:`aquafish_gym.progress.progress_bar`: a tqdm bar on a
    terminal, else one line per generation), with the best and mean fitness so far.

    Args:
        total: the run's total generations.
        initial: generations already done (a resumed run).
        desc: the bar's label.
        disable: no bar at all.
    """

    def __init__(self, total: int, initial: int = 0, desc: str = "NEAT generations", disable: bool = False):
        self.bar = progress_bar(total, initial=initial, desc=desc, unit="gen", disable=disable)
        self.best = -np.inf

    def post_evaluate(self, config, population, species, best_genome) -> None:
        self.best = max(self.best, float(best_genome.fitness))
        mean = float(np.mean([g.fitness for g in population.values()]))
        self.bar.set_postfix(best=f"{self.best:.3f}", mean=f"{mean:.3f}", species=len(species.species))

    def end_generation(self, config, population, species_set) -> None:
        self.bar.update(1)

    def close(self) -> None:
        """Close the bar (leaves its last line on screen)."""
        self.bar.close()

    def __getstate__(self) -> dict:
        # NEAT checkpoints pickle the species set, which holds the reporters: the bar stays here
        return {"best": self.best}

    def __setstate__(self, state: dict) -> None:
        self.best = state["best"]
        self.bar = progress_bar(disable=True)


class QuietCheckpointer(neat.Checkpointer):
    """``neat.Checkpointer`` that writes each checkpoint atomically and without its "Saving
    checkpoint to ..." line (the bar shows progress).

    The file has neat-python's format (a gzip-compressed pickle of ``(generation, config,
    population, species_set, random state)``, read by ``neat.Checkpointer.restore_checkpoint``),
    but is compressed in memory and written with :func:`aquafish_gym.files.atomic_write`, so a
    kill while saving leaves the previous checkpoints and no truncated one.

    With ``population_file``, the same population is written there as data first
    (:func:`gait.population_file.save_population`): what another run starts from, read without
    unpickling.
    """

    def __init__(self, *args, population_file=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.population_file = population_file

    def save_checkpoint(self, config, population, species_set, generation):
        """Write ``PREFIX<generation>`` atomically (see the class)."""
        if self.population_file is not None:  # before the pickle, which uses up a species key
            from gait.population_file import save_population

            save_population(self.population_file, config, population, species_set, generation)
        buffer = io.BytesIO()
        with gzip.GzipFile(fileobj=buffer, mode="wb", compresslevel=5, mtime=0) as f:
            pickle.dump((generation, config, population, species_set, random.getstate()), f,
                        protocol=pickle.HIGHEST_PROTOCOL)
        atomic_write(f"{self.filename_prefix}{generation}", buffer.getvalue())


class PoolEvaluator:
    """Evaluate a generation's genomes on a process pool, in order, without a bar of its own.

    Args:
        workers: processes (>= 2; evaluate in-process for one).
        evaluate: ``evaluate(genome, config) -> fitness``, a picklable top-level callable.

    Use as a context manager; the pool ("spawn" start method: PyBullet clients must not be
    forked) lives until exit, and its workers die with the process that made it.
    """

    def __init__(self, workers: int, evaluate):
        self.evaluate = evaluate
        self.pool = spawn_pool(workers)

    def __call__(self, genomes, config) -> None:
        genomes = list(genomes)
        fitnesses = self.pool.map(self.evaluate, [g for _, g in genomes], [config] * len(genomes))
        for (_, genome), fitness in zip(genomes, fitnesses):
            genome.fitness = fitness

    def __enter__(self) -> "PoolEvaluator":
        return self

    def __exit__(self, *exc) -> None:
        self.pool.shutdown()
