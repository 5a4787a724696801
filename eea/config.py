"""Settings of one EEA run: :class:`EEAConfig`, with the paper's defaults (section 4).

Every field is also a command-line flag of ``aquafish eea`` (``--estimation-population``
for ``estimation_population``); :data:`FIELD_HELP` gives each one's help text. The config
is frozen and validated on construction, so a typo or an out-of-range value fails before
any simulation runs::

    config = EEAConfig(inference="in_band", rounds=10, seed=3)
    config.steps          # 128 (= duration_s / 0.01 s)

Named methods and budgets (:mod:`eea.methods`; ``--method`` and ``--budget`` on the command
line) spell out the settings the studies use (docs/studies.md), so a run is two names instead
of a dozen flags::

    EEAConfig.from_method("profile_lineages", "reduced", damage="caudal_half", seed=3)
"""

from __future__ import annotations

import dataclasses
import math
import os

from aquafish_gym import DT_S, SimParams, get_damage
from aquafish_gym.params import DEFAULT_WATERLINE
from aquafish_gym.checks import check_int
from eea.behaviour import SUMMARIES
from eea.compat import strip_retired
from eea.encoding import ACTION_BITS, MODEL_SPACES
from eea.exploration import ExplorationSettings
from eea.ga import GASettings
from eea.inference import INFERENCE_NAMES, InBandSettings, OutOfBandSettings, ProfileSettings
from eea.methods import budget_fields, method_fields
from eea.search import SEARCH_NAMES, CMASettings

__all__ = ["ESTIMATION_SEARCHES", "MODEL_SPACE_NAMES", "EEAConfig", "FIELD_HELP", "RESULT_NEUTRAL_FIELDS", "SECTIONS"]

#: Names of the estimation searches (:data:`eea.search.MODEL_SEARCHES`): the paper's
#: GA and CMA-ES (:mod:`eea.search.cma`).
ESTIMATION_SEARCHES: tuple[str, ...] = SEARCH_NAMES

#: The sections of :class:`EEAConfig`, each a frozen settings class next to its component's
#: code that validates its own fields (``config.ga`` is ``GASettings.from_config(config)``).
#: Each class's ``CONFIG_FIELDS`` maps its fields to the config's; the config's other fields
#: are the run's own (inference, damage, model space, summary, duration, rounds, seed, the
#: estimation's population, generations and search, lineages, workers, chunking, waterline).
SECTIONS: dict[str, type] = {"ga": GASettings, "cma": CMASettings, "in_band": InBandSettings,
                             "out_of_band": OutOfBandSettings, "profile": ProfileSettings,
                             "exploration": ExplorationSettings}

#: Names of the model spaces (:data:`eea.encoding.MODEL_SPACES`): the paper's flipper
#: dimensions, or those and one gain per servo (not the paper's).
MODEL_SPACE_NAMES: tuple[str, ...] = tuple(MODEL_SPACES)

#: Fields that never change a run's results (resuming with other values is allowed):
#: the number of worker processes and the chunk size of simulator calls, and ``rounds``,
#: the stopping criterion (a finished run can be extended to more rounds).
RESULT_NEUTRAL_FIELDS: tuple[str, ...] = ("workers", "max_batch_robots", "rounds")

