"""EEAConfig: the paper's defaults (section 4) and validation with clear errors."""

import dataclasses
import json
from pathlib import Path

import pytest

from eea.config import FIELD_HELP, EEAConfig
from eea.methods import BUDGETS, METHODS, method_of


def test_defaults_are_the_papers():
    c = EEAConfig()
    assert (c.inference, c.damage, c.duration_s, c.rounds) == ("out_of_band", "left_pectoral_half", 1.28, 25)
    assert (c.exploration_population, c.exploration_generations) == (25, 25)
    assert (c.estimation_population, c.estimation_generations) == (25, 100)
    assert (c.crossover_rate, c.tournament_size, c.mutation_bits) == (0.75, 2, 1.0)
    assert (c.k_best, c.in_band_confidence, c.oob_period, c.oob_sample) == (3, 0.5, 35, 5)
    assert c.steps == 128 and EEAConfig(duration_s=10.24).steps == 1024 and c.workers >= 1


def test_every_field_has_help():
    assert set(FIELD_HELP) == {f.name for f in dataclasses.fields(EEAConfig)}


@pytest.mark.parametrize("changes, match", [
    ({"inference": "telepathy"}, "valid names: known, none, in_band, out_of_band"),
    ({"damage": "dented"}, "valid names: .*left_pectoral_half"),
    ({"duration_s": 0.015}, "multiple of 0.01"),
    ({"duration_s": 0.01}, "at least 2 steps"),
    ({"rounds": 0}, "rounds must be an int >= 1"),
    ({"rounds": 2.0}, "rounds must be an int"),
    ({"estimation_population": 1}, "estimation_population must be an int >= 2"),
    ({"k_best": 26}, "k_best .* must be <= estimation_population"),
    ({"oob_sample": 30}, "oob_sample"),
    ({"crossover_rate": 1.5}, "crossover_rate must be in"),
    ({"in_band_confidence": float("nan")}, "in_band_confidence"),
    ({"mutation_bits": -1}, "mutation_bits"),
    ({"workers": 0}, "workers"),
])
def test_invalid_values_raise(changes, match):
    with pytest.raises(ValueError, match=match):
        EEAConfig(**changes)


def test_dict_round_trip_and_unknown_keys():
    c = EEAConfig(inference="in_band", seed=7, workers=1)
    assert EEAConfig.from_dict(c.to_dict()) == c
    with pytest.raises(ValueError, match="unknown EEAConfig keys \\['estimaton_population'\\]"):
        EEAConfig.from_dict({**c.to_dict(), "estimaton_population": 3})


def test_same_results_ignores_workers_chunking_and_rounds():
    c = EEAConfig(workers=1)
    assert c.same_results_as(c.replace(workers=2, max_batch_robots=7, rounds=40))
    assert not c.same_results_as(c.replace(seed=1))
    assert not c.same_results_as(c.replace(inference="none"))


def test_the_best_method_spells_out_the_published_lineage_runs():
    # docs/results/lph_lin2 (docs/self_modeling.md) ran the best method at the reduced budget
    published = json.loads((Path(__file__).parents[2] / "docs/results/lph_lin2/study.json").read_text())["base"]
    ran = EEAConfig.from_dict(published).replace(inference="profile")  # its condition, "profile", set inference
    assert ran.waterline is None                                      # written before the surface swimmer: deep water
    assert ran.same_results_as(EEAConfig.from_method("profile_lineages", "reduced", seed=ran.seed, waterline=None))
    assert method_of(ran) == "profile_lineages"


