"""eea.analysis.compare: variants paired by seed, Welch's p on the common seeds, rounds to a level."""

import numpy as np
import pytest
from scipy.stats import ttest_ind

from aquafish.cli import main
from eea.analysis.compare import compare_variants, comparison_table, parse_variant, plot_variants
from eea.config import EEAConfig
from eea.analysis.plot import find_runs
from eea.record import ROUND_COLUMNS, round_columns, write_config, write_rounds


def _fake_run(path, seed, objective, simulations_per_round=10, rounds=None, inference="profile", left_rad=0.0):
    """A run directory with the given OBJ_FIT per round (true left angle 0, inferred ``left_rad``)."""
    path.mkdir(parents=True)
    write_config(path, EEAConfig.from_flat({"inference": inference, "seed": seed, "rounds": rounds or len(objective),
                                            "workers": 1}))
    write_rounds(path, [{c: 0.0 for c in ROUND_COLUMNS} | {
        "round": i + 1, "objective_fitness": v, "target_experiments": i + 1, "inferred_left_rad": left_rad,
        "simulations": simulations_per_round * (i + 1), "wall_seconds": 30.0 * (i + 1)} for i, v in enumerate(objective)])


def test_summary_pairs_seeds_and_counts_the_first_round_at_the_level(tmp_path):
    _fake_run(tmp_path / "a" / "seed0", 0, [0.7, 0.92, 0.85], simulations_per_round=100, left_rad=np.pi / 2)
    _fake_run(tmp_path / "a" / "seed1", 1, [0.6, 0.8, 0.96], simulations_per_round=300, left_rad=np.pi / 2)
    _fake_run(tmp_path / "a" / "seed2", 2, [0.5, 0.6, 0.7])
    _fake_run(tmp_path / "a" / "seed3", 3, [0.9], rounds=3)  # unfinished: left out
    s = compare_variants({"a": find_runs([tmp_path / "a"])})["a"]
    assert s.rounds == 3 and s.left_out == 1
    np.testing.assert_array_equal(s.seeds, [0, 1, 2])
    np.testing.assert_allclose(s.final, [0.85, 0.96, 0.7])
    np.testing.assert_array_equal(s.reached, [2, 3, 0])  # seed 0 reaches 0.9 at round 2 and falls back
    np.testing.assert_allclose(s.curve, [(0.7 + 0.6 + 0.5) / 3, (0.92 + 0.8 + 0.6) / 3, (0.85 + 0.96 + 0.7) / 3])
    np.testing.assert_allclose(s.mean, (0.85 + 0.96 + 0.7) / 3)
    np.testing.assert_allclose(s.std, np.std([0.85, 0.96, 0.7]))
    assert s.simulations_per_round == pytest.approx((100 + 300 + 10) / 3)
    assert s.wall_seconds == pytest.approx(90.0)                        # 30 s a round, to round 3
    assert "| 137 | 1.5 |" in comparison_table({"a": s}).splitlines()[2]   # simulations a round, wall minutes
    assert s.median_error_deg[0] == pytest.approx(90.0)  # 6 of the 9 rounds are off by 90 deg


def test_p_value_uses_only_the_seeds_both_variants_ran(tmp_path):
    base = {0: 0.70, 1: 0.75, 2: 0.80, 3: 0.72}
    new = {0: 0.90, 1: 0.95, 2: 0.97, 5: 0.10}
    for s, v in base.items():
        _fake_run(tmp_path / "base" / f"seed{s}", s, [v], inference="out_of_band")
    for s, v in new.items():
        _fake_run(tmp_path / "new" / f"seed{s}", s, [0.5, v])
    summary = compare_variants({"base": find_runs([tmp_path / "base"]), "new": find_runs([tmp_path / "new"])},
                               rounds=1)
    assert summary["new"].final.tolist() == [0.5] * 4  # round 1 of every run
    with pytest.raises(ValueError, match="variant 'base': none of its 4 runs has finished round 2"):
        compare_variants({"base": find_runs([tmp_path / "base"]), "new": find_runs([tmp_path / "new"])}, rounds=2)
    base_runs = find_runs([tmp_path / "base"])
    for r in base_runs:  # give the baseline a second round with the same final values
        write_rounds(r.out_dir, r.rounds + [dict(r.rounds[0], round=2)])
    summary = compare_variants({"base": find_runs([tmp_path / "base"]), "new": find_runs([tmp_path / "new"])},
                               rounds=2)
    table = comparison_table(summary, baseline="base").splitlines()
    expected = ttest_ind([0.90, 0.95, 0.97], [0.70, 0.75, 0.80], equal_var=False).pvalue
    assert f"| {expected:.2g} (3) |" in table[3]  # seeds 0-2 only: seed 3 and seed 5 are unpaired
    values = [0.70, 0.75, 0.80, 0.72]
    assert table[2].startswith(f"| base | 0-3 | {np.mean(values):.3f} ± {np.std(values):.3f} | 0.700 0.750 0.800 0.720 | - |")
    assert "| new | 0,1,2,5 |" in table[3] and "| 3/4 (2) | 2/4 |" in table[3]  # 0.90 reaches 0.9; 0.95 and 0.97 are >= 0.95
    with pytest.raises(ValueError, match="baseline 'x' is not a variant; variants: base, new"):
        comparison_table(summary, baseline="x")


