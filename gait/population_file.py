"""A NEAT population as data: a gait run's final population in JSON, read without unpickling.

A gait run (:func:`gait.neat_evolution.evolve_gait` with an ``out_dir``) writes its final
population to ``RUN/final_population.json`` (:data:`POPULATION_FILE`) beside its checkpoints.
A NEAT checkpoint is a pickle (neat-python's format), which runs code when loaded: it resumes
only the run directory that wrote it. What another run starts from, a mission's new gaits from
the prior's final population (:func:`gait.neat_evolution.evolve_from_population`, ``aquafish
mission --self-model DIR``), is this file, which holds plain numbers and names:

* ``genomes``: in the population's order, each with its ``key``, ``fitness``, ``nodes``
  (``key`` and the node gene's attributes: ``bias``, ``response``, ``activation``,
  ``aggregation``, ``time_constant``) and ``connections`` (``key`` ``[in, out]``,
  ``innovation`` and ``weight``, ``enabled``);
* ``species``: each species' ``key``, ``created``, ``last_improved``, ``representative`` and
  ``members`` (genome keys), ``fitness``, ``adjusted_fitness``, ``fitness_history``; the
  genome-to-species map and the next species key;
* the counters that new genes continue from: the next node key (``node_indexer``) and the
  innovation tracker (``innovation``);
* ``generation``, ``population_size`` and ``num_inputs``; the NEAT config is the run's own
  ``neat_config.ini`` (an INI file: data too).

The file is written with every checkpoint, from the same state, just before it
(:class:`gait.neat_progress.QuietCheckpointer`): it always holds the latest checkpoint's
population, and a finished run's is its final population.

:func:`load_population` rebuilds the ``neat.Population`` that
``neat.Checkpointer.restore_checkpoint`` gives from the final checkpoint: the same genomes
(floats round-trip exactly through JSON), species and counters, so a population continued from
either evolves the same genomes to the same fitnesses. It validates every field and refuses a
file that is not such a population (:class:`~aquafish_gym.rundir.FileError`, naming it).
"""

from __future__ import annotations

import itertools
import json
import math
import os
from pathlib import Path
from typing import Any

import neat
import numpy as np
from neat.innovation import InnovationTracker
from neat.species import Species

from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import FileError, read_json

__all__ = ["POPULATION_FILE", "load_population", "population_to_dict", "save_population"]

#: The final population of a gait run, written beside its ``checkpoints/``.
POPULATION_FILE = "final_population.json"
#: The version of the file's layout.
FORMAT = 1
#: The most genomes, and genes per genome, a population file may hold (the project's runs hold
#: at most a few hundred genomes of a few dozen genes).
MAX_GENOMES, MAX_GENES = 10_000, 10_000


def _peek(counter) -> int | None:
    """The next value of the ``itertools.count`` ``counter`` (None for None); it is used up, so the
    caller puts ``itertools.count(value)`` back in its place."""
    return None if counter is None else next(counter)


def _genes(genes: dict, gene_type) -> list[dict]:
    out = []
    for key, gene in genes.items():
        row: dict[str, Any] = {"key": list(key) if isinstance(key, tuple) else key}
        if hasattr(gene, "innovation"):
            row["innovation"] = gene.innovation
        row.update({a.name: getattr(gene, a.name) for a in gene_type._gene_attributes})
        out.append(row)
    return out


def population_to_dict(config: neat.Config, genomes: dict, species_set, generation: int) -> dict:
    """A population as a checkpoint holds it (``config``, ``genomes``, ``species_set`` at the start
    of ``generation``), as JSON-ready data. Its counters are read without being advanced."""
    genome_config = config.genome_config
    node_next = _peek(genome_config.node_indexer)
    if node_next is not None:
        genome_config.node_indexer = itertools.count(node_next)
    species_next = _peek(species_set.indexer)
    if species_next is not None:
        species_set.indexer = itertools.count(species_next)
    tracker = genome_config.innovation_tracker
    return {
        "format": FORMAT,
        "generation": generation,
        "population_size": config.pop_size,
        "num_inputs": genome_config.num_inputs,
        "node_indexer": node_next,
        "innovation": {"global_counter": tracker.global_counter,
                       "generation_innovations": [[*key, number] for key, number in
                                                  tracker.generation_innovations.items()]},
        "genomes": [{"key": key, "fitness": genome.fitness,
                     "nodes": _genes(genome.nodes, genome_config.node_gene_type),
                     "connections": _genes(genome.connections, genome_config.connection_gene_type)}
                    for key, genome in genomes.items()],
        "species": {"next_key": species_next,
                    "species": [{"key": s.key, "created": s.created, "last_improved": s.last_improved,
                                 "representative": s.representative.key, "members": list(s.members),
                                 "fitness": s.fitness, "adjusted_fitness": s.adjusted_fitness,
                                 "fitness_history": list(s.fitness_history)}
                                for s in species_set.species.values()],
                    "genome_to_species": [[g, s] for g, s in species_set.genome_to_species.items()]},
    }


