"""Generational genetic algorithm on bit strings with an ask/tell interface (paper 3.2, 4).

The paper's two GAs (exploration over 18-bit actions, estimation over 45-bit models) both
use tournament selection of size two, a crossover rate of 0.75 and a mean mutation rate of
one bit per genome. :class:`BitGA` implements that, with elitism, and leaves evaluation to
the caller so a whole population can go into one batched simulator call::

    ga = BitGA(45, 25, rng)
    for _ in range(100):
        genomes = ga.ask()                 # (25, 45) uint8
        ga.tell(evaluate(genomes))         # (25,) fitness, higher is better
    ga.best_genome, ga.best_fitness

``ask`` and ``tell`` alternate: ``tell`` takes the fitness of exactly the population the
last ``ask`` returned, and asking twice or telling twice raises :class:`RuntimeError`
naming the misuse (read the current population without asking through
:attr:`BitGA.population`). The
elites are carried over unchanged as the first ``elitism`` rows of the next population and
are evaluated again with it, so noisy fitness or a changed context (e.g. newly inferred
initial angles) is re-measured every generation; callers that want to save simulations can
cache results by genome themselves.

:class:`GASettings` is the section of :class:`eea.config.EEAConfig` that every GA of a run
shares (crossover rate, tournament size, mutation bits, elitism); it validates itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquafish_gym.checks import check_int
from eea.encoding import ACTION_BITS

__all__ = ["BitGA", "GASettings", "TellRecord"]


@dataclasses.dataclass(frozen=True)
class GASettings:
    """The settings every GA of a run shares (the ``EEAConfig`` section ``config.ga``).

    The exploration GA, the estimation's model GA and the out-of-band inference's inner GA
    (paper section 4) breed with the same crossover rate, tournament size and elitism, and
    flip ``mutation_bits`` bits of a genome on average (:meth:`options` turns that into each
    genome's per-bit rate).

    Args:
        crossover_rate: probability in [0, 1] that a parent pair is recombined (paper: 0.75).
        tournament_size: entrants per tournament, >= 1 (paper: 2).
        mutation_bits: mean flipped bits per genome, in [0, 18]: at most the 18 bits of the
            action genome (``eea.encoding.ACTION_BITS``); ``EEAConfig`` also caps it at the
            out-of-band genome's ``3 * oob_bits``.
        elitism: best genomes copied unchanged into the next generation, >= 0
            (``EEAConfig`` caps it at every population).

    Raises:
        ValueError: naming the field as ``EEAConfig.<field>`` if one is out of range.
    """

    crossover_rate: float = 0.75
    tournament_size: int = 2
    mutation_bits: float = 1.0
    elitism: int = 1

    def __post_init__(self) -> None:
        value = self.crossover_rate
        if not isinstance(value, (int, float)) or not 0.0 <= value <= 1.0:  # NaN fails
            raise ValueError(f"EEAConfig.crossover_rate must be in [0, 1], got {value!r}")
        object.__setattr__(self, "crossover_rate", float(value))
        check_int("EEAConfig.tournament_size", self.tournament_size, 1)
        check_int("EEAConfig.elitism", self.elitism, 0)
        value, high = self.mutation_bits, float(ACTION_BITS)
        if not isinstance(value, (int, float)) or not 0.0 <= value <= high:
            raise ValueError(f"EEAConfig.mutation_bits must be in [0, {high}], got {value!r}")
        object.__setattr__(self, "mutation_bits", float(value))

    def options(self, n_bits: int) -> dict:
        """Keyword arguments of :class:`BitGA` for a genome of ``n_bits`` bits: the crossover
        rate, the per-bit mutation rate ``mutation_bits / n_bits``, the tournament size and
        the elitism."""
        return {"crossover_rate": self.crossover_rate, "mutation_rate": self.mutation_bits / n_bits,
                "tournament_size": self.tournament_size, "elitism": self.elitism}

_CROSSOVERS = ("one_point", "uniform")
_STATE_KEYS = (
    "n_bits", "population_size", "crossover_rate", "mutation_rate", "tournament_size",
    "elitism", "crossover", "generation", "asked", "population", "best_genome", "best_fitness",
)


def _check_bits(x, shape_hint: str, name: str) -> np.ndarray:
    a = np.asarray(x)
    if a.ndim != 2:
        raise ValueError(f"{name} must have shape {shape_hint}, got {a.shape}")
    if not np.all((a == 0) | (a == 1)):
        raise ValueError(f"{name} must contain only 0 and 1")
    return a.astype(np.uint8)


class TellRecord:
    """What an ask/tell search reports after ``tell`` (the generation count and the best
    genome), and its one check of ask/tell misuse.

    Shared by :class:`BitGA` and :class:`eea.search.cma.CMAModelSearch`; a subclass sets
    ``_generation``, ``_best_genome`` (None before the first ``tell``), ``_best_fitness`` and
    ``_asked`` (cleared by ``tell``).
    """

    n_bits: int
    _generation: int
    _best_genome: np.ndarray | None
    _best_fitness: float
    _asked: bool

    def _start_ask(self) -> None:
        """Mark the population asked; raise RuntimeError if it already was (ask twice)."""
        if self._asked:
            raise RuntimeError(f"ask() called twice: generation {self._generation}'s population was asked and "
                               f"not told; tell() its fitness first (or read {type(self).__name__}.population)")
        self._asked = True

    def _check_tell(self) -> None:
        """Raise RuntimeError if nothing was asked since the last ``tell`` (tell before ask, tell twice)."""
        if not self._asked:
            raise RuntimeError("tell() called without a preceding ask(): call ask() to get generation "
                               f"{self._generation}'s population, evaluate it, then tell() its fitness once")

    @property
    def generation(self) -> int:
        """Number of completed ``tell`` calls (0 before the first)."""
        return self._generation

    @property
    def best_genome(self) -> np.ndarray:
        """``(n_bits,)`` uint8 fittest genome of the last told population.

        Raises:
            RuntimeError: before the first ``tell``.
        """
        if self._best_genome is None:
            raise RuntimeError("best_genome is undefined before the first tell()")
        return self._best_genome.copy()

    @property
    def best_fitness(self) -> float:
        """Fitness of ``best_genome`` as told.

        Raises:
            RuntimeError: before the first ``tell``.
        """
        if self._best_genome is None:
            raise RuntimeError("best_fitness is undefined before the first tell()")
        return self._best_fitness


class BitGA(TellRecord):
    """Generational GA over fixed-length bit strings (maximises fitness).

    Breeding, once per ``tell``: the ``elitism`` fittest genomes are copied unchanged
    (ties go to the lower index); every other child comes from two parents chosen by
    tournament selection (``tournament_size`` entrants drawn uniformly *with*
    replacement, the fittest wins). With probability ``crossover_rate`` a pair of parents
    is recombined by one-point crossover (cut uniform in 1..n_bits-1; keeps neighbouring
    bits, i.e. a flipper's fields, together) or, with ``crossover="uniform"``, by a
    per-bit coin flip, giving two children; otherwise the children are copies of the
    parents. Each child bit is then flipped with probability ``mutation_rate``.

    Args:
        n_bits: genome length (45 for models, 18 for actions).
        population_size: P, number of genomes per generation (>= 1).
        rng: the only source of randomness.
        crossover_rate: probability in [0, 1] that a parent pair is recombined.
        mutation_rate: per-bit flip probability in [0, 1]; default ``1 / n_bits``
            (one flipped bit per genome on average, as in the paper).
        tournament_size: entrants per tournament (>= 1; 1 is random selection).
        elitism: number of best genomes copied unchanged, in [0, P].
        crossover: ``"one_point"`` (default) or ``"uniform"``.
        initial: optional ``(k, n_bits)`` 0/1 array, k <= P, used as the first k genomes
            of the first population (e.g. last round's models); the rest are uniform.

    Raises:
        ValueError: if any argument is outside the range given above.
    """

    def __init__(
        self,
        n_bits: int,
        population_size: int,
        rng: np.random.Generator,
        *,
        crossover_rate: float = 0.75,
        mutation_rate: float | None = None,
        tournament_size: int = 2,
        elitism: int = 1,
        crossover: str = "one_point",
        initial=None,
    ) -> None:
        if not isinstance(rng, np.random.Generator):
            raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        for name, value, low in (
            ("n_bits", n_bits, 1), ("population_size", population_size, 1),
            ("tournament_size", tournament_size, 1), ("elitism", elitism, 0),
        ):
            check_int(name, value, low)
        if elitism > population_size:
            raise ValueError(
                f"elitism must be <= population_size ({population_size}), got {elitism}"
            )
        if mutation_rate is None:
            mutation_rate = 1.0 / n_bits
        for name, value in (("crossover_rate", crossover_rate), ("mutation_rate", mutation_rate)):
            try:
                valid = 0.0 <= float(value) <= 1.0  # False for NaN
            except (TypeError, ValueError):
                valid = False
            if not valid:
                raise ValueError(f"{name} must be in [0, 1], got {value!r}")
        if crossover not in _CROSSOVERS:
            raise ValueError(f"crossover must be one of {_CROSSOVERS}, got {crossover!r}")
        self.n_bits, self.population_size = int(n_bits), int(population_size)
        self.crossover_rate, self.mutation_rate = float(crossover_rate), float(mutation_rate)
        self.tournament_size, self.elitism = int(tournament_size), int(elitism)
        self.crossover = crossover
        self._rng = rng
        init = np.zeros((0, self.n_bits), dtype=np.uint8)
        if initial is not None:
            hint = f"(k <= {self.population_size}, {self.n_bits})"
            init = _check_bits(initial, hint, "initial")
            if init.shape[1] != self.n_bits or init.shape[0] > self.population_size:
                raise ValueError(f"initial must have shape {hint}, got {init.shape}")
        fill = rng.integers(0, 2, size=(self.population_size - len(init), self.n_bits),
                            dtype=np.uint8)
        self._population = np.concatenate([init, fill])
        self._generation = 0
        self._asked = False
        self._best_genome: np.ndarray | None = None
        self._best_fitness = float("nan")

    # -- ask / tell ---------------------------------------------------------------------

    @property
    def population(self) -> np.ndarray:
        """The population the next (or pending) ``ask`` returns, ``(P, n_bits)`` uint8 (a copy)."""
        return self._population.copy()

    def ask(self) -> np.ndarray:
        """Return the current population, ``(P, n_bits)`` uint8 (a copy), to be evaluated.

        Raises:
            RuntimeError: if the population was already asked and not told (ask twice).
        """
        self._start_ask()
        return self._population.copy()

    def restart(self) -> None:
        """No-op: the GA's population carries over between rounds as it is (the paper's EEA)."""

    def seed_at(self, genome) -> None:
        """Warm start: put ``genome`` ``(n_bits,)`` in the first row of the next population
        (the rest stays as drawn), so the first generation holds it.

        Raises:
            ValueError: a genome of another length, or an ask pending.
        """
        if self._asked:
            raise ValueError("seed_at must come before ask: this generation was already asked (tell it first)")
        row = _check_bits(np.asarray(genome).reshape(1, -1), f"({self.n_bits},)", "genome")
        if row.shape[1] != self.n_bits:
            raise ValueError(f"genome must have {self.n_bits} bits, got {row.shape[1]}")
        self._population[0] = row[0]

    def tell(self, fitness) -> None:
        """Record the fitness of the last asked population and breed the next one.

        Args:
            fitness: ``(P,)`` real fitness of the genomes returned by the last ``ask``,
                row for row; higher is better. Infinities are allowed (``-inf``: infeasible).

        Raises:
            RuntimeError: if ``ask`` was not called since the last ``tell`` (tell before
                ask, or tell twice).
            ValueError: if ``fitness`` is not shaped ``(P,)`` or contains NaN.
        """
        self._check_tell()
        f = np.asarray(fitness, dtype=np.float64)
        if f.shape != (self.population_size,):
            raise ValueError(
                f"fitness must have shape ({self.population_size},), got {f.shape}"
            )
        if np.any(np.isnan(f)):
            rows = np.flatnonzero(np.isnan(f)).tolist()
            raise ValueError(f"fitness contains NaN at rows {rows}")
        order = np.argsort(-f, kind="stable")
        self._best_genome = self._population[order[0]].copy()
        self._best_fitness = float(f[order[0]])
        children = self._breed(f, self.population_size - self.elitism)
        self._population = np.concatenate([self._population[order[: self.elitism]], children])
        self._generation += 1
        self._asked = False

    # -- operators ----------------------------------------------------------------------

    def _select(self, fitness: np.ndarray, n: int) -> np.ndarray:
        """Indices (n,) of tournament winners (first drawn wins ties)."""
        entrants = self._rng.integers(0, self.population_size, size=(n, self.tournament_size))
        return entrants[np.arange(n), np.argmax(fitness[entrants], axis=1)]

    def _breed(self, fitness: np.ndarray, n_children: int) -> np.ndarray:
        """Children (n_children, n_bits) by selection, crossover and mutation."""
        if n_children == 0:
            return np.empty((0, self.n_bits), dtype=np.uint8)
        n_pairs = (n_children + 1) // 2
        winners = self._select(fitness, 2 * n_pairs)
        parents = self._population[winners].reshape(n_pairs, 2, self.n_bits)
        a, b = parents[:, 0].copy(), parents[:, 1].copy()
        crossed = self._rng.random(n_pairs) < self.crossover_rate
        if self.crossover == "one_point":
            cut = self._rng.integers(1, max(self.n_bits, 2), size=n_pairs)
            swap = np.arange(self.n_bits) >= cut[:, None]
        else:
            swap = self._rng.random((n_pairs, self.n_bits)) < 0.5
        swap &= crossed[:, None]
        a[swap], b[swap] = parents[:, 1][swap], parents[:, 0][swap]
        children = np.stack([a, b], axis=1).reshape(2 * n_pairs, self.n_bits)[:n_children]
        flips = self._rng.random(children.shape) < self.mutation_rate
        return children ^ flips.astype(np.uint8)

    # -- results and checkpointing ------------------------------------------------------

    def state_dict(self) -> dict:
        """Settings and state as plain ints, floats, str and numpy arrays (for ``np.savez``).

        The caller's ``rng`` is not included: to resume bit-for-bit, checkpoint it too
        (``rng.bit_generator.state``).
        """
        return {
            "n_bits": self.n_bits, "population_size": self.population_size,
            "crossover_rate": self.crossover_rate, "mutation_rate": self.mutation_rate,
            "tournament_size": self.tournament_size, "elitism": self.elitism,
            "crossover": self.crossover, "generation": self._generation,
            "asked": int(self._asked),
            "population": self._population.copy(),
            "best_genome": (np.zeros(0, np.uint8) if self._best_genome is None
                            else self._best_genome.copy()),
            "best_fitness": self._best_fitness,
        }

    @classmethod
    def _build(cls, n_bits: int, population_size: int, rng: np.random.Generator, **options) -> "BitGA":
        """Construct from the full argument list (subclasses with fixed ``n_bits`` override it)."""
        return cls(n_bits, population_size, rng, **options)

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator) -> "BitGA":
        """Rebuild a GA saved by :meth:`state_dict`, drawing from ``rng`` from now on.

        Raises:
            ValueError: if a key is missing or unknown, or a value is invalid.
        """
        keys = set(_STATE_KEYS)
        if set(state) != keys:
            raise ValueError(f"state keys differ: missing {sorted(keys - set(state))}, "
                             f"unknown {sorted(set(state) - keys)}")
        ga = cls._build(int(state["n_bits"]), int(state["population_size"]), rng,
                 crossover_rate=float(state["crossover_rate"]),
                 mutation_rate=float(state["mutation_rate"]),
                 tournament_size=int(state["tournament_size"]), elitism=int(state["elitism"]),
                 crossover=str(state["crossover"]), initial=state["population"])
        if np.asarray(state["population"]).shape[0] != ga.population_size:
            raise ValueError("state['population'] must have population_size rows")
        best = np.asarray(state["best_genome"], dtype=np.uint8)
        if best.shape not in ((0,), (ga.n_bits,)):
            raise ValueError(f"state['best_genome'] must have shape (0,) or ({ga.n_bits},)")
        ga._generation, ga._asked = int(state["generation"]), bool(state["asked"])
        ga._best_genome = best.copy() if best.size else None
        ga._best_fitness = float(state["best_fitness"])
        return ga
