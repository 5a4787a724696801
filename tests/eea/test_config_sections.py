"""The sections of EEAConfig: each component owns a frozen settings class
next to its code that validates its own fields; the flat config builds them, keeps their
normalised values and checks only what spans sections."""

import dataclasses

import pytest

from eea.config import SECTIONS, EEAConfig
from eea.encoding import ACTION_BITS
from eea.exploration import Exploration, ExplorationSettings
from eea.ga import GASettings
from eea.inference import InBand, InBandSettings, OutOfBand, OutOfBandSettings, Profile, ProfileSettings
from eea.search import CMAModelSearch, CMASettings, ModelGA

#: The run's own fields: checked by EEAConfig itself, in no section.
RUN_FIELDS = {"inference", "damage", "model_space", "behaviour_summary", "duration_s", "rounds", "seed",
              "estimation_population", "estimation_generations", "estimation_search", "lineages", "workers",
              "max_batch_robots", "waterline"}


def test_the_sections_are_the_components_settings_next_to_their_code():
    assert SECTIONS == {"ga": GASettings, "cma": CMASettings, "in_band": InBandSettings,
                        "out_of_band": OutOfBandSettings, "profile": ProfileSettings,
                        "exploration": ExplorationSettings}
    assert {name: section.__module__ for name, section in SECTIONS.items()} == {
        "ga": "eea.ga", "cma": "eea.search.cma", "in_band": "eea.inference.paper",
        "out_of_band": "eea.inference.paper", "profile": "eea.inference.profile", "exploration": "eea.exploration"}


def test_every_field_is_in_one_section_or_the_runs_own():
    fields = [f.name for f in dataclasses.fields(EEAConfig)]
    placed = [field for section in SECTIONS.values() for field in section.CONFIG_FIELDS.values()]
    assert len(placed) == len(set(placed))                                # no field in two sections
    assert set(placed) | RUN_FIELDS == set(fields) and not set(placed) & RUN_FIELDS
    for section in SECTIONS.values():
        assert list(section.CONFIG_FIELDS) == [f.name for f in dataclasses.fields(section)]


@pytest.mark.parametrize("changes", [{}, {"estimation_search": "cma", "cma_sigma": 1, "cma_global_share": 4,
                                          "cma_carry_condition": 100, "cma_global_keep": 3, "crossover_rate": 1,
                                          "mutation_bits": 2, "in_band_confidence": 0, "in_band_widen": 1,
                                          "exploration_diversity": 0, "profile_refine": 10, "oob_bits": 5}])
def test_a_config_reads_its_sections_and_keeps_their_normalised_values(changes):
    config = EEAConfig(**changes)
    for name, section in SECTIONS.items():
        settings = getattr(config, name)
        assert type(settings) is section and settings == section.from_config(config)
        for field, config_field in section.CONFIG_FIELDS.items():
            value = getattr(settings, field)
            assert value == getattr(config, config_field) and type(value) is type(getattr(config, config_field))
    assert config.cma.sigma == config.cma_sigma and config.ga.options(45)["mutation_rate"] == config.mutation_bits / 45
    for name in ("cma_sigma", "cma_carry_condition", "crossover_rate", "mutation_bits", "in_band_confidence",
                 "in_band_widen", "exploration_diversity"):
        assert type(getattr(config, name)) is float, name                # as before the split
    assert EEAConfig.from_dict(config.to_dict()) == config


def test_a_sections_defaults_are_the_configs():
    config = EEAConfig()
    for name, section in SECTIONS.items():
        assert section() == getattr(config, name)


#: (section, its arguments, the message it and EEAConfig raise, the EEAConfig arguments).
BAD = [
    (GASettings, {"crossover_rate": 1.5}, "EEAConfig.crossover_rate must be in [0, 1], got 1.5", {}),
    (GASettings, {"tournament_size": 0}, "EEAConfig.tournament_size must be an int >= 1, got 0", {}),
    (GASettings, {"mutation_bits": -1}, "EEAConfig.mutation_bits must be in [0, 18.0], got -1", {}),
    (GASettings, {"mutation_bits": 19}, "EEAConfig.mutation_bits must be in [0, 18.0], got 19", {}),
    (GASettings, {"elitism": -1}, "EEAConfig.elitism must be an int >= 0, got -1", {}),
    (CMASettings, {"sigma": 0.0}, "EEAConfig.cma_sigma must be in (0, 1], got 0.0", {}),
    (CMASettings, {"sigma": True}, "EEAConfig.cma_sigma must be in (0, 1], got True", {}),
    (CMASettings, {"carry_condition": 0.5},
     "EEAConfig.cma_carry_condition must be 0 (off) or a finite number >= 1, got 0.5", {"estimation_search": "cma"}),
    (CMASettings, {"global_share": -1}, "EEAConfig.cma_global_share must be an int >= 0, got -1", {}),
    (CMASettings, {"global_keep": 2},
     "EEAConfig.cma_global_keep > 0 needs cma_global_share > 0 (a global share to keep), got 2 and 0",
     {"estimation_search": "cma"}),
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
]


