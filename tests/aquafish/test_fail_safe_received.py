"""Fail safe, round 3: what a command is given to read is data, and what it writes stays in its
directory. One test, or parametrised family, per security cause of the issue; each failed before
its fix. The conventions of ``test_fail_safe.py`` (its tiny settings and ``fails_safe`` helper):
in-process through :func:`aquafish.cli.main`, or the library call the command makes.

1. a received prior (``aquafish mission --self-model DIR``) runs no code: the final NEAT
   population is read from ``gait/final_population.json``, never from a checkpoint, and a new
   gait evolved from it is the one evolved from the checkpoint, genome for genome;
2. no write follows a directory link planted in a run directory (``make_subdir``, and a lock
   below a locked run directory);
4. a directory the command did not make is read without unpickling: ``aquafish diagnose`` reads
   ``run_data.npz``, and a finished benchmark cell checked again is read from its data, any
   pickle refused unread.
"""

from __future__ import annotations

import gzip
import json
import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest

import aquafish.mission
import aquafish.recovery
import eea
from aquafish.cli import main
from aquafish.mission import MISSION_PRESETS, load_prior, make_prior, new_gait_kinds
from aquafish_gym import Morphology, get_damage
from aquafish_gym.rundir import FileError, read_pickle, run_lock
from eea.checkpoint import STATE_FILE, load_state
from eea.fault_check import FAULT_CHECK_FILE, read_fault_check
from gait import neat_evolution
from gait.robots import Robot
from test_fail_safe import TINY_EEA, TINY_GAIT, TINY_STUDY, fails_safe

SPACE = eea.get_model_space("morphology+servos")
#: The data files of a gait run and an EEA run (gait.population_file.POPULATION_FILE,
#: eea.checkpoint.RUN_DATA_FILE; spelt out, as the helpers below are imported in the tests, so that
#: this module runs on versions without them, where its tests must fail rather than not import).
POPULATION_FILE, RUN_DATA_FILE = "final_population.json", "run_data.npz"


def load_population(*args):
    from gait.population_file import load_population

    return load_population(*args)


def make_subdir(*args):
    from aquafish_gym.rundir import make_subdir

    return make_subdir(*args)


def refuse_pickles(why: str):
    from aquafish_gym.rundir import refuse_pickles

    return refuse_pickles(why)


def load_run_data(out_dir):
    from eea.checkpoint import load_run_data

    return load_run_data(out_dir)


def _main(argv) -> int:
    return main([str(a) for a in argv])


