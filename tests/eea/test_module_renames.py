"""The modules moved into :mod:`eea.search` and :mod:`eea.inference` leave no shim at
their old paths, and pickles naming the old paths still load through
:data:`eea.compat.MODULE_RENAMES` (the checkpoints of ``tests/eea/data`` are checked end to
end by ``test_checkpoint_compat.py``)."""

import importlib
import io
import pickle
from pathlib import Path

import numpy as np
import pytest

import eea
from eea.compat import MODULE_RENAMES, RenamingUnpickler, loads

#: The classes and functions every moved module defined before the move (commit f83ff8c).
BEFORE = {
    "eea.cma_search": ["unit_to_genomes", "genomes_to_unit", "carried_shape", "_StandardNormal", "CMAModelSearch"],
    "eea.model_search": ["ModelSearch", "ModelGA", "check_model_search", "_search_class", "make_model_search",
                         "model_search_from_state"],
    # lineage_columns and write_lineages, record-keeping functions a checkpoint never pickles,
    # have moved on to eea.record since
    "eea.lineages": ["LineageStrategies", "Lineages", "make_estimation", "make_strategy",
                     "estimation_from_state", "chosen_inference_state"],
    "eea.strategy": ["InferenceStrategy"],
    "eea.profile": ["Profile", "_into_range", "_check_fit_arrays", "_angle_distance"],
    "eea.selection": ["Selection", "select_model"],
}
#: eea.inference kept its path (a package now); what the module defined, the package exports.
INFERENCE_BEFORE = ["Known", "NoInference", "InBand", "OutOfBand", "make_inference", "InferenceStrategy",
                    "INFERENCE_STRATEGIES", "INFERENCE_NAMES"]


def test_the_map_covers_every_moved_module_and_no_shim_is_left():
    assert set(MODULE_RENAMES) == set(BEFORE)
    root = Path(eea.__file__).parent
    for old in MODULE_RENAMES:
        rest = old.split(".")[1:]
        assert not root.joinpath(*rest[:-1], f"{rest[-1]}.py").exists(), old
        assert not root.joinpath(*rest, "__init__.py").exists(), old


@pytest.mark.parametrize("old", sorted(BEFORE))
def test_every_name_of_a_moved_module_is_found_under_its_old_path(old):
    unpickler = RenamingUnpickler(io.BytesIO(b""))
    new = importlib.import_module(MODULE_RENAMES[old])
    for name in BEFORE[old]:
        assert unpickler.find_class(old, name) is getattr(new, name)


def test_the_inference_package_keeps_the_old_modules_names():
    import eea.inference
    for name in INFERENCE_BEFORE:
        assert hasattr(eea.inference, name), name


def test_a_cma_search_pickled_under_its_old_path_loads():
    from eea.search.cma import CMAModelSearch
    search = CMAModelSearch(8, np.random.default_rng(0))
    search.ask()
    search.tell(np.arange(8.0))
    data = pickle.dumps(search, protocol=0)  # text GLOBAL opcodes: the module path can be swapped
    assert b"ceea.search.cma\n" in data
    old = data.replace(b"ceea.search.cma\n", b"ceea.cma_search\n")
    back = loads(old)
    assert type(back) is CMAModelSearch
    assert np.array_equal(back.ask(), pickle.loads(data).ask())
    restored = CMAModelSearch.from_state_dict({"search": "cma", "pickle": old})
    assert np.array_equal(restored.best_genome, search.best_genome)
