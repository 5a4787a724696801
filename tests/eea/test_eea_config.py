"""EEAConfig: the paper's defaults (section 4), validation with clear errors, the nested sections
and the flat names (flags, methods, budgets, published config.json files) that map onto them."""

import dataclasses
import json
from pathlib import Path

import pytest

from eea.compat import upgrade_flat_fields
from eea.config import FIELD_HELP, FLAT_DEFAULTS, FLAT_FIELDS, EEAConfig, method_of, nest_flat
from eea.inference import InBandSettings, KnownSettings, OutOfBandSettings
from eea.methods import BUDGETS, METHODS
from eea.search import GASearchSettings

F = EEAConfig.from_flat


def test_defaults_are_the_papers():
    c = EEAConfig()
    assert (c.inference.name, c.damage, c.duration_s, c.rounds) == ("out_of_band", "left_pectoral_half", 1.28, 25)
    assert (c.exploration.population, c.exploration.generations) == (25, 25)
    assert (c.estimation.population, c.estimation.generations, c.estimation.search) == (25, 100, GASearchSettings())
    assert (c.ga.crossover_rate, c.ga.tournament_size, c.ga.mutation_bits) == (0.75, 2, 1.0)
    assert (c.inference.period, c.inference.sample) == (35, 5)
    assert (InBandSettings().k_best, InBandSettings().confidence) == (3, 0.5)
    assert c.steps == 128 and EEAConfig(duration_s=10.24).steps == 1024 and c.runtime.workers >= 1


def test_every_flat_name_has_help_and_a_default():
    assert set(FIELD_HELP) == set(FLAT_FIELDS) == set(FLAT_DEFAULTS)
    assert FLAT_DEFAULTS["oob_period"] == 35 and FLAT_DEFAULTS["cma_sigma"] == 0.3 and FLAT_DEFAULTS["k_best"] == 3


@pytest.mark.parametrize("changes, match", [
    ({"inference": "telepathy"}, "valid names: known, none, in_band, out_of_band"),
    ({"damage": "dented"}, "valid names: .*left_pectoral_half"),
    ({"duration_s": 0.015}, "multiple of 0.01"),
    ({"duration_s": 0.01}, "at least 2 steps"),
    ({"rounds": 0}, "rounds must be an int >= 1"),
    ({"rounds": 2.0}, "rounds must be an int"),
    ({"estimation_population": 1}, "estimation_population must be an int >= 2"),
    ({"inference": "in_band", "k_best": 26}, "k_best .* must be <= estimation_population"),
    ({"oob_sample": 30}, "oob_sample"),
    ({"crossover_rate": 1.5}, "crossover_rate must be in"),
    ({"inference": "in_band", "in_band_confidence": float("nan")}, "in_band_confidence"),
    ({"mutation_bits": -1}, "mutation_bits"),
    ({"workers": 0}, "EEAConfig.workers must be an int >= 1"),
    ({"max_batch_robots": 0}, "EEAConfig.max_batch_robots must be an int >= 1"),
    ({"exploration_angles": 1}, "EEAConfig.exploration_angles must be 0"),
    ({"oob_period": 0}, "EEAConfig.oob_period must be an int >= 1"),
    ({"estimation_search": "cma", "cma_sigma": 0.0}, r"EEAConfig.cma_sigma must be in \(0, 1\]"),
    ({"inference": "profile", "profile_library": -1}, "EEAConfig.profile_library must be an int >= 0"),
])
def test_invalid_values_raise(changes, match):
    with pytest.raises(ValueError, match=match):
        F(changes)


def test_a_section_of_the_wrong_class_is_refused():
    with pytest.raises(ValueError, match="EEAConfig.inference must be the settings of a strategy"):
        EEAConfig(inference="in_band")
    with pytest.raises(ValueError, match="EEAConfig.ga must be a GASettings"):
        EEAConfig(ga=OutOfBandSettings())
    with pytest.raises(ValueError, match="EEAConfig.estimation_search: .* is no search's settings"):
        F({}).estimation.__class__(search=KnownSettings())


