"""Checkpoints written before the reshaping of :mod:`eea` (retired variants, subpackages) still
resume, and the resumed run gives the golden rows bit for bit.

``tests/eea/data/checkpoints_before_the_split/`` holds two tiny runs stopped after round 2 of 3,
written by the code of commit eb57391 (before the change): the best method (the ``lineages``
preset, CMA-ES) and the paper's out-of-band strategy with the GA. Their ``config.json`` and
``state.pkl`` carry every field of that day's :class:`~eea.config.EEAConfig`, retired ones
included (at their defaults). Resumed to round 3 they must write the rows of the uninterrupted
golden runs (``tests/eea/test_golden_rounds/``).
"""

import json
import pickletools
import shutil
from pathlib import Path

import pytest

import eea
from eea.config import EEAConfig

from test_golden_rounds import _without_wall_seconds

DATA = Path(__file__).parent / "data" / "checkpoints_before_the_split"
GOLDEN = Path(__file__).parent / "test_golden_rounds"
RUNS = ("lineages_cma", "out_of_band_ga")


@pytest.mark.parametrize("name", RUNS)
def test_a_checkpoint_written_before_the_split_resumes_to_the_golden_rows(tmp_path, name):
    out = tmp_path / name
    shutil.copytree(DATA / f"{name}_round2", out)
    flat = json.loads((out / "config.json").read_text())
    assert "oob_period" in flat and "estimation" not in flat       # written before the sections: flat
    config = EEAConfig.from_dict({**flat, "rounds": 3})             # through eea.compat
    result = eea.run(config, out, progress=False)
    assert len(result.rounds) == 3
    assert _without_wall_seconds(out / "rounds.csv") == (GOLDEN / f"{name}.csv").read_text()
    # the resumed run writes today's nested config.json and checkpoint config, of the same run
    nested = json.loads((out / "config.json").read_text())
    assert nested == config.to_dict() and nested["inference"]["name"] == flat["inference"]
    from eea.checkpoint import load_state

    assert load_state(out).config == nested and EEAConfig.from_dict(flat).same_results_as(config)
    if name == "lineages_cma":
        assert (out / "lineages.csv").read_text() == (GOLDEN / "lineages_cma_lineages.csv").read_text()


def _eea_globals(data: bytes) -> set[str]:
    """Modules of the eea classes a pickle references, also inside pickles nested as bytes."""
    found, last = set(), []
    for op, arg, _ in pickletools.genops(data):
        if isinstance(arg, bytes) and arg[:1] == b"\x80":
            try:
                found |= _eea_globals(arg)
            except Exception:
                pass
        if isinstance(arg, str):
            last.append(arg)
            if op.name == "GLOBAL":
                last = [arg.split()[0]]
            if last[-1].split(".")[0] == "eea":
                found.add(last[-1])
    return found


def test_checkpoints_pickle_only_the_cma_search_class():
    """The CMA-ES search is pickled whole (its pycma state), under eea.cma_search: moving that
    module needs an alias for these checkpoints; every other eea object is a plain dict."""
    assert _eea_globals((DATA / "out_of_band_ga_round2" / "state.pkl").read_bytes()) == set()
    assert _eea_globals((DATA / "lineages_cma_round2" / "state.pkl").read_bytes()) == {"eea.cma_search"}
