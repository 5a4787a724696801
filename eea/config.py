"""Settings of one EEA run: :class:`EEAConfig`, with the paper's defaults (section 4).

The config nests its sections, each a frozen settings class next to its component's code that
validates its own fields::

    EEAConfig(damage, model_space, behaviour_summary, duration_s, rounds, seed, waterline,
              exploration,   # ExplorationSettings: population, generations, models, angles, diversity
              estimation,    # EstimationSettings: population, generations, lineages, search
              ga,            # GASettings: shared by every GA of the run
              inference,     # one of KnownSettings, NoneSettings, InBandSettings, OutOfBandSettings,
                             # ProfileSettings (its ``name`` is the strategy's)
              runtime)       # RuntimeSettings: workers, max_batch_robots (never change results)

``estimation.search`` is a :class:`~eea.search.GASearchSettings` (the paper's GA) or a
:class:`~eea.search.CMASettings`. The settings of an inactive strategy or search do not exist in
the object: ``config.inference.name == "out_of_band"`` says which strategy runs, and only its
settings are there.

The command-line flags (``--oob-period``), the keys of a TOML config file, the named methods and
budgets (:mod:`eea.methods`) and every ``config.json`` written before the sections speak the
*flat* names (``oob_period``, ``cma_sigma``); :data:`FLAT_FIELDS` is the one table that maps each
to its place in the nested config, and :meth:`EEAConfig.from_flat` builds a config from them::

    config = EEAConfig.from_flat({"inference": "in_band", "rounds": 10, "seed": 3})
    config.inference.k_best      # 3
    config.steps                 # 128 (= duration_s / 0.01 s)
    EEAConfig.from_method("profile_lineages", "reduced", damage="caudal_half", seed=3)

The flat-name rule (:meth:`EEAConfig.from_flat`): a field of a strategy or search the config does
not run (``oob_period`` beside ``inference="known"``) is dropped when it comes from a budget or a
method, or has its default value; given explicitly (a flag, a keyword) at another value it is a
:class:`ValueError` naming the field and what it needs.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Mapping

from aquafish_gym import DT_S, SimParams, get_damage
from aquafish_gym.params import DEFAULT_WATERLINE
from aquafish_gym.checks import check_int
from eea.behaviour import SUMMARIES
from eea.compat import strip_retired_sections, upgrade_flat_fields
from eea.encoding import ACTION_BITS, MODEL_SPACES
from eea.estimation import EstimationSettings
from eea.evaluation import RuntimeSettings
from eea.exploration import ExplorationSettings
from eea.ga import GASettings
from eea.inference import INFERENCE_NAMES, INFERENCE_SETTINGS, InferenceSettings, OutOfBandSettings
from eea.methods import METHODS, budget_fields, method_fields
from eea.search import SEARCH_NAMES, SEARCH_SETTINGS

__all__ = ["ESTIMATION_SEARCHES", "FIELD_HELP", "FLAT_DEFAULTS", "FLAT_FIELDS", "MODEL_SPACE_NAMES",
           "RESULT_NEUTRAL_FIELDS", "SECTIONS", "VARIANT_SLOTS", "EEAConfig", "method_of", "nest_flat"]

#: Names of the estimation searches (:data:`eea.search.MODEL_SEARCHES`): the paper's
#: GA and CMA-ES (:mod:`eea.search.cma`).
ESTIMATION_SEARCHES: tuple[str, ...] = SEARCH_NAMES

#: The sections of :class:`EEAConfig` with a single settings class, by attribute; the two
#: variant slots (:data:`VARIANT_SLOTS`) hold one of several classes.
SECTIONS: dict[str, type] = {"exploration": ExplorationSettings, "estimation": EstimationSettings,
                             "ga": GASettings, "runtime": RuntimeSettings}

#: The slots that hold one of several variants, each a settings class with a ``name``: the path
#: in the nested config, the flat name that chooses the variant, and the classes by name.
VARIANT_SLOTS: dict[str, tuple[str, dict[str, type]]] = {
    "inference": ("inference", INFERENCE_SETTINGS),
    "estimation.search": ("estimation_search", SEARCH_SETTINGS),
}

#: Names of the model spaces (:data:`eea.encoding.MODEL_SPACES`): the paper's flipper
#: dimensions, or those and one gain per servo (not the paper's).
MODEL_SPACE_NAMES: tuple[str, ...] = tuple(MODEL_SPACES)

#: THE mapping of the flat names (command-line flags without dashes, TOML keys, the fields of
#: methods and budgets, the keys of a ``config.json`` written before the sections) to the nested
#: config: flat name -> (dotted path, the variant it needs or None). A path ending in ``.name``
#: chooses the variant of its slot (:data:`VARIANT_SLOTS`); a field that needs a variant exists
#: only in a config that runs it.
FLAT_FIELDS: dict[str, tuple[str, str | None]] = {
    "inference": ("inference.name", None),
    "damage": ("damage", None),
    "model_space": ("model_space", None),
    "behaviour_summary": ("behaviour_summary", None),
    "duration_s": ("duration_s", None),
    "rounds": ("rounds", None),
    "seed": ("seed", None),
    "exploration_population": ("exploration.population", None),
    "exploration_generations": ("exploration.generations", None),
    "exploration_models": ("exploration.models", None),
    "exploration_angles": ("exploration.angles", None),
    "exploration_diversity": ("exploration.diversity", None),
    "estimation_population": ("estimation.population", None),
    "estimation_generations": ("estimation.generations", None),
    "estimation_search": ("estimation.search.name", None),
    "cma_sigma": ("estimation.search.sigma", "cma"),
    "cma_global_share": ("estimation.search.global_share", "cma"),
    "cma_carry_condition": ("estimation.search.carry_condition", "cma"),
    "cma_global_keep": ("estimation.search.global_keep", "cma"),
    "cma_flip_gains": ("estimation.search.flip_gains", "cma"),
    "lineages": ("estimation.lineages", None),
    "crossover_rate": ("ga.crossover_rate", None),
    "tournament_size": ("ga.tournament_size", None),
    "mutation_bits": ("ga.mutation_bits", None),
    "elitism": ("ga.elitism", None),
    "k_best": ("inference.k_best", "in_band"),
    "in_band_confidence": ("inference.confidence", "in_band"),
    "in_band_widen": ("inference.widen", "in_band"),
    "oob_period": ("inference.period", "out_of_band"),
    "oob_sample": ("inference.sample", "out_of_band"),
    "oob_population": ("inference.population", "out_of_band"),
    "oob_generations": ("inference.generations", "out_of_band"),
    "oob_bits": ("inference.bits", "out_of_band"),
    "profile_proposals": ("inference.proposals", "profile"),
    "profile_initial": ("inference.initial", "profile"),
    "profile_refine": ("inference.refine", "profile"),
    "profile_contenders": ("inference.contenders", "profile"),
    "profile_library": ("inference.library", "profile"),
    "waterline": ("waterline", None),
    "workers": ("runtime.workers", None),
    "max_batch_robots": ("runtime.max_batch_robots", None),
}

#: The nested keys that never change a run's results (resuming with other values is allowed):
#: ``runtime`` (worker processes, chunk size of simulator calls) and ``rounds``, the stopping
#: criterion (a finished run can be extended to more rounds).
RESULT_NEUTRAL_FIELDS: tuple[str, ...] = ("runtime", "rounds")

#: One help line per flat name (command-line ``--help`` and documentation).
FIELD_HELP: dict[str, str] = {
    "inference": f"context inference strategy, one of {', '.join(INFERENCE_NAMES)} (paper 3.3, 3.4, 4)",
    "damage": "damage of the target robot (paper section 5): a preset name (aquafish_gym.DAMAGES), a JSON fault "
              "inline or as FILE.json (keys scale, seized, gains; recorded as its canonical JSON) or sampled:SEED",
    "behaviour_summary": "dft (the paper's DFT magnitudes), signed_dft (the zero-frequency term keeps its sign, "
                         "so a robot and its mirror image differ; not the paper's) or gyro_dft (the DFT magnitudes "
                         "of the angular rates, a gyroscope's signal, eq. 2 at MAX 1000; a reading of the paper)",
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
    "estimation_search": "estimation search: ga (the paper's bit-string GA), cma (CMA-ES over the nine "
                         "dimensions, eea.search.cma; not the paper's) or hypotheses (no search: the design's fault "
                         "hypotheses ranked, morphology+servos only, eea.search.hypotheses; not the paper's, in measurement)",
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

#: The top-level fields of :class:`EEAConfig` that are no section.
_RUN_FIELDS = ("damage", "model_space", "behaviour_summary", "duration_s", "rounds", "seed", "waterline")


def nest_flat(flat: Mapping, explicit: Mapping | None = None) -> dict:
    """Flat fields (:data:`FLAT_FIELDS`) as a nested dict, each at its path, without the fields
    of a strategy or search they do not choose (the flat-name rule of :meth:`EEAConfig.from_flat`).

    Args:
        flat: ``{flat name: value}``.
        explicit: the fields among them given explicitly: one of an inactive strategy or search
            at another value than its default is an error (None: none is).

    Returns:
        The nested dict, each variant slot with its ``name``: e.g. ``{"inference": {"name":
        "out_of_band", "period": 10}}`` for ``{"oob_period": 10}``.

    Raises:
        ValueError: on a name that is not in :data:`FLAT_FIELDS` (the message lists the valid
            names), an unknown strategy or search, or an explicit field of an inactive one.
    """
    unknown = sorted(set(flat) - set(FLAT_FIELDS))
    if unknown:
        raise ValueError(f"unknown EEAConfig keys {unknown}; valid keys: {', '.join(sorted(FLAT_FIELDS))}")
    explicit = explicit or {}
    chosen, nested = {}, {}
    for slot, (selector, classes) in VARIANT_SLOTS.items():
        chosen[selector] = flat.get(selector, FLAT_DEFAULTS[selector])
        if not isinstance(chosen[selector], str) or chosen[selector] not in classes:
            raise ValueError(f"unknown {selector} {chosen[selector]!r}; valid names: {', '.join(classes)}")
        _put(nested, f"{slot}.name", chosen[selector])
    for name, value in flat.items():
        path, variant = FLAT_FIELDS[name]
        if variant is not None:
            selector = VARIANT_SLOTS[path.rsplit(".", 1)[0]][0]
            if chosen[selector] != variant:
                if name in explicit and not _is_default(name, explicit[name]):
                    raise ValueError(f"EEAConfig.{name} needs {selector}={variant!r}, got {chosen[selector]!r}")
                continue
        _put(nested, path, value)
    return nested


def _put(nested: dict, path: str, value) -> None:
    """Set ``value`` at the dotted ``path`` of ``nested``, making the dicts on the way."""
    *sections, field = path.split(".")
    for section in sections:
        nested = nested.setdefault(section, {})
    nested[field] = value


def _is_default(name: str, value) -> bool:
    """Whether ``value`` is the flat field ``name``'s default (``2`` for ``2.0`` too, not ``True`` for ``1``)."""
    default = FLAT_DEFAULTS[name]
    return not isinstance(value, bool) and isinstance(value, (int, float)) and value == default \
        if isinstance(default, (int, float)) else value == default


