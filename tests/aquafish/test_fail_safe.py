"""Every command fails safe: one clear line, exit status 2, no traceback, nothing
half-written, and a run directory that cannot be mislabelled.

One regression test (or parametrised family) per root cause of the issue:

1. filesystem errors (a file as ``--out``, ``--out`` under a file, a read-only ``--out``);
2. corrupt or unreadable files (truncated checkpoints, garbled JSON, truncated ``rounds.csv``);
3. a checkpoint checked against its config (edited, copied-in, deleted ``config.json``);
4. re-used output checked against the settings (gait, damages/baselines gaits, PPO, rl);
5. a lock on every run directory (a concurrent writer fails at once);
6. pool workers die with their parent (``kill -9`` of a study);
7. atomic NEAT checkpoints;
8. validation gaps (negative seeds, durations, zero counts, empty lists, memory);
9. nothing half-written on a validation error;
10. ``rounds.csv`` contents validated;
11. misleading messages.

Everything runs in-process through :func:`aquafish.cli.main` with tiny settings, except the
kill -9 test, which needs a parent process to kill.
"""

from __future__ import annotations

import fcntl
import gzip
import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aquafish.cli import main
#: The lock file of a run directory (aquafish_gym.rundir.LOCK_FILE; spelt out so that this module runs on
#: versions without it, where its tests must fail rather than not import).
LOCK_FILE = ".aquafish.lock"

#: A tiny EEA run (~0.5 s), as command-line flags.
TINY_EEA = ["--duration", "0.16", "--rounds", "2", "--exploration-population", "4", "--exploration-generations", "2",
            "--exploration-models", "3", "--estimation-population", "5", "--estimation-generations", "3",
            "--no-progress"]   # no strategy's flags: a flag of a strategy the run does not use is an error
TINY_STUDY = ["--methods", "known", "--durations", "0.16", "--replicates", "1", "--rounds", "1",
              "--exploration-population", "4", "--exploration-generations", "2", "--exploration-models", "3",
              "--estimation-population", "5", "--estimation-generations", "3", "--processes", "1"]
TINY_GAIT = ["--generations", "1", "--population-size", "4", "--episode-duration-s", "0.5", "--workers", "1",
             "--quiet", "--checkpoint-every", "1"]
#: A PPO section that trains in a second.
TINY_PPO = {"ppo": {"AquaFish-v0": {"n_timesteps": 64, "policy": "MlpPolicy", "n_envs": 1, "n_steps": 32,
                                    "batch_size": 16, "n_epochs": 1, "policy_kwargs": {"net_arch": [8]}}}}


