"""CMA-ES over model morphologies behind the ask/tell interface of :class:`eea.ga.BitGA`.

An alternative search for the estimation phase (``--estimation-search cma``: ``config.estimation.search`` a :class:`CMASettings`),
not the paper's: the paper evolves models with the bit-string GA of section 4, which stays
the default. MOD_FIT (eq. 3) of this robot has narrow diagonal ridges that single-field
bit-flip mutation cannot follow; CMA-ES (the ``cma`` package) adapts a full covariance and
so walks along correlated directions (docs/self_modeling.md, "Estimation search").

Search space: the unit cube ``[0, 1]^9``, one coordinate per morphology dimension (order
``aquafish_gym.MORPHOLOGY_FIELDS``). A point ``x`` is the model genome whose field ``d`` holds
level ``floor(x_d * 2**bits_d)`` (the top level for ``x_d = 1``), i.e. the cell of the
half-open model grid that contains it. ``ask`` returns those genomes, so the rest of the
EEA (evaluation cache, inference, records) sees ordinary 45-bit model genomes.

In the ``morphology+servos`` model space (``model_space``, not the paper's;
:class:`eea.encoding.ModelSpace`) the cube is ``[0, 1]^12``: the nine dimensions as above and
one coordinate per servo gain, whose 4-bit field holds code ``floor(x_d * 16)`` (15 for
``x_d = 1``), i.e. the cube's coordinate is spread evenly over the field's 16 codes, and code c
is gain level ``k = c + (c > 0)`` of :func:`eea.encoding.decode_gains` (so the lowest code's
cell covers twice the gain step: one gain level is left out of the grid).

Local and global search in the same round (``global_share`` G > 0, off by default): every
round two distributions share the P points of a generation. The local one restarts at the
best point with P - G samples, as without; the global one restarts at a uniformly random
point with G samples. Each is told its own points. The generation's best point, from either,
is injected into the local one (elitism), and the global one's own best into the global one,
so a better basin found globally pulls the local search there within the round. The global
share joins in round 2: round 1 samples all P points from the local distribution.

A global share that keeps its lineage (``global_keep`` k > 0, off by default; needs
``global_share``): the global distribution restarts at a random point only every k-th round
(round 2, then k + 2, ...) and otherwise at its own best point of the last round, with its own
carried covariance (``carry_condition``) like the local one: a second, independent lineage
whose models inherit angles from their own parents.

Carried covariance (``carry_condition`` c >= 1, off by default): a restart at the best point
keeps the shape of the covariance the previous round's distribution learned, not only its
best point, since MOD_FIT's ridges are long and narrow. The carried matrix is scaled so that
its longest axis has the initial step size, and its eigenvalues are floored at 1/c of the
largest (axes at least 1/sqrt(c) as long), so the new distribution still samples across the
ridge, which a new experiment may have moved.

What each option measured: docs/studies/unknown_angles.md ("Global restarts" and after).

Randomness: CMA-ES draws its normal samples from a child ``numpy.random.Generator``
spawned from the run's generator at construction and saved with the search state, so a run
is reproducible and resumes bit-for-bit.

Settings: :class:`CMASettings`, ``config.estimation.search`` of an :class:`eea.config.EEAConfig`
with ``estimation_search="cma"`` (the flags ``--cma-sigma``, ``--cma-global-share``,
``--cma-carry-condition``, ``--cma-global-keep``, ``--cma-flip-gains``).
"""

from __future__ import annotations

import dataclasses
import math
import pickle
from typing import ClassVar

import numpy as np

from aquafish_gym import MORPHOLOGY_BOUNDS
from aquafish_gym.checks import check_int
from eea.encoding import (MODEL_BITS, MODEL_FIELD_BITS, _bits_to_ints, _ints_to_bits, decode_models, encode_models,
                          get_model_space)
from eea.compat import loads, upgrade_cma_search
from eea.ga import TellRecord

__all__ = ["CMAModelSearch", "CMASettings", "carried_shape", "genomes_to_unit", "unit_to_genomes"]

_LEVELS = 2 ** np.asarray(MODEL_FIELD_BITS)