def _section(cls: type, data, where: str):
    """``cls(**data)``, an unknown key a ValueError naming the valid ones."""
    if not isinstance(data, Mapping):
        raise ValueError(f"EEAConfig.{where} must be a dict of its fields, got {data!r}")
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    if unknown:
        raise ValueError(f"unknown keys {unknown} in EEAConfig.{where} ({cls.__name__}); "
                         f"valid keys: {', '.join(sorted(names)) or 'none'}")
    return cls(**data)


def _variant(slot: str, data):
    """The settings of the variant ``data["name"]`` of ``slot`` (no name: the default variant)."""
    selector, classes = VARIANT_SLOTS[slot]
    if not isinstance(data, Mapping):
        raise ValueError(f"EEAConfig.{slot} must be a dict of its name and fields, got {data!r}")
    data = dict(data)
    name = data.pop("name", FLAT_DEFAULTS[selector])
    if not isinstance(name, str) or name not in classes:
        raise ValueError(f"unknown {selector} {name!r}; valid names: {', '.join(classes)}")
    return _section(classes[name], data, slot)


@dataclasses.dataclass(frozen=True)
class EEAConfig:
    """Frozen, validated settings of one EEA run; defaults are the paper's (section 4).

    :data:`FIELD_HELP` describes every setting by its flat name (:data:`FLAT_FIELDS` says where
    it lives). ``steps`` (derived) is the number of 0.01 s simulation steps of every experiment.
    Each section validates its own fields; the config checks its own and the rules that span
    sections (a count at most a population, ``cma_flip_gains`` only in ``morphology+servos``, the
    CMA-ES global share at most the population less 2, the mutation bits at most every GA's
    genome). Build one from flat names with :meth:`from_flat`, :meth:`from_method` or
    :meth:`replace`; from sections directly (``EEAConfig(inference=InBandSettings(k_best=2))``);
    change a section with ``dataclasses.replace(config, inference=...)``.

    Args:
        damage: the target's damage (``--damage``; recorded as its canonical text).
        model_space: what a self-model holds (:data:`MODEL_SPACE_NAMES`).
        behaviour_summary: ``dft``, ``signed_dft`` or ``gyro_dft`` (:data:`eea.behaviour.SUMMARIES`).
        duration_s: seconds of every experiment, a multiple of 0.01 s, at least 2 steps.
        rounds: EEA rounds, >= 1.
        seed: seed of the run's one generator, >= 0.
        waterline: the free surface's height (units), or None: deep water.
        exploration: the exploration phase's :class:`~eea.exploration.ExplorationSettings`.
        estimation: the estimation phase's :class:`~eea.estimation.EstimationSettings` (and its search).
        ga: the :class:`~eea.ga.GASettings` every GA of the run shares.
        inference: the inference strategy's settings, one of :data:`eea.inference.INFERENCE_SETTINGS`
            (``inference.name`` is the strategy).
        runtime: the :class:`~eea.evaluation.RuntimeSettings` (never change results).

    Raises:
        ValueError: on an unknown damage, summary or model space (the message lists the valid
            names), a duration that is not a positive multiple of 0.01 s (at least 2 steps), a
            non-integer or out-of-range count, a rate outside [0, 1], a section of the wrong
            class, or a rule across sections broken; a message names the setting by its flat
            name as ``EEAConfig.<flat name>``.
    """

    damage: str = "left_pectoral_half"
    model_space: str = "morphology"
    behaviour_summary: str = "dft"
    duration_s: float = 1.28
    rounds: int = 25
    seed: int = 0
    waterline: float | None = DEFAULT_WATERLINE
    exploration: ExplorationSettings = dataclasses.field(default_factory=ExplorationSettings)
    estimation: EstimationSettings = dataclasses.field(default_factory=EstimationSettings)
    ga: GASettings = dataclasses.field(default_factory=GASettings)
    inference: InferenceSettings = dataclasses.field(default_factory=OutOfBandSettings)
    runtime: RuntimeSettings = dataclasses.field(default_factory=RuntimeSettings)

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "waterline", SimParams(waterline=self.waterline).waterline)
        except ValueError as err:
            raise ValueError(f"EEAConfig.waterline: {err}") from None
        # the damage's canonical text (a JSON file is read once, here): config.json records the fault itself
        object.__setattr__(self, "damage", get_damage(self.damage).name)  # raises ValueError naming what is valid
        if self.behaviour_summary not in SUMMARIES:
            raise ValueError(f"unknown behaviour_summary {self.behaviour_summary!r}; valid names: {', '.join(SUMMARIES)}")
        if self.model_space not in MODEL_SPACE_NAMES:
            raise ValueError(f"unknown model_space {self.model_space!r}; valid names: {', '.join(MODEL_SPACE_NAMES)}")
        check_int("EEAConfig.rounds", self.rounds, 1)
        check_int("EEAConfig.seed", self.seed, 0)
        for name, cls in SECTIONS.items():
            if type(getattr(self, name)) is not cls:
                raise ValueError(f"EEAConfig.{name} must be a {cls.__name__}, got {getattr(self, name)!r}")
        if type(self.inference) not in INFERENCE_SETTINGS.values():
            raise ValueError(f"EEAConfig.inference must be the settings of a strategy "
                             f"({', '.join(c.__name__ for c in INFERENCE_SETTINGS.values())}), got {self.inference!r}")
        self._check_across_sections()
        duration = self.duration_s
        steps = round(duration / DT_S) if isinstance(duration, (int, float)) and math.isfinite(duration) else 0
        if isinstance(duration, bool) or steps < 2 or abs(duration / DT_S - steps) > 1e-6:
            raise ValueError(f"EEAConfig.duration_s must be a multiple of {DT_S} s of at least 2 steps, got {duration!r}")
        object.__setattr__(self, "duration_s", float(duration))

    def _check_across_sections(self) -> None:
        """The checks that span sections (or a section and the run's own fields); each section
        has checked its own fields."""
        flat = self.to_flat()
        for name, population in (("elitism", "exploration_population"), ("elitism", "estimation_population"),
                                 ("k_best", "estimation_population"), ("oob_sample", "estimation_population"),
                                 ("elitism", "oob_population")):
            if name in flat and population in flat and flat[name] > flat[population]:
                raise ValueError(f"EEAConfig.{name} ({flat[name]}) must be <= {population} ({flat[population]})")
        if flat.get("cma_flip_gains") and self.model_space != "morphology+servos":
            raise ValueError(f"EEAConfig.cma_flip_gains = 1 needs model_space='morphology+servos' (gains to flip), "
                             f"got {self.model_space!r}")
        share, population = flat.get("cma_global_share", 0), self.estimation.population
        if share and not 2 <= share <= population - 2:
            raise ValueError(f"EEAConfig.cma_global_share must be 0 or in [2, estimation_population - 2] "
                             f"= [2, {population - 2}] (each CMA-ES needs 2 points), got {share}")
        # every GA's genome: actions, and the out-of-band angles when that strategy runs
        high = float(min(ACTION_BITS, 3 * flat.get("oob_bits", ACTION_BITS)))
        if self.ga.mutation_bits > high:
            raise ValueError(f"EEAConfig.mutation_bits must be in [0, {high}], got {self.ga.mutation_bits!r}")

    @property
    def sim_params(self) -> SimParams:
        """The simulator parameters of the target and the models (the defaults but ``waterline``)."""
        return SimParams(waterline=self.waterline)

    @property
    def steps(self) -> int:
        """Simulation steps of every experiment: ``round(duration_s / 0.01)``."""
        return round(self.duration_s / DT_S)

    def to_flat(self) -> dict:
        """The settings by flat name (:data:`FLAT_FIELDS`), those of the strategy and search the
        config runs only (``oob_period`` only with ``inference="out_of_band"``).

        Returns:
            ``{flat name: value}`` in :data:`FLAT_FIELDS` order.
        """
        selected = {"inference": self.inference.name, "estimation.search": self.estimation.search.name}
        flat = {}
        for name, (path, variant) in FLAT_FIELDS.items():
            if variant is not None and selected[path.rsplit(".", 1)[0]] != variant:
                continue
            value = self
            for part in path.split("."):
                value = getattr(value, part)
            flat[name] = value
        return flat

    def to_dict(self) -> dict:
        """The nested, JSON-ready dict (the content of ``config.json``): the run's own fields, then
        every section as a dict, the two variants (``inference``, ``estimation.search``) with
        their ``name``.

        Returns:
            e.g. ``{"damage": ..., "exploration": {"population": 25, ...}, "estimation":
            {"population": 25, "generations": 100, "lineages": 1, "search": {"name": "ga"}},
            "ga": {...}, "inference": {"name": "out_of_band", "period": 35, ...}, "runtime": {...}}``.
        """
        data = {name: getattr(self, name) for name in _RUN_FIELDS}
        estimation = dataclasses.asdict(self.estimation)
        estimation["search"] = {"name": self.estimation.search.name, **estimation["search"]}
        data.update(exploration=dataclasses.asdict(self.exploration), estimation=estimation,
                    ga=dataclasses.asdict(self.ga),
                    inference={"name": self.inference.name, **dataclasses.asdict(self.inference)},
                    runtime=dataclasses.asdict(self.runtime))
        return data

    @classmethod
    def from_dict(cls, data: Mapping) -> "EEAConfig":
        """Inverse of :meth:`to_dict` (what ``config.json`` holds); a section or field left out
        gets its default.

        A dict without any section (no value is a dict) is a flat ``config.json`` written before
        the sections, or a flat ``base`` of a ``study.json``: it is brought up to date by
        :func:`eea.compat.upgrade_flat_fields` (a ``waterline`` absent is deep water, retired
        fields at their defaults are dropped) and nested by :func:`nest_flat` (a ``model_space``
        absent is the paper's, as any field left out; the fields of the strategy and search the
        run did not use are dropped, whatever their values).

        Args:
            data: the nested dict (or a flat one, above).

        Raises:
            ValueError: on an unknown key (typos fail fast; the message lists the valid keys),
                an invalid value, or a flat dict :func:`eea.compat.upgrade_flat_fields` refuses
                (a retired variant).
        """
        if not isinstance(data, Mapping):
            raise ValueError(f"an EEAConfig dict must be a dict, got {type(data).__name__}")
        if not any(isinstance(value, Mapping) for value in data.values()):
            data = nest_flat(upgrade_flat_fields(data))  # written before the sections
        else:
            data = strip_retired_sections(data)  # written before a variant was retired
        valid = (*_RUN_FIELDS, *SECTIONS, "inference")
        unknown = sorted(set(data) - set(valid))
        if unknown:
            raise ValueError(f"unknown EEAConfig keys {unknown}; valid keys: {', '.join(valid)}")
        fields = {name: data[name] for name in _RUN_FIELDS if name in data}
        sections = {}
        for name, cls_ in SECTIONS.items():
            if name in data:
                section = data[name]
                if name == "estimation" and isinstance(section, Mapping):
                    section = {**section, "search": _variant("estimation.search", section.get("search", {}))}
                sections[name] = _section(cls_, section, name)
        if "inference" in data:
            sections["inference"] = _variant("inference", data["inference"])
        return cls(**fields, **sections)

    @classmethod
    def from_flat(cls, fields: Mapping, *, optional: Mapping | None = None) -> "EEAConfig":
        """A config from flat names (:data:`FLAT_FIELDS`: the flags, TOML keys, method and budget
        fields); every name left out keeps its default.

        The flat-name rule: ``fields`` are given explicitly (a flag, a keyword), ``optional``
        fields come from a budget, a method or a config being changed, and ``fields`` win over
        them. A field of a strategy or search the config does not run (``oob_period`` with
        ``inference="known"``, ``cma_sigma`` with ``estimation_search="ga"``) is dropped when it
        is optional or has its default value; given explicitly at another value it is an error.

        Args:
            fields: ``{flat name: value}`` given explicitly.
            optional: ``{flat name: value}`` that apply where the config holds their section.

        Raises:
            ValueError: on an unknown name (the message lists the valid ones), an explicit field
                of an inactive strategy or search ("EEAConfig.oob_period needs
                inference='out_of_band', got 'known'"), or an invalid value.
        """
        return cls.from_dict(nest_flat({**(optional or {}), **fields}, explicit=fields))

    @classmethod
    def from_method(cls, method: str, budget: str = "paper", **fields) -> "EEAConfig":
        """Settings of the named method at the named budget (:mod:`eea.methods`), then ``fields``
        (flat names, given explicitly: :meth:`from_flat`'s rule).

        Args:
            method: a name of :data:`eea.methods.METHODS`.
            budget: a name of :data:`eea.methods.BUDGETS`.
            **fields: flat fields over the method's and the budget's.

        Raises:
            ValueError: an unknown method or budget (the message lists the valid names), or as
                :meth:`from_flat` raises.
        """
        return cls.from_flat(fields, optional={**budget_fields(budget), **method_fields(method)})

    def replace(self, **changes) -> "EEAConfig":
        """A validated copy with some settings changed, by flat name (:meth:`from_flat` with
        ``changes`` explicit over this config's :meth:`to_flat`): switching the strategy or search
        drops the old one's settings; a field of a strategy or search the copy does not run is an
        error. Change a whole section with ``dataclasses.replace(config, inference=...)``.

        Args:
            **changes: ``flat name=value``.

        Raises:
            ValueError: as :meth:`from_flat` raises.
        """
        return type(self).from_flat(changes, optional=self.to_flat())

    def same_results_as(self, other: "EEAConfig") -> bool:
        """Whether two configs give the same rounds: everything but :data:`RESULT_NEUTRAL_FIELDS`
        (``runtime``, ``rounds``) agrees.

        Args:
            other: the config to compare with.
        """
        return self.result_fields() == other.result_fields()

    def result_fields(self) -> dict:
        """The settings that define a run's results, by flat name: :meth:`to_flat` without those
        under :data:`RESULT_NEUTRAL_FIELDS` (a run's fingerprint; a difference reads as its flag)."""
        return {k: v for k, v in self.to_flat().items() if FLAT_FIELDS[k][0].split(".")[0] not in RESULT_NEUTRAL_FIELDS}


