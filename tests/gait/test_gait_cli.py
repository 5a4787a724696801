"""The gait, transfer and rl sub-commands, through an argparse parser like ``aquafish``'s."""

import argparse
import json
import subprocess
import sys

import pytest

from gait import cli


def _run(argv):
    parser = argparse.ArgumentParser(prog="aquafish")
    cli.add_commands(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    return args.func(args)


def test_gait_then_transfer(tmp_path, capsys):
    out = tmp_path / "gait"
    assert _run(["gait", "--morphology", "healthy", "--generations", "2", "--population-size", "4", "--seed", "1",
                 "--workers", "1", "--episode-duration-s", "1", "--quiet", "--out", str(out)]) == 0
    assert "best forward distance" in capsys.readouterr().out
    assert json.loads((out / "run.json").read_text())["generations"] == 2
    assert (out / "fitness_history.png").is_file()

    assert _run(["gait", "--generations", "3", "--workers", "1", "--episode-duration-s", "1", "--quiet",
                 "--seed", "1", "--out", str(out), "--resume", "latest"]) == 0
    assert len(json.loads((out / "fitness_history.json").read_text())) == 3

    tout = tmp_path / "transfer"
    assert _run(["transfer", "--controller", str(out), str(out / "best_controller.json"), "--native", "healthy",
                 "--target", "left_pectoral_half", "--seed", "1", "--out", str(tout), "--title", "a", "b"]) == 0
    results = json.loads((tout / "transfer.json").read_text())
    assert len(results) == 2 and results[0]["target"]["damage"] == "left_pectoral_half"
    assert (tout / "transfer.png").is_file()
    assert len(results[0]["native_trajectory"]) == 201  # 20 s, every 0.1 s


@pytest.mark.parametrize("argv, match", [
    (["gait", "--morphology", "1,2", "--generations", "1"], "shape"),
    (["transfer", "--controller", "nowhere.pkl", "--target", "healthy"], "no controller file"),
    (["transfer", "--controller", "a", "b", "--native", "healthy", "healthy", "healthy", "--target", "healthy"], "one --native"),
    (["transfer", "--controller", "a", "--target", "healthy", "--initial-angles", "1,2"], "--initial-angles"),
])
def test_bad_input_raises_value_error(argv, match, tmp_path):
    with pytest.raises(ValueError, match=match):
        _run(argv + ["--out", str(tmp_path)])


def test_gait_works_without_the_rl_extra():
    """Importing gait (and its CLI) does not import stable-baselines3 or torch."""
    code = "import sys, gait, gait.cli; print(any(m in sys.modules for m in ('stable_baselines3', 'torch')))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"