@pytest.mark.parametrize("section, changes, message, context", BAD,
                         ids=[f"{s.__name__}.{next(iter(c))}={next(iter(c.values()))!r}" for s, c, _, _ in BAD])
def test_a_section_validates_its_fields_and_the_config_raises_the_same(section, changes, message, context):
    with pytest.raises(ValueError) as err:
        section(**changes)
    assert str(err.value) == message
    config_changes = {section.CONFIG_FIELDS[k]: v for k, v in changes.items()}
    with pytest.raises(ValueError) as err:
        EEAConfig(**context, **config_changes)
    assert str(err.value) == message


@pytest.mark.parametrize("name", list(SECTIONS))
def test_a_section_is_frozen(name):
    settings = getattr(EEAConfig(), name)
    field = dataclasses.fields(settings)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(settings, field, getattr(settings, field))


@pytest.mark.parametrize("section, changes, config_changes, message", [
    (GASettings, {"elitism": 26}, {}, "EEAConfig.elitism (26) must be <= exploration_population (25)"),
    (GASettings, {"elitism": 11}, {"exploration_population": 30, "estimation_population": 30},
     "EEAConfig.elitism (11) must be <= oob_population (10)"),
    (GASettings, {"mutation_bits": 7}, {"oob_bits": 2}, "EEAConfig.mutation_bits must be in [0, 6.0], got 7"),
    (InBandSettings, {"k_best": 26}, {}, "EEAConfig.k_best (26) must be <= estimation_population (25)"),
    (OutOfBandSettings, {"sample": 26}, {}, "EEAConfig.oob_sample (26) must be <= estimation_population (25)"),
    (CMASettings, {"global_share": 24}, {"estimation_search": "cma"},
     "EEAConfig.cma_global_share must be 0 or in [2, estimation_population - 2] = [2, 23] (each CMA-ES needs 2 "
     "points), got 24"),
    (CMASettings, {"global_share": 4}, {}, "EEAConfig.cma_global_share > 0 needs estimation_search='cma', got 'ga'"),
    (CMASettings, {"carry_condition": 10}, {}, "EEAConfig.cma_carry_condition > 0 needs estimation_search='cma', got 'ga'"),
])
def test_the_checks_across_sections_stay_in_the_config(section, changes, config_changes, message):
    section(**changes)                                                    # valid on its own
    with pytest.raises(ValueError) as err:
        EEAConfig(**config_changes, **{section.CONFIG_FIELDS[k]: v for k, v in changes.items()})
    assert str(err.value) == message


def test_the_components_are_built_from_their_sections():
    import numpy as np

    config = EEAConfig(estimation_search="cma", cma_sigma=0.5, cma_global_share=4, cma_global_keep=2,
                       cma_carry_condition=50, crossover_rate=0.6, mutation_bits=2, tournament_size=3, elitism=2,
                       k_best=4, in_band_confidence=0.25, in_band_widen=0.1, oob_bits=6, profile_library=3)
    exploration = Exploration.from_config(config)
    assert (exploration.population, exploration.generations, exploration.angle_sets) == (25, 25, 0)
    assert exploration.ga_options == {"crossover_rate": 0.6, "mutation_rate": 2 / ACTION_BITS, "tournament_size": 3,
                                      "elitism": 2}
    oob = OutOfBand.from_config(config)
    assert (oob.period, oob.sample, oob.population, oob.generations, oob.bits) == (35, 5, 10, 10, 6)
    assert oob.ga_options["mutation_rate"] == 2 / 18 and oob.ga_options["elitism"] == 2
    in_band = InBand.from_config(config)
    assert (in_band.k_best, in_band.confidence, in_band.widen) == (4, 0.25, 0.1)
    profile = Profile.from_config(config)
    assert (profile.proposals, profile.initial, profile.refine, profile.contenders, profile.library) == (2, 8, 0, 3, 3)
    cma = CMAModelSearch.from_config(config, np.random.default_rng(0))
    assert (cma.sigma0, cma.global_share, cma.global_keep, cma.carry_condition, cma.elitism) == (0.5, 4, 2, 50.0, 1)
    ga = ModelGA.from_config(config.replace(estimation_search="ga", cma_global_share=0, cma_global_keep=0,
                                            cma_carry_condition=0), np.random.default_rng(0))
    assert (ga.crossover_rate, ga.mutation_rate, ga.tournament_size, ga.elitism) == (0.6, 2 / 45, 3, 2)
