"""eea.diagnosis: MOD_FIT of the final and the true morphology under inferred and true angles."""

from pathlib import Path

import pytest

from aquafish.cli import main
from eea.diagnosis import RunDiagnosis, diagnose_run
from eea.run import run


@pytest.mark.parametrize("inference", ["known", "none"])
def test_truth_reproduces_the_target_exactly_under_true_angles(tmp_path, tiny_config, inference):
    result = run(tiny_config(inference=inference), tmp_path, progress=False)
    d = diagnose_run(tmp_path)
    assert d.experiments == 2 and d.inference == inference
    assert d.true_true_angles == 1.0                  # the damaged robot is an exact model genome
    # the final model's fitness under the inferred angles is what the run recorded as MOD_FIT
    # when the final model is that round's best (it is: one GA, best of the last generation)
    assert d.final_inferred == pytest.approx(result.rounds[-1]["model_fitness"], abs=1e-12)
    if inference == "known":                          # inferred = true angles
        assert d.true_inferred == 1.0 and d.final_true_angles == d.final_inferred
    else:                                             # zero state: the truth no longer fits exactly
        assert d.true_inferred < 1.0


def test_verdict_names_the_failure():
    trapped = RunDiagnosis(Path("r"), "out_of_band", 10, final_inferred=0.985, true_inferred=0.976,
                           final_true_angles=0.976, true_true_angles=1.0)
    missed = RunDiagnosis(Path("r"), "known", 10, final_inferred=0.988, true_inferred=1.0,
                          final_true_angles=0.988, true_true_angles=1.0)
    assert trapped.verdict == "inference" and missed.verdict == "search"


def test_cli_prints_one_line_per_run(tmp_path, tiny_config, capsys):
    for seed in (0, 1):
        run(tiny_config(inference="none", seed=seed), tmp_path / f"seed{seed}", progress=False)
    assert main(["diagnose", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 3 and lines[0].split()[:3] == ["run", "inference", "E"]
    assert all(line.split()[1:3] == ["none", "2"] and line.split()[-2] == "1.0000" for line in lines[1:])


def test_no_finished_round_raises(tmp_path):
    with pytest.raises(ValueError, match="not an EEA run directory"):
        diagnose_run(tmp_path)
