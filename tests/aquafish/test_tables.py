"""``aquafish tables``: the README's result tables agree with the records they are rendered from;
a changed number is named by table, row and column; ``--write`` restores it; bad markers name their line."""

import json
from pathlib import Path

import pytest

from aquafish.cli import main
from aquafish.tables import TABLES, RecoveryColumn, check_page, find_tables, recovery_table, render_page

ROOT = Path(__file__).parents[2]
README = ROOT / "README.md"


def test_the_readmes_tables_agree_with_their_records(capsys):
    assert main(["tables", "--check", str(README)]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert out == [f"{README}: its 3 tables agree with their records"]
    assert {b.name for b in find_tables(README.read_text())} == set(TABLES)


def _changed_copy(tmp_path: Path) -> Path:
    text = README.read_text()
    row = next(line for line in text.splitlines() if line.startswith("| **the self-model** |"))
    changed = row.replace("| **the self-model** | **", "| **the self-model** | **9", 1)
    copy = tmp_path / "README.md"
    copy.write_text(text.replace(row, changed, 1))
    return copy


def test_a_changed_number_fails_naming_its_table_row_and_column(tmp_path, capsys):
    copy = _changed_copy(tmp_path)
    assert main(["tables", "--check", str(copy), "--root", str(ROOT)]) == 1
    out = capsys.readouterr().out
    [difference] = [line for line in out.splitlines() if "row" in line]
    header = [cell.strip() for cell in TABLES["recovery"].table(ROOT).splitlines()[0].strip("|").split("|")][1]
    assert "table 'recovery'" in difference and "row '**the self-model**'" in difference
    assert f"column {header!r}" in difference
    assert "the page has '**9" in difference and "the records give '**" in difference
    assert "1 differences" in out


def test_write_restores_a_changed_copy(tmp_path, capsys):
    copy = _changed_copy(tmp_path)
    assert main(["tables", "--write", str(copy), "--root", str(ROOT)]) == 0
    assert copy.read_text() == README.read_text()
    assert main(["tables", "--write", str(copy), "--root", str(ROOT)]) == 0  # nothing to change
    assert "nothing written" in capsys.readouterr().out


def test_without_a_root_the_records_are_looked_up_beside_the_page(tmp_path):
    copy = _changed_copy(tmp_path)
    with pytest.raises(SystemExit) as exc:  # the records are not under tmp_path: one line, status 2
        main(["tables", "--check", str(copy)])
    assert exc.value.code == 2


@pytest.mark.parametrize("text, message", [
    ("intro\n\n<!-- table: nosuch -->\n| a |\n<!-- /table -->\n", r"line 3: unknown table 'nosuch'"),
    ("intro\n<!-- table: recovery -->\n| a |\n|---|\n", r"line 2: table 'recovery' is not closed"),
    ("<!-- table: recovery -->\n<!-- table: mission -->\n<!-- /table -->\n", r"line 1: table 'recovery' is not closed"),
    ("a\nb\n<!-- /table -->\n", r"line 3: <!-- /table --> closes no table"),
    ("<!-- table -->\n", r"line 1: malformed table marker"),
])
def test_bad_markers_raise_naming_the_line(text, message):
    with pytest.raises(ValueError, match=message):
        find_tables(text, source="page.md")
    with pytest.raises(ValueError, match=message):
        check_page(text, ROOT)


def test_an_unknown_table_on_the_command_line_is_one_line(tmp_path, capsys):
    page = tmp_path / "page.md"
    page.write_text("# page\n\n<!-- table: nosuch -->\n\n<!-- /table -->\n")
    with pytest.raises(SystemExit) as exc:
        main(["tables", "--check", str(page)])
    assert exc.value.code == 2
    assert "line 3: unknown table 'nosuch'" in capsys.readouterr().err


def _summary(cells: int, breaking: int, damages: list[str]) -> dict:
    """A hand-made ``summary.json`` (aquafish.recovery.summarize's layout) of ``breaking`` breaking cells."""
    return {"settings": {"preset": "quick", "episode_duration_s": 20.0, "damages": damages, "seeds": [0]},
            "missing": [],
            "cells": [{"damage": d, "seed": 0, "breaks": i < breaking} for i, d in enumerate(damages[:cells])],
            "totals": {"cells": cells, "breaking": breaking,
                       "rows": {"self_model": {"recovers": 2, "of": 3, "rate": 2 / 3},
                                "ppo": {"recovers": 1, "of": 2, "rate": 0.5}},
                       "identified": {"right": 3, "of": 3, "rate": 1.0}}}


def test_the_recovery_renderer_on_a_small_summary(tmp_path):
    damages = ["sampled:7", "sampled:8", "sampled:9", "reversed_left_pectoral"]
    (tmp_path / "s.json").write_text(json.dumps(_summary(4, 3, damages)))
    table = recovery_table([RecoveryColumn("{duration} s, {damages}: {breaking} of {cells} break", "s.json")],
                           tmp_path, rows=[("**self-model**", "self_model"), ("PPO", "ppo"),
                                           ("plain", "plain_eea"), ("signs right", "identified")])
    assert table.splitlines() == [
        "| gait of | 20 s, `sampled:7`-`9`, `reversed_left_pectoral`: 3 of 4 break |",
        "|---|---|",
        "| **self-model** | **2** |",
        "| PPO | 1 of 2 |",  # only 2 of the 3 breaking cells have the row
        "| plain | |",  # a row the benchmark did not run
        "| signs right | 3 |",
    ]


def test_a_cells_record_must_hold_the_summarys_breaking_cells(tmp_path):
    damages = ["sampled:1", "sampled:2", "sampled:3"]
    (tmp_path / "all.json").write_text(json.dumps(_summary(3, 2, damages)))
    (tmp_path / "breaking.json").write_text(json.dumps(_summary(2, 2, damages)))
    column = RecoveryColumn("{breaking} of {cells}", "breaking.json", cells="all.json")
    assert recovery_table([column], tmp_path, rows=[("s", "self_model")]).splitlines()[0] == "| gait of | 2 of 3 |"
    (tmp_path / "breaking.json").write_text(json.dumps(_summary(1, 1, damages)))
    with pytest.raises(ValueError, match="breaking cells are not those of all.json"):
        recovery_table([column], tmp_path, rows=[("s", "self_model")])
    with pytest.raises(ValueError, match="unknown recovery rows"):
        recovery_table([column], tmp_path, rows=[("s", "self_modle")])
    with pytest.raises(ValueError, match="nosuch.json: no such record"):
        recovery_table([RecoveryColumn("x", "nosuch.json")], tmp_path, rows=[("s", "self_model")])


def test_render_page_keeps_the_rest_of_the_page(tmp_path):
    (tmp_path / "s.json").write_text(json.dumps(_summary(2, 1, ["none", "sampled:1"])))
    tables = {"t": TABLES["recovery"].__class__(
        records=(RecoveryColumn("{cells} cells", "s.json"),),
        render=lambda records, root: recovery_table(records, root, rows=[("s", "self_model")]))}
    page = "# Title\n\ntext\n<!-- table: t -->\nold\n<!-- /table -->\nmore\n"
    new = render_page(page, tmp_path, tables=tables)
    assert new == "# Title\n\ntext\n<!-- table: t -->\n\n| gait of | 2 cells |\n|---|---|\n| s | 2 of 3 |\n\n" \
                  "<!-- /table -->\nmore\n"
    assert check_page(new, tmp_path, tables=tables) == (1, [])
    count, differences = check_page(page, tmp_path, tables=tables)
    assert count == 1 and differences and "table 't'" in differences[0]


def test_printing_a_table_gives_its_markers(capsys):
    assert main(["tables", "recovery"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("<!-- table: recovery -->\n\n| gait of |") and out.rstrip().endswith("<!-- /table -->")



def test_the_obj_fit_table_ends_with_the_papers_values_from_their_record_and_a_missing_record_is_named():
    from functools import partial

    from aquafish.tables import TABLES, study_table

    spec = TABLES["obj_fit"]
    rows = spec.render.keywords["rows"]
    lines = spec.table(ROOT).splitlines()
    published = json.loads((ROOT / "docs/results/paper_reference.json").read_text())["objective_fitness"]
    assert lines[0].endswith("| paper |")
    for line, row in zip(lines[2:], rows):
        assert line.endswith(f"| {published.get(row.variant, '')} |".replace("|  |", "| |"))
    with pytest.raises(ValueError, match="no_such.json"):
        partial(study_table, rows=rows, reference=("paper", "no_such.json"))(spec.records, ROOT)
