"""The sections of EEAConfig: each component owns a frozen settings class next to its code
that validates its own fields; the config nests them, holds only the strategy and search it
runs, checks only what spans sections, and maps the flat names onto them in one table."""

import dataclasses

import numpy as np
import pytest

from eea.config import FLAT_FIELDS, SECTIONS, VARIANT_SLOTS, EEAConfig
from eea.encoding import ACTION_BITS
from eea.estimation import Estimation, EstimationSettings
from eea.evaluation import RuntimeSettings
from eea.exploration import Exploration, ExplorationSettings
from eea.ga import GASettings
from eea.inference import (INFERENCE_SETTINGS, InBand, InBandSettings, KnownSettings, NoneSettings, OutOfBand,
                           OutOfBandSettings, Profile, ProfileSettings, make_inference)
from eea.search import (SEARCH_SETTINGS, CMAModelSearch, CMASettings, GASearchSettings, HypothesisSettings, ModelGA,
                        make_model_search)

F = EEAConfig.from_flat


def test_the_sections_are_the_components_settings_next_to_their_code():
    assert SECTIONS == {"exploration": ExplorationSettings, "estimation": EstimationSettings, "ga": GASettings,
                        "runtime": RuntimeSettings}
    assert {name: section.__module__ for name, section in SECTIONS.items()} == {
        "exploration": "eea.exploration", "estimation": "eea.estimation", "ga": "eea.ga", "runtime": "eea.evaluation"}
    assert INFERENCE_SETTINGS == {"known": KnownSettings, "none": NoneSettings, "in_band": InBandSettings,
                                  "out_of_band": OutOfBandSettings, "profile": ProfileSettings}
    assert SEARCH_SETTINGS == {"ga": GASearchSettings, "cma": CMASettings, "hypotheses": HypothesisSettings}
    assert {cls.__module__ for cls in INFERENCE_SETTINGS.values()} == {"eea.inference.paper", "eea.inference.profile"}
    assert {cls.__module__ for cls in SEARCH_SETTINGS.values()} == {"eea.search.model_ga", "eea.search.cma",
                                                                    "eea.search.hypotheses"}
    for name, cls in {**INFERENCE_SETTINGS, **SEARCH_SETTINGS}.items():
        assert cls.name == name and "name" not in {f.name for f in dataclasses.fields(cls)}  # a name, no field


def test_every_flat_name_maps_to_one_place_and_every_place_has_one_name():
    places = [(path, variant) for path, variant in FLAT_FIELDS.values()]
    assert len(places) == len(set(places))
    expected = {(name, None) for name in ("damage", "model_space", "behaviour_summary", "duration_s", "rounds",
                                          "seed", "waterline")}
    for section, cls in SECTIONS.items():
        expected |= {(f"{section}.{f.name}", None) for f in dataclasses.fields(cls) if f.name != "search"}
    for slot, (_, classes) in VARIANT_SLOTS.items():
        expected.add((f"{slot}.name", None))
        expected |= {(f"{slot}.{f.name}", name) for name, cls in classes.items() for f in dataclasses.fields(cls)}
    assert set(places) == expected


@pytest.mark.parametrize("changes", [{}, {"estimation_search": "cma", "cma_sigma": 1, "cma_global_share": 4,
                                          "cma_carry_condition": 100, "cma_global_keep": 3, "crossover_rate": 1,
                                          "mutation_bits": 2, "exploration_diversity": 0, "inference": "in_band",
                                          "in_band_confidence": 0, "in_band_widen": 1}])
def test_a_config_holds_its_sections_with_their_normalised_values(changes):
    config = F(changes)
    for name, section in SECTIONS.items():
        assert type(getattr(config, name)) is section
    assert type(config.inference) is INFERENCE_SETTINGS[changes.get("inference", "out_of_band")]
    assert type(config.estimation.search) is SEARCH_SETTINGS[changes.get("estimation_search", "ga")]
    flat = config.to_flat()
    for name, value in changes.items():
        assert flat[name] == value
    for name in ("cma_sigma", "cma_carry_condition", "crossover_rate", "mutation_bits", "in_band_confidence",
                 "in_band_widen", "exploration_diversity"):
        if name in flat:
            assert type(flat[name]) is float, name                       # as before the sections
    assert EEAConfig.from_dict(config.to_dict()) == config


def test_an_inactive_strategys_or_searchs_settings_do_not_exist():
    config = F({"inference": "known"})
    assert config.inference == KnownSettings() and not dataclasses.fields(config.inference)
    assert not {name for name in config.to_flat() if name.startswith(("oob_", "profile_", "cma_", "k_best", "in_band"))}
    assert config.to_dict()["inference"] == {"name": "known"}
    assert config.to_dict()["estimation"]["search"] == {"name": "ga"}


def test_a_sections_defaults_are_the_configs():
    config = EEAConfig()
    for name, section in SECTIONS.items():
        assert section() == getattr(config, name)
    assert config.inference == OutOfBandSettings() and config.estimation.search == GASearchSettings()


