"""The interface every context inference strategy implements (paper 3.3, 3.4, 4).

The target's initial angles are unknown (its servos have no position feedback). A
strategy decides, for every (model, experiment) simulation of the estimation phase, the
initial angles, and may refine each experiment's :class:`~eea.experiment.Context`.
Strategies are chosen by name (:data:`eea.inference.INFERENCE_STRATEGIES`).

Hook order within one estimation phase (:class:`eea.estimation.Estimation`)::

    experiments = begin_round(experiments)
    for generation in range(G):
        genomes = search.ask()
        experiments = before_generation(generation, ranked_genomes, experiments, evaluator, rng,
                                        genomes=genomes)
        angles = angles(experiments, genomes, rng)   # (P, E, 3), then fitness, then
        experiments = after_generation(genomes, angles, fitness, experiments)
    experiments = end_round(experiments)

Experiments are immutable: a hook that refines a context returns new experiments
(:meth:`Experiment.with_context`) and the estimation phase passes them on. The paper's
strategies keep no state of their own (everything they infer lives in the contexts, which
the run checkpoints); a strategy that does returns it from :meth:`InferenceStrategy.state_dict`
and the run checkpoints that too.
"""

from __future__ import annotations

from typing import ClassVar, Sequence

import numpy as np

from eea.experiment import Context, Experiment

__all__ = ["Experiments", "InferenceStrategy"]

#: What every hook takes and returns: the run's experiments, oldest first.
Experiments = Sequence[Experiment]


class InferenceStrategy:
    """Interface of a context inference strategy; the base class's hooks return the experiments unchanged."""

    name: ClassVar[str] = ""

    @classmethod
    def from_settings(cls, settings, ga=None) -> "InferenceStrategy":
        """Build from the strategy's settings (``config.inference`` of an
        :class:`eea.config.EEAConfig`; subclasses read their fields).

        Args:
            settings: the strategy's settings (one of :data:`eea.inference.INFERENCE_SETTINGS`).
            ga: the run's :class:`eea.ga.GASettings` (a strategy with a GA of its own breeds
                with it; None: the defaults).
        """
        return cls()

    def new_context(self, true_angles: np.ndarray) -> Context:
        """Context of a freshly performed experiment whose true angles are ``(3,)`` rad."""
        raise NotImplementedError

    def begin_round(self, experiments: Experiments) -> Experiments:
        """Called once before the estimation generations of a round; returns the experiments to use."""
        return experiments

    def angles(self, experiments: Experiments, genomes: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Initial angles of every model in every experiment (the paper's PERFORM()).

        Args:
            experiments: the E experiments.
            genomes: ``(P, 45)`` the models about to be evaluated (the base class uses only P).
            rng: the run's generator.

        Returns:
            ``(P, E, 3)`` radians, experiment e's column drawn by :meth:`Context.sample`
            of its context.
        """
        n_models = len(genomes)
        if not experiments:
            return np.zeros((n_models, 0, 3))
        return np.stack([exp.context.sample(rng, n_models) for exp in experiments], axis=1)

    def before_generation(self, generation: int, ranked_genomes: np.ndarray, experiments: Experiments,
                          evaluator, rng: np.random.Generator, genomes: np.ndarray | None = None) -> Experiments:
        """Called before estimation generation ``generation`` (0-based) is evaluated.

        Args:
            ranked_genomes: ``(R, 45)`` distinct model genomes, best first by their last
                fitness (population order before any fitness is known).
            genomes: ``(P, 45)`` the generation about to be evaluated (None: not known).

        Returns:
            The experiments the generation is evaluated on.
        """
        return experiments

    def after_generation(self, genomes: np.ndarray, angles: np.ndarray, fitness: np.ndarray,
                         experiments: Experiments) -> Experiments:
        """Called with a generation's ``(P, 45)`` genomes, ``(P, E, 3)`` angles, ``(P,)`` fitness."""
        return experiments

    def end_round(self, experiments: Experiments) -> Experiments:
        """Called once after the estimation generations of a round; returns the final experiments."""
        return experiments

    def state_dict(self) -> dict:
        """What the strategy remembers between generations beyond the contexts (checkpointed
        with the run; ``{}`` for the paper's strategies, which keep nothing)."""
        return {}

    def load_state_dict(self, state: dict) -> None:
        """Restore :meth:`state_dict` (the paper's strategies: nothing to restore).

        Raises:
            ValueError: if ``state`` is not empty (a stateless strategy was given state).
        """
        if state:
            raise ValueError(f"inference {self.name!r} keeps no state, got keys {sorted(state)}")