def save_population(path: str | os.PathLike, config: neat.Config, genomes: dict, species_set, generation: int) -> None:
    """Write a population (:func:`population_to_dict`'s arguments) to ``path`` as JSON, atomically.

    A gait run's checkpointer writes it just before each checkpoint, from the same state
    (:class:`gait.neat_progress.QuietCheckpointer`): pickling neat-python's species set uses up a
    species key, so the file is written first and holds what the checkpoint holds.
    """
    atomic_write(Path(path), (json.dumps(population_to_dict(config, genomes, species_set, generation),
                                         default=_plain) + "\n").encode())


def _plain(value):
    """A NumPy number (a fitness from the batched evaluator) as the Python number it equals."""
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


# -- reading -------------------------------------------------------------------------------------------------


class _Bad(Exception):
    """A field of the file that is not what it must be (the message names it)."""


def _int(value, what: str, low: int | None = None) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or (low is not None and value < low):
        raise _Bad(f"{what} must be an integer{'' if low is None else f' >= {low}'}, got {_short(value)}")
    return value


def _float(value, what: str, none: bool = False) -> float | None:
    if value is None and none:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or math.isnan(value):
        raise _Bad(f"{what} must be a number, got {_short(value)}")
    return float(value)


def _list(value, what: str, limit: int = MAX_GENOMES) -> list:
    if not isinstance(value, list):
        raise _Bad(f"{what} must be a list, got {_short(value)}")
    if len(value) > limit:
        raise _Bad(f"{what} holds {len(value):,} entries, more than {limit:,}")
    return value


def _short(value) -> str:
    text = json.dumps(value) if not isinstance(value, float) or math.isfinite(value) else repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _gene(row, gene_type, genome_config, what: str, connection: bool):
    if not isinstance(row, dict):
        raise _Bad(f"{what} must be an object")
    names = [a.name for a in gene_type._gene_attributes]
    expected = {"key", *names, *(["innovation"] if connection else [])}
    if set(row) != expected:
        raise _Bad(f"{what} must have the fields {sorted(expected)}, got {sorted(row)}")
    if connection:
        key = _list(row["key"], f"{what}.key")
        if len(key) != 2:
            raise _Bad(f"{what}.key must be [input, output]")
        gene = gene_type(tuple(_int(k, f"{what}.key") for k in key),
                         innovation=_int(row["innovation"], f"{what}.innovation"))
    else:
        gene = gene_type(_int(row["key"], f"{what}.key"))
    for attribute in gene_type._gene_attributes:
        value, name = row[attribute.name], f"{what}.{attribute.name}"
        kind = type(attribute).__name__
        if kind == "FloatAttribute":
            value = _float(value, name)
            if not math.isfinite(value):
                raise _Bad(f"{name} must be finite, got {value!r}")
        elif kind == "BoolAttribute":
            if not isinstance(value, bool):
                raise _Bad(f"{name} must be true or false, got {_short(value)}")
        elif kind == "StringAttribute":
            defs = {"activation": genome_config.activation_defs,
                    "aggregation": genome_config.aggregation_function_defs}.get(attribute.name)
            if not isinstance(value, str) or (defs is not None and not defs.is_valid(value)):
                raise _Bad(f"{name} must name a NEAT {attribute.name} function, got {_short(value)}")
        else:  # an attribute type this file does not know: refuse rather than guess
            raise _Bad(f"{name} has the unknown attribute type {kind}")
        setattr(gene, attribute.name, value)
    return gene


def _genome(row, config, what: str):
    genome_config = config.genome_config
    if not isinstance(row, dict) or set(row) != {"key", "fitness", "nodes", "connections"}:
        raise _Bad(f"{what} must be an object with key, fitness, nodes and connections")
    genome = config.genome_type(_int(row["key"], f"{what}.key"))
    genome.fitness = _float(row["fitness"], f"{what}.fitness", none=True)
    for i, gene in enumerate(_list(row["nodes"], f"{what}.nodes", MAX_GENES)):
        node = _gene(gene, genome_config.node_gene_type, genome_config, f"{what}.nodes[{i}]", False)
        if node.key in genome.nodes or node.key < 0:
            raise _Bad(f"{what}.nodes[{i}].key {node.key} is repeated or an input's")
        genome.nodes[node.key] = node
    for key in genome_config.output_keys:
        if key not in genome.nodes:
            raise _Bad(f"{what} has no node for the output {key}")
    inputs = set(genome_config.input_keys)
    for i, gene in enumerate(_list(row["connections"], f"{what}.connections", MAX_GENES)):
        connection = _gene(gene, genome_config.connection_gene_type, genome_config, f"{what}.connections[{i}]", True)
        source, target = connection.key
        if connection.key in genome.connections or (source not in inputs and source not in genome.nodes) \
                or target not in genome.nodes:
            raise _Bad(f"{what}.connections[{i}].key {list(connection.key)} is repeated or joins an unknown node")
        genome.connections[connection.key] = connection
    return genome


