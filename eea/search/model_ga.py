"""The paper's estimation GA (section 4) as a model search: :class:`ModelGA`.

A :class:`eea.ga.BitGA` over model genomes (45 bits in the paper's ``morphology`` model space,
57 in ``morphology+servos``: :class:`eea.encoding.ModelSpace`), registered as ``ga`` in
:data:`eea.search.MODEL_SEARCHES`. The bit-string GA itself stays in the core
(:mod:`eea.ga`): the exploration phase and the out-of-band inference evolve with it too.
"""

from __future__ import annotations

import dataclasses
from typing import ClassVar

import numpy as np

from eea.encoding import MODEL_BITS, get_model_space, model_space_of
from eea.ga import BitGA

__all__ = ["GASearchSettings", "ModelGA"]


@dataclasses.dataclass(frozen=True)
class GASearchSettings:
    """The paper's GA search's settings (``config.estimation.search`` of an ``EEAConfig`` with
    ``estimation_search="ga"``, the default): none of its own. Its breeding settings are the
    run's shared :class:`eea.ga.GASettings` (``config.ga``)."""

    #: The search's registry name (:data:`eea.search.MODEL_SEARCHES`).
    name: ClassVar[str] = "ga"


class ModelGA(BitGA):
    """The paper's estimation GA: a :class:`~eea.ga.BitGA` over 45-bit model genomes (57-bit
    with ``model_space="morphology+servos"``, not the paper's).

    Its population carries over between rounds (``restart`` is a no-op).
    """

    name: ClassVar[str] = "ga"

    def __init__(self, population_size: int, rng: np.random.Generator, *, model_space="morphology",
                 **options) -> None:
        space = get_model_space(model_space)
        super().__init__(space.n_bits, population_size, rng, **options)
        #: The :class:`~eea.encoding.ModelSpace` of the genomes (saved with the state: two spaces
        #: have 45-bit genomes).
        self.model_space = space

    @classmethod
    def from_settings(cls, estimation, ga, model_space, rng: np.random.Generator) -> "ModelGA":
        """Sized by the estimation's settings (``config.estimation`` of an
        :class:`eea.config.EEAConfig`: its population) and tuned by the run's GA settings
        (``config.ga``: crossover, mutation ``mutation_bits / n_bits``, i.e. / 45 in the paper's
        space, tournament, elitism).

        Args:
            estimation: an :class:`eea.estimation.EstimationSettings` (its ``search`` a
                :class:`GASearchSettings`).
            ga: the run's :class:`eea.ga.GASettings`.
            model_space: the run's model space (a name or an :class:`eea.encoding.ModelSpace`).
            rng: the run's generator (the initial population).

        Raises:
            ValueError: if ``estimation.search`` is not a :class:`GASearchSettings`.
        """
        if not isinstance(estimation.search, GASearchSettings):
            raise ValueError(f"a GA search needs GASearchSettings, got {estimation.search!r}")
        space = get_model_space(model_space)
        return cls(estimation.population, rng, model_space=space, **ga.options(space.n_bits))

    def state_dict(self) -> dict:
        """:meth:`BitGA.state_dict` with ``"search": "ga"`` and the ``"model_space"`` name."""
        return {"search": self.name, "model_space": self.model_space.name, **super().state_dict()}

    @classmethod
    def _build(cls, n_bits: int, population_size: int, rng: np.random.Generator, **options) -> "ModelGA":
        try:
            space = model_space_of(n_bits)
        except ValueError:
            raise ValueError(f"a model GA evolves {MODEL_BITS}-bit genomes (57 with servo gains), "
                             f"the state has {n_bits} bits") from None
        return cls(population_size, rng, model_space=space, **options)

    @classmethod
    def from_state_dict(cls, state: dict, rng: np.random.Generator) -> "ModelGA":
        """Rebuild from :meth:`state_dict` (or a plain :meth:`BitGA.state_dict` of 45- or 57-bit genomes).

        Raises:
            ValueError: if the state is not a model GA's, or as :meth:`BitGA.from_state_dict`.
        """
        ga = super().from_state_dict({k: v for k, v in state.items() if k not in ("search", "model_space")}, rng)
        if "model_space" in state:                     # else a state saved before the name was kept: by width
            space = get_model_space(str(state["model_space"]))
            if space.n_bits != ga.n_bits:
                raise ValueError(f"a model GA state of {ga.n_bits}-bit genomes names the {space.name} model space "
                                 f"({space.n_bits} bits)")
            ga.model_space = space
        return ga