class _Payload:
    """Unpickling this writes the file ``path``: a pickle that runs code."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (Path.write_text, (Path(self.path), "ran\n"))


def _plant(path: Path, marker: Path, gzipped: bool = False) -> None:
    data = pickle.dumps(_Payload(marker))
    path.write_bytes(gzip.compress(data) if gzipped else data)


def _no_work(*args, **kwargs):
    raise AssertionError("the command started work it should have refused")


# -- 1. a received prior is data ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def prior(tmp_path_factory):
    """A smoke prior (the true healthy robot as its self-model), as a mission makes it."""
    d = tmp_path_factory.mktemp("prior")
    make_prior(d, SPACE.encode(SPACE.truth("none")[None])[0], Robot(Morphology.healthy(), "none", "healthy"), "smoke",
               0, workers=1, calibration_seeds=2, progress=False)
    return d


def _received(prior: Path, tmp_path: Path, marker: Path) -> Path:
    """A copy of ``prior`` whose every NEAT checkpoint is a pickle that writes ``marker``."""
    received = tmp_path / "received"
    shutil.copytree(prior, received)
    checkpoints = sorted((received / "gait" / "checkpoints").iterdir())
    assert checkpoints
    for path in [*checkpoints, received / "gait" / "checkpoints" / "neat-checkpoint-99"]:
        _plant(path, marker, gzipped=True)
    return received


def _kinds(prior_dir: Path) -> dict:
    robot = Robot(get_damage("reversed_left_pectoral").apply(), "reversed_left_pectoral", "damaged")
    return new_gait_kinds(robot, load_prior(prior_dir), MISSION_PRESETS["smoke"], 3, 1, False, 120.0)


def _outcome(kinds: dict) -> dict:
    return {kind: ([(h["best_fitness"], h["mean_fitness"]) for h in result.history],
                   [str(c.genome) for c in result.candidates], result.candidate_generations,
                   rehearsal.scores.tolist(), rehearsal.index)
            for kind, (result, rehearsal) in kinds.items()}


def test_a_pickle_planted_in_a_received_prior_never_runs_and_the_new_gaits_are_the_checkpoints(prior, tmp_path,
                                                                                            monkeypatch):
    marker = tmp_path / "ran.txt"
    received = _received(prior, tmp_path, marker)
    from_data = _outcome(_kinds(received))  # the recovery's new gaits, from the received prior
    assert not marker.exists()
    # the same evolutions from the prior's own final checkpoint (as the mission read it before):
    # the same genomes, fitnesses, candidates and rehearsals, to the bit
    monkeypatch.setattr(neat_evolution, "load_population", lambda path: neat_evolution.neat.Checkpointer
                        .restore_checkpoint(str(neat_evolution.latest_checkpoint(prior / "gait"))))
    assert _outcome(_kinds(prior)) == from_data


def test_the_population_file_is_the_final_checkpoints_population(prior):
    gait_dir = prior / "gait"
    restored = neat_evolution.neat.Checkpointer.restore_checkpoint(str(neat_evolution.latest_checkpoint(gait_dir)))
    loaded = load_population(gait_dir / POPULATION_FILE)
    assert loaded.generation == restored.generation and list(loaded.population) == list(restored.population)
    for key, genome in restored.population.items():
        assert str(loaded.population[key]) == str(genome) and loaded.population[key].fitness == genome.fitness
    assert {k: (s.representative.key, list(s.members), s.fitness_history, s.last_improved)
            for k, s in loaded.species.species.items()} == \
        {k: (s.representative.key, list(s.members), s.fitness_history, s.last_improved)
         for k, s in restored.species.species.items()}
    assert loaded.reproduction.innovation_tracker.global_counter == \
        restored.reproduction.innovation_tracker.global_counter


def test_a_prior_without_its_population_file_is_refused_in_one_line_and_made_again_only_by_its_maker(prior, tmp_path,
                                                                                                    capsys,
                                                                                                    monkeypatch):
    received = tmp_path / "old"
    shutil.copytree(prior, received)
    (received / "gait" / POPULATION_FILE).unlink()  # a prior made before the file existed
    monkeypatch.setattr(aquafish.mission, "_run", _no_work)
    fails_safe(["mission", "--damage", "caudal_half", "--preset", "smoke", "--out", tmp_path / "m",
                "--self-model", received], capsys, "--self-model", f"gait/{POPULATION_FILE}")
    # the directory that made it writes it from its checkpoint, the file the run itself writes now
    neat_evolution.write_population_file(received / "gait")
    assert (received / "gait" / POPULATION_FILE).read_bytes() == (prior / "gait" / POPULATION_FILE).read_bytes()


@pytest.mark.parametrize("edit, names", [
    (lambda d: d["genomes"][0]["nodes"][0].update(activation="os.system"), "activation"),
    (lambda d: d["genomes"][0]["connections"][0].update(weight=float("nan")), "weight"),
    (lambda d: d["species"]["species"][0].update(members=[10**6]), "not in the population"),
    (lambda d: d.update(genomes="x"), "genomes must be a list"),
])
def test_a_crafted_population_file_is_refused_naming_it(edit, names, prior, tmp_path):
    path = tmp_path / POPULATION_FILE
    data = json.loads((prior / "gait" / POPULATION_FILE).read_text())
    edit(data)
    path.write_text(json.dumps(data))
    with pytest.raises(FileError, match=names) as err:
        load_population(path, prior / "gait" / "neat_config.ini")
    assert str(path) in str(err.value)


@pytest.mark.slow
def test_a_mission_from_a_received_prior_runs_no_planted_pickle(prior, tmp_path):
    marker = tmp_path / "ran.txt"
    received = _received(prior, tmp_path, marker)
    assert _main(["mission", "--damage", '{"seized": [true, true, true]}', "--preset", "smoke", "--onset-s", "8",
                  "--duration-s", "30", "--no-video", "--no-oracle", "--workers", "1", "--no-progress",
                  "--self-model", received, "--out", tmp_path / "m"]) == 0
    assert json.loads((tmp_path / "m" / "mission.json").read_text())["alarm_s"] is not None
    assert not marker.exists()


# -- 2. no write follows a planted directory link ---------------------------------------------------------------


@pytest.mark.parametrize("kind", ["link to a directory", "dangling link", "file"])
def test_make_subdir_refuses_a_link_or_a_file_naming_it_and_writes_nothing_there(kind, tmp_path):
    out, outside = tmp_path / "out", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    planted = out / "cells"
    if kind == "file":
        planted.write_text("x")
    else:
        planted.symlink_to(outside if kind == "link to a directory" else tmp_path / "nowhere")
    with pytest.raises(FileError, match="symbolic link|is a file") as err:
        make_subdir(out, "cells", "caudal_half", "seed0")
    assert str(planted) in str(err.value) and "\n" not in str(err.value)
    assert not any(outside.iterdir()) and not (tmp_path / "nowhere").exists()
    with pytest.raises(FileError, match="not a sub-directory name"):
        make_subdir(out, "..", "escape")
    assert make_subdir(out, "shared", "seed0") == out / "shared" / "seed0" and (out / "shared" / "seed0").is_dir()


def test_a_lock_below_a_locked_run_directory_never_goes_through_a_link(tmp_path):
    out, outside = tmp_path / "out", tmp_path / "outside"
    outside.mkdir()
    with run_lock(out, command="case-study"):
        (out / "eea_none").symlink_to(outside)
        with pytest.raises(FileError, match="symbolic link") as err:
            with run_lock(out / "eea_none" / "deeper", command="eea"):
                pass
        assert str(out / "eea_none") in str(err.value)
        with run_lock(out / "gait_healthy", command="gait"):   # a real sub-directory: made and locked
            assert (out / "gait_healthy").is_dir()
    assert not any(outside.iterdir())


def test_gait_refuses_a_checkpoints_link_and_writes_nothing_outside(tmp_path, capsys):
    out, outside = tmp_path / "run", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    (out / "checkpoints").symlink_to(outside)
    fails_safe(["gait", *TINY_GAIT, "--out", out], capsys, out / "checkpoints", "symbolic link")
    assert not any(outside.iterdir())


def test_a_mission_refuses_a_self_model_link_before_any_work(tmp_path, capsys):
    out, outside = tmp_path / "m", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    (out / "self_model").symlink_to(outside)
    fails_safe(["mission", "--damage", "caudal_half", "--preset", "smoke", "--no-progress", "--out", out], capsys,
               out / "self_model", "symbolic link")
    assert not any(outside.iterdir())


@pytest.mark.parametrize("planted", ["cells", "shared", "oracles", "cells/caudal_half/seed0"])
def test_recovery_refuses_a_planted_link_before_any_cell_runs(planted, tmp_path, capsys, monkeypatch):
    out, outside = tmp_path / "bench", tmp_path / "outside"
    (out / planted).parent.mkdir(parents=True)
    outside.mkdir()
    (out / planted).symlink_to(outside)
    monkeypatch.setattr(aquafish.recovery, "_run_tasks", _no_work)
    fails_safe(["recovery", "--budget", "smoke", "--damages", "caudal_half", "--no-progress", "--out", out], capsys,
               out / planted, "symbolic link")
    assert not any(outside.iterdir())


def test_a_study_refuses_a_planted_link_before_any_run(tmp_path, capsys, monkeypatch):
    import aquafish.study

    out, outside = tmp_path / "study", tmp_path / "outside"
    out.mkdir()
    outside.mkdir()
    (out / "known").symlink_to(outside)
    monkeypatch.setattr(aquafish.study, "run_dir_tasks", _no_work)
    fails_safe(["study", *TINY_STUDY, "--out", out], capsys, out / "known", "symbolic link")
    assert not any(outside.iterdir())


# -- 4. a directory the command did not make is read without unpickling --------------------------------------


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    """A finished tiny EEA run."""
    out = tmp_path_factory.mktemp("eea") / "run"
    assert _main(["eea", *TINY_EEA, "--inference", "known", "--workers", "1", "--out", out]) == 0
    return out


def test_diagnose_reads_the_run_as_data_and_never_its_state_pkl(run_dir, tmp_path, capsys):
    run = tmp_path / "received"
    shutil.copytree(run_dir, run)
    marker = tmp_path / "ran.txt"
    _plant(run / STATE_FILE, marker)
    assert _main(["diagnose", run]) == 0
    assert not marker.exists()
    (run / RUN_DATA_FILE).unlink()  # a run without its data: refused in one line, the pickle unread
    fails_safe(["diagnose", run], capsys, RUN_DATA_FILE, "never from the checkpoint")
    assert not marker.exists()


def test_the_run_data_holds_what_the_checkpoint_holds(run_dir):
    state, data = load_state(run_dir), load_run_data(run_dir)
    assert data.rounds_done == state.rounds_done and data.config == json.loads(json.dumps(state.config))
    assert [e.state_dict().keys() for e in data.experiments] == [e.keys() for e in state.experiments]
    for mine, theirs in zip(data.experiments, state.experiments):
        for key in ("action", "imu_log", "summary", "true_angles", "start_motion"):
            np.testing.assert_array_equal(getattr(mine, key), theirs[key])
        assert mine.context.starts == tuple(theirs["context"]["starts"])
    assert data.evaluator == state.evaluator and data.inference == state.inference
    with np.load(run_dir / RUN_DATA_FILE, allow_pickle=False) as arrays:  # plain arrays only
        assert all(arrays[name].dtype != object for name in arrays.files)


def test_pickles_are_refused_unread_where_refused(tmp_path):
    marker = tmp_path / "ran.txt"
    _plant(tmp_path / "x.pkl", marker)
    with refuse_pickles("the directory is read as data"):
        with pytest.raises(FileError, match="refused unread"):
            read_pickle(tmp_path / "x.pkl")
    assert not marker.exists()


@pytest.fixture(scope="module")
def servo_run(tmp_path_factory):
    """A finished tiny morphology+servos run (checked against fault hypotheses)."""
    out = tmp_path_factory.mktemp("servo") / "run"
    assert _main(["eea", *TINY_EEA, "--rounds", "1", "--inference", "profile", "--model-space", "morphology+servos",
                  "--behaviour-summary", "signed_dft", "--damage", "reversed_left_pectoral", "--workers", "1",
                  "--out", out]) == 0
    return out


def test_a_finished_run_is_checked_again_from_its_data_alone_to_the_bit(servo_run, tmp_path):
    """A finished cell checked again (recovery's ``check_stale``) reads its EEA runs as data: the
    check from the data is the check from the checkpoint, and a planted state.pkl never runs."""
    config = eea.load_result(servo_run).config
    made = read_fault_check(servo_run)  # made from the run's own state at its end
    received = tmp_path / "received"
    shutil.copytree(servo_run, received)
    (received / FAULT_CHECK_FILE).unlink()  # as a check of an earlier procedure: due again
    marker = tmp_path / "ran.txt"
    _plant(received / STATE_FILE, marker)
    with refuse_pickles("the finished cell is checked again from its data"):
        eea.run(config, received, progress=False)
    again = read_fault_check(received)
    assert not marker.exists()
    assert (again.round, again.index, again.simulations, again.procedure) == \
        (made.round, made.index, made.simulations, made.procedure)
    np.testing.assert_array_equal(again.models, made.models)
    np.testing.assert_array_equal(again.model_fitness, made.model_fitness)
    # a run the data cannot show finished (no data file) is not unpickled where pickles are refused
    (received / FAULT_CHECK_FILE).unlink()
    (received / RUN_DATA_FILE).unlink()
    with refuse_pickles("the finished cell is checked again from its data"):
        with pytest.raises(FileError, match="state.pkl.*refused unread"):
            eea.run(config, received, progress=False)
    assert not marker.exists()


def test_a_stale_cell_is_checked_again_only_from_data_and_its_pickles_refused(tmp_path, monkeypatch):
    from aquafish.case_study import eea_dir_name

    cell = tmp_path / "cell"
    model = {"method": "profile", "model_space": "morphology+servos", "behaviour_summary": "signed_dft",
             "fault_check": {"procedure": "an earlier one"}}
    report = {"models": {"self_model": model}}
    run = cell / eea_dir_name("profile", "morphology+servos", "signed_dft")
    run.mkdir(parents=True)
    (run / STATE_FILE).write_bytes(b"")
    assert not aquafish.recovery.check_stale(report, cell)  # a checkpoint alone: read back as it is
    (run / RUN_DATA_FILE).write_bytes(b"")
    assert aquafish.recovery.check_stale(report, cell)
    marker = tmp_path / "ran.txt"
    _plant(tmp_path / "state.pkl", marker)

    def case_study(*args, **kwargs):  # a case study that would load a planted checkpoint
        read_pickle(tmp_path / "state.pkl")

    monkeypatch.setattr("aquafish.case_study.run_case_study", case_study)
    with pytest.raises(FileError, match="refused unread"):
        aquafish.recovery._run_cell("smoke", "caudal_half", 0, str(cell), str(tmp_path / "shared"), 20.0, 1, False,
                                    recheck=True)
    assert not marker.exists()


@pytest.mark.slow
def test_a_recovery_rerun_of_an_edited_cell_runs_no_planted_pickle(tmp_path, capsys):
    out = tmp_path / "bench"
    argv = ["recovery", "--budget", "smoke", "--damages", "reversed_left_pectoral", "--all-rows", "--workers", "1",
            "--no-progress", "--out", out]
    assert _main(argv) == 0
    cell = out / "cells" / "reversed_left_pectoral" / "seed0"
    report = json.loads((cell / "report.json").read_text())
    del report["models"]["self_model"]["fault_check"]["procedure"]  # one report field edited
    (cell / "report.json").write_text(json.dumps(report))
    marker = tmp_path / "ran.txt"
    for state in cell.rglob(STATE_FILE):
        _plant(state, marker)
    assert _main(argv) == 0
    assert not marker.exists()
    assert json.loads((cell / "report.json").read_text())["models"]["self_model"]["fault_check"]["procedure"]
