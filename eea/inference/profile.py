"""Profile inference: every model keeps its own best initial angles (not the paper's).

The paper's strategies give all models of a generation the same context per experiment, and
out-of-band's angles and models lock in (docs/studies.md, "Why out-of-band inference helps so
little"). Here the initial angles are nuisance parameters profiled out per model: a model is
scored by MOD_FIT (eq. 3) under the best angles found *for it*, so the true morphology, given
its true angles, scores 1 whatever the other models believe.

Per estimation generation, for every distinct model about to be evaluated and every
experiment, :class:`Profile` tries

* its remembered best angles (free: the evaluator has them cached),
* the angles of the best model so far,
* ``proposals`` perturbations of its own best (each flipper moved with probability 1/2,
  at least one: pectorals by a normal step of 0.1, 0.4 or 1.2 rad, the caudal fin by 0.02,
  0.08 or 0.2 rad, one scale drawn per candidate; one in four a uniform random draw),

in one batched :meth:`Evaluator.similarities` call (an experiment's similarity depends only
on its own angles), and keeps the best per experiment. A model never seen before inherits the
memory of the nearest model of the previous generation in Hamming distance between genomes
(its parent). A new experiment is first tried from ``initial`` random angle sets per model.
The estimation generation itself then simulates nothing new: its angles are the remembered ones.

Contender refinement (``refine`` R > 0, off by default): the ``contenders`` K fittest models
that are new this generation get R more rounds of ``proposals`` perturbations each before the
generation is scored, so a newly proposed model is not judged under angles refined once
against an incumbent's refined for many generations.

Angle library (``library`` L > 0, off by default, with ``refine`` > 0): every angle set the
strategy scores feeds, per experiment, a library of the L best-scoring sets at least
``LIBRARY_SPACING_RAD`` apart (any model's scores; largest flipper difference, pectorals on
the circle, the caudal difference counted 3 times), and every contender first tries all L
sets of every experiment, then refines from the best. Cost: ``K L E`` more simulations per
generation with new models.

Compass polish and per-flipper scan (:meth:`Profile.polish_angles`, :meth:`Profile.scan_angles`;
used by the round's equal angle fit of ``--lineages``, :func:`eea.inference.selection.select_model`).
The polish is a compass search, one experiment at a time: from the finest random step (0.1 rad
pectorals, 0.02 rad caudal), each of the 3 angles is moved by +-step, the best of the 6 moves is
kept if it scores higher, up to ``POLISH_ITERATIONS`` times, and the step is halved
``len(POLISH_STEPS_RAD) - 1`` times (finest 0.0031 rad). A local search: it stops at a nearby
maximum. Cost: at most ``6 E`` simulations per model and iteration, about 60-90 per experiment
and model in practice. A cycle of the scan: for each flipper in turn, its angle in every
experiment is set to each of :data:`SCAN_PECTORAL` values round the circle
(:data:`SCAN_CAUDAL` across the caudal sweep) with the other two kept, and the best is kept
per experiment. Cost: ``2 SCAN_PECTORAL + SCAN_CAUDAL`` simulations per cycle, model and
experiment. Why both (MOD_FIT is a narrow cone round the truth's true angles):
docs/studies/unknown_angles.md, "The angle cone".

Cost: about ``U (proposals + 1) E`` simulations per generation for U distinct models and E
experiments, plus ``U initial`` at the first generation of a round (3-4 times ``known``'s
estimation), plus ``K R proposals E`` for the contenders (K = 3, R = 10: about 1.3 times).

The memory is the strategy's state (:meth:`Profile.state_dict`); the run checkpoints it.
The experiments' contexts hold the best model's angles (the ``inferred_*`` columns of
``rounds.csv``). What each option measured: docs/studies/unknown_angles.md; the retired ones:
docs/studies/retired_variants.md.

Settings: :class:`ProfileSettings`, ``config.inference`` of an :class:`eea.config.EEAConfig`
with ``inference="profile"`` (the flags ``--profile-*``).
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from aquafish_gym.checks import check_int
from eea.arc import TWO_PI
from eea.diversity import diverse_indices
from eea.encoding import genome_keys, genomes_from_keys
from eea.experiment import CAUDAL_LIMIT_RAD, Context, random_angles
from eea.fitness import model_fitness_from_similarities
from eea.inference.strategy import Experiments, InferenceStrategy

__all__ = ["LIBRARY_SPACING_RAD", "POLISH_ITERATIONS", "POLISH_STEPS_RAD", "Profile", "ProfileSettings",
           "SCAN_CAUDAL",
           "SCAN_PECTORAL"]

#: Normal step sizes of a perturbation (rad): pectorals, caudal fin; one pair drawn per candidate.
_STEPS_RAD = np.array([[0.1, 0.02], [0.4, 0.08], [1.2, 0.2]])
_RANDOM_SHARE = 0.25

#: Minimum distance between two angle sets of one experiment's library (rad; module docstring).
LIBRARY_SPACING_RAD = 0.5
#: The polish's compass steps (rad): pectorals, caudal fin; the finest random step halved 5 times.
POLISH_STEPS_RAD = _STEPS_RAD[0] / 2.0 ** np.arange(6)[:, None]
#: Compass moves per step size at most (one per angle suffices once the step before converged).
POLISH_ITERATIONS = 3
#: Angles per flipper of the scan before the polish: pectorals round the circle (15 deg apart),
#: the caudal fin across its sweep (7.5 deg apart).
SCAN_PECTORAL, SCAN_CAUDAL = 24, 9
_CAUDAL_WEIGHT = 3.0


@dataclasses.dataclass(frozen=True)
class ProfileSettings:
    """Profile inference's settings (``config.inference`` with ``inference="profile"``, the
    flags ``--profile-*``; the arguments of :class:`Profile`).

    Args:
        proposals: perturbed angle sets per model, experiment and generation, >= 1.
        initial: random angle sets per model for a new experiment, >= 1.
        refine: extra perturbation rounds of each contender, >= 0 (0 = off).
        contenders: new models refined per generation, >= 1.
        library: angle sets per experiment every contender tries first, >= 0 (0 = off).

    Raises:
        ValueError: naming the field as ``EEAConfig.profile_<field>`` if one is out of range.
    """

    #: The strategy's registry name (:data:`eea.inference.INFERENCE_STRATEGIES`).
    name: ClassVar[str] = "profile"

    proposals: int = 2
    initial: int = 8
    refine: int = 0
    contenders: int = 3
    library: int = 0

    def __post_init__(self) -> None:
        for name, low in (("proposals", 1), ("initial", 1), ("refine", 0), ("contenders", 1), ("library", 0)):
            check_int(f"EEAConfig.profile_{name}", getattr(self, name), low)


class Profile(InferenceStrategy):
    """Per-model initial angles, profiled out of MOD_FIT (see the module docstring).

    Args:
        proposals: perturbed angle sets tried per model, experiment and generation (>= 1).
        initial: random angle sets tried per model for a new experiment (>= 1).
        refine: extra perturbation rounds for each contender (>= 0; 0 = off).
        contenders: new models refined per generation, the fittest first (>= 1).
        library: L >= 0, angle sets per experiment every contender tries before its
            refinement (0: off; needs ``refine`` > 0 to matter).

    Raises:
        ValueError: if ``proposals``, ``initial`` or ``contenders`` is < 1, or ``refine`` or
            ``library`` < 0.
    """

    name = "profile"

    def __init__(self, proposals: int = 2, initial: int = 8, refine: int = 0, contenders: int = 3,
                 library: int = 0) -> None:
        if proposals < 1 or initial < 1 or contenders < 1 or refine < 0:
            raise ValueError(f"Profile needs proposals >= 1, initial >= 1, refine >= 0 and contenders >= 1, "
                             f"got {proposals}, {initial}, {refine}, {contenders}")
        self.library = check_int("Profile library", library, 0)
        self._library: list[tuple[np.ndarray, np.ndarray]] = []        # per experiment: (L_e, 3) angles, (L_e,) sims
        self.proposals, self.initial = int(proposals), int(initial)
        self.refine, self.contenders = int(refine), int(contenders)
        self._memory: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}  # genome -> ((E, 3) angles, (E,) sims)
        self._best: bytes | None = None                                 # the best genome of the last generation

    @classmethod
    def from_settings(cls, settings: ProfileSettings, ga=None) -> "Profile":
        """Built from its :class:`ProfileSettings` (``config.inference``).

        Args:
            settings: the strategy's settings.
            ga: unused (the profile's angle fit is no GA).
        """
        return cls(**dataclasses.asdict(settings))

    def new_context(self, true_angles):
        return Context.exact(np.zeros(3))  # replaced by the best model's angles after each generation

    # -- memory ---------------------------------------------------------------------------
    def _recall(self, genomes: np.ndarray, n_experiments: int, rng: np.random.Generator):
        """Remembered (or inherited) angles ``(U, E, 3)``, their similarities ``(U, E)`` (NaN:
        not evaluated for this model) and which entries have no angles at all ``(U, E)``."""
        angles = np.empty((len(genomes), n_experiments, 3))
        sims = np.full((len(genomes), n_experiments), np.nan)
        fresh = np.zeros((len(genomes), n_experiments), dtype=bool)
        known = list(self._memory)
        parents = genomes_from_keys(known, len(known[0])) if known else None  # 45 bits, 57 with servo gains
        for u, key in enumerate(genome_keys(genomes)):
            entry = self._memory.get(key)
            if entry is None and parents is not None:  # the nearest model of the last generation
                nearest = int(np.argmin((parents != genomes[u]).sum(axis=1)))
                entry = self._memory[known[nearest]]
                entry = (entry[0], np.full(len(entry[1]), np.nan))  # its angles, not its scores
            m = 0 if entry is None else len(entry[1])
            if m:
                angles[u, :m], sims[u, :m] = entry[0][:n_experiments], entry[1][:n_experiments]
            if m < n_experiments:
                angles[u, m:] = random_angles(rng, n_experiments - m)
                fresh[u, m:] = True
        return angles, sims, fresh

    def _recall_scored(self, genomes: np.ndarray, experiments, evaluator, rng: np.random.Generator):
        """:meth:`_recall`'s angles ``(U, E, 3)`` and similarities ``(U, E)``, every entry scored:
        inherited angles as they are, and the best of ``initial`` random starts where a model
        has none for an experiment."""
        angles, sims, fresh = self._recall(genomes, len(experiments), rng)
        if np.isnan(sims).any():
            starts = np.repeat(angles[None], self.initial if fresh.any() else 1, axis=0)
            if fresh.any():
                starts[:, fresh] = random_angles(rng, self.initial * int(fresh.sum())).reshape(self.initial, -1, 3)
            self._try(starts, genomes, angles, sims, experiments, evaluator)
        return angles, sims

    def _perturb(self, angles: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """One perturbed copy of ``(U, E, 3)`` angles (a quarter of the entries redrawn at random)."""
        u, e = angles.shape[:2]
        steps = _STEPS_RAD[rng.integers(0, len(_STEPS_RAD), size=(u, e))]            # (U, E, 2)
        moved = rng.random((u, e, 3)) < 0.5                                             # each flipper: 1 in 2
        moved[np.arange(u)[:, None], np.arange(e), rng.integers(0, 3, (u, e))] = True   # at least one
        out = angles + rng.standard_normal((u, e, 3)) * steps[..., [0, 0, 1]] * moved
        _into_range(out)
        redraw = rng.random((u, e)) < _RANDOM_SHARE
        out[redraw] = random_angles(rng, int(redraw.sum()))
        return out

    def _try(self, candidates: np.ndarray, genomes: np.ndarray, angles: np.ndarray, sims: np.ndarray,
             experiments, evaluator) -> None:
        """Evaluate ``(C, U, E, 3)`` candidates; keep, per model and experiment, the best (in place)."""
        c, u, e = candidates.shape[:3]
        scores = evaluator.similarities(np.tile(genomes, (c, 1)), experiments,
                                        candidates.reshape(c * u, e, 3)).reshape(c, u, e)
        scores = np.concatenate([np.where(np.isnan(sims), -np.inf, sims)[None], scores])
        if self.library:
            self._add_to_library(candidates, scores[1:])
        best = np.argmax(scores, axis=0)                                                # (U, E); 0 = keep
        everything = np.concatenate([angles[None], candidates])
        angles[:] = np.take_along_axis(everything, best[None, :, :, None], axis=0)[0]
        sims[:] = np.take_along_axis(scores, best[None], axis=0)[0]

    # -- hooks ----------------------------------------------------------------------------
    def before_generation(self, generation, ranked_genomes, experiments, evaluator, rng, genomes=None):
        if genomes is None or not len(experiments):
            return experiments
        distinct = np.unique(np.asarray(genomes, dtype=np.uint8), axis=0)
        n_exp = len(experiments)
        keys = genome_keys(distinct)
        new = np.array([key not in self._memory for key in keys])
        angles, sims = self._recall_scored(distinct, experiments, evaluator, rng)
        candidates = [self._perturb(angles, rng) for _ in range(self.proposals)]
        if self._best is not None and self._best in self._memory:
            shared = self._memory[self._best][0]
            if len(shared) == n_exp:
                candidates.append(np.broadcast_to(shared, angles.shape))
        self._try(np.stack(candidates), distinct, angles, sims, experiments, evaluator)
        if self.refine and new.any():
            self._refine(np.flatnonzero(new), distinct, angles, sims, experiments, evaluator, rng)
        self._memory = {key: (angles[u].copy(), sims[u].copy()) for u, key in enumerate(keys)}
        return experiments

    def _add_to_library(self, candidates: np.ndarray, scores: np.ndarray) -> None:
        """Merge ``(C, U, E, 3)`` scored candidates into every experiment's library: the
        ``library`` best-scoring sets, each at least :data:`LIBRARY_SPACING_RAD` from every
        better one."""
        while len(self._library) < candidates.shape[2]:
            self._library.append((np.empty((0, 3)), np.empty(0)))
        for e in range(candidates.shape[2]):
            old_angles, old_sims = self._library[e]
            pool = np.concatenate([old_angles, candidates[:, :, e].reshape(-1, 3)])
            pool_sims = np.concatenate([old_sims, scores[:, :, e].ravel()])
            order = np.argsort(-pool_sims, kind="stable")
            pool, pool_sims = pool[order], pool_sims[order]
            keep: list[int] = []
            for i in range(len(pool)):
                if len(keep) == self.library:
                    break
                if not keep or _angle_distance(pool[keep], pool[i]).min() >= LIBRARY_SPACING_RAD:
                    keep.append(i)
            self._library[e] = (pool[keep], pool_sims[keep])

    def _library_ready(self, n_experiments: int) -> bool:
        """Whether every one of ``n_experiments`` experiments has at least one library set."""
        return bool(self.library) and len(self._library) >= n_experiments \
            and all(len(self._library[e][1]) for e in range(n_experiments))

    def _library_candidates(self, n_models: int, n_experiments: int, count: int) -> np.ndarray:
        """``(count, n_models, E, 3)``: candidate l holds library set l of every experiment (the
        best set where an experiment has fewer than ``count``)."""
        out = np.empty((count, n_models, n_experiments, 3))
        for e in range(n_experiments):
            sets = self._library[e][0]
            rows = np.minimum(np.arange(count), len(sets) - 1)
            out[:, :, e] = sets[rows][:, None]
        return out

    def _refine(self, rows: np.ndarray, genomes, angles, sims, experiments, evaluator, rng) -> None:
        """``refine`` more perturbation rounds for the ``contenders`` fittest distinct models of
        ``rows``, after a try of every library set (in place)."""
        fitness = model_fitness_from_similarities(sims[rows])
        top = rows[diverse_indices(genomes[rows], fitness, self.contenders, 0.0)]
        a, s = angles[top], sims[top]
        self._fit_hard(genomes[top], a, s, experiments, evaluator, rng, self.refine)
        angles[top], sims[top] = a, s

    def scan_angles(self, genomes, angles, sims, experiments, evaluator, cycles: int) -> None:
        """Per-flipper scan of every model's angles (module docstring), ``cycles`` times.

        For each flipper in turn, every experiment's angle of that flipper is set to each of
        :data:`SCAN_PECTORAL` values 15 deg apart (caudal: :data:`SCAN_CAUDAL` values across the
        sweep) with the other two kept, and each model and experiment keeps the best. Costs
        ``cycles (2 SCAN_PECTORAL + SCAN_CAUDAL) U E`` simulations at most (cached sets are free).

        Args:
            genomes: ``(U, 45)`` model genomes.
            angles: ``(U, E, 3)`` starting angles (rad), replaced by the best found.
            sims: ``(U, E)`` their similarities (NaN: not scored yet), replaced too.
            experiments: the E target experiments.
            evaluator: an :class:`eea.evaluation.Evaluator` (or anything with its ``similarities``).
            cycles: scans of all three flippers, >= 0.

        Raises:
            ValueError: if the shapes disagree or ``cycles`` < 0.
        """
        check_int("scan_angles cycles", cycles, 0)
        _check_fit_arrays("scan_angles", genomes, angles, sims, experiments)
        values = (np.linspace(0.0, TWO_PI, SCAN_PECTORAL, endpoint=False),) * 2 \
            + (np.linspace(-CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD, SCAN_CAUDAL),)
        for _ in range(cycles):
            for flipper, grid in enumerate(values):
                candidates = np.repeat(angles[None], len(grid), axis=0)
                candidates[..., flipper] = grid[:, None, None]
                self._try(candidates, genomes, angles, sims, experiments, evaluator)

    def polish_angles(self, genomes, angles, sims, experiments, evaluator) -> None:
        """Compass search of every model's angles, experiment by experiment (module docstring).

        For each step pair of :data:`POLISH_STEPS_RAD` (pectorals, caudal fin), up to
        :data:`POLISH_ITERATIONS` times: the 6 moves of one angle by +-step are tried for every
        model and experiment at once, each entry keeps its best if it scores higher, and the
        step is halved when no entry improved or after the last iteration. Pectoral angles wrap round the circle, the caudal
        angle is clipped to the sweep. Costs at most ``6 U E`` simulations per iteration.

        Args:
            genomes: ``(U, 45)`` model genomes.
            angles: ``(U, E, 3)`` starting angles (rad), replaced by the polished ones.
            sims: ``(U, E)`` their similarities (eq. 2; NaN: not scored yet), replaced too.
            experiments: the E target experiments.
            evaluator: an :class:`eea.evaluation.Evaluator` (or anything with its
                ``similarities``).

        Raises:
            ValueError: if ``angles`` is not ``(U, E, 3)`` or ``sims`` not ``(U, E)``.
        """
        _check_fit_arrays("polish_angles", genomes, angles, sims, experiments)
        moves = np.zeros((6, 3))
        moves[np.arange(6), np.repeat(np.arange(3), 2)] = np.tile([1.0, -1.0], 3)
        for pectoral, caudal in POLISH_STEPS_RAD:
            for _ in range(POLISH_ITERATIONS):
                before = np.where(np.isnan(sims), -np.inf, sims)
                candidates = angles[None] + (moves * [pectoral, pectoral, caudal])[:, None, None, :]
                _into_range(candidates)
                self._try(candidates, genomes, angles, sims, experiments, evaluator)
                if not np.any(sims > before):
                    break

    def _fit_hard(self, genomes, angles, sims, experiments, evaluator, rng, rounds: int) -> None:
        """Every library set of every experiment (once the library covers them all), then
        ``rounds`` rounds of ``proposals`` perturbations, for ``(U, 45)`` genomes' ``(U, E, 3)``
        angles and ``(U, E)`` similarities (in place)."""
        if self._library_ready(len(experiments)):
            self._try(self._library_candidates(len(genomes), len(experiments), self.library), genomes, angles, sims,
                      experiments, evaluator)
        for _ in range(rounds):
            self._try(np.stack([self._perturb(angles, rng) for _ in range(self.proposals)]), genomes, angles, sims,
                      experiments, evaluator)

    def library_sets(self, experiment: int) -> tuple[np.ndarray, np.ndarray]:
        """Experiment ``experiment``'s angle library: ``(L_e, 3)`` angles (rad), best first, and
        ``(L_e,)`` the similarity each scored (L_e = 0 before any was scored or with ``library`` 0)."""
        if experiment >= len(self._library):
            return np.empty((0, 3)), np.empty(0)
        return self._library[experiment][0].copy(), self._library[experiment][1].copy()

    def starting_angles(self, genomes, n_experiments: int, rng: np.random.Generator) -> np.ndarray:
        """The angles models would start from if the search proposed them now, before any fit.

        A remembered model's own angles; any other model's are those of the nearest
        remembered model (in Hamming distance), as in :meth:`before_generation`; random angles for experiments
        nobody has angles for yet. :mod:`eea.analysis.diagnosis` scores the truth under them: what it
        would be judged by the moment the search proposed it.

        Args:
            genomes: ``(P, 45)`` model genomes.
            n_experiments: E >= 0, the number of experiments.
            rng: draws the random angles.

        Returns:
            ``(P, E, 3)`` angles (rad).
        """
        return self._recall(np.atleast_2d(np.asarray(genomes, dtype=np.uint8)), int(n_experiments), rng)[0]

    def angles(self, experiments: Experiments, genomes: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Each model's remembered angles ``(P, E, 3)`` (the contexts' for a model not profiled yet)."""
        remembered = self.remembered_angles(genomes, len(experiments))
        return super().angles(experiments, genomes, rng) if remembered is None else remembered

    def remembered_angles(self, genomes, n_experiments: int) -> np.ndarray | None:
        """The angles remembered for each of ``(N, n_bits)`` genomes on all ``n_experiments``
        experiments, ``(N, E, 3)`` (rad), or None when any of them has none for some experiment
        (a model never profiled, or not since the newest experiment)."""
        rows = [self._memory.get(key) for key in genome_keys(np.asarray(genomes, dtype=np.uint8))]
        if any(r is None or len(r[1]) != n_experiments for r in rows):
            return None
        return np.stack([r[0] for r in rows])

    def after_generation(self, genomes, angles, fitness, experiments):
        best = int(np.argmax(fitness))
        self._best = genome_keys(genomes[best : best + 1])[0]
        return tuple(e.with_context(Context.exact(angles[best, i])) for i, e in enumerate(experiments))

    # -- a fit on its own -----------------------------------------------------------------
    def fit(self, genomes, experiments: Experiments, evaluator, rng: np.random.Generator, generations: int,
            start=None) -> tuple[np.ndarray, np.ndarray]:
        """Fit every model's own initial angles, equally hard for all, outside any EEA run.

        Forgets what was remembered and runs ``generations`` generations of the per-model
        search described in the module docstring, without the shared best-model candidate
        and without contender refinement:
        the first tries ``initial`` random angle sets per model and experiment (and then
        ``start``, if given). Used by :mod:`eea.analysis.diagnosis` and
        ``docs/studies/probes/angle_identifiability.py``. Costs about
        ``P E (initial + 1 + generations proposals)`` simulations.

        Args:
            genomes: ``(P, 45)`` distinct model genomes.
            experiments: the target experiments (E >= 1).
            evaluator: an :class:`eea.evaluation.Evaluator` of the experiments' length.
            rng: draws the random starts and perturbations.
            generations: search generations, >= 1.
            start: optional ``(P, E, 3)`` angles (rad) tried beside the random starts, or
                ``(S, P, E, 3)``: S such sets.

        Returns:
            ``(angles, fitness)``: ``(P, E, 3)`` each model's best angles (rad) and ``(P,)``
            its MOD_FIT (eq. 3) under them.

        Raises:
            ValueError: if ``experiments`` is empty, the genomes repeat or
                ``generations < 1``.
        """
        genomes = np.asarray(genomes, dtype=np.uint8)
        if not len(experiments):
            raise ValueError("Profile.fit needs at least one experiment")
        if len(np.unique(genomes, axis=0)) != len(genomes):
            raise ValueError("Profile.fit needs distinct genomes")
        if generations < 1:
            raise ValueError(f"generations must be >= 1, got {generations}")
        self._memory, self._best, self._library = {}, None, []
        keys = genome_keys(genomes)
        # every model fitted as hard: no contenders
        refine, self.refine = self.refine, 0
        try:
            for generation in range(generations):
                self.before_generation(generation, genomes, experiments, evaluator, rng, genomes=genomes)
                if generation == 0 and start is not None:
                    angles = np.stack([self._memory[k][0] for k in keys])
                    sims = np.stack([self._memory[k][1] for k in keys])
                    sets = np.asarray(start, dtype=np.float64)
                    self._try(sets[None] if sets.ndim == 3 else sets, genomes, angles, sims, experiments, evaluator)
                    self._memory = {key: (angles[u], sims[u]) for u, key in enumerate(keys)}
        finally:
            self.refine = refine
        angles = np.stack([self._memory[k][0] for k in keys])
        return angles, model_fitness_from_similarities(np.stack([self._memory[k][1] for k in keys]))

    # -- checkpoint -----------------------------------------------------------------------
    def state_dict(self) -> dict:
        """The memory (genome bytes -> angles, similarities), the last best genome and the angle
        library."""
        return {"memory": {k: (a.copy(), s.copy()) for k, (a, s) in self._memory.items()}, "best": self._best,
                "library": [(a.copy(), s.copy()) for a, s in self._library]}

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict` (an empty dict: nothing remembered yet).

        Raises:
            ValueError: on unknown keys.
        """
        unknown = set(state) - {"memory", "best", "library"}
        if unknown:
            raise ValueError(f"profile inference state has unknown keys {sorted(unknown)}")
        self._memory = {k: (np.asarray(a), np.asarray(s)) for k, (a, s) in state.get("memory", {}).items()}
        self._best = state.get("best")
        self._library = [(np.asarray(a), np.asarray(s)) for a, s in state.get("library", [])]


def _into_range(angles: np.ndarray) -> None:
    """Wrap ``(..., 3)`` angles' pectorals into [0, 2 pi) and clip the caudal fin's to its sweep (in place)."""
    angles[..., :2] = np.mod(angles[..., :2], TWO_PI)
    angles[..., 2] = np.clip(angles[..., 2], -CAUDAL_LIMIT_RAD, CAUDAL_LIMIT_RAD)


def _check_fit_arrays(what: str, genomes, angles, sims, experiments) -> None:
    """Raise ``ValueError`` unless ``angles`` is ``(U, E, 3)`` and ``sims`` ``(U, E)`` for U genomes, E experiments."""
    u, e = len(genomes), len(experiments)
    if np.shape(angles) != (u, e, 3) or np.shape(sims) != (u, e):
        raise ValueError(f"{what} needs angles ({u}, {e}, 3) and sims ({u}, {e}), "
                         f"got {np.shape(angles)} and {np.shape(sims)}")


def _angle_distance(sets: np.ndarray, one: np.ndarray) -> np.ndarray:
    """``(n,)`` distance (rad) of ``(n, 3)`` angle sets to one ``(3,)``: the largest flipper
    difference, pectorals on the circle, the caudal difference times 3."""
    d = np.abs(sets - one)
    d[:, :2] = np.minimum(d[:, :2], TWO_PI - d[:, :2])
    d[:, 2] *= _CAUDAL_WEIGHT
    return d.max(axis=1)