def fails_safe(argv, capsys, *names) -> str:
    """Run ``aquafish ARGV``; assert exit status 2 and one line on stderr, without a traceback,
    that contains every one of ``names``; return the line."""
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:
        main([str(a) for a in argv])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err and lines[0].startswith("aquafish ")
    for name in names:
        assert str(name) in lines[0], (name, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Finished tiny outputs to break: two EEA runs (seeds 0 and 1), a gait run and a PPO model."""
    root = tmp_path_factory.mktemp("made")
    for seed in (0, 1):
        assert main(["eea", *TINY_EEA, "--inference", "known", "--workers", "1", "--seed", str(seed),
                     "--out", str(root / "runs" / f"seed{seed}")]) == 0
    assert main(["gait", *TINY_GAIT, "--out", str(root / "gait")]) == 0
    return root


@pytest.fixture
def copy(made, tmp_path):
    """``copy(name)``: a fresh copy of a made output in this test's directory."""
    def make(name: str) -> Path:
        shutil.copytree(made / name, tmp_path / Path(name).name)
        return tmp_path / Path(name).name
    return make


def _eea(out, *flags):
    return ["eea", *TINY_EEA, "--inference", "known", "--workers", "1", *flags, "--out", out]


# -- 1. filesystem errors: a file as --out, --out under a file, read-only --out -----------------------------

def _commands(made: Path, out: Path) -> dict[str, list]:
    """Every command that writes, with ``out`` as its output."""
    controller = made / "gait" / "best_controller.json"
    return {
        "swim": ["swim", "--duration", "0.1", "--out", out],
        "eea": _eea(out),
        "study": ["study", *TINY_STUDY, "--out", out],
        "gait": ["gait", *TINY_GAIT, "--out", out],
        "transfer": ["transfer", "--controller", controller, "--target", "left_pectoral_half", "--out", out],
        "rl": ["rl", "--timesteps", "64", "--out", out],
        "case-study": ["case-study", "--preset", "smoke", "--workers", "1", "--out", out],
        "damages": ["damages", "--damages", "caudal_half", "--generations", "1", "--population-size", "2",
                    "--starts", "1", "--out", out],
        "baselines": ["baselines", "--envs", "AquaFish-v0", "--neat-generations", "1", "--neat-population", "2",
                      "--ppo-timesteps", "0", "--starts", "1", "--out", out],
        "plot": ["plot", made / "runs", "--output", out / "fig.png"],
        "compare": ["compare", f"a={made / 'runs'}", "--output", out / "fig.png"],
    }


COMMANDS = ["swim", "eea", "study", "gait", "transfer", "rl", "case-study", "damages", "baselines", "plot", "compare"]


@pytest.mark.parametrize("command", COMMANDS)
@pytest.mark.parametrize("kind", ["file as --out", "--out under a file"])
def test_unwritable_output_is_one_line_before_any_work(command, kind, made, tmp_path, capsys, monkeypatch):
    if command == "rl":
        pytest.importorskip("stable_baselines3")
    monkeypatch.chdir(tmp_path)
    blocker = tmp_path / "blocker"
    blocker.write_text("a file\n")
    if kind == "file as --out":
        argv = _commands(made, blocker)[command]
        if command in ("plot", "compare"):  # their output is a file: a directory in its place
            blocker.unlink()
            blocker.mkdir()
            argv = [blocker if isinstance(a, Path) and a.parent == blocker else a for a in argv]
            argv[-1] = blocker
    else:
        argv = _commands(made, blocker / "sub")[command]
    before = sorted(p.name for p in tmp_path.iterdir())
    start = time.perf_counter()
    line = fails_safe(argv, capsys, "blocker")
    assert time.perf_counter() - start < 15, "refused only after working"
    assert any(w in line for w in ("is a file", "is a directory", "not a directory")), line
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing created
    if blocker.is_dir():
        assert not any(blocker.iterdir())


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only directories")
@pytest.mark.parametrize("command", ["eea", "study", "gait", "damages", "baselines", "swim", "case-study"])
def test_read_only_output_is_one_line(command, made, tmp_path, capsys):
    locked = tmp_path / "ro"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        fails_safe(_commands(made, locked / "new")[command], capsys, "ro", "not writable")
    finally:
        locked.chmod(0o755)


def test_debug_shows_the_traceback(tmp_path):
    (tmp_path / "f").write_text("")
    for argv in (["--debug", *_eea(tmp_path / "f")], [*_eea(tmp_path / "f"), "--debug"]):
        with pytest.raises(ValueError, match="is a file"):
            main([str(a) for a in argv])


# -- 2. corrupt or unreadable files -------------------------------------------------------------------------

def _truncate(path: Path, keep: int = 60) -> None:
    path.write_bytes(path.read_bytes()[:keep])


@pytest.mark.parametrize("case", ["truncated state.pkl", "garbled config.json", "config.json a list",
                                  "truncated rounds.csv", "state.pkl not a checkpoint"])
def test_corrupt_run_files_name_the_file(case, copy, capsys):
    run = copy("runs/seed0")
    target = {"truncated state.pkl": "state.pkl", "garbled config.json": "config.json",
              "config.json a list": "config.json", "truncated rounds.csv": "rounds.csv",
              "state.pkl not a checkpoint": "state.pkl"}[case]
    path = run / target
    if case == "garbled config.json":
        path.write_text(path.read_text()[:-40])
    elif case == "config.json a list":
        path.write_text("[1, 2]")
    elif case == "truncated rounds.csv":
        path.write_text(path.read_text()[:-200])
    elif case == "state.pkl not a checkpoint":
        path.write_bytes(pickle.dumps([1, 2, 3]))
    else:
        _truncate(path)
    if target == "rounds.csv":  # the checkpoint is the record: a resume rewrites rounds.csv from it
        broken = path.read_text()
        assert main([str(a) for a in _eea(run)]) == 0 and len(path.read_text().splitlines()) == 3
        path.write_text(broken)
    else:
        fails_safe(_eea(run), capsys, path)
    if target != "state.pkl":  # diagnose reads the run as data (run_data.npz), never its checkpoint
        fails_safe(["plot", run, "--output", run / "p.png"], capsys, path)
        fails_safe(["compare", f"a={run}"], capsys, path)
        fails_safe(["diagnose", run], capsys, path)


def test_truncated_neat_checkpoint_and_garbled_json_of_a_gait_run(copy, capsys):
    run = copy("gait")
    latest = run / "checkpoints" / "neat-checkpoint-1"
    good = latest.read_bytes()
    _truncate(latest)
    fails_safe(["gait", *TINY_GAIT, "--generations", "2", "--resume", "latest", "--out", run], capsys, latest,
               "truncated or corrupt")
    latest.write_bytes(good)
    settings = run / "fitness_settings.json"
    settings.write_text(settings.read_text()[:30])
    fails_safe(["gait", *TINY_GAIT, "--generations", "2", "--resume", "latest", "--out", run], capsys, settings,
               "not valid JSON")
    _truncate(run / "best_controller.json")
    fails_safe(["transfer", "--controller", run / "best_controller.json", "--target", "healthy", "--out", run / "t"],
               capsys, run / "best_controller.json")


def test_garbled_study_json_names_the_file(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    (out / "study.json").write_text('{"conditions": ["known"], "base": ')
    fails_safe(["study", *TINY_STUDY, "--out", out], capsys, out / "study.json", "not valid JSON")
    (out / "study.json").write_text('{"conditions": ["known"]}')
    fails_safe(["study", *TINY_STUDY, "--out", out], capsys, out / "study.json")


# -- 3. a checkpoint is checked against its config ----------------------------------------------------------

def test_edited_damage_in_config_json_is_refused_by_resume_and_diagnose(copy, capsys):
    run = copy("runs/seed0")
    config = json.loads((run / "config.json").read_text())
    config["damage"] = "caudal_half"
    (run / "config.json").write_text(json.dumps(config))
    fails_safe(_eea(run, "--damage", "caudal_half"), capsys, "state.pkl", "damage")
    fails_safe(["diagnose", run], capsys, "run_data.npz", "damage")


def test_a_state_pkl_copied_from_another_run_is_refused(made, copy, capsys):
    run = copy("runs/seed0")
    shutil.copy(made / "runs" / "seed1" / "state.pkl", run / "state.pkl")
    fails_safe(_eea(run, "--rounds", "3"), capsys, "state.pkl", "seed: 1 -> 0")


def test_a_resume_without_config_json_is_refused_unread(copy, capsys):
    # a checkpoint is a pickle: it is read only beside its manifest, whatever the flags
    run = copy("runs/seed0")
    (run / "config.json").unlink()
    rows = (run / "rounds.csv").read_text()
    for flags in (("--seed", "5"), ("--seed", "0")):
        fails_safe(_eea(run, *flags), capsys, "state.pkl", "config.json")
    assert (run / "rounds.csv").read_text() == rows and not (run / "config.json").exists()


# -- 4. re-used output is checked against the settings ------------------------------------------------------

def test_gait_into_a_run_of_another_seed_is_refused_and_latest_stays_its_own(copy, capsys):
    run = copy("gait")
    before = sorted(p.name for p in (run / "checkpoints").iterdir())
    fails_safe(["gait", *TINY_GAIT, "--seed", "5", "--out", run], capsys, run, "seed: 0 -> 5")
    fails_safe(["gait", *TINY_GAIT, "--out", run], capsys, run, "already holds a gait run", "--resume latest")
    fails_safe(["gait", *TINY_GAIT, "--seed", "5", "--generations", "2", "--resume", "latest", "--out", run], capsys,
               "neat-checkpoint-1", "seed: 0 -> 5")
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == before


def test_reused_gaits_and_policies_are_checked_against_the_budget(copy, tmp_path):
    from gait import evolve_or_load_gait

    run = copy("gait")
    kw = dict(population_size=4, episode_duration_s=0.5, workers=1, progress=False)
    evolve_or_load_gait("healthy", run, generations=1, **kw)  # the same budget: reused
    with pytest.raises(ValueError, match="generations: 1 -> 3"):  # damages/baselines with a new budget
        evolve_or_load_gait("healthy", run, generations=3, **kw)
    with pytest.raises(ValueError, match="population_size: 4 -> 6"):
        evolve_or_load_gait("healthy", run, generations=1, **(kw | dict(population_size=6)))
    pytest.importorskip("stable_baselines3")
    from gait.rl import train_or_load_rl

    hp = tmp_path / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO))
    out = tmp_path / "ppo"
    rl = dict(hyperparams_path=hp, episode_duration_s=0.5, progress=False, num_threads=1)
    path = train_or_load_rl("ppo", "healthy", 32, 0, out, **rl)
    assert train_or_load_rl("ppo", "healthy", 32, 0, out, **rl) == path
    with pytest.raises(ValueError, match="timesteps: 32 -> 64"):
        train_or_load_rl("ppo", "healthy", 64, 0, out, **rl)