def _flat_defaults() -> dict[str, object]:
    """Every flat name's default: the default config's value, or a variant's settings class's."""
    config, defaults = EEAConfig(), {}
    for name, (path, variant) in FLAT_FIELDS.items():
        slot, _, field = path.rpartition(".")
        value = config if variant is None else VARIANT_SLOTS[slot][1][variant]()
        for part in (path.split(".") if variant is None else (field,)):
            value = getattr(value, part)
        defaults[name] = value
    return defaults


#: Every flat name's default value (a variant's field: its settings class's default; ``workers``:
#: the machine's CPU count).
FLAT_DEFAULTS: dict[str, object] = _flat_defaults()


def method_of(config: EEAConfig) -> str:
    """The name of the method (:data:`eea.methods.METHODS`) ``config`` runs, or ``"custom"``
    when it matches none.

    A config runs method M when every field M sets has M's value and every other field any
    method sets has its default or is not in the config (a field of a strategy or search it
    does not run). So a published ``config.json`` names its method, flat or nested.

    Args:
        config: the run's settings.
    """
    flat = config.to_flat()
    method_keys = {key for m in METHODS.values() for key in m.fields}
    for name, m in METHODS.items():
        if all(flat[key] == m.fields.get(key, FLAT_DEFAULTS[key]) if key in flat else key not in m.fields
               for key in method_keys):
            return name
    return "custom"