def test_budgets_and_methods_are_independent_axes_and_fields_win():
    assert EEAConfig.from_method("out_of_band") == EEAConfig.from_method("out_of_band", "paper") == EEAConfig()
    reduced = EEAConfig.from_method("out_of_band", "reduced")
    assert (reduced.rounds, reduced.estimation_generations, reduced.exploration_generations, reduced.oob_period) \
        == (10, 30, 10, 10)
    assert reduced.replace(rounds=25, estimation_generations=100, exploration_generations=25, oob_period=35) \
        == EEAConfig()                                   # nothing else differs from the paper's settings
    c = EEAConfig.from_method("profile_lineages", "reduced", damage="caudal_half", rounds=4)
    assert (c.inference, c.estimation_search, c.profile_library, c.damage, c.rounds) == ("profile", "cma", 8, "caudal_half", 4)
    for method in METHODS.values():
        assert not set(method.fields) & set().union(*BUDGETS.values())     # the axes share no field
        for budget in BUDGETS:                                             # every method runs at every budget
            assert method_of(EEAConfig.from_method(method.name, budget, seed=3)) == method.name
    assert method_of(EEAConfig(inference="profile")) == "custom"           # a method's field missing: no name
    assert method_of(EEAConfig(inference="none", lineages=2)) == "custom"  # another method's field set: no name
    with pytest.raises(ValueError, match="unknown method 'library'; valid names: known, none, in_band, out_of_band"):
        EEAConfig.from_method("library")
    with pytest.raises(ValueError, match="unknown budget 'fast'; valid names: smoke, quick, reduced, medium, paper"):
        EEAConfig.from_method("none", "fast")
    with pytest.raises(ValueError, match="unknown EEAConfig keys"):
        EEAConfig.from_method("none", "reduced", round=3)


def test_a_config_written_before_the_retirement_loads_unless_it_used_a_retired_variant():
    from eea.compat import RETIRED_FIELDS

    old = {**EEAConfig(workers=1).to_dict(), **RETIRED_FIELDS}          # config.json of a run before the retirement
    assert EEAConfig.from_dict(old) == EEAConfig(workers=1)
    assert not set(RETIRED_FIELDS) & set(EEAConfig().to_dict())
    with pytest.raises(ValueError, match=r"EEAConfig.profile_scan = 1: this run used a retired variant"):
        EEAConfig.from_dict({**old, "profile_scan": 1})
    with pytest.raises(ValueError, match="unknown EEAConfig keys"):
        EEAConfig.from_method("profile_lineages", profile_scan=0)               # a new config cannot set one
    servos = {**EEAConfig(estimation_search="cma", model_space="morphology+servos").to_dict(), "cma_flip_gains": 2}
    with pytest.raises(ValueError, match=r"EEAConfig.cma_flip_gains = 2: this run used a retired variant"):
        EEAConfig.from_dict(servos)                                            # the fault classes
    assert EEAConfig.from_dict({**servos, "cma_flip_gains": 1}).cma_flip_gains == 1
    with pytest.raises(ValueError, match=r"EEAConfig.cma_global_flip = 1: this run used a retired variant"):
        EEAConfig.from_dict({**servos, "cma_flip_gains": 1, "cma_global_flip": 1})  # the global flip


def test_every_published_config_loads_or_names_its_retired_variant():
    from eea.compat import RETIRED_FIELDS, RETIRED_VALUES

    results = Path(__file__).parents[2] / "docs/results"
    loaded = refused = 0
    for path in sorted(results.glob("**/config.json")):
        data = json.loads(path.read_text())
        retired = [k for k in RETIRED_FIELDS if k in data and data[k] != RETIRED_FIELDS[k]]
        retired += [k for k in RETIRED_VALUES if data.get(k) in RETIRED_VALUES[k]]
        if retired:
            with pytest.raises(ValueError, match="used a retired variant"):
                EEAConfig.from_dict(data)
            refused += 1
        else:
            EEAConfig.from_dict(data)
            loaded += 1
    assert loaded > 100 and refused > 0


def test_behaviour_summary_is_named_and_checked():
    assert EEAConfig().behaviour_summary == "dft"                        # the paper's
    assert EEAConfig(behaviour_summary="signed_dft").behaviour_summary == "signed_dft"
    with pytest.raises(ValueError, match="unknown behaviour_summary 'signed'; valid names: dft, signed_dft"):
        EEAConfig(behaviour_summary="signed")