def test_rl_does_not_overwrite_a_trained_model(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    hp = tmp_path / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO))
    argv = ["rl", "--hyperparams", hp, "--episode-duration-s", "0.5", "--timesteps", "32", "--out", tmp_path / "rl"]
    assert main([str(a) for a in argv]) == 0
    model = (tmp_path / "rl" / "model.zip").read_bytes()
    fails_safe(argv, capsys, "already holds this trained model")
    fails_safe([*argv, "--seed", "2"], capsys, "seed: 0 -> 2")
    assert (tmp_path / "rl" / "model.zip").read_bytes() == model


# -- 5. a lock on every run directory -----------------------------------------------------------------------

def _hold_lock(directory: Path):
    """Lock ``directory`` as another process would (its own open file description)."""
    directory.mkdir(parents=True, exist_ok=True)
    fd = os.open(directory / LOCK_FILE, os.O_RDWR | os.O_CREAT)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    os.write(fd, b"4242\n")
    return fd


@pytest.mark.parametrize("command", ["eea", "study", "gait", "damages", "baselines", "case-study", "rl"])
def test_a_second_writer_fails_at_once(command, made, tmp_path, capsys):
    if command == "rl":
        pytest.importorskip("stable_baselines3")
    out = tmp_path / "busy"
    fd = _hold_lock(out)
    try:
        start = time.perf_counter()
        fails_safe(_commands(made, out)[command], capsys, "busy", "in use by another aquafish process (pid 4242)")
        assert time.perf_counter() - start < 15
    finally:
        os.close(fd)
    assert sorted(p.name for p in out.iterdir()) == [LOCK_FILE]  # nothing written by the refused command