#: One help line per field (command-line ``--help`` and documentation).
FIELD_HELP: dict[str, str] = {
    "inference": f"context inference strategy, one of {', '.join(INFERENCE_NAMES)} (paper 3.3, 3.4, 4)",
    "damage": "damage of the target robot (paper section 5): a preset name (aquafish_gym.DAMAGES), a JSON fault "
              "inline or as FILE.json (keys scale, seized, gains; recorded as its canonical JSON) or sampled:SEED",
    "behaviour_summary": "dft (the paper's DFT magnitudes) or signed_dft (the zero-frequency term keeps its sign, "
                         "so a robot and its mirror image differ; not the paper's)",
    "model_space": "what a self-model holds: morphology (the paper's 9 flipper dimensions, 45-bit genomes) or "
                   "morphology+servos (those and a gain per servo, pectorals in [-1, 1], caudal in [0, 1], 57-bit "
                   "genomes, OBJ_FIT over 12; eea.encoding; not the paper's)",
    "duration_s": "length of every experiment in seconds, a multiple of 0.01 s (paper: 1.28 ... 10.24)",
    "rounds": "EEA rounds (one exploration, one target experiment and one estimation each)",
    "seed": "seed of the run's only random generator (target angles, GAs, inference)",
    "exploration_population": "actions per exploration GA generation (paper: 25)",
    "exploration_generations": "exploration GA generations per round (paper: 25)",
    "exploration_models": "at most this many distinct candidate models, best first, whose "
                          "disagreement scores an action (eq. 1)",
    "exploration_angles": "0: every model is simulated from the zero state during exploration (the paper's); "
                          "K >= 2: from K random angle sets per round, and an action scores the models' "
                          "disagreement minus the spread the angles cause (eq. 1 with an angle term; not the paper's)",
    "exploration_diversity": "0: the exploration's candidate models are the distinct models of the last "
                             "estimation generation (the paper's); d > 0: the fittest models the whole round "
                             "evaluated, each at least d apart (1 - OBJ_FIT between them; not the paper's)",
    "estimation_population": "models per estimation GA generation (paper: 25)",
    "estimation_generations": "estimation GA generations per round (paper: 100)",
    "estimation_search": "estimation search: ga (the paper's bit-string GA) or cma (CMA-ES over the nine "
                         "dimensions, eea.search.cma; not the paper's)",
    "cma_sigma": "cma: initial step size as a fraction of each dimension's range, in (0, 1]",
    "cma_carry_condition": "cma: 0: every restart at the best model is isotropic; c >= 1: it keeps the shape of "
                           "the covariance the last round learned, condition number capped at c (not the paper's)",
    "cma_global_share": "cma: G >= 2 of the estimation_population models of every generation come from a second "
                        "CMA-ES that starts every round at a uniformly random point (0 = off; not the paper's)",
    "cma_flip_gains": "cma, morphology+servos: 1: every round's restart also tries the best model with each pectoral "
                      "gain's sign flipped (left, right, both), so a wrong-sign basin is left when the other side fits "
                      "better; 0: off (not the paper's)",
    "cma_global_keep": "cma: 0: the global share restarts at a random point every round; k > 0: only every k-th "
                       "round, otherwise at its own best point with its own covariance, a second lineage (needs "
                       "cma_global_share; not the paper's)",
    "lineages": "1: one estimation search (the paper's); N >= 2: N independent estimation lineages, each with its "
                "own search and inference state, share each round's experiment (chosen to split the union of their "
                "models) and the round's model is the lineage best whose angles, fitted equally hard, score the "
                "highest MOD_FIT (eea.search.lineages; 1.6x the simulations with N = 2; not the paper's)",
    "crossover_rate": "probability that a parent pair is recombined (paper: 0.75)",
    "tournament_size": "entrants per tournament (paper: 2)",
    "mutation_bits": "mean number of flipped bits per genome of every GA (paper: 1); at most 18",
    "elitism": "best genomes copied unchanged into the next generation (estimation_search=cma: "
               "any value >= 1 carries the one best point)",
    "k_best": "in_band: models whose initial angles define the inferred arc (paper: K = 3)",
    "in_band_confidence": "in_band: confidence of the newest experiment during its round (paper: 0.5)",
    "in_band_widen": "in_band: widen the arc by this fraction of its width on each side "
                     "(paper 4.3 tried 0.2; default 0 = off)",
    "oob_period": "out_of_band: infer angles every this many estimation generations (paper: 35)",
    "oob_sample": "out_of_band: best distinct models that score candidate angles (paper: 5)",
    "oob_population": "out_of_band: candidate angle sets per inner GA generation",
    "oob_generations": "out_of_band: inner GA generations per inference",
    "oob_bits": "out_of_band: bits per angle in the inner GA genome (3 angles)",
    "profile_proposals": "profile: perturbed angle sets tried per model, experiment and generation (not the paper's)",
    "profile_initial": "profile: random angle sets tried per model for a new experiment",
    "profile_refine": "profile: extra perturbation rounds of the angles of each contender, a model new this "
                      "generation, before it is scored (0 = off; not the paper's)",
    "profile_contenders": "profile: the fittest new models refined per generation (with profile_refine > 0)",
    "profile_library": "profile: 0: off; L > 0: every contender (profile_refine > 0) first tries, per experiment, "
                       "the L best-scoring angle sets any model has tried, at least 0.5 rad apart (not the paper's)",
    "waterline": "height of the free surface above the body's centre (units; the surface swimmer, default 0.3); "
                 "None: deep water, the physics of every run published before the surface swimmer",
    "workers": "worker processes for simulations (1 = serial); never changes results",
    "max_batch_robots": "at most this many robots per simulate_batch call (chunking; 32-64 is fastest, "
                        "larger worlds cost more per robot-step); never changes results",
}


def _default_workers() -> int:
    return os.cpu_count() or 1