def test_bad_input_is_named(tmp_path):
    _fake_run(tmp_path / "study" / "profile" / "seed0", 0, [0.8])
    _fake_run(tmp_path / "study" / "known" / "seed0", 0, [0.9], inference="known")
    with pytest.raises(ValueError, match="two runs with seed 0"):
        compare_variants({"mixed": find_runs([tmp_path / "study"])})
    runs = find_runs([tmp_path / "study" / "known"])
    with pytest.raises(ValueError, match="rounds must be an integer >= 1"):
        compare_variants({"k": runs}, rounds=0)
    with pytest.raises(ValueError, match=r"level must be in \(0, 1\]"):
        compare_variants({"k": runs}, level=1.5)
    with pytest.raises(ValueError, match="variants without runs: k"):
        compare_variants({"k": []})
    assert parse_variant("global restarts=runs/a=b") == ("global restarts", __import__("pathlib").Path("runs/a=b"))
    for text in ("runs/a", "=runs/a", "label="):
        with pytest.raises(ValueError, match="a variant is LABEL=DIR"):
            parse_variant(text)


def test_cli_prints_the_table_and_draws_the_curves(tmp_path, capsys):
    _fake_run(tmp_path / "a" / "seed0", 0, [0.7, 0.8])
    _fake_run(tmp_path / "a" / "seed1", 1, [0.8, 0.95])
    _fake_run(tmp_path / "b" / "seed0", 0, [0.6, 0.7])
    _fake_run(tmp_path / "b" / "seed1", 1, [0.65], rounds=2)  # unfinished
    png = tmp_path / "fig" / "curves.png"
    assert main(["compare", f"a={tmp_path / 'a'}", f"b={tmp_path / 'b'}", "-o", str(png)]) == 0
    out = capsys.readouterr().out
    assert "| a | 0-1 | 0.875 ± 0.075 | 0.800 0.950 |" in out and "| b | 0 | 0.700 ± 0.000 |" in out
    assert "runs left out (round not finished): b 1" in out
    assert png.stat().st_size > 1000 and not list(png.parent.glob("*.tmp*"))
    _fake_run(tmp_path / "c" / "seed2", 2, [0.9, 0.5])  # a label given twice: the runs of both directories
    assert main(["compare", f"a={tmp_path / 'a'}", f"a={tmp_path / 'c'}"]) == 0
    assert "| a | 0-2 | 0.750 ± 0.187 | 0.800 0.950 0.500 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):  # the same seed twice
        main(["compare", f"a={tmp_path / 'a'}", f"a={tmp_path / 'b'}"])
    assert "variant 'a' has two runs with seed 0" in capsys.readouterr().err
    summary = compare_variants({"a": find_runs([tmp_path / "a"])})
    assert plot_variants(summary, tmp_path / "one.png").exists()


def _servo_run(path, seed, left, right, objective=0.8):
    """A ``morphology+servos`` run of ``reversed_left_pectoral`` (true gains -1, 1, 1) whose
    one round's model has the pectoral gains ``left``, ``right``."""
    path.mkdir(parents=True)
    write_config(path, EEAConfig.from_flat({"inference": "profile", "seed": seed, "rounds": 1, "workers": 1,
                                            "model_space": "morphology+servos", "damage": "reversed_left_pectoral",
                                            "estimation_search": "cma"}))
    write_rounds(path, [{c: 0.0 for c in round_columns("morphology+servos")} | {
        "round": 1, "objective_fitness": objective, "target_experiments": 1, "simulations": 10,
        "model_left_pectoral_gain": left, "model_right_pectoral_gain": right, "model_caudal_gain": 1.0}],
                 "morphology+servos")


