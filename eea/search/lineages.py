"""Independent estimation lineages that share each round's experiment (not the paper's).

Under unknown initial angles a run of the EEA settles early in one basin of MOD_FIT and the
basin decides where it ends (docs/studies.md, "Two estimation lineages: where it stands").
Here one run keeps N independent estimations ("lineages"), each with its own model search
and its own inference strategy (its own remembered angles, library and contexts), started
from its own random population. Every round:

* **exploration** evolves the action that splits the union of the lineages' candidate
  models (eq. 1 over :meth:`Lineages.ranked_models`: the lineages' candidates interleaved,
  best first), so the experiment is chosen to tell the lineages' hypotheses apart;
* **target**: one experiment, as in the paper;
* **estimation**: every lineage runs its estimation phase on all experiments
  (:meth:`eea.estimation.Estimation.run`), independently of the others;
* **selection**: the lineages' best models get their own initial angles fitted equally hard
  on all experiments (:func:`eea.inference.selection.select_model`: :meth:`eea.inference.profile.Profile.fit`
  from random starts and each lineage's own angles, then a per-flipper scan and a compass
  polish), and the highest MOD_FIT (eq. 3) is the round's self-model. No oracle is used.
  The lineages do not adopt it: each keeps its own search, so a lineage in a wrong basin
  cannot drag the others into it.

Cost per round: N times the estimation's simulations; the exploration's as before (its
candidate models are capped by ``exploration_models``); plus the selection's, about
``250 N E`` simulations for E experiments (some 3% of a 10-round run with N = 2).

A run with lineages also writes ``lineages.csv`` beside ``rounds.csv`` (:func:`write_lineages`,
columns :data:`LINEAGE_COLUMNS`): every lineage's best model of every round, its own MOD_FIT,
its MOD_FIT under the round's equal fit and whether it was chosen.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

from eea.encoding import model_space_of
from eea.estimation import Estimation, EstimationResult, distinct_ranked
from eea.experiment import Context, Experiment
from eea.inference import InferenceStrategy, make_inference
from eea.inference.selection import select_model

__all__ = ["LineageStrategies", "Lineages", "SELECT_GENERATIONS", "SELECT_SCAN_CYCLES", "chosen_inference_state",
           "estimation_from_state", "make_estimation", "make_strategy", "warm_start"]

#: The round's selection: generations of the equal angle fit and cycles of the per-flipper
#: scan before the polish (:func:`eea.inference.selection.select_model`).
SELECT_GENERATIONS, SELECT_SCAN_CYCLES = 30, 2

class LineageStrategies:
    """One inference strategy per lineage, checkpointed together.

    Only the run-level part of :class:`~eea.inference.InferenceStrategy` is implemented:
    :meth:`new_context` (the same for every lineage's strategy of one name),
    :meth:`state_dict` and :meth:`load_state_dict`; the estimation hooks are each
    lineage's own (:meth:`Lineages.run` hands lineage i ``members[i]``).

    Args:
        members: N >= 2 strategies of one name.

    Raises:
        ValueError: if fewer than two strategies are given or their names differ.
    """

    def __init__(self, members: Sequence[InferenceStrategy]) -> None:
        members = tuple(members)
        if len(members) < 2:
            raise ValueError(f"LineageStrategies needs at least 2 strategies, got {len(members)}")
        names = {m.name for m in members}
        if len(names) != 1:
            raise ValueError(f"the lineages' strategies must share one name, got {sorted(names)}")
        self.members = members
        self.name = members[0].name

    def new_context(self, true_angles: np.ndarray) -> Context:
        """Context of a freshly performed experiment (the first member's; all agree)."""
        return self.members[0].new_context(true_angles)

    def state_dict(self) -> dict:
        """``{"lineages": [each member's state_dict()]}``."""
        return {"lineages": [m.state_dict() for m in self.members]}

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict` (an empty dict: nothing remembered yet).

        Raises:
            ValueError: on unknown keys or a state of another number of lineages.
        """
        if not state:
            return
        if set(state) != {"lineages"} or len(state["lineages"]) != len(self.members):
            raise ValueError(f"lineage strategies' state must be {{'lineages': [{len(self.members)} states]}}, "
                             f"got keys {sorted(state)} with {len(state.get('lineages', ()))} states")
        for member, member_state in zip(self.members, state["lineages"]):
            member.load_state_dict(member_state)


class Lineages:
    """N independent estimation phases sharing the run's experiments, selected each round.

    Has the interface :func:`eea.round.run_round` uses of an
    :class:`~eea.estimation.Estimation` (:meth:`run`, :meth:`ranked_models`,
    :meth:`state_dict`); see the module docstring.

    Args:
        members: N >= 2 :class:`~eea.estimation.Estimation` phases.
        select_generations: generations of the selection's angle fit, >= 1.
        select_scan_cycles: cycles of its per-flipper angle scan, >= 0.

    Attributes:
        history: one dict per finished round: ``model_fitness`` ``(N,)`` each lineage's own
            MOD_FIT, ``selection_fitness`` ``(N,)`` its MOD_FIT under the equal fit,
            ``genomes`` ``(N, 45)`` the lineages' best models, ``chosen`` the selected row.

    Raises:
        ValueError: if fewer than two members are given.
    """

    def __init__(self, members: Sequence[Estimation], select_generations: int = SELECT_GENERATIONS,
                 select_scan_cycles: int = SELECT_SCAN_CYCLES) -> None:
        members = tuple(members)
        if len(members) < 2:
            raise ValueError(f"Lineages needs at least 2 estimations, got {len(members)}")
        if select_generations < 1 or select_scan_cycles < 0:
            raise ValueError(f"Lineages needs select_generations >= 1 and select_scan_cycles >= 0, "
                             f"got {select_generations} and {select_scan_cycles}")
        self.members = members
        self.select_generations, self.select_scan_cycles = int(select_generations), int(select_scan_cycles)
        self._experiments: list[tuple[Experiment, ...]] = [() for _ in members]  # each lineage's contexts
        self.history: list[dict] = []

    @classmethod
    def from_settings(cls, settings, ga, model_space, rng: np.random.Generator) -> "Lineages":
        """``settings.lineages`` fresh estimations (:meth:`Estimation.from_settings`), each with
        its own random initial population drawn from ``rng`` in turn.

        Args:
            settings: the estimation's :class:`eea.estimation.EstimationSettings` (``config.estimation``).
            ga: the run's :class:`eea.ga.GASettings`.
            model_space: the run's model space.
            rng: the run's generator.

        Raises:
            ValueError: if ``settings.lineages`` < 2.
        """
        return cls([Estimation.from_settings(settings, ga, model_space, rng) for _ in range(settings.lineages)])

    def run(self, experiments: Sequence[Experiment], strategy: LineageStrategies, evaluator,
            rng: np.random.Generator, generations: int,
            on_generation: Callable[[int, float], None] | None = None) -> EstimationResult:
        """Every lineage's estimation phase, then the round's selection.

        Args:
            experiments: the E >= 1 recorded experiments, newest last; the ones a lineage has
                not seen yet (the newest) join its own experiments with their fresh contexts.
            strategy: the lineages' :class:`LineageStrategies` (member i serves lineage i).
            evaluator: as :meth:`Estimation.run`.
            rng: as :meth:`Estimation.run`.
            generations: as :meth:`Estimation.run`.
            on_generation: as :meth:`Estimation.run`; called for every lineage's generations
                in turn.

        Returns:
            The :class:`~eea.estimation.EstimationResult` of the selected model: the
            experiments with its equally fitted angles as exact contexts, its genome and its
            MOD_FIT under those angles.

        Raises:
            ValueError: if there are no experiments, fewer than a lineage has already seen,
                ``generations < 1``, or ``strategy`` has another number of lineages.
        """
        experiments = tuple(experiments)
        if not experiments:
            raise ValueError("estimation needs at least one experiment")
        if len(getattr(strategy, "members", ())) != len(self.members):
            raise ValueError(f"{len(self.members)} lineages need LineageStrategies of as many strategies, got {strategy!r}")
        seen = len(self._experiments[0])
        if len(experiments) < seen:
            raise ValueError(f"the lineages have seen {seen} experiments, got only {len(experiments)}")
        new = experiments[seen:]
        best = []
        for i, (member, member_strategy) in enumerate(zip(self.members, strategy.members)):
            result = member.run((*self._experiments[i], *new), member_strategy, evaluator, rng, generations,
                                on_generation)
            self._experiments[i] = result.experiments
            best.append((result.best_genome, result.best_fitness))
        genomes = np.stack([g for g, _ in best])
        start = np.stack([[e.context.estimate() for e in exps] for exps in self._experiments])  # (N, E, 3)
        space = model_space_of(genomes.shape[1])
        selection = select_model(space.decode(genomes), experiments, evaluator, rng,
                                 generations=self.select_generations, scan_cycles=self.select_scan_cycles,
                                 start=start, model_space=space)
        chosen = selection.index
        self.history.append({"model_fitness": np.array([f for _, f in best]),
                             "selection_fitness": selection.model_fitness.copy(), "genomes": genomes.copy(),
                             "chosen": int(chosen)})
        fitted = tuple(e.with_context(Context.exact(selection.angles[chosen, k])) for k, e in enumerate(experiments))
        return EstimationResult(fitted, genomes[chosen], float(selection.model_fitness[chosen]))

    def ranked_models(self, limit: int | None = None, min_distance: float = 0.0) -> np.ndarray:
        """The lineages' candidate models for the exploration, interleaved, at most ``limit``.

        Each lineage's :meth:`Estimation.ranked_models` ``(limit, min_distance)``, taken in
        turn (every lineage's best first, then every lineage's second, ...), a model given by
        two lineages kept once.

        Returns:
            ``(R, 45)`` uint8.

        Raises:
            ValueError: as :meth:`Estimation.ranked_models`.
        """
        per_lineage = [m.ranked_models(limit, min_distance) for m in self.members]
        interleaved = [ranked[k] for k in range(max(map(len, per_lineage))) for ranked in per_lineage if k < len(ranked)]
        ranked = distinct_ranked(np.stack(interleaved), None)  # first occurrence kept, order unchanged
        return ranked if limit is None else ranked[:limit]

    def state_dict(self) -> dict:
        """Every lineage's :meth:`Estimation.state_dict`, its experiments (with its own
        contexts) and the selection history, for the run checkpoint."""
        return {"lineages": [m.state_dict() for m in self.members],
                "experiments": [[e.state_dict() for e in exps] for exps in self._experiments],
                "history": [dict(h) for h in self.history],
                "select": (self.select_generations, self.select_scan_cycles)}

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator) -> "Lineages":
        """Rebuild from :meth:`state_dict`, drawing from ``rng`` from now on.

        Raises:
            ValueError: on an invalid state.
        """
        lineages = cls([Estimation.from_state_dict(s, rng) for s in state["lineages"]], *state["select"])
        lineages._experiments = [tuple(Experiment.from_state_dict(e) for e in exps) for exps in state["experiments"]]
        lineages.history = [dict(h) for h in state["history"]]
        return lineages


def make_estimation(settings, ga, model_space, rng: np.random.Generator) -> Estimation | Lineages:
    """The estimation phase of a run: one :class:`Estimation` (the paper's), or
    :class:`Lineages` of ``settings.lineages`` of them when that is >= 2.

    Args:
        settings: the run's :class:`eea.estimation.EstimationSettings` (``config.estimation``).
        ga: the run's :class:`eea.ga.GASettings` (``config.ga``).
        model_space: the run's model space (``config.model_space``).
        rng: the run's generator (the initial populations).
    """
    if settings.lineages > 1:
        return Lineages.from_settings(settings, ga, model_space, rng)
    return Estimation.from_settings(settings, ga, model_space, rng)


def warm_start(estimation: Estimation | Lineages, genome) -> None:
    """Seed an estimation phase at a known model before its first round (a warm start).

    Every model search of the phase (each lineage's, with lineages) gets ``genome`` through
    its ``seed_at``: CMA-ES restarts its distribution at the model's point with the model
    injected (:meth:`eea.search.cma.CMAModelSearch.seed_at`), the GA puts it in its first
    population's first row (:meth:`eea.ga.BitGA.seed_at`). The first estimation generation
    of every lineage then holds the model, and the search starts around it. ``aquafish
    mission`` warm-starts the EEA after a damage at the self-model from before it.

    Args:
        estimation: a fresh :class:`~eea.estimation.Estimation` or :class:`Lineages`.
        genome: ``(n_bits,)`` a model genome of the phase's model space.

    Raises:
        ValueError: a search that cannot be seeded, or a genome of another length.
    """
    members = estimation.members if isinstance(estimation, Lineages) else (estimation,)
    for member in members:
        seed_at = getattr(member.search, "seed_at", None)
        if seed_at is None:
            raise ValueError(f"the {type(member.search).__name__} search cannot be warm-started (it has no seed_at)")
        seed_at(genome)


def make_strategy(settings, ga, lineages: int = 1) -> InferenceStrategy | LineageStrategies:
    """The inference strategy of a run (:func:`eea.inference.make_inference`), or one per
    lineage (:class:`LineageStrategies`) when ``lineages`` >= 2.

    Args:
        settings: the run's inference settings (``config.inference``, one of
            :data:`eea.inference.INFERENCE_SETTINGS`).
        ga: the run's :class:`eea.ga.GASettings` (out-of-band inference's inner GA).
        lineages: the run's estimation lineages (``config.estimation.lineages``).
    """
    if lineages > 1:
        return LineageStrategies([make_inference(settings, ga) for _ in range(lineages)])
    return make_inference(settings, ga)


def estimation_from_state(state: dict, rng: np.random.Generator) -> Estimation | Lineages:
    """Inverse of either phase's ``state_dict`` (a checkpoint's ``estimation``)."""
    if "lineages" in state:
        return Lineages.from_state_dict(state, rng)
    return Estimation.from_state_dict(state, rng)


def chosen_inference_state(estimation_state: dict, inference_state: dict) -> dict:
    """The inference state behind a checkpoint's final model.

    A plain run's ``inference_state`` as it is; of a :class:`Lineages` run, the state of the
    lineage the last round chose (its remembered angles are the ones its model was found
    with; :mod:`eea.analysis.diagnosis` uses them).

    Raises:
        ValueError: if a lineage run's checkpoint has no finished round.
    """
    if "lineages" not in estimation_state:
        return inference_state
    if not estimation_state["history"]:
        raise ValueError("the lineage run has no finished round, so no lineage was chosen yet")
    return inference_state["lineages"][estimation_state["history"][-1]["chosen"]]