def unit_to_genomes(x, model_space="morphology") -> np.ndarray:
    """Model genomes of points of the unit cube (see the module docstring).

    Args:
        x: ``(P, n)`` coordinates in [0, 1], order ``ModelSpace.fields`` (n = 9:
            ``aquafish_gym.MORPHOLOGY_FIELDS``; 12 in ``morphology+servos``, the gains last).
        model_space: a :class:`eea.encoding.ModelSpace` or its name.

    Returns:
        ``(P, n_bits)`` uint8 model genomes (45 bits; 57).

    Raises:
        ValueError: if ``x`` is not ``(P, n)`` or holds a value outside [0, 1] or NaN.
    """
    space = get_model_space(model_space)
    levels_per_field = 2 ** np.asarray(space.field_bits)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != len(levels_per_field):
        raise ValueError(f"x must have shape (P, {len(levels_per_field)}), got {x.shape}")
    if not np.all((x >= 0.0) & (x <= 1.0)):
        raise ValueError(f"x must lie in the unit cube [0, 1]^{len(levels_per_field)} (no NaN)")
    if space.servos:  # every field's code straight from its coordinate
        codes = np.minimum(np.floor(x * levels_per_field), levels_per_field - 1)
        return _ints_to_bits(codes.astype(np.int64), space.field_bits)
    levels = np.minimum(np.floor(x * _LEVELS), _LEVELS - 1)
    lo, hi = MORPHOLOGY_BOUNDS[:, 0], MORPHOLOGY_BOUNDS[:, 1]
    return encode_models(lo + (hi - lo) * levels / _LEVELS)


def genomes_to_unit(genomes, model_space="morphology") -> np.ndarray:
    """The centres of the model genomes' cells in the unit cube: the inverse of
    :func:`unit_to_genomes` (``unit_to_genomes(genomes_to_unit(g))`` is ``g``).

    Args:
        genomes: ``(P, n_bits)`` model genomes (0/1).
        model_space: a :class:`eea.encoding.ModelSpace` or its name.

    Returns:
        ``(P, n)`` coordinates in (0, 1), order ``ModelSpace.fields``.

    Raises:
        ValueError: as :func:`eea.encoding.decode_models` does for a malformed genome.
    """
    space = get_model_space(model_space)
    if space.servos:
        codes, _ = _bits_to_ints(genomes, space.field_bits)
        return (codes + 0.5) / 2 ** np.asarray(space.field_bits)
    lo, hi = MORPHOLOGY_BOUNDS[:, 0], MORPHOLOGY_BOUNDS[:, 1]
    return (np.atleast_2d(decode_models(genomes)) - lo) / (hi - lo) + 0.5 / _LEVELS


def carried_shape(covariance, condition: float) -> np.ndarray:
    """The covariance shape a restart carries over (see the module docstring).

    Args:
        covariance: ``(n, n)`` symmetric positive semi-definite matrix (CMA-ES's ``C``).
        condition: c >= 1, the largest condition number of the result.

    Returns:
        ``(n, n)`` the matrix with the same eigenvectors, its eigenvalues divided by the largest
        and floored at 1/c: the largest is 1, the smallest >= 1/c.

    Raises:
        ValueError: if ``covariance`` is not a finite square matrix with a positive eigenvalue,
            or ``condition`` < 1.
    """
    c = np.asarray(covariance, dtype=np.float64)
    if c.ndim != 2 or c.shape[0] != c.shape[1] or not np.all(np.isfinite(c)):
        raise ValueError(f"covariance must be a finite square matrix, got shape {c.shape}")
    if not condition >= 1:
        raise ValueError(f"condition must be >= 1, got {condition!r}")
    values, vectors = np.linalg.eigh((c + c.T) / 2)
    if values[-1] <= 0:
        raise ValueError("covariance has no positive eigenvalue")
    values = np.maximum(values / values[-1], 1.0 / condition)
    return (vectors * values) @ vectors.T