def _flat_name(section: type, field: str) -> tuple[str, dict]:
    """The flat name of a section's field and the variant choice it needs."""
    for name, (path, variant) in FLAT_FIELDS.items():
        head, _, last = path.rpartition(".")
        owner = VARIANT_SLOTS[head][1].get(variant) if variant else SECTIONS.get(head)
        if last == field and owner is section:
            return name, ({VARIANT_SLOTS[head][0]: variant} if variant else {})
    raise KeyError(field)


#: (section, its arguments, the message it and EEAConfig raise, more EEAConfig flat fields).
BAD = [
    (GASettings, {"crossover_rate": 1.5}, "EEAConfig.crossover_rate must be in [0, 1], got 1.5", {}),
    (GASettings, {"tournament_size": 0}, "EEAConfig.tournament_size must be an int >= 1, got 0", {}),
    (GASettings, {"mutation_bits": -1}, "EEAConfig.mutation_bits must be in [0, 18.0], got -1", {}),
    (GASettings, {"mutation_bits": 19}, "EEAConfig.mutation_bits must be in [0, 18.0], got 19", {}),
    (GASettings, {"elitism": -1}, "EEAConfig.elitism must be an int >= 0, got -1", {}),
    (CMASettings, {"sigma": 0.0}, "EEAConfig.cma_sigma must be in (0, 1], got 0.0", {}),
    (CMASettings, {"sigma": True}, "EEAConfig.cma_sigma must be in (0, 1], got True", {}),
    (CMASettings, {"carry_condition": 0.5},
     "EEAConfig.cma_carry_condition must be 0 (off) or a finite number >= 1, got 0.5", {}),
    (CMASettings, {"global_share": -1}, "EEAConfig.cma_global_share must be an int >= 0, got -1", {}),
    (CMASettings, {"global_keep": 2},
     "EEAConfig.cma_global_keep > 0 needs cma_global_share > 0 (a global share to keep), got 2 and 0", {}),
    (InBandSettings, {"k_best": 0}, "EEAConfig.k_best must be an int >= 1, got 0", {}),
    (InBandSettings, {"confidence": float("nan")}, "EEAConfig.in_band_confidence must be in [0, 1], got nan", {}),
    (InBandSettings, {"widen": -0.1}, "EEAConfig.in_band_widen must be in [0, inf], got -0.1", {}),
    (OutOfBandSettings, {"period": 0}, "EEAConfig.oob_period must be an int >= 1, got 0", {}),
    (OutOfBandSettings, {"sample": 0}, "EEAConfig.oob_sample must be an int >= 1, got 0", {}),
    (OutOfBandSettings, {"population": 1.0}, "EEAConfig.oob_population must be an int >= 1, got 1.0", {}),
    (OutOfBandSettings, {"generations": 0}, "EEAConfig.oob_generations must be an int >= 1, got 0", {}),
    (OutOfBandSettings, {"bits": 31}, "EEAConfig.oob_bits must be an int >= 2 and <= 30, got 31", {}),
    (ProfileSettings, {"proposals": 0}, "EEAConfig.profile_proposals must be an int >= 1, got 0", {}),
    (ProfileSettings, {"initial": 0}, "EEAConfig.profile_initial must be an int >= 1, got 0", {}),
    (ProfileSettings, {"refine": -1}, "EEAConfig.profile_refine must be an int >= 0, got -1", {}),
    (ProfileSettings, {"contenders": 0}, "EEAConfig.profile_contenders must be an int >= 1, got 0", {}),
    (ProfileSettings, {"library": -1}, "EEAConfig.profile_library must be an int >= 0, got -1", {}),
    (ExplorationSettings, {"population": 0}, "EEAConfig.exploration_population must be an int >= 1, got 0", {}),
    (ExplorationSettings, {"generations": 0}, "EEAConfig.exploration_generations must be an int >= 1, got 0", {}),
    (ExplorationSettings, {"models": 1}, "EEAConfig.exploration_models must be an int >= 2, got 1", {}),
    (ExplorationSettings, {"angles": 1}, "EEAConfig.exploration_angles must be 0 (the zero state) or >= 2 "
                                         "(a spread needs two angle sets), got 1", {}),
    (ExplorationSettings, {"diversity": 1.0}, "EEAConfig.exploration_diversity must be in [0, 1), got 1.0", {}),
    (EstimationSettings, {"population": 1}, "EEAConfig.estimation_population must be an int >= 2, got 1", {}),
    (EstimationSettings, {"generations": 0}, "EEAConfig.estimation_generations must be an int >= 1, got 0", {}),
    (EstimationSettings, {"lineages": 0}, "EEAConfig.lineages must be an int >= 1, got 0", {}),
    (RuntimeSettings, {"workers": 0}, "EEAConfig.workers must be an int >= 1, got 0", {}),
    (RuntimeSettings, {"max_batch_robots": 0.5}, "EEAConfig.max_batch_robots must be an int >= 1, got 0.5", {}),
]


