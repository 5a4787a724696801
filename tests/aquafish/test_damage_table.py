"""The damage table (aquafish.damage_table): rows, ratio, qualification, reuse of evolved gaits."""

import json

import numpy as np

import pytest

from aquafish.damage_table import QUALIFY_RATIO, GaitBudget, damage_table, format_table
from aquafish.cli import main

TINY = GaitBudget(generations=1, population_size=2, episodes_per_genome=1, seed=0, workers=1)


def test_damage_table_rows_ratio_and_reuse(tmp_path):
    rows = damage_table(tmp_path, damages=["caudal_missing"], budget=TINY, starts=2, eval_seed=100)
    (row,) = rows
    assert row["damage"] == "caudal_missing"
    healthy, oracle = row["healthy_gait_on_damaged"], row["oracle_gait_on_damaged"]
    assert len(healthy["distances"]) == 2 and healthy["mean"] == pytest.approx(sum(healthy["distances"]) / 2)
    if oracle["mean"] > 0:
        assert row["recovery_needed"] == pytest.approx(healthy["mean"] / oracle["mean"])
        assert row["qualifies"] == (row["recovery_needed"] <= QUALIFY_RATIO
                                    and oracle["mean"] >= QUALIFY_RATIO * row["healthy_gait_on_healthy"]["mean"])
    else:
        assert row["recovery_needed"] is None and not row["qualifies"]
    # a tailless robot cannot use the tail-driven swimming of the healthy robot
    assert healthy["mean"] < 0.2 * row["healthy_gait_on_healthy"]["mean"] or row["healthy_gait_on_healthy"]["mean"] <= 0
    long = row["healthy_gait_on_damaged_long"]                    # the same gait over 60 s episodes
    assert len(long["distances"]) == 2 and row["healthy_gait_on_healthy_long"]["mean"] > row["healthy_gait_on_healthy"]["mean"]
    saved = json.loads((tmp_path / "damage_table.json").read_text())
    assert saved["rows"] == rows and saved["starts"] == 2
    assert "caudal_missing" in (tmp_path / "damage_table.md").read_text()

    gait_file = tmp_path / "gaits" / "caudal_missing" / "best_controller.json"
    stamp = gait_file.stat().st_mtime_ns
    assert damage_table(tmp_path, damages=["caudal_missing"], budget=TINY, starts=2, eval_seed=100) == rows
    assert gait_file.stat().st_mtime_ns == stamp  # reused, not evolved again


def test_format_table_cells():
    summary = {"mean": 1.5, "min": -0.25, "max": 3.0, "distances": [-0.25, 3.0]}
    row = {"damage": "x", "healthy_gait_on_healthy": summary, "healthy_gait_on_damaged": summary,
           "oracle_gait_on_damaged": summary, "recovery_needed": 0.4, "qualifies": True}
    text = format_table([row], 2)
    assert "| `x` | 1.50 (-0.25 to 3.00) |" in text and "| 0.40 | yes |" in text
    assert "over 2 fresh starts" in text
    assert "| n/a | no |" in format_table([row | {"recovery_needed": None, "qualifies": False}], 2)


@pytest.mark.parametrize("kwargs, match", [({"damages": ["none"]}, "unknown damage"),
                                           ({"damages": ["broken_fin"]}, "unknown damage"),
                                           ({"starts": 0}, "starts")])
def test_bad_arguments_raise(tmp_path, kwargs, match):
    with pytest.raises(ValueError, match=match):
        damage_table(tmp_path, budget=TINY, **kwargs)


def test_cli_reports_a_bad_damage(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["damages", "--out", str(tmp_path), "--damages", "broken_fin"])
    assert exc.value.code == 2
    assert "unknown damage" in capsys.readouterr().err


@pytest.mark.parametrize("ratio, oracle, healthy, expected", [
    (0.3, 6.0, 10.0, True),     # broken healthy gait, oracle swims well again
    (0.6, 6.0, 10.0, False),    # the healthy gait keeps too much
    (0.3, 4.0, 10.0, False),    # the oracle itself swims less than half the healthy robot's distance
    (None, -1.0, 10.0, False),  # the oracle does not swim forward
])
def test_qualification_needs_a_broken_healthy_gait_and_an_oracle_that_swims(ratio, oracle, healthy, expected):
    from aquafish.damage_table import qualifies

    # a Python bool also from NumPy means (the table is written as JSON)
    assert qualifies(ratio, np.float64(oracle), np.float64(healthy)) is expected