def test_two_eea_runs_of_other_seeds_on_one_out_keep_the_first(tmp_path, capsys):
    out = tmp_path / "run"
    fd = _hold_lock(out)  # run 1 is still running
    try:
        fails_safe(_eea(out, "--seed", "2"), capsys, "in use")
    finally:
        os.close(fd)
    assert main([str(a) for a in _eea(out, "--seed", "1")]) == 0
    assert json.loads((out / "config.json").read_text())["seed"] == 1
    fails_safe(_eea(out, "--seed", "2"), capsys, "seed: 1 -> 2")
    assert not (out / LOCK_FILE).exists()  # released and removed after the run


def test_a_lock_left_by_a_killed_writer_does_not_block(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / LOCK_FILE).write_text("999999\n")  # the file of a writer killed with -9: no flock held
    assert main([str(a) for a in _eea(out)]) == 0


# -- 6. pool workers die with their parent ------------------------------------------------------------------

def _children(pid: int) -> list[int]:
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_kill_9_of_a_study_leaves_no_worker_running(tmp_path):
    argv = ["study", *TINY_STUDY, "--replicates", "3", "--rounds", "40", "--processes", "2", "--out", str(tmp_path / "s")]
    parent = subprocess.Popen([sys.executable, "-c", f"from aquafish.cli import main; main({argv!r})"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        workers = []
        while time.monotonic() < deadline and len(workers) < 2:
            time.sleep(0.2)
            workers = [p for p in _children(parent.pid) if _alive(p)]
            assert parent.poll() is None, "the study ended before it could be killed"
        assert len(workers) >= 2, "the pool did not start"
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(p) for p in workers):
            time.sleep(0.1)
        assert not any(_alive(p) for p in workers), "pool workers outlived their parent"
    finally:
        if parent.poll() is None:
            parent.kill()
        for p in _children(parent.pid):
            os.kill(p, signal.SIGKILL)


# -- 7. NEAT checkpoints are written atomically -------------------------------------------------------------

def test_a_failed_checkpoint_write_leaves_no_truncated_checkpoint(tmp_path, monkeypatch):
    from gait import evolve_gait

    real = pickle.dump

    def dies_half_way(obj, file, *args, **kwargs):
        if isinstance(obj, tuple) and len(obj) == 5:  # a NEAT checkpoint
            file.write(pickle.dumps(obj)[:100])
            raise OSError(28, "No space left on device")
        return real(obj, file, *args, **kwargs)

    monkeypatch.setattr(pickle, "dump", dies_half_way)
    with pytest.raises(OSError):
        evolve_gait(None, generations=2, population_size=4, episode_duration_s=0.5, workers=1, checkpoint_every=1,
                    out_dir=tmp_path, progress=False)
    assert not list((tmp_path / "checkpoints").iterdir())  # neither a truncated checkpoint nor a temporary file


def test_checkpoints_are_neat_pythons_format_with_the_fingerprint(made):
    with gzip.open(made / "gait" / "checkpoints" / "neat-checkpoint-1") as f:
        generation, config, population, species, rndstate = pickle.load(f)
    assert generation == 1 and len(population) == 4
    assert config.aquafish_fingerprint == json.loads((made / "gait" / "fitness_settings.json").read_text())
    assert config.aquafish_fingerprint["seed"] == 0 and config.aquafish_fingerprint["population_size"] == 4


# -- 8. validation gaps -------------------------------------------------------------------------------------

@pytest.mark.parametrize("argv, names", [
    (["transfer", "--controller", "c.pkl", "--target", "healthy", "--seed", "-1"], ["--seed", ">= 0"]),
    (["rl", "--seed", "-1"], ["--seed", ">= 0"]),
    (["damages", "--out", "o", "--eval-seed", "-1"], ["--eval-seed", ">= 0"]),
    (["baselines", "--out", "o", "--eval-seed", "-1"], ["--eval-seed", ">= 0"]),
    (["swim", "--duration", "0"], ["--duration", "> 0"]),
    (["swim", "--duration", "-3"], ["--duration", "> 0"]),
    (["swim", "--duration", "nan"], ["--duration", "finite"]),
    (["swim", "--duration", "inf"], ["--duration", "finite"]),
    (["swim", "--episode-duration-s", "0"], ["--episode-duration-s", "> 0"]),
    (["swim", "--episode-duration-s", "1e9"], ["--episode-duration-s 1e+09", "memory"]),
    (["swim", "--duration", "1e9"], ["--episode-duration-s 1e+09", "memory"]),  # the old name
    (["study", "--out", "o", "--processes", "0"], ["--processes", ">= 1"]),
    (["gait", "--out", "o", "--population-size", "1000000000"], ["1000000000", "memory", "--population-size"]),
    (["gait", "--out", "o", "--episode-duration-s", "1e12"], ["memory", "--episode-duration-s"]),
    (["eea", "--out", "o", "--estimation-population", "1000000000"], ["1000000000", "memory"]),
    (["rl", "--num-threads", "0"], ["--num-threads", ">= 1"]),
    (["bench", "NAME"], ["NAME", "sim"]),
    (["baselines", "--out", "o", "--envs", ""], ["--envs", "at least one"]),
    (["damages", "--out", "o", "--damages", ","], ["--damages", "at least one"]),
    (["eea", "--out", ""], ["--out", "is empty"]),
    (["gait", "--out", ""], ["--out", "is empty"]),
    (["rl", "--out", ""], ["--out", "is empty"]),
    (["case-study", "--workers", "0"], ["--workers", ">= 1"]),
    (["gait", "--out", "o", "--workers", "0"], ["--workers", ">= 1"]),
    (["swim", "--action", "1,2"], ["--action", "3"]),
])
def test_bad_settings_are_refused_up_front(argv, names, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    start = time.perf_counter()
    fails_safe(argv, capsys, *names)
    assert time.perf_counter() - start < 15
    assert list(tmp_path.iterdir()) == []  # nothing written, not even into the current directory


# -- 9. nothing half-written on a validation error ----------------------------------------------------------

@pytest.mark.parametrize("argv, names", [
    (["gait", *TINY_GAIT, "--episode-duration-s", "-1"], ["--episode-duration-s"]),
    (["eea", *TINY_EEA, "--estimation-population", "1000000000"], ["memory"]),
    (["study", *TINY_STUDY, "--estimation-population", "1000000000"], ["memory"]),
    (["rl", "--seed", "-1"], ["--seed"]),
    (["gait", *TINY_GAIT, "--env", "Nope"], ["Nope"]),
    (["gait", *TINY_GAIT, "--config", "missing.ini"], ["missing.ini"]),
    (["gait", *TINY_GAIT, "--damage", "broken"], ["broken"]),
    (["eea", *TINY_EEA, "--k-best", "50"], ["k_best"]),
    (["eea", *TINY_EEA, "--damage", "broken"], ["broken"]),
    (["study", *TINY_STUDY, "--methods", "bogus"], ["bogus"]),
    (["rl", "--hyperparams", "missing.yml"], ["missing.yml"]),
    (["rl", "--env", "Nope"], ["Nope"]),
    (["case-study", "--damage", "broken"], ["broken"]),
])
def test_a_validation_error_leaves_no_directory(argv, names, tmp_path, capsys, monkeypatch):
    if argv[0] == "rl":
        pytest.importorskip("stable_baselines3")
    monkeypatch.chdir(tmp_path)
    fails_safe([*argv, "--out", tmp_path / "new"], capsys, *names)
    assert not (tmp_path / "new").exists()


# -- 10. rounds.csv contents are validated ------------------------------------------------------------------

@pytest.mark.parametrize("edit, names", [
    (lambda lines: [lines[0], lines[1].replace(lines[1].split(",")[1], "nan", 1), *lines[2:]], ["line 2", "non-finite"]),
    (lambda lines: [lines[0], lines[1], lines[1]], ["line 3", "repeats round 1"]),
    (lambda lines: [lines[0], lines[2]], ["line 2", "skips to round 2"]),
    (lambda lines: [lines[0].replace("round,", "rnd,", 1), *lines[1:]], ["missing columns ['round']"]),
])
def test_rounds_csv_rows_are_finite_unique_and_consecutive(edit, names, copy, capsys):
    run = copy("runs/seed0")
    path = run / "rounds.csv"
    path.write_text("\n".join(edit(path.read_text().splitlines())) + "\n")
    fails_safe(["plot", run, "--output", run / "p.png"], capsys, path, *names)
    assert not (run / "p.png").exists()


# -- 11. misleading messages --------------------------------------------------------------------------------

def test_diagnose_names_a_missing_run_data_file(copy, capsys):
    run = copy("runs/seed0")
    (run / "run_data.npz").unlink()
    line = fails_safe(["diagnose", run], capsys, "run_data.npz", "`aquafish eea`")
    assert "no finished round" not in line


def test_rl_reports_the_steps_it_trained(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    hp = tmp_path / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO))
    assert main([str(a) for a in ["rl", "--hyperparams", hp, "--episode-duration-s", "0.5", "--timesteps", "10",
                                  "--out", tmp_path / "rl"]]) == 0
    out = capsys.readouterr().out
    assert "--timesteps 10 was rounded up to 32 steps" in out and "PPO on AquaFish-v0: 32 steps" in out
    meta = json.loads((tmp_path / "rl" / "model.json").read_text())
    assert (meta["timesteps"], meta["timesteps_requested"]) == (32, 10)


def test_a_smaller_rounds_keeps_config_json(copy, capsys):
    run = copy("runs/seed0")
    config = (run / "config.json").read_text()
    assert main([str(a) for a in _eea(run, "--rounds", "1")]) == 0
    assert (run / "config.json").read_text() == config
    assert "2 rounds" in capsys.readouterr().out


# -- 12. a missing optional extra is a one-line error, before anything is created ----------------------------

@pytest.fixture
def without_rl(monkeypatch):
    """Simulate an install without the [rl] extra: ``import stable_baselines3`` raises ImportError."""
    for name in ("stable_baselines3", "sb3_contrib"):
        monkeypatch.setitem(sys.modules, name, None)


def test_transfer_of_an_sb3_model_without_the_rl_extra_names_the_extra(made, tmp_path, capsys, without_rl):
    model = tmp_path / "ppo" / "model.zip"
    model.parent.mkdir()
    model.write_bytes(b"not read")
    (tmp_path / "ppo" / "model.json").write_text(json.dumps({"algo": "ppo", "clock_period_s": 1.0}))
    out = tmp_path / "t"
    # the NEAT gait first: it must not be scored before the SB3 model is refused
    fails_safe(["transfer", "--controller", made / "gait", model, "--target", "healthy", "--out", out], capsys,
               "[rl]", "pip install 'aquafish[rl]'")
    assert not out.exists()
    fails_safe(["rl", "--timesteps", "64", "--out", out], capsys, "pip install 'aquafish[rl]'")
    assert not out.exists()


def test_baselines_with_ppo_steps_without_the_rl_extra_refuses_before_any_work(tmp_path, capsys, without_rl):
    out = tmp_path / "b"
    argv = ["baselines", "--envs", "AquaFish-v0", "--neat-generations", "1", "--neat-population", "4",
            "--neat-episodes", "1", "--starts", "1", "--out", out]
    fails_safe([*argv, "--ppo-timesteps", "100"], capsys, "--ppo-timesteps 100", "pip install 'aquafish[rl]'",
               "--ppo-timesteps 0")
    assert not out.exists()
    from aquafish.task_table import BaselineBudget, task_table
    with pytest.raises(ValueError, match=r"aquafish\[rl\]"):
        task_table(out, env_ids=["AquaFish-v0"], budget=BaselineBudget(1, 4, 1, 100), starts=1, progress=False)
    assert not out.exists()


# -- 13. no file a user may receive from someone else runs code when loaded ---------------------------------

class _Payload:
    """Pickles to a call that creates the directory ``marker`` when it is unpickled."""

    def __init__(self, marker):
        self.marker = str(marker)

    def __reduce__(self):
        return os.mkdir, (self.marker,)


def test_a_pickled_controller_or_a_foreign_checkpoint_is_refused_unread(copy, tmp_path, capsys):
    marker = tmp_path / "ran"
    evil = tmp_path / "evil.pkl"
    evil.write_bytes(pickle.dumps(_Payload(marker)))
    out = tmp_path / "t"
    fails_safe(["transfer", "--controller", evil, "--target", "healthy", "--out", out], capsys, evil, "runs code",
               "best_controller.json")
    assert not out.exists()
    with gzip.open(tmp_path / "neat-checkpoint-1", "wb") as f:
        pickle.dump(_Payload(marker), f)
    fails_safe(["gait", *TINY_GAIT, "--generations", "2", "--resume", tmp_path / "neat-checkpoint-1", "--out",
                tmp_path / "g"], capsys, tmp_path / "neat-checkpoint-1", "fitness_settings.json")
    run = copy("gait")  # a checkpoint swapped into a run of other settings
    shutil.copy(tmp_path / "neat-checkpoint-1", run / "checkpoints" / "neat-checkpoint-1")
    fails_safe(["gait", *TINY_GAIT, "--seed", "5", "--generations", "2", "--resume", "latest", "--out", run], capsys,
               "fitness_settings.json", "seed")
    assert not marker.exists()
    # the help says a run directory is trusted like code
    with pytest.raises(SystemExit):
        main(["gait", "--help"])
    assert "trusted like code" in " ".join(capsys.readouterr().out.split())


def test_a_reader_that_stops_reading_ends_the_command_quietly(tmp_path):
    """``aquafish ... | head``: the closed pipe ends the command with the shell's SIGPIPE status
    (141) and no traceback or error line."""
    import subprocess
    import sys

    driver = tmp_path / "flood.py"
    driver.write_text(
        "import sys\n"
        "from aquafish import cli\n"
        "build = cli.build_parser\n"
        "def flooding_parser():\n"
        "    parser = build()\n"
        "    sub = next(a for a in parser._actions if a.dest == 'command')\n"
        "    def flood(args):\n"
        "        for _ in range(100000):\n"
        "            print('x' * 60)\n"
        "        return 0\n"
        "    sub.add_parser('flood').set_defaults(func=flood, command='flood')\n"
        "    return parser\n"
        "cli.build_parser = flooding_parser\n"
        "sys.exit(cli.main(['flood']))\n")
    reader = subprocess.Popen([sys.executable, str(driver)], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    reader.stdout.read(100)
    reader.stdout.close()  # the reader goes away
    stderr = reader.stderr.read().decode()
    assert reader.wait(timeout=60) == 141, stderr
    assert stderr == ""
