"""eea.run: records, determinism, resume after an interruption, config checks, CLI."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from aquafish_gym.rundir import COMMAND_FILE

import eea
import eea.estimation
from eea.fitness import objective_fitness
from eea.record import MODEL_COLUMNS, ROUND_COLUMNS, load_result, read_csv, write_csv
from aquafish_gym import get_damage


def _csv_without_wall(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [{k: v for k, v in r.items() if k != "wall_seconds"} for r in rows]


def test_run_writes_config_and_one_row_per_round(tmp_path, tiny_config):
    config = tiny_config(inference="known", rounds=3)
    result = eea.run(config, tmp_path, progress=False)
    assert json.loads((tmp_path / "config.json").read_text()) == config.to_dict()
    with open(tmp_path / "rounds.csv", newline="") as f:
        reader = csv.DictReader(f)
        assert tuple(reader.fieldnames) == ROUND_COLUMNS
        assert len(list(reader)) == 3
    rows = result.rounds
    assert [r["round"] for r in rows] == [1, 2, 3] and [r["target_experiments"] for r in rows] == [1, 2, 3]
    assert 0 < rows[0]["simulations"] < rows[1]["simulations"] < rows[2]["simulations"]
    target = get_damage("left_pectoral_half").apply().to_array()
    for r in rows:
        dims = np.array([r[c] for c in MODEL_COLUMNS])
        assert r["objective_fitness"] == pytest.approx(objective_fitness(dims, target))
        assert 0 <= r["model_fitness"] <= 1 and 0 <= r["action_fitness"] <= 1
        for f in ("left", "right", "caudal"):                     # known: inferred == true
            assert r[f"inferred_{f}_rad"] == pytest.approx(r[f"true_{f}_rad"], abs=1e-12)
    loaded = load_result(tmp_path)
    assert loaded.rounds == rows and loaded.config == config and loaded.finished
    np.testing.assert_array_equal(loaded.best_morphology.to_array(), [rows[-1][c] for c in MODEL_COLUMNS])
    # no temp files left; the run directory records the command that made it
    assert sorted(os.listdir(tmp_path)) == [COMMAND_FILE, "config.json", "rounds.csv", "run_data.npz", "state.pkl"]
    assert (tmp_path / COMMAND_FILE).read_text() == "eea\n"

@pytest.mark.parametrize("inference", ["none", "out_of_band", "in_band"])
def test_same_seed_same_rounds_other_seed_differs(tmp_path, tiny_config, inference):
    eea.run(tiny_config(inference=inference), tmp_path / "a", progress=False)
    eea.run(tiny_config(inference=inference), tmp_path / "b", progress=False)
    eea.run(tiny_config(inference=inference, seed=1), tmp_path / "c", progress=False)
    a, b, c = (_csv_without_wall(tmp_path / d / "rounds.csv") for d in "abc")
    assert a == b and a != c


def test_resume_extends_a_finished_run_like_a_straight_run(tmp_path, tiny_config, simulator_spy):
    eea.run(tiny_config(inference="in_band", rounds=2), tmp_path / "resumed", progress=False)
    calls = len(simulator_spy.calls)
    eea.run(tiny_config(inference="in_band", rounds=2), tmp_path / "resumed", progress=False)
    assert len(simulator_spy.calls) == calls                            # finished: nothing simulated
    eea.run(tiny_config(inference="in_band", rounds=4), tmp_path / "resumed", progress=False)
    eea.run(tiny_config(inference="in_band", rounds=4), tmp_path / "straight", progress=False)
    straight = _csv_without_wall(tmp_path / "straight" / "rounds.csv")
    assert _csv_without_wall(tmp_path / "resumed" / "rounds.csv") == straight and len(straight) == 4


@pytest.mark.parametrize("search", ["ga", "cma"])
def test_resume_after_an_interruption_mid_round(tmp_path, tiny_config, monkeypatch, search):
    config = tiny_config(inference="out_of_band", rounds=4, estimation_search=search)
    real_run = eea.estimation.Estimation.run
    rounds_started = []

    def interrupted(self, experiments, *args, **kw):
        rounds_started.append(len(experiments))
        if len(experiments) == 3:
            raise KeyboardInterrupt("simulated kill during round 3's estimation")
        return real_run(self, experiments, *args, **kw)

    monkeypatch.setattr(eea.estimation.Estimation, "run", interrupted)
    with pytest.raises(KeyboardInterrupt):
        eea.run(config, tmp_path / "killed", progress=False)
    assert len(_csv_without_wall(tmp_path / "killed" / "rounds.csv")) == 2
    monkeypatch.setattr(eea.estimation.Estimation, "run", real_run)
    eea.run(config, tmp_path / "killed", progress=False)
    eea.run(config, tmp_path / "straight", progress=False)
    assert _csv_without_wall(tmp_path / "killed" / "rounds.csv") == _csv_without_wall(tmp_path / "straight" / "rounds.csv")


def test_a_different_config_in_the_directory_raises(tmp_path, tiny_config):
    eea.run(tiny_config(rounds=1), tmp_path, progress=False)
    with pytest.raises(ValueError, match="different config.*seed: 0 -> 3"):
        eea.run(tiny_config(rounds=1, seed=3), tmp_path, progress=False)
    eea.run(tiny_config(rounds=1, workers=2, max_batch_robots=5), tmp_path, progress=False)  # results-neutral


def test_rounds_without_a_checkpoint_are_refused_and_left_as_they_are(tmp_path, tiny_config):
    # a published run keeps config.json and rounds.csv but no state.pkl: starting it over would
    # overwrite its rounds with a new run's
    eea.run(tiny_config(rounds=2), tmp_path, progress=False)
    (tmp_path / "state.pkl").unlink()
    rounds = (tmp_path / "rounds.csv").read_bytes()
    for rounds_asked in (2, 3):  # finished, or to be extended
        with pytest.raises(ValueError, match=r"rounds.csv: holds 2 finished rounds but the run has no checkpoint "
                                             r"\(state.pkl\).*use another --out"):
            eea.run(tiny_config(rounds=rounds_asked), tmp_path, progress=False)
    assert (tmp_path / "rounds.csv").read_bytes() == rounds
    (tmp_path / "rounds.csv").unlink()  # as the message says: the run starts over
    assert len(eea.run(tiny_config(rounds=1), tmp_path, progress=False).rounds) == 1


def test_workers_do_not_change_results(tmp_path, tiny_config):
    eea.run(tiny_config(inference="out_of_band", workers=1), tmp_path / "one", progress=False)
    eea.run(tiny_config(inference="out_of_band", workers=2), tmp_path / "two", progress=False)
    assert _csv_without_wall(tmp_path / "one" / "rounds.csv") == _csv_without_wall(tmp_path / "two" / "rounds.csv")


def test_cli_runs_with_every_field_as_a_flag(tmp_path, capsys):
    from aquafish.cli import main

    out = tmp_path / "cli"
    args = ["eea", "--inference", "none", "--damage", "caudal_half", "--duration", "0.16", "--rounds", "1",
            "--seed", "4", "--out", str(out), "--no-progress", "--exploration-population", "3",
            "--exploration-generations", "1", "--exploration-models", "2", "--estimation-population", "4",
            "--estimation-generations", "2", "--oob-sample", "5", "--workers", "1"]  # --oob-sample at its default
    assert main(args) == 0
    saved = json.loads((out / "config.json").read_text())                      # nested
    assert (saved["inference"], saved["damage"], saved["duration_s"], saved["seed"]) == ({"name": "none"}, "caudal_half",
                                                                                         0.16, 4)
    assert saved["estimation"]["population"] == 4 and "1 rounds" in capsys.readouterr().out
    # a flag of a strategy the run does not use, at another value: one line naming it, nothing run
    with pytest.raises(SystemExit) as exit:
        main([*args, "--k-best", "2", "--out", str(tmp_path / "k")])
    assert exit.value.code == 2 and "EEAConfig.k_best needs inference='in_band', got 'none'" in capsys.readouterr().err
    assert not (tmp_path / "k").exists()


def test_module_help_works():
    done = subprocess.run([sys.executable, "-m", "aquafish", "eea", "--help"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and "--estimation-population" in done.stdout and "--oob-period" in done.stdout


@pytest.mark.slow
def test_kill_9_mid_round_then_rerun_matches_straight_run(tmp_path):
    """A real SIGKILL in the middle of a round; rerunning the same command finishes the same rounds.csv."""
    flags = ["--inference", "out_of_band", "--duration", "0.32", "--rounds", "5", "--seed", "2",
             "--exploration-population", "6", "--exploration-generations", "3", "--estimation-population", "6",
             "--estimation-generations", "8", "--oob-period", "4", "--oob-population", "4", "--oob-generations", "3",
             "--workers", "1", "--no-progress"]
    killed = tmp_path / "killed"
    proc = subprocess.Popen([sys.executable, "-m", "aquafish", "eea", "--out", str(killed), *flags],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.time() + 300
    while time.time() < deadline and len(_rows(killed)) < 2:
        time.sleep(0.02)
    time.sleep(0.3)                                                     # well into round 3
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done_before = len(_rows(killed))
    assert 2 <= done_before < 5
    for out in (killed, tmp_path / "straight"):
        subprocess.run([sys.executable, "-m", "aquafish", "eea", "--out", str(out), *flags], check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=600)
    assert _csv_without_wall(killed / "rounds.csv") == _csv_without_wall(tmp_path / "straight" / "rounds.csv")
    assert not [f for f in os.listdir(killed) if f.endswith(".tmp")]


def _rows(out):
    try:
        return _csv_without_wall(out / "rounds.csv")
    except FileNotFoundError:
        return []


def test_csv_records_round_trip_floats_exactly_and_ints_as_ints(tmp_path):
    rows = [{"round": 1, "fitness": 0.1 + 0.2, "angle_rad": -np.pi},
            {"round": 2, "fitness": 1 / 3, "angle_rad": 5e-324}]
    write_csv(tmp_path / "r.csv", ("round", "fitness", "angle_rad"), rows)
    columns, back = read_csv(tmp_path / "r.csv", ("round",))
    assert columns == ("round", "fitness", "angle_rad")
    assert back == rows and [type(r["round"]) for r in back] == [int, int]
    assert not list(tmp_path.glob("*.tmp*"))
    with pytest.raises(ValueError):  # a key outside the header
        write_csv(tmp_path / "r.csv", ("round",), rows)
    assert read_csv(tmp_path / "r.csv", ("round",))[1] == rows  # the failed write left the file whole