def test_dict_round_trip_and_unknown_keys():
    c = F({"inference": "in_band", "seed": 7, "workers": 1, "estimation_search": "cma", "cma_sigma": 0.2})
    data = c.to_dict()
    assert data["inference"] == {"name": "in_band", "k_best": 3, "confidence": 0.5, "widen": 0.0}
    assert data["estimation"]["search"] == {"name": "cma", "sigma": 0.2, "global_share": 0, "carry_condition": 0.0,
                                            "global_keep": 0, "flip_gains": 0}
    assert data["runtime"] == {"workers": 1, "max_batch_robots": 64}
    assert EEAConfig.from_dict(json.loads(json.dumps(data))) == c       # config.json is the nested dict
    assert EEAConfig.from_dict({"rounds": 3, "inference": {"name": "known"}, "ga": {}}) \
        == EEAConfig(rounds=3, inference=KnownSettings())              # a section or field left out: its default
    with pytest.raises(ValueError, match="unknown EEAConfig keys \\['estimaton_population'\\]"):
        EEAConfig.from_dict({**data, "estimaton_population": 3})
    with pytest.raises(ValueError, match=r"unknown keys \['period'\] in EEAConfig.inference \(InBandSettings\)"):
        EEAConfig.from_dict({**data, "inference": {"name": "in_band", "period": 3}})   # another strategy's field
    with pytest.raises(ValueError, match="unknown inference 'guess'; valid names: known"):
        EEAConfig.from_dict({**data, "inference": {"name": "guess"}})
    with pytest.raises(ValueError, match="unknown EEAConfig keys \\['estimaton_population'\\]"):
        F({"estimaton_population": 3})


def test_a_flag_of_a_strategy_or_search_the_run_does_not_use_raises_unless_a_budget_or_default_gave_it():
    with pytest.raises(ValueError, match="EEAConfig.oob_period needs inference='out_of_band', got 'known'"):
        F({"inference": "known", "oob_period": 10})
    with pytest.raises(ValueError, match="EEAConfig.cma_sigma needs estimation_search='cma', got 'ga'"):
        F({"cma_sigma": 0.2})
    with pytest.raises(ValueError, match="EEAConfig.k_best needs inference='in_band', got 'profile'"):
        EEAConfig.from_method("profile_lineages", "smoke", k_best=3 - 1)
    with pytest.raises(ValueError, match="EEAConfig.profile_refine needs inference='profile', got 'none'"):
        EEAConfig.from_method("none", profile_refine=4)
    # a budget's or a method's field, or one at its default value, is dropped where its strategy does not run
    known = EEAConfig.from_method("known", "quick", oob_period=35, cma_sigma=0.3)
    assert known.inference == KnownSettings() and known.estimation.search == GASearchSettings()
    assert "oob_period" not in known.to_flat() and known.to_flat()["rounds"] == 8
    assert F({"inference": "known"}, optional={"oob_period": 10}) == F({"inference": "known"})
    # replace: the flat names again, explicit; switching the strategy drops the old one's settings
    oob = F({"oob_period": 10})
    assert oob.replace(inference="in_band").inference == InBandSettings()
    assert oob.replace(oob_sample=2).inference == OutOfBandSettings(period=10, sample=2)
    with pytest.raises(ValueError, match="EEAConfig.oob_period needs inference='out_of_band', got 'none'"):
        oob.replace(inference="none", oob_period=12)
    assert dataclasses.replace(oob, inference=InBandSettings(k_best=2)).to_flat()["k_best"] == 2  # a whole section


def test_same_results_ignores_workers_chunking_and_rounds():
    from eea.config import RESULT_NEUTRAL_FIELDS

    c = F({"workers": 1})
    assert RESULT_NEUTRAL_FIELDS == ("runtime", "rounds")
    assert c.same_results_as(c.replace(workers=2, max_batch_robots=7, rounds=40))
    assert not c.same_results_as(c.replace(seed=1))
    assert not c.same_results_as(c.replace(inference="none"))


def test_the_best_method_spells_out_the_published_lineage_runs():
    # docs/results/lph_lin2 (docs/self_modeling.md) ran the best method at the reduced budget
    published = json.loads((Path(__file__).parents[2] / "docs/results/lph_lin2/study.json").read_text())["base"]
    from eea.compat import upgrade_flat_fields

    ran = F({"inference": "profile"}, optional=upgrade_flat_fields(published))  # its condition, "profile", set inference
    assert ran.waterline is None                                      # written before the surface swimmer: deep water
    assert ran.same_results_as(EEAConfig.from_method("profile_lineages", "reduced", seed=ran.seed, waterline=None))
    assert method_of(ran) == "profile_lineages"