@dataclasses.dataclass(frozen=True)
class EEAConfig:
    """Frozen, validated settings of one EEA run; defaults are the paper's (section 4).

    See :data:`FIELD_HELP` for each field. ``steps`` (derived) is the number of 0.01 s
    simulation steps of every experiment.

    The fields stay flat (``config.json`` and the command-line flags have one entry per
    field), but each component owns its section (:data:`SECTIONS`): a frozen settings class
    next to its code that validates its own fields, read as ``config.ga``, ``config.cma``,
    ``config.in_band``, ``config.out_of_band``, ``config.profile`` and ``config.exploration``
    (e.g. ``config.cma.sigma`` is ``config.cma_sigma``). The config checks its own fields and
    the rules that span sections (a count at most a population, the CMA settings only with
    ``estimation_search="cma"``, the mutation bits at most every GA's genome).

    Raises:
        ValueError: on an unknown inference strategy or damage (the message lists the valid
            names), a duration that is not a positive multiple of 0.01 s (at least 2 steps),
            a non-integer or out-of-range count, or a rate outside [0, 1]; a message names the
            field as ``EEAConfig.<field>``.
    """

    inference: str = "out_of_band"
    damage: str = "left_pectoral_half"
    model_space: str = "morphology"
    behaviour_summary: str = "dft"
    duration_s: float = 1.28
    rounds: int = 25
    seed: int = 0
    exploration_population: int = 25
    exploration_generations: int = 25
    exploration_models: int = 25
    exploration_angles: int = 0
    exploration_diversity: float = 0.0
    estimation_population: int = 25
    estimation_generations: int = 100
    estimation_search: str = "ga"
    cma_sigma: float = 0.3
    cma_global_share: int = 0
    cma_carry_condition: float = 0.0
    cma_global_keep: int = 0
    cma_flip_gains: int = 0
    lineages: int = 1
    crossover_rate: float = 0.75
    tournament_size: int = 2
    mutation_bits: float = 1.0
    elitism: int = 1
    k_best: int = 3
    in_band_confidence: float = 0.5
    in_band_widen: float = 0.0
    oob_period: int = 35
    oob_sample: int = 5
    oob_population: int = 10
    oob_generations: int = 10
    oob_bits: int = 8
    profile_proposals: int = 2
    profile_initial: int = 8
    profile_refine: int = 0
    profile_contenders: int = 3
    profile_library: int = 0
    workers: int = dataclasses.field(default_factory=_default_workers)
    max_batch_robots: int = 64
    waterline: float | None = DEFAULT_WATERLINE

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "waterline", SimParams(waterline=self.waterline).waterline)
        except ValueError as err:
            raise ValueError(f"EEAConfig.waterline: {err}") from None
        if self.inference not in INFERENCE_NAMES:
            raise ValueError(f"unknown inference {self.inference!r}; valid names: {', '.join(INFERENCE_NAMES)}")
        # the damage's canonical text (a JSON file is read once, here): config.json records the fault itself
        object.__setattr__(self, "damage", get_damage(self.damage).name)  # raises ValueError naming what is valid
        if self.behaviour_summary not in SUMMARIES:
            raise ValueError(f"unknown behaviour_summary {self.behaviour_summary!r}; valid names: {', '.join(SUMMARIES)}")
        if self.model_space not in MODEL_SPACE_NAMES:
            raise ValueError(f"unknown model_space {self.model_space!r}; valid names: {', '.join(MODEL_SPACE_NAMES)}")
        if self.estimation_search not in ESTIMATION_SEARCHES:
            raise ValueError(f"unknown estimation_search {self.estimation_search!r}; "
                             f"valid names: {', '.join(ESTIMATION_SEARCHES)}")
        minimum = {"rounds": 1, "seed": 0, "estimation_population": 2, "estimation_generations": 1, "workers": 1,
                   "max_batch_robots": 1, "lineages": 1}
        for name, low in minimum.items():
            check_int(f"EEAConfig.{name}", getattr(self, name), low)
        sections = [section.from_config(self) for section in SECTIONS.values()]  # each validates its fields
        self._check_across_sections()
        for settings in sections:  # keep each section's normalised values (a float field as a float)
            for name, field in settings.CONFIG_FIELDS.items():
                object.__setattr__(self, field, getattr(settings, name))
        duration = self.duration_s
        steps = round(duration / DT_S) if isinstance(duration, (int, float)) and math.isfinite(duration) else 0
        if isinstance(duration, bool) or steps < 2 or abs(duration / DT_S - steps) > 1e-6:
            raise ValueError(f"EEAConfig.duration_s must be a multiple of {DT_S} s of at least 2 steps, got {duration!r}")
        object.__setattr__(self, "duration_s", float(duration))

    def _check_across_sections(self) -> None:
        """The checks that span sections (or a section and the run's own fields); each section
        has checked its own fields."""
        for name, population in (("elitism", "exploration_population"), ("elitism", "estimation_population"),
                                 ("k_best", "estimation_population"), ("oob_sample", "estimation_population"),
                                 ("elitism", "oob_population")):
            if getattr(self, name) > getattr(self, population):
                raise ValueError(f"EEAConfig.{name} ({getattr(self, name)}) must be <= {population} ({getattr(self, population)})")
        for name in ("cma_global_share", "cma_carry_condition", "cma_flip_gains"):
            if getattr(self, name) and self.estimation_search != "cma":
                raise ValueError(f"EEAConfig.{name} > 0 needs estimation_search='cma', got {self.estimation_search!r}")
        if self.cma_flip_gains and self.model_space != "morphology+servos":
            raise ValueError(f"EEAConfig.cma_flip_gains = 1 needs model_space='morphology+servos' (gains to flip), "
                             f"got {self.model_space!r}")
        if self.cma_global_share and not 2 <= self.cma_global_share <= self.estimation_population - 2:
            raise ValueError(f"EEAConfig.cma_global_share must be 0 or in [2, estimation_population - 2] "
                             f"= [2, {self.estimation_population - 2}] (each CMA-ES needs 2 points), "
                             f"got {self.cma_global_share}")
        high = float(min(ACTION_BITS, 3 * self.oob_bits))  # every GA's genome: actions, out-of-band angles
        if self.mutation_bits > high:
            raise ValueError(f"EEAConfig.mutation_bits must be in [0, {high}], got {self.mutation_bits!r}")

    @property
    def ga(self) -> GASettings:
        """The settings every GA shares (crossover_rate, tournament_size, mutation_bits, elitism)."""
        return GASettings.from_config(self)

    @property
    def cma(self) -> CMASettings:
        """The CMA-ES search's settings (the ``cma_*`` fields)."""
        return CMASettings.from_config(self)

    @property
    def in_band(self) -> InBandSettings:
        """In-band inference's settings (k_best, in_band_confidence, in_band_widen)."""
        return InBandSettings.from_config(self)

    @property
    def out_of_band(self) -> OutOfBandSettings:
        """Out-of-band inference's settings (the ``oob_*`` fields)."""
        return OutOfBandSettings.from_config(self)

    @property
    def profile(self) -> ProfileSettings:
        """Profile inference's settings (the ``profile_*`` fields)."""
        return ProfileSettings.from_config(self)

    @property
    def exploration(self) -> ExplorationSettings:
        """The exploration phase's settings (the ``exploration_*`` fields)."""
        return ExplorationSettings.from_config(self)

    @property
    def sim_params(self) -> SimParams:
        """The simulator parameters of the target and the models (the defaults but ``waterline``)."""
        return SimParams(waterline=self.waterline)

    @property
    def steps(self) -> int:
        """Simulation steps of every experiment: ``round(duration_s / 0.01)``."""
        return round(self.duration_s / DT_S)

    def to_dict(self) -> dict:
        """All fields as a JSON-ready dict (the content of ``config.json``)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> "EEAConfig":
        """Inverse of :meth:`to_dict` (what ``config.json`` holds).

        A dict without ``waterline`` was written before the surface swimmer became the
        default physics: it describes a deep-water run and loads as ``waterline=None``. One
        without ``model_space`` was written before servo gains could be modelled: it loads as
        the default, ``"morphology"``. A field of :data:`eea.compat.RETIRED_FIELDS` at its
        default is dropped (the run did not use the retired variant; :func:`eea.compat.strip_retired`).

        Raises:
            ValueError: on an unknown key (typos fail fast), an invalid value, a retired
                field with another value than its default, or a value of
                :data:`eea.compat.RETIRED_VALUES` (the run used a retired variant; rerun it at the commit
                docs/studies/retired_variants.md names).
        """
        if "waterline" not in data:  # written before the surface swimmer: a deep-water run
            data = {**data, "waterline": None}
        return cls._from_fields(strip_retired(data))  # runs written before variants were retired

    @classmethod
    def _from_fields(cls, data: dict) -> "EEAConfig":
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(data) - names)
        if unknown:
            raise ValueError(f"unknown EEAConfig keys {unknown}; valid keys: {', '.join(sorted(names))}")
        return cls(**data)

    @classmethod
    def from_method(cls, method: str, budget: str = "paper", **fields) -> "EEAConfig":
        """Settings of the named method at the named budget (:mod:`eea.methods`), then ``fields``.

        Raises:
            ValueError: an unknown method or budget (the message lists the valid names), or an
                invalid field as :class:`EEAConfig` raises.
        """
        return cls._from_fields({**budget_fields(budget), **method_fields(method), **fields})

    def replace(self, **changes) -> "EEAConfig":
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)

    def same_results_as(self, other: "EEAConfig") -> bool:
        """Whether two configs give the same rounds (fields other than RESULT_NEUTRAL_FIELDS agree)."""
        mine, theirs = self.to_dict(), other.to_dict()
        return all(mine[k] == theirs[k] for k in mine if k not in RESULT_NEUTRAL_FIELDS)
