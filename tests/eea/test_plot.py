"""eea.plot: mean and std objective fitness per (strategy, duration) from run directories."""

import numpy as np
import pytest

from eea.config import EEAConfig
from eea.plot import final_round_table, find_runs, plot_runs, summarise_runs
from eea.record import ROUND_COLUMNS, write_config, write_rounds


def _fake_run(path, inference, seed, objective, duration_s=1.28):
    path.mkdir(parents=True)
    write_config(path, EEAConfig(inference=inference, seed=seed, rounds=len(objective), duration_s=duration_s,
                                 workers=1))
    rows = [{c: 0.0 for c in ROUND_COLUMNS} | {"round": i + 1, "objective_fitness": v, "target_experiments": i + 1,
                                               "simulations": 10} for i, v in enumerate(objective)]
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
    assert rows[1].split() == ["known", "1.28", "1", "1", "1.0000", "0.0000"]
    assert rows[2].split() == ["out_of_band", "1.28", "2", "2", "0.8000", "0.1000"]


def test_no_runs_raises(tmp_path):
    with pytest.raises(ValueError, match="no EEA run"):
        find_runs([tmp_path])
    with pytest.raises(ValueError, match="does not exist"):
        find_runs([tmp_path / "nope"])