def test_budgets_and_methods_are_independent_axes_and_fields_win():
    assert EEAConfig.from_method("out_of_band") == EEAConfig.from_method("out_of_band", "paper") == EEAConfig()
    reduced = EEAConfig.from_method("out_of_band", "reduced")
    assert (reduced.rounds, reduced.estimation.generations, reduced.exploration.generations, reduced.inference.period) \
        == (10, 30, 10, 10)
    assert reduced.replace(rounds=25, estimation_generations=100, exploration_generations=25, oob_period=35) \
        == EEAConfig()                                   # nothing else differs from the paper's settings
    c = EEAConfig.from_method("profile_lineages", "reduced", damage="caudal_half", rounds=4)
    assert (c.inference.name, c.estimation.search.name, c.inference.library, c.damage, c.rounds) \
        == ("profile", "cma", 8, "caudal_half", 4)
    for method in METHODS.values():
        assert not set(method.fields) & set().union(*BUDGETS.values())     # the axes share no field
        for budget in BUDGETS:                                             # every method runs at every budget
            assert method_of(EEAConfig.from_method(method.name, budget, seed=3)) == method.name
    assert method_of(F({"inference": "profile"})) == "custom"              # a method's field missing: no name
    assert method_of(F({"inference": "none", "lineages": 2})) == "custom"  # another method's field set: no name
    with pytest.raises(ValueError, match="unknown method 'library'; valid names: known, none, in_band, out_of_band"):
        EEAConfig.from_method("library")
    with pytest.raises(ValueError, match="unknown budget 'fast'; valid names: smoke, quick, reduced, medium, paper"):
        EEAConfig.from_method("none", "fast")
    with pytest.raises(ValueError, match="unknown EEAConfig keys"):
        EEAConfig.from_method("none", "reduced", round=3)


def test_a_config_written_before_the_retirement_loads_unless_it_used_a_retired_variant():
    from eea.compat import RETIRED_FIELDS

    old = {**FLAT_DEFAULTS, "workers": 1, **RETIRED_FIELDS}     # config.json of a run before the retirement
    assert EEAConfig.from_dict(old) == F({"workers": 1})
    assert not set(RETIRED_FIELDS) & set(FLAT_FIELDS)
    with pytest.raises(ValueError, match=r"EEAConfig.profile_scan = 1: this run used a retired variant"):
        EEAConfig.from_dict({**old, "profile_scan": 1})
    with pytest.raises(ValueError, match="unknown EEAConfig keys"):
        EEAConfig.from_method("profile_lineages", profile_scan=0)               # a new config cannot set one
    servos = {**FLAT_DEFAULTS, "estimation_search": "cma", "model_space": "morphology+servos", "cma_flip_gains": 2}
    with pytest.raises(ValueError, match=r"EEAConfig.cma_flip_gains = 2: this run used a retired variant"):
        EEAConfig.from_dict(servos)                                            # the fault classes
    assert EEAConfig.from_dict({**servos, "cma_flip_gains": 1}).estimation.search.flip_gains == 1
    with pytest.raises(ValueError, match=r"EEAConfig.cma_global_flip = 1: this run used a retired variant"):
        EEAConfig.from_dict({**servos, "cma_flip_gains": 1, "cma_global_flip": 1})  # the global flip


def test_a_nested_config_written_before_a_retirement_loads_unless_it_used_the_retired_variant():
    """A ``config.json`` with sections (written since 2026-11-2x) holds out-of-band's ``draw``
    from before its retirement: at its default ("best") the run is today's out-of-band, at
    "random" it ran the retired variant; a run of the retired model space is refused by name."""
    oob = F({"oob_period": 10})
    written = oob.to_dict()
    assert EEAConfig.from_dict({**written, "inference": {**written["inference"], "draw": "best"}}) == oob
    with pytest.raises(ValueError, match=r"EEAConfig.inference.draw = 'random': this run used a retired variant"):
        EEAConfig.from_dict({**written, "inference": {**written["inference"], "draw": "random"}})
    known = F({"inference": "known"}).to_dict()                  # another strategy's section keeps its keys
    with pytest.raises(ValueError, match=r"unknown keys \['draw'\] in EEAConfig.inference"):
        EEAConfig.from_dict({**known, "inference": {**known["inference"], "draw": "best"}})
    with pytest.raises(ValueError, match=r"EEAConfig.model_space = 'morphology_nonzero': this run used a retired"):
        EEAConfig.from_dict({**written, "model_space": "morphology_nonzero"})
    with pytest.raises(ValueError, match=r"EEAConfig.model_space = 'morphology_nonzero': this run used a retired"):
        EEAConfig.from_dict({**FLAT_DEFAULTS, "model_space": "morphology_nonzero"})     # flat
    with pytest.raises(ValueError, match="unknown EEAConfig keys"):
        F({"oob_draw": "best"})                                   # a new config cannot set it


