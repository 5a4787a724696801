"""examples/: the scripts the README quotes run and compute what they say."""

import importlib.util
from pathlib import Path

import numpy as np

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _load(name):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_local_maxima_are_periodic_and_sorted():
    landscape = _load("angle_landscape")
    x = np.linspace(-np.pi, np.pi, 12, endpoint=False)
    grid = np.cos(x)[:, None] + 0.5 * np.cos(2 * x)[None, :]   # peaks at (0, 0) and (0, pi = -pi, wrapped)
    assert landscape.local_maxima(grid) == [(6, 0), (6, 6)]    # x[6] = 0, x[0] = -pi; equal heights: row order
    grid[6, 6] += 0.1
    assert landscape.local_maxima(grid)[0] == (6, 6)


def test_angle_landscape_peaks_at_the_true_angles(tmp_path, tiny_config, capsys):
    from eea.run import run

    run(tiny_config(inference="none"), tmp_path, progress=False)
    _load("angle_landscape").main([str(tmp_path), "--experiment", "1", "--grid", "4"])
    out = capsys.readouterr().out
    assert "model: truth" in out
    peaks = out.splitlines()[-1]
    assert peaks.strip().startswith("(0, 0): 0.00000")          # the truth reproduces the target exactly there


def test_vestigial_flipper_splits_the_objective_error_by_flipper(tmp_path, tiny_config, capsys):
    from eea.fitness import objective_fitness
    from eea.run import run

    vestigial = _load("vestigial_flipper")
    truth = np.array([0.0, 0.0, 0.0, 0.25, 1.0, 0.0625, 0.25, 0.875, 0.375])   # left_pectoral_missing
    model = truth.copy()
    model[[0, 2]] = 0.5, 0.25                                   # span half its range, thickness half its range
    shares = vestigial.error_shares(model, truth)
    np.testing.assert_allclose(shares, [0.5 / 9, 0, 0.5 / 9, 0, 0, 0, 0, 0, 0])
    assert np.isclose(1 - shares.sum(), objective_fitness(model, truth))
    run(tiny_config(inference="none", damage="left_pectoral_missing"), tmp_path, progress=False)
    vestigial.main([str(tmp_path), "--actions", "2"])
    rows = capsys.readouterr().out.splitlines()
    obj, flipper, rest = map(float, rows[1].split()[1:4])
    assert np.isclose(obj, 1 - flipper - rest, atol=2e-3)       # the two parts are all of the error (3 decimals)
    assert rows[-1].startswith(f"mean error: {flipper:.3f} on the left_pectoral, {rest:.3f} on the rest")