@pytest.mark.parametrize("section, changes, message, context", BAD,
                         ids=[f"{s.__name__}.{next(iter(c))}={next(iter(c.values()))!r}" for s, c, _, _ in BAD])
def test_a_section_validates_its_fields_and_the_config_raises_the_same(section, changes, message, context):
    with pytest.raises(ValueError) as err:
        section(**changes)
    assert str(err.value) == message
    flat = {}
    for field, value in changes.items():
        name, needs = _flat_name(section, field)
        flat.update(needs, **{name: value})
    with pytest.raises(ValueError) as err:
        F({**context, **flat})
    assert str(err.value) == message


@pytest.mark.parametrize("name", ["exploration", "estimation", "ga", "inference", "runtime"])
def test_a_section_is_frozen(name):
    settings = getattr(EEAConfig(), name)
    field = dataclasses.fields(settings)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(settings, field, getattr(settings, field))


@pytest.mark.parametrize("flat, message", [
    ({"elitism": 26}, "EEAConfig.elitism (26) must be <= exploration_population (25)"),
    ({"elitism": 11, "exploration_population": 30, "estimation_population": 30},
     "EEAConfig.elitism (11) must be <= oob_population (10)"),
    ({"mutation_bits": 7, "oob_bits": 2}, "EEAConfig.mutation_bits must be in [0, 6.0], got 7.0"),
    ({"inference": "in_band", "k_best": 26}, "EEAConfig.k_best (26) must be <= estimation_population (25)"),
    ({"oob_sample": 26}, "EEAConfig.oob_sample (26) must be <= estimation_population (25)"),
    ({"estimation_search": "cma", "cma_global_share": 24},
     "EEAConfig.cma_global_share must be 0 or in [2, estimation_population - 2] = [2, 23] (each CMA-ES needs 2 "
     "points), got 24"),
    ({"estimation_search": "cma", "cma_flip_gains": 1},
     "EEAConfig.cma_flip_gains = 1 needs model_space='morphology+servos' (gains to flip), got 'morphology'"),
    ({"cma_global_share": 4}, "EEAConfig.cma_global_share needs estimation_search='cma', got 'ga'"),
    ({"cma_carry_condition": 10}, "EEAConfig.cma_carry_condition needs estimation_search='cma', got 'ga'"),
])
def test_the_checks_across_sections_stay_in_the_config(flat, message):
    with pytest.raises(ValueError) as err:
        F(flat)
    assert str(err.value) == message
    # the cap of mutation_bits by the out-of-band genome holds only while out-of-band runs
    assert F({"inference": "none", "mutation_bits": 7}).ga.mutation_bits == 7.0


def test_the_components_are_built_from_their_sections():
    config = F({"estimation_search": "cma", "cma_sigma": 0.5, "cma_global_share": 4, "cma_global_keep": 2,
                "cma_carry_condition": 50, "crossover_rate": 0.6, "mutation_bits": 2, "tournament_size": 3,
                "elitism": 2, "oob_bits": 6})
    exploration = Exploration.from_settings(config.exploration, config.ga)
    assert (exploration.population, exploration.generations, exploration.angle_sets) == (25, 25, 0)
    assert exploration.ga_options == {"crossover_rate": 0.6, "mutation_rate": 2 / ACTION_BITS, "tournament_size": 3,
                                      "elitism": 2}
    oob = make_inference(config.inference, config.ga)
    assert type(oob) is OutOfBand and oob.ga_options["mutation_rate"] == 2 / 18 and oob.ga_options["elitism"] == 2
    assert (oob.period, oob.sample, oob.population, oob.generations, oob.bits) == (35, 5, 10, 10, 6)
    in_band = InBand.from_settings(InBandSettings(k_best=4, confidence=0.25, widen=0.1))
    assert (in_band.k_best, in_band.confidence, in_band.widen) == (4, 0.25, 0.1)
    profile = make_inference(ProfileSettings(library=3))
    assert type(profile) is Profile
    assert (profile.proposals, profile.initial, profile.refine, profile.contenders, profile.library) == (2, 8, 0, 3, 3)
    cma = make_model_search(config.estimation, config.ga, config.model_space, np.random.default_rng(0))
    assert type(cma) is CMAModelSearch
    assert (cma.sigma0, cma.global_share, cma.global_keep, cma.carry_condition, cma.elitism) == (0.5, 4, 2, 50.0, 1)
    ga_config = config.replace(estimation_search="ga")       # the CMA-ES settings go with their search
    assert ga_config.estimation.search == GASearchSettings()
    ga = Estimation.from_settings(ga_config.estimation, ga_config.ga, "morphology", np.random.default_rng(0)).search
    assert type(ga) is ModelGA
    assert (ga.crossover_rate, ga.mutation_rate, ga.tournament_size, ga.elitism) == (0.6, 2 / 45, 3, 2)
    with pytest.raises(ValueError, match="a GA search needs GASearchSettings"):
        ModelGA.from_settings(config.estimation, config.ga, "morphology", np.random.default_rng(0))