#: One published config.json of each kind the loader must read (tests/data/published_configs/README.md).
PUBLISHED_CONFIGS = Path(__file__).parents[1] / "data/published_configs"


def test_every_kind_of_published_config_loads_or_names_its_retired_variant():
    from eea.compat import RETIRED_FIELDS, RETIRED_VALUES

    loaded = refused = 0
    methods = set()
    for path in sorted(PUBLISHED_CONFIGS.glob("*.json")):
        data = json.loads(path.read_text())
        retired = [k for k in RETIRED_FIELDS if k in data and data[k] != RETIRED_FIELDS[k]]
        retired += [k for k in RETIRED_VALUES if data.get(k) in RETIRED_VALUES[k]]
        if retired:
            with pytest.raises(ValueError, match="used a retired variant"):
                EEAConfig.from_dict(data)
            refused += 1
        else:
            config = EEAConfig.from_dict(data)     # flat: through eea.compat
            assert EEAConfig.from_dict(config.to_dict()) == config
            assert method_of(config) == _flat_method_of(data), path   # named as the flat fields name it
            assert path.name.startswith(method_of(config) + "_"), path  # the kind the file is named after
            methods.add(method_of(config))
            loaded += 1
    assert (loaded, refused) == (11, 8) and methods == {"custom", *METHODS}


def _flat_method_of(data: dict) -> str:
    """The method a flat config dict runs, by its flat fields (every field any method sets has
    the method's value, or its default)."""
    keys = {key for m in METHODS.values() for key in m.fields}
    for name, m in METHODS.items():
        if all(data.get(k, FLAT_DEFAULTS[k]) == m.fields.get(k, FLAT_DEFAULTS[k]) for k in keys):
            return name
    return "custom"


def test_a_flat_published_config_and_its_nested_upgrade_are_the_same_run():
    methods = set()
    for name in ("profile_lineages_deep_morphology_dft", "in_band_surface_morphology_dft",
                 "known_surface_morphology_dft", "out_of_band_deep_morphology_dft"):
        flat = json.loads((PUBLISHED_CONFIGS / f"{name}.json").read_text())
        config, nested = EEAConfig.from_dict(flat), nest_flat(upgrade_flat_fields(flat))
        assert EEAConfig.from_dict(nested) == config and config.to_dict()["inference"]["name"] == flat["inference"]
        assert all(flat[k] == v for k, v in config.to_flat().items() if k in flat)   # every used field kept
        methods.add(method_of(config))
        assert method_of(EEAConfig.from_dict(config.to_dict())) == method_of(config)
    assert methods == {"profile_lineages", "in_band", "known", "out_of_band"}
    # the inactive strategies' fields of a flat file are dropped, whatever their values (they did nothing)
    flat = {**FLAT_DEFAULTS, "inference": "known", "oob_period": 10, "cma_sigma": 0.9}
    assert EEAConfig.from_dict(flat).inference == KnownSettings()
    assert EEAConfig.from_dict({k: v for k, v in flat.items() if k != "waterline"}).waterline is None  # deep water


def test_behaviour_summary_is_named_and_checked():
    assert EEAConfig().behaviour_summary == "dft"                        # the paper's
    assert F({"behaviour_summary": "signed_dft"}).behaviour_summary == "signed_dft"
    assert F({"behaviour_summary": "gyro_dft"}).behaviour_summary == "gyro_dft"
    with pytest.raises(ValueError, match="unknown behaviour_summary 'signed'; valid names: dft, signed_dft, gyro_dft"):
        EEAConfig(behaviour_summary="signed")