@dataclasses.dataclass(frozen=True)
class CMASettings:
    """The CMA-ES search's settings (``config.estimation.search`` of an ``EEAConfig`` with
    ``estimation_search="cma"``; the flags ``--cma-*``).

    Args:
        sigma: initial step size as a fraction of every dimension's range, in (0, 1].
        global_share: G >= 0 points per generation of the global distribution (0 = off;
            ``EEAConfig`` checks 2 <= G <= estimation_population - 2).
        carry_condition: 0 (off) or a finite c >= 1 (module docstring).
        global_keep: k >= 0, needs ``global_share`` > 0 (module docstring).
        flip_gains: 0 (off) or 1: every restart also injects the best point with each pectoral
            gain's sign flipped (left, right, both; ``morphology+servos`` only; not the paper's).

    Raises:
        ValueError: naming the field as ``EEAConfig.cma_<field>`` if one is out of range, or
            ``global_keep`` > 0 without a ``global_share``.
    """

    #: The search's registry name (:data:`eea.search.MODEL_SEARCHES`).
    name: ClassVar[str] = "cma"

    sigma: float = 0.3
    global_share: int = 0
    carry_condition: float = 0.0
    global_keep: int = 0
    flip_gains: int = 0

    def __post_init__(self) -> None:
        if isinstance(self.sigma, bool) or not isinstance(self.sigma, (int, float)) or not 0.0 < self.sigma <= 1.0:
            raise ValueError(f"EEAConfig.cma_sigma must be in (0, 1], got {self.sigma!r}")
        object.__setattr__(self, "sigma", float(self.sigma))
        value = self.carry_condition
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (value == 0 or 1 <= value < math.inf):
            raise ValueError(f"EEAConfig.cma_carry_condition must be 0 (off) or a finite number >= 1, got {value!r}")
        object.__setattr__(self, "carry_condition", float(value))
        check_int("EEAConfig.cma_global_share", self.global_share, 0)
        check_int("EEAConfig.cma_global_keep", self.global_keep, 0)
        if self.flip_gains not in (0, 1) or isinstance(self.flip_gains, bool):
            raise ValueError(f"EEAConfig.cma_flip_gains must be 0 (off) or 1, got {self.flip_gains!r}")
        if self.global_keep and not self.global_share:
            raise ValueError(f"EEAConfig.cma_global_keep > 0 needs cma_global_share > 0 (a global share to keep), "
                             f"got {self.global_keep} and {self.global_share}")


