"""eea.analysis.plot: mean and std objective fitness per (strategy, duration) from run directories."""

import numpy as np
import pytest

from eea.config import EEAConfig
from eea.analysis.plot import final_round_table, find_runs, plot_runs, summarise_runs, welch_p_value
from eea.record import ROUND_COLUMNS, load_result, write_config, write_rounds


def _fake_run(path, inference, seed, objective, duration_s=1.28, angles=None):
    """A run directory with the given OBJ_FIT per round; ``angles``: per round ((true 3), (inferred 3)) rad."""
    path.mkdir(parents=True)
    write_config(path, EEAConfig.from_flat(dict(inference=inference, seed=seed, rounds=len(objective),
                                                 duration_s=duration_s, workers=1)))
    rows = [{c: 0.0 for c in ROUND_COLUMNS} | {"round": i + 1, "objective_fitness": v, "target_experiments": i + 1,
                                               "simulations": 10} for i, v in enumerate(objective)]
    for row, (true, inferred) in zip(rows, angles or []):
        row.update({f"true_{f}_rad": a for f, a in zip(("left", "right", "caudal"), true)})
        row.update({f"inferred_{f}_rad": a for f, a in zip(("left", "right", "caudal"), inferred)})
    write_rounds(path, rows)


def test_plot_means_and_table(tmp_path):
    _fake_run(tmp_path / "known" / "seed0", "known", 0, [0.6, 0.8, 1.0])
    _fake_run(tmp_path / "known" / "seed1", "known", 1, [0.8, 0.9, 0.9])
    _fake_run(tmp_path / "none" / "seed0", "none", 0, [0.5, 0.6, 0.7])
    (tmp_path / "empty").mkdir()
    summary = summarise_runs(find_runs([tmp_path]))
    np.testing.assert_allclose(summary[("known", 1.28)].mean, [0.7, 0.85, 0.95])
    np.testing.assert_allclose(summary[("known", 1.28)].std, [0.1, 0.05, 0.05])
    assert summary[("none", 1.28)].runs == 1
    table = plot_runs([tmp_path / "known", tmp_path / "none" / "seed0"], tmp_path / "out" / "fig.png")
    assert (tmp_path / "out" / "fig.png").stat().st_size > 1000
    assert not list((tmp_path / "out").glob("*.tmp*"))
    assert "known" in table and "0.9500" in table and "0.7000" in table


def test_groups_by_duration_truncate_to_common_rounds_and_keep_paper_order(tmp_path):
    _fake_run(tmp_path / "oob" / "seed0", "out_of_band", 0, [0.5, 0.7, 0.9])
    _fake_run(tmp_path / "oob" / "seed1", "out_of_band", 1, [0.7, 0.9])  # unfinished: 2 of 3 rounds
    _fake_run(tmp_path / "oob_long" / "seed0", "out_of_band", 0, [0.9], duration_s=2.56)
    _fake_run(tmp_path / "known" / "seed0", "known", 0, [1.0])
    summary = summarise_runs(find_runs([tmp_path]))
    assert list(summary) == [("known", 1.28), ("out_of_band", 1.28), ("out_of_band", 2.56)]
    np.testing.assert_allclose(summary[("out_of_band", 1.28)].mean, [0.6, 0.8])  # rounds every run reached
    np.testing.assert_allclose(summary[("out_of_band", 1.28)].std, [0.1, 0.1])
    rows = final_round_table(summary).splitlines()
    assert rows[1].split() == ["known", "1.28", "1", "1", "1.0000", "0.0000", "-", "0.0", "0.0", "0.0"]
    assert rows[2].split() == ["out_of_band", "1.28", "2", "2", "0.8000", "0.1000", "-", "0.0", "0.0", "0.0"]


def test_inference_error_wraps_pectorals_but_not_the_caudal_fin(tmp_path):
    # round 1: left 0.1 vs 2 pi - 0.1 (0.2 rad = 11.459 deg through 0), right pi vs 0 (180),
    #          caudal -0.25 vs 0.25 (0.5 rad = 28.648 deg); round 2: exact
    _fake_run(tmp_path / "r", "out_of_band", 0, [0.5, 0.6],
              angles=[((0.1, np.pi, -0.25), (2 * np.pi - 0.1, 0.0, 0.25)), ((1.0, 2.0, 0.1), (1.0, 2.0, 0.1))])
    errors = load_result(tmp_path / "r").inference_error_deg
    np.testing.assert_allclose(errors, [[11.459156, 180.0, 28.647890], [0.0, 0.0, 0.0]], atol=1e-5)
    summary = summarise_runs(find_runs([tmp_path]))
    np.testing.assert_allclose(summary[("out_of_band", 1.28)].median_error_deg, [5.729578, 90.0, 14.323945],
                               atol=1e-5)


def test_welch_p_value_against_none_hand_computed(tmp_path):
    # t = (0.7 - 0.6) / sqrt(0.02/2 + 0.02/2) = 0.70711 with 2 degrees of freedom (Welch-Satterthwaite);
    # the t(2) cdf is 1/2 + t / (2 sqrt(2 + t^2)), so p = 1 - t / sqrt(2 + t^2) = 1 - 0.70711/1.58114 = 0.55279
    assert welch_p_value([0.6, 0.8], [0.5, 0.7]) == pytest.approx(0.552786, abs=1e-6)
    assert np.isnan(welch_p_value([0.6], [0.5, 0.7]))
    assert np.isnan(welch_p_value([0.6, 0.6], [0.5, 0.5]))
    _fake_run(tmp_path / "oob0", "out_of_band", 0, [0.6])
    _fake_run(tmp_path / "oob1", "out_of_band", 1, [0.8])
    _fake_run(tmp_path / "none0", "none", 0, [0.5])
    _fake_run(tmp_path / "none1", "none", 1, [0.7])
    _fake_run(tmp_path / "known_long", "known", 0, [1.0], duration_s=2.56)  # no none at 2.56 s
    rows = {line.split()[0]: line.split() for line in final_round_table(summarise_runs(find_runs([tmp_path]))).splitlines()}
    assert rows["out_of_band"][6] == "0.553"
    assert rows["none"][6] == "-" and rows["known"][6] == "-"


def test_no_runs_raises(tmp_path):
    with pytest.raises(ValueError, match="no EEA run"):
        find_runs([tmp_path])
    with pytest.raises(ValueError, match="does not exist"):
        find_runs([tmp_path / "nope"])


def test_runs_found_in_natural_seed_order(tmp_path):
    for seed in (10, 2, 1, 0):
        _fake_run(tmp_path / "s" / f"seed{seed}", "none", seed, [0.5])
    assert [r.out_dir.name for r in find_runs([tmp_path])] == ["seed0", "seed1", "seed2", "seed10"]