def load_population(path: str | os.PathLike, config_path: str | os.PathLike | None = None) -> neat.Population:
    """The ``neat.Population`` saved in ``path`` (:func:`save_population`), without unpickling.

    Args:
        path: the population file.
        config_path: the NEAT config (INI) it was evolved with (default: ``neat_config.ini``
            beside ``path``, else :data:`gait.neat_evolution.DEFAULT_CONFIG`).

    Returns:
        The population, as ``neat.Checkpointer.restore_checkpoint`` would give it from the
        run's final checkpoint (no reporters).

    Raises:
        FileError: (a ``ValueError``) the file is missing, is not valid JSON, or any field is
            not what it must be (named), e.g. an unknown activation or a NaN weight.
    """
    from gait.neat_evolution import DEFAULT_CONFIG, load_neat_config, set_num_inputs

    path = Path(path)
    if not path.is_file():
        raise FileError(path, "does not exist", "give the directory of a finished gait run")
    data = read_json(path)
    if config_path is None:
        config_path = path.with_name("neat_config.ini") if path.with_name("neat_config.ini").is_file() else DEFAULT_CONFIG
    try:
        if data.get("format") != FORMAT:
            raise _Bad(f"format must be {FORMAT}, got {_short(data.get('format'))}")
        config = load_neat_config(config_path, population_size=_int(data.get("population_size"), "population_size", 2))
        set_num_inputs(config, _int(data.get("num_inputs"), "num_inputs", 1))
        genome_config = config.genome_config
        node_next = data.get("node_indexer")
        genome_config.node_indexer = None if node_next is None else itertools.count(_int(node_next, "node_indexer"))
        innovation = data.get("innovation")
        if not isinstance(innovation, dict) or set(innovation) != {"global_counter", "generation_innovations"}:
            raise _Bad("innovation must be an object with global_counter and generation_innovations")
        tracker = InnovationTracker(_int(innovation["global_counter"], "innovation.global_counter", 0))
        for row in _list(innovation["generation_innovations"], "innovation.generation_innovations"):
            if not (isinstance(row, list) and len(row) == 4 and isinstance(row[2], str)):
                raise _Bad("innovation.generation_innovations entries must be [input, output, kind, number]")
            tracker.generation_innovations[(_int(row[0], "innovation input"), _int(row[1], "innovation output"),
                                            row[2])] = _int(row[3], "innovation number")
        genomes = {}
        for i, row in enumerate(_list(data.get("genomes"), "genomes")):
            genome = _genome(row, config, f"genomes[{i}]")
            if genome.key in genomes:
                raise _Bad(f"genomes[{i}].key {genome.key} is repeated")
            genomes[genome.key] = genome
        if not genomes:
            raise _Bad("genomes is empty")
        species_set = config.species_set_type(config.species_set_config, neat.reporting.ReporterSet())
        species = data.get("species")
        if not isinstance(species, dict) or set(species) != {"next_key", "species", "genome_to_species"}:
            raise _Bad("species must be an object with next_key, species and genome_to_species")
        next_key = species["next_key"]
        species_set.indexer = None if next_key is None else itertools.count(_int(next_key, "species.next_key", 1))
        for i, row in enumerate(_list(species["species"], "species.species")):
            what = f"species.species[{i}]"
            fields = {"key", "created", "last_improved", "representative", "members", "fitness", "adjusted_fitness",
                      "fitness_history"}
            if not isinstance(row, dict) or set(row) != fields:
                raise _Bad(f"{what} must be an object with {sorted(fields)}")
            s = Species(_int(row["key"], f"{what}.key"), _int(row["created"], f"{what}.created", 0))
            s.last_improved = _int(row["last_improved"], f"{what}.last_improved", 0)
            members = [_int(g, f"{what}.members") for g in _list(row["members"], f"{what}.members")]
            representative = _int(row["representative"], f"{what}.representative")
            if any(g not in genomes for g in [representative, *members]) or s.key in species_set.species:
                raise _Bad(f"{what} names a genome that is not in the population, or repeats a species key")
            s.update(genomes[representative], {g: genomes[g] for g in members})
            s.fitness = _float(row["fitness"], f"{what}.fitness", none=True)
            s.adjusted_fitness = _float(row["adjusted_fitness"], f"{what}.adjusted_fitness", none=True)
            s.fitness_history = [_float(f, f"{what}.fitness_history") for f in
                                 _list(row["fitness_history"], f"{what}.fitness_history")]
            species_set.species[s.key] = s
        for row in _list(species["genome_to_species"], "species.genome_to_species"):
            if not (isinstance(row, list) and len(row) == 2):
                raise _Bad("species.genome_to_species entries must be [genome, species]")
            genome_key, species_key = (_int(v, "species.genome_to_species") for v in row)
            if genome_key not in genomes or species_key not in species_set.species:
                raise _Bad(f"species.genome_to_species maps {genome_key} to {species_key}, which are not there")
            species_set.genome_to_species[genome_key] = species_key
        generation = _int(data.get("generation"), "generation", 0)
    except _Bad as err:
        raise FileError(path, f"is not a NEAT population file: {err}",
                        "give the directory of a finished gait run, or make it again") from None
    population = neat.Population(config, (genomes, species_set, generation))
    population.reproduction.innovation_tracker = tracker
    genome_config.innovation_tracker = tracker
    return population