class _StandardNormal:
    """``randn(lam, n)`` for ``cma`` drawn from a numpy Generator (picklable, unlike a lambda)."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def __call__(self, lam: int, n: int) -> np.ndarray:
        return self.rng.standard_normal((lam, n))


class CMAModelSearch(TellRecord):
    """CMA-ES over the 9 morphology dimensions (and 3 servo gains), asked and told like a :class:`~eea.ga.BitGA`.

    Each ``tell`` updates the distribution (``cma.CMAEvolutionStrategy``, population
    ``population_size``, box [0, 1]^9, or [0, 1]^12 with the gains) and, with ``elitism``, injects the generation's best
    point into the next population, so a round's best model is re-evaluated (against the
    grown experiment set) rather than lost.

    Args:
        population_size: P, points per generation (>= 2; the paper's GA uses 25).
        rng: the run's generator; one integer is drawn from it to seed the search's own
            stream.
        sigma0: initial step size as a fraction of every dimension's range, in (0, 1].
        elitism: 0 or 1, whether the best point of a generation is carried into the next.
        global_share: G = 0 (off) or 2 <= G <= P - 2, points per generation sampled by a second,
            global distribution restarted every round (module docstring).
        carry_condition: c = 0 (off: every restart is isotropic) or c >= 1, the largest
            condition number of the covariance carried into a restart at the best point
            (module docstring).
        global_keep: k >= 0 (needs ``global_share``): the global distribution restarts at a
            random point every k-th round and at its own best point otherwise (module
            docstring); 0 = at a random point every round.
        model_space: ``"morphology"`` (the default, 9 coordinates, 45-bit genomes) or
            ``"morphology+servos"`` (12, 57-bit; module docstring).
        flip_gains: 0 or 1 (``morphology+servos`` only): every :meth:`restart` also injects the
            best point with the left, the right and both pectoral gains' signs flipped, so a
            lineage caught in a wrong-sign basin (e.g. a healthy servo modelled as reversed) sees
            the other side every round (not the paper's).

    Raises:
        ValueError: if an argument is outside the ranges above, or ``global_keep`` > 0 without
            ``global_share``.
    """

    name: ClassVar[str] = "cma"
    n_bits: int = MODEL_BITS

    def __init__(self, population_size: int, rng: np.random.Generator, *, sigma0: float = 0.3,
                 elitism: int = 1, global_share: int = 0, carry_condition: float = 0.0, global_keep: int = 0,
                 model_space="morphology", flip_gains: int = 0) -> None:
        space = get_model_space(model_space)
        check_int("population_size", population_size, 2)
        check_int("global_keep", global_keep, 0)
        if global_keep and not global_share:
            raise ValueError(f"global_keep > 0 needs a global_share (a global distribution to keep), got {global_keep}")
        check_int("global_share", global_share, 0)
        if global_share and not 2 <= global_share <= population_size - 2:
            raise ValueError(f"global_share must be 0 or in [2, population_size - 2] = [2, {population_size - 2}] "
                             f"(each distribution samples at least 2 points), got {global_share}")
        if not (isinstance(sigma0, (int, float)) and 0.0 < sigma0 <= 1.0):
            raise ValueError(f"sigma0 must be in (0, 1], got {sigma0!r}")
        if elitism not in (0, 1):
            raise ValueError(f"elitism must be 0 or 1 for CMA-ES, got {elitism!r}")
        if isinstance(carry_condition, bool) or not isinstance(carry_condition, (int, float)) \
                or not (carry_condition == 0 or 1 <= carry_condition < np.inf):
            raise ValueError(f"carry_condition must be 0 (off) or a finite number >= 1, got {carry_condition!r}")
        self.carry_condition = float(carry_condition)
        if space.servos:  # the paper's space keeps the class attributes (and its checkpoints their layout)
            self.model_space, self.n_bits = space.name, space.n_bits
        if flip_gains not in (0, 1) or isinstance(flip_gains, bool):
            raise ValueError(f"flip_gains must be 0 or 1, got {flip_gains!r}")
        if flip_gains and not space.servos:
            raise ValueError("flip_gains needs the morphology+servos model space (gains to flip)")
        if flip_gains:  # only when on: a search without it pickles as before
            self.flip_gains = 1
        n_dims = self._n_dims
        self.population_size, self.sigma0, self.elitism = population_size, float(sigma0), int(elitism)
        self.global_share, self.global_keep = int(global_share), int(global_keep)
        self._stream = np.random.default_rng(int(rng.integers(2**63)))
        self._global_es = None                     # the global distribution (global_share > 0, from round 2)
        self._global_best_x: np.ndarray | None = None  # its best point of the last told generation (9,)
        self._global_restarts = 0                  # its starts so far (every global_keep-th is at random)
        self._es = self._new_strategy(self._stream.random(n_dims), population_size)
        self._x: np.ndarray | None = None          # sampled points (P, 9), None after tell
        self._asked = False
        self._best_x: np.ndarray | None = None     # best point of the last told generation (9,)
        self._best_genome: np.ndarray | None = None
        self._best_fitness = float("nan")
        self._generation = 0

    #: The model space's name; the class value is the paper's (and that of checkpoints written
    #: before model spaces), an instance of ``morphology+servos`` sets its own.
    model_space: ClassVar[str] = "morphology"
    #: 0: no gain flips at a restart (the class value, and that of checkpoints written before).
    flip_gains: ClassVar[int] = 0

    @property
    def _n_dims(self) -> int:
        """Coordinates of the cube: 9, or 12 with the servo gains."""
        return len(get_model_space(self.model_space).field_bits)

    def _genomes(self, x: np.ndarray) -> np.ndarray:
        return unit_to_genomes(x, self.model_space)

    @classmethod
    def from_settings(cls, estimation, ga, model_space, rng: np.random.Generator) -> "CMAModelSearch":
        """Sized and tuned by the estimation's settings (``config.estimation`` of an
        :class:`eea.config.EEAConfig`, its ``search`` a :class:`CMASettings`) and the run's GA
        settings (any ``elitism`` >= 1 carries the one best point).

        Args:
            estimation: an :class:`eea.estimation.EstimationSettings` whose ``search`` is a
                :class:`CMASettings`.
            ga: the run's :class:`eea.ga.GASettings`.
            model_space: the run's model space (a name or an :class:`eea.encoding.ModelSpace`).
            rng: the run's generator (one integer seeds the search's own stream).

        Raises:
            ValueError: if ``estimation.search`` is not a :class:`CMASettings`.
        """
        cma = estimation.search
        if not isinstance(cma, CMASettings):
            raise ValueError(f"a CMA-ES search needs CMASettings, got {cma!r}")
        return cls(estimation.population, rng, sigma0=cma.sigma, elitism=1 if ga.elitism else 0,
                   global_share=cma.global_share, carry_condition=cma.carry_condition, global_keep=cma.global_keep,
                   model_space=model_space, flip_gains=cma.flip_gains)

    def _new_strategy(self, mean: np.ndarray, popsize: int):
        import cma  # here, not at module level: importing cma takes ~1.5 s, and only cma runs need it

        return cma.CMAEvolutionStrategy(
            mean, self.sigma0,
            {"popsize": popsize, "bounds": [0.0, 1.0], "randn": _StandardNormal(self._stream),
             "verbose": -9, "seed": np.nan, "tolfun": 0.0, "tolx": 0.0, "tolfunhist": 0.0,
             "tolstagnation": np.inf, "tolflatfitness": np.inf, "maxiter": np.inf, "maxfevals": np.inf})

    def restart(self) -> None:
        """Restart the distribution with the initial step size at the best point of the last
        generation (and the global share's, from round 2; module docstring).

        Called by the estimation phase at the start of every round: a new experiment
        changes MOD_FIT, and a distribution that converged on the old one cannot move.
        That point is injected into the first population (elitism). No-op before the first
        ``tell``.
        """
        if self._best_x is None:
            return
        self._es = self._restarted(self._es, self._best_x, self.population_size - self.global_share)
        if self.flip_gains:
            self._inject_flips()
        if self.global_share:
            keep = self.global_keep and self._global_es is not None and self._global_restarts % self.global_keep
            self._global_es = self._restarted(self._global_es, self._global_best_x, self.global_share) if keep \
                else self._new_strategy(self._stream.random(self._n_dims), self.global_share)
            self._global_restarts += 1
        self._x, self._asked = None, False

    def seed_at(self, genome) -> None:
        """Warm start: centre the search on the model ``genome`` before its first generation.

        The point at the centre of ``genome``'s cell (:func:`genomes_to_unit`) becomes the
        best point, as if a generation had found it, and the distribution restarts there
        (the initial step size, the point injected, so the next ``ask`` holds ``genome``
        itself; with ``flip_gains`` its sign-flipped pectoral gains too). The estimation
        phase's own :meth:`restart` at the start of the round then restarts there again
        (the global share, if any, joining as in a later round). Used when
        a known self-model is the prior (``aquafish mission``: the EEA after a damage starts
        from the self-model it had before).

        Args:
            genome: ``(n_bits,)`` a model genome of this search's model space.

        Raises:
            ValueError: a genome of another length.
        """
        genome = np.asarray(genome, dtype=np.uint8).reshape(1, -1)
        if genome.shape[1] != get_model_space(self.model_space).n_bits:
            raise ValueError(f"seed_at needs a {get_model_space(self.model_space).n_bits}-bit model genome of the "
                             f"{self.model_space} model space, got {genome.shape[1]} bits")
        self._best_x = genomes_to_unit(genome, self.model_space)[0]
        self._best_genome = genome[0].copy()
        local = self.population_size - (self.global_share if self._global_es is not None else 0)
        self._es = self._restarted(self._es, self._best_x, local)
        if self.flip_gains:
            self._inject_flips()
        self._x, self._asked = None, False

    def _inject_flips(self) -> None:
        """Inject the best point with the pectoral gains (coordinates 9, 10 on [-1, 1]) mirrored about 0."""
        flips = [self._best_x.copy() for _ in range(3)]
        for x, dims in zip(flips, ([9], [10], [9, 10])):
            x[dims] = 1.0 - x[dims]
        self._es.inject(flips, force=True)

    def _restarted(self, es, best_x: np.ndarray, popsize: int):
        """A new distribution of ``popsize`` at ``best_x`` with ``es``'s carried covariance shape
        (``carry_condition`` > 0) and ``best_x`` injected (``elitism``)."""
        shape = carried_shape(es.sm.C, self.carry_condition) if self.carry_condition else None
        new = self._new_strategy(best_x, popsize)
        if shape is not None:
            new.sm.C = shape
            new.sm._decompose_C()  # pycma's sampler: eigen-decompose the matrix just set
        if self.elitism:
            new.inject([best_x], force=True)
        return new

    @property
    def population(self) -> np.ndarray:
        """The population the next (or pending) ``ask`` returns, ``(P, 45)`` uint8 model genomes.

        Samples it from the distribution if that has not happened yet (the same points
        ``ask`` then returns).
        """
        if self._x is None:
            self._x = np.clip(np.asarray(self._es.ask(), dtype=np.float64), 0.0, 1.0)
            if self._global_es is not None:  # the last G rows: the global distribution's
                self._x = np.vstack([self._x, np.clip(np.asarray(self._global_es.ask(), dtype=np.float64), 0.0, 1.0)])
        return self._genomes(self._x)

    def ask(self) -> np.ndarray:
        """The current population as ``(P, 45)`` uint8 model genomes, to be evaluated.

        Raises:
            RuntimeError: if the population was already asked and not told (ask twice).
        """
        genomes = self.population
        self._start_ask()
        return genomes

    def tell(self, fitness) -> None:
        """Record the fitness of the last asked population (higher is better) and update.

        Args:
            fitness: ``(P,)`` finite fitness, row for row of the last ``ask``.

        Raises:
            RuntimeError: if ``ask`` was not called since the last ``tell``.
            ValueError: if ``fitness`` is not shaped ``(P,)`` or is not finite.
        """
        self._check_tell()
        f = np.asarray(fitness, dtype=np.float64)
        if f.shape != (self.population_size,):
            raise ValueError(f"fitness must have shape ({self.population_size},), got {f.shape}")
        if not np.all(np.isfinite(f)):
            raise ValueError(f"fitness must be finite, got non-finite values at rows {np.flatnonzero(~np.isfinite(f)).tolist()}")
        best = int(np.argmax(f))
        self._best_x = self._x[best].copy()
        self._best_genome = self._genomes(self._x[best : best + 1])[0]
        self._best_fitness = float(f[best])
        if self._global_es is not None:  # local rows first, then the global distribution's G rows
            local = self.population_size - self.global_share
            self._es.tell(list(self._x[:local]), list(-f[:local]))  # cma minimises
            self._global_es.tell(list(self._x[local:]), list(-f[local:]))
            self._global_best_x = self._x[local + int(np.argmax(f[local:]))].copy()
            if self.elitism:  # the generation's best into the local distribution, the global one's best into it
                self._es.inject([self._x[best]], force=True)
                self._global_es.inject([self._global_best_x], force=True)
        else:
            self._es.tell(list(self._x), list(-f))  # cma minimises
            if self.elitism:  # the best point
                self._es.inject([self._x[best]], force=True)
        self._x, self._asked = None, False
        self._generation += 1

    def state_dict(self) -> dict:
        """The whole search (distribution, its random stream, asked points) for the checkpoint."""
        return {"search": "cma", "pickle": pickle.dumps(self)}

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator | None = None) -> "CMAModelSearch":
        """Rebuild from :meth:`state_dict`; ``rng`` is unused (the search has its own stream).

        Raises:
            ValueError: if ``state`` is not a CMA search state.
        """
        if state.get("search") != "cma":
            raise ValueError("state is not a CMAModelSearch state_dict")
        search = loads(state["pickle"])  # eea.compat's unpickler: older checkpoints name the old module path
        if not isinstance(search, cls):
            raise ValueError("state holds no CMAModelSearch")
        upgrade_cma_search(search)  # older checkpoints: attributes added or retired since
        return search
