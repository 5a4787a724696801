"""Golden ``rounds.csv`` of tiny runs: every inference strategy with both estimation searches,
the ``library`` preset and the best method, the ``lineages`` preset.

The files in ``tests/eea/test_golden_rounds/`` were recorded on main before the EEA's
composition was reshaped and must stay identical, except the ``wall_seconds``
column: every text field and integer byte for byte, every real number to 1e-12 relative
(:func:`_same_rounds`; the last bit of a NumPy sum can differ between machines, by the CPU's
SIMD paths: one action fitness came out 0.011514829633879634 against ...963 on another machine,
with NumPy 2.4.5 and 2.4.6 alike). A refactor that changes one random draw,
one cache key or one tournament moves numbers by far more and shows up here (``profile_*`` and ``library*`` were recorded later, when they
were added). A change that is *meant* to change results (new physics, a
new algorithm setting) regenerates them with
``pytest tests/eea/test_golden_rounds.py --force-regen`` and says so in its commit. They run
in deep water (``waterline=None``, the ``tiny_config`` fixture), the physics they were
recorded in; ``surface_*`` are the default physics, the surface swimmer.
"""

import csv
import io

import pytest

import eea
from eea.methods import method_fields

#: (inference, extra config) of every recorded run; each with the GA and with CMA-ES.
VARIANTS = {
    "known": dict(inference="known"),
    "none": dict(inference="none"),
    "in_band": dict(inference="in_band"),
    "out_of_band": dict(inference="out_of_band"),
    "profile": dict(inference="profile"),
}

#: Not the paper's, CMA-ES only (the global share and the carried covariance are CMA-ES
#: options): the best method in one lineage, once the ``library`` preset (population 10, the
#: smallest its global share of 8 allows; docs/self_modeling.md). The options once measured on top of it were
#: retired with their golden file (docs/studies/retired_variants.md).
LIBRARY = {k: v for k, v in method_fields("profile_lineages").items() if k not in ("lineages", "cma_global_keep")}
CMA_VARIANTS = {
    "library": dict(LIBRARY, estimation_population=10),
}


def _without_wall_seconds(path) -> str:
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        columns = [c for c in reader.fieldnames if c != "wall_seconds"]
        rows = list(reader)
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=columns, extrasaction="ignore", lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    return out.getvalue()


def _cells(path) -> list[list[str]]:
    with open(path, newline="") as f:
        return list(csv.reader(f))


def _same_rounds(obtained, expected) -> None:
    """``file_regression``'s ``check_fn``: the two CSV files have the same header and cells, real
    numbers equal to 1e-12 relative (see the module docstring), everything else exactly."""
    got, want = _cells(obtained), _cells(expected)
    assert len(got) == len(want) and got[0] == want[0], f"{obtained}: other rows or columns than {expected}"
    for row, (a, b) in enumerate(zip(got[1:], want[1:]), start=2):
        assert len(a) == len(b), f"{obtained} line {row}: {len(a)} cells, expected {len(b)}"
        for column, x, y in zip(want[0], a, b):
            if x == y:
                continue
            try:
                close = "." in x + y and float(x) == pytest.approx(float(y), rel=1e-12, abs=1e-15)
            except ValueError:
                close = False
            assert close, f"{obtained} line {row}, {column}: {x} != {y} (recorded)"


def _check_recorded_run(tmp_path, config, file_regression, basename: str) -> None:
    """Run ``config`` (3 rounds) and compare its ``rounds.csv`` with ``basename``.csv."""
    eea.run(config, tmp_path, progress=False)
    text = _without_wall_seconds(tmp_path / "rounds.csv")
    assert text.count("\n") == 4                                  # header + 3 rounds
    file_regression.check(text, basename=basename, extension=".csv", check_fn=_same_rounds)


@pytest.mark.parametrize("search", ["ga", "cma"])
@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_rounds_csv_matches_the_recorded_run(tmp_path, tiny_config, file_regression, variant, search):
    _check_recorded_run(tmp_path, tiny_config(rounds=3, seed=7, estimation_search=search, **VARIANTS[variant]),
                        file_regression, f"{variant}_{search}")


#: The surface swimmer (the default physics; the runs above pin deep water, the
#: physics they were recorded in): the paper's four strategies, recorded when it landed.
SURFACE_VARIANTS = ("known", "none", "in_band", "out_of_band")


@pytest.mark.parametrize("variant", SURFACE_VARIANTS)
def test_surface_rounds_csv_matches_the_recorded_run(tmp_path, tiny_config, file_regression, variant):
    from aquafish_gym.params import DEFAULT_WATERLINE

    _check_recorded_run(tmp_path, tiny_config(rounds=3, seed=7, estimation_search="ga", waterline=DEFAULT_WATERLINE,
                                              **VARIANTS[variant]), file_regression, f"surface_{variant}_ga")


@pytest.mark.parametrize("variant", sorted(CMA_VARIANTS))
def test_library_rounds_csv_matches_the_recorded_run(tmp_path, tiny_config, file_regression, variant):
    _check_recorded_run(tmp_path, tiny_config(rounds=3, seed=7, **CMA_VARIANTS[variant]), file_regression,
                        f"{variant}_cma")


def test_lineages_rounds_and_lineages_csv_match_the_recorded_run(tmp_path, tiny_config, file_regression):
    """The best method (the ``lineages`` preset): its ``rounds.csv`` and its
    ``lineages.csv`` (recorded before :mod:`eea` was split into subpackages)."""
    config = tiny_config(rounds=3, seed=7, **dict(method_fields("profile_lineages"), estimation_population=10))
    _check_recorded_run(tmp_path, config, file_regression, "lineages_cma")
    lineages = (tmp_path / "lineages.csv").read_text()
    assert lineages.count("\n") == 1 + 3 * 2                      # header + 3 rounds x 2 lineages
    file_regression.check(lineages, basename="lineages_cma_lineages", extension=".csv", check_fn=_same_rounds)