def test_pectoral_signs_are_counted_and_compared_with_fishers_exact_test(tmp_path):
    from scipy.stats import fisher_exact

    from eea.analysis.compare import fisher_p_value

    # the record's case: 17 of 20 against 10 of 20
    assert fisher_p_value(17, 20, 10, 20) == pytest.approx(fisher_exact([[17, 3], [10, 10]])[1]) == pytest.approx(
        0.0407, abs=5e-4)
    with pytest.raises(ValueError, match="counts"):
        fisher_p_value(3, 2, 1, 2)
    base = [(-1.0, 1.0), (0.5, 1.0), (-0.5, 1.0), (1.0, -1.0)]        # 2 of 4 right
    new = [(-1.0, 1.0), (-0.5, 0.25), (-0.125, 1.0), (-1.0, 0.5), (-1.0, 1.0)]  # all right; seed 4 unpaired
    for s, (left, right) in enumerate(base):
        _servo_run(tmp_path / "base" / f"seed{s}", s, left, right)
    for s, (left, right) in enumerate(new):
        _servo_run(tmp_path / "new" / f"seed{s}", s, left, right)
    summary = compare_variants({"base": find_runs([tmp_path / "base"]), "new": find_runs([tmp_path / "new"])})
    assert summary["base"].signs_right.tolist() == [True, False, True, False]
    table = comparison_table(summary).splitlines()
    header = table[0].split(" | ")
    assert header[-3:] == ["pectoral signs right (Fisher p vs base)", "self-model OBJ_FIT (after the check)",
                           "self-model signs right (Fisher p vs base) |"]
    p = fisher_exact([[4, 0], [2, 2]])[1]                                # seeds 0-3, the ones both ran
    assert table[2].split(" | ")[-3] == "2/4" and table[3].split(" | ")[-3] == f"5/5 (p {p:.2g}, 4)"
    # unchecked runs: the self-model is the round's model
    assert table[2].endswith("| 2/4; 0 checked |")


def test_the_self_model_columns_read_the_check_against_fault_hypotheses(tmp_path):
    from aquafish_gym import Morphology
    from eea.fault_check import FAULT_CHECK_PROCEDURE, FaultCheck, write_fault_check
    from eea.fitness import objective_fitness
    from eea.inference.selection import fault_hypotheses

    design = Morphology.healthy().to_array()
    hypotheses = fault_hypotheses(design)
    truth = np.concatenate([design, [-1.0, 1.0, 1.0]])
    for s, (left, right) in enumerate([(1.0, 1.0), (0.5, 1.0), (-1.0, 1.0)]):  # the search: 1 of 3 right
        _servo_run(tmp_path / "new" / f"seed{s}", s, left, right)
    # the checks of seeds 0 and 1 keep the truth (a hypothesis); seed 2's is of an earlier procedure
    kept = int(np.flatnonzero((hypotheses == truth).all(axis=1))[0]) + 1
    for s, procedure in ((0, FAULT_CHECK_PROCEDURE), (1, FAULT_CHECK_PROCEDURE), (2, "")):
        run = find_runs([tmp_path / "new" / f"seed{s}"])[0]
        models = np.vstack([run.best_model, hypotheses])
        write_fault_check(run.out_dir, FaultCheck(1, models, np.linspace(0.9, 0.99, len(models)), kept, 5, 1.0,
                                                  procedure))
    summary = compare_variants({"new": find_runs([tmp_path / "new"])})["new"]
    assert summary.checked.tolist() == [True, True, False]
    assert summary.signs_right.tolist() == [False, False, True]
    assert summary.self_model_signs_right.tolist() == [True, True, True]
    np.testing.assert_allclose(summary.self_model_final[:2], 1.0)                     # the truth kept
    bounds = find_runs([tmp_path / "new" / "seed2"])[0].model_space.bounds
    assert summary.self_model_final[2] == pytest.approx(objective_fitness(
        find_runs([tmp_path / "new" / "seed2"])[0].best_model, truth, bounds))          # stale: the round's model
    row = comparison_table({"new": summary}).splitlines()[2]
    assert row.endswith(f"| 1/3 | {summary.self_model_final.mean():.3f} ± {summary.self_model_final.std():.3f} "
                        "| 3/3; 2 checked |")
