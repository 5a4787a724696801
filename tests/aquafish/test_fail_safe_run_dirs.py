"""Fail safe, round 2: the run directory's own causes (the flags that build a config, the
lock, the command that made a directory, refusals that left directories, files that ran code,
leftover temporaries, messages). One test, or parametrised family, per cause and command; each
failed before its fix. The same conventions as ``test_fail_safe.py`` (whose tiny settings and
``fails_safe`` helper are used): in-process through :func:`aquafish.cli.main`, except where a
process must be killed or interrupted.
"""

from __future__ import annotations

import errno
import json
import os
import pickle
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from aquafish.cli import main
from aquafish_gym.files import atomic_write
from aquafish_gym.rundir import COMMAND_FILE, LOCK_FILE, FileError, check_memory, command_of, run_lock
from test_fail_safe import TINY_EEA, TINY_GAIT, TINY_STUDY, fails_safe


def _main(argv) -> int:
    return main([str(a) for a in argv])


def _eea(out, *flags):
    return ["eea", *TINY_EEA, "--inference", "known", "--workers", "1", *flags, "--out", out]


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    """Finished tiny outputs: an EEA run, a study and a gait run."""
    root = tmp_path_factory.mktemp("made2")
    assert _main(_eea(root / "eea")) == 0
    assert _main(["study", *TINY_STUDY, "--out", root / "study"]) == 0
    assert _main(["gait", *TINY_GAIT, "--out", root / "gait"]) == 0
    return root


@pytest.fixture
def copy(made, tmp_path):
    def make(name: str) -> Path:
        shutil.copytree(made / name, tmp_path / name)
        return tmp_path / name
    return make


# -- 1. --waterline deep reaches the config ---------------------------------------------------------------

def test_waterline_deep_is_recorded_as_deep_water_by_eea_and_study(tmp_path):
    assert _main(_eea(tmp_path / "deep", "--waterline", "deep")) == 0
    assert json.loads((tmp_path / "deep" / "config.json").read_text())["waterline"] is None
    assert _main(["study", *TINY_STUDY, "--waterline", "none", "--out", tmp_path / "study"]) == 0
    assert json.loads((tmp_path / "study" / "study.json").read_text())["base"]["waterline"] is None
    run = next((tmp_path / "study").rglob("config.json"))
    assert json.loads(run.read_text())["waterline"] is None


def test_not_giving_waterline_keeps_the_surface_and_a_surface_run_refuses_deep(copy, capsys):
    run = copy("eea")
    assert json.loads((run / "config.json").read_text())["waterline"] == 0.3
    fails_safe(_eea(run, "--waterline", "deep", "--rounds", "3"), capsys, "waterline: 0.3 -> None")


# -- 3. the lock never follows a symbolic link ---------------------------------------------------------------

def test_a_planted_lock_symlink_is_refused_and_its_target_untouched(tmp_path, capsys):
    victim = tmp_path / "victim.txt"
    victim.write_text("precious\n")
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_FILE).symlink_to(victim)
    fails_safe(_eea(out), capsys, LOCK_FILE, "symbolic link")
    assert victim.read_text() == "precious\n"
    assert not (out / "config.json").exists()


# -- 4. a run directory knows the command that made it ---------------------------------------------------

@pytest.mark.parametrize("into, argv, maker", [
    ("gait", lambda out: _eea(out), "gait"),
    ("eea", lambda out: ["gait", *TINY_GAIT, "--out", out], "eea"),
    ("eea", lambda out: ["study", *TINY_STUDY, "--out", out], "eea"),
    ("study", lambda out: _eea(out), "study"),
    ("study", lambda out: ["case-study", "--preset", "smoke", "--workers", "1", "--out", out], "study"),
])
def test_another_commands_directory_is_refused_by_name(into, argv, maker, copy, capsys):
    out = copy(into)
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    fails_safe(argv(out), capsys, f"`aquafish {maker}`", "another --out")
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before  # nothing mixed in


def test_directories_record_their_command_and_older_ones_are_known_by_their_manifest(copy):
    dirs = {name: copy(name) for name in ("eea", "study", "gait")}
    assert {name: command_of(d) for name, d in dirs.items()} == {"eea": "eea", "study": "study", "gait": "gait"}
    (dirs["study"] / COMMAND_FILE).unlink()  # a study written before the command was recorded
    assert command_of(dirs["study"]) == "study"
    with pytest.raises(ValueError, match="aquafish study"):
        with run_lock(dirs["study"], command="eea"):
            pass


# -- 6. a refused command leaves no directory ------------------------------------------------------------

@pytest.mark.parametrize("argv, names", [
    (["damages", "--damages", "typo", "--generations", "1", "--population-size", "2", "--starts", "1"], ["typo"]),
    (["baselines", "--envs", "typo", "--neat-generations", "1", "--neat-population", "2", "--ppo-timesteps", "0",
      "--starts", "1"], ["typo"]),
])
def test_a_refused_command_leaves_no_directory(argv, names, tmp_path, capsys):
    fails_safe([*argv, "--out", tmp_path / "a" / "b" / "new"], capsys, *names)
    assert list(tmp_path.iterdir()) == []


def test_an_overlong_name_is_refused_before_any_parent_is_made(tmp_path, capsys):
    out = tmp_path / "parent" / "child" / ("x" * 300)
    fails_safe(_eea(out), capsys, "300 bytes long", "shorter name")
    assert list(tmp_path.iterdir()) == []


def test_a_lock_removes_only_the_directories_it_made(tmp_path):
    with pytest.raises(RuntimeError):
        with run_lock(tmp_path / "a" / "b", command="eea"):
            raise RuntimeError("refused")
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "kept").mkdir()
    with pytest.raises(RuntimeError):
        with run_lock(tmp_path / "kept" / "new") as d:
            (d / "result.txt").write_text("written\n")
            raise RuntimeError("failed after writing")
    assert (tmp_path / "kept" / "new" / "result.txt").read_text() == "written\n"



def test_two_runs_that_create_one_parent_at_the_same_moment_both_start_and_neither_removes_it(tmp_path,
                                                                                              monkeypatch):
    # the race of two benchmark workers locking shared/seed0 and shared/seed1 under a missing
    # shared/: each found it missing, the other created it first, so this mkdir finds it made
    import os

    real_lexists = os.path.lexists
    raced = tmp_path / "shared"

    def lexists(path):
        if Path(path) == raced and not getattr(lexists, "done", False):
            lexists.done = True
            raced.mkdir()  # the other process, between the check and this process's mkdir
            return False
        return real_lexists(path)

    monkeypatch.setattr("aquafish_gym.rundir.os.path.lexists", lexists)
    with pytest.raises(RuntimeError):
        with run_lock(raced / "seed1", command="recovery"):
            raise RuntimeError("failed before writing")
    # seed1, which this run made, is removed; shared/, which the other made, is not
    assert raced.is_dir() and list(raced.iterdir()) == []
    monkeypatch.undo()
    (tmp_path / "file").write_text("")
    monkeypatch.setattr("aquafish_gym.rundir.os.path.lexists",
                        lambda path: False if Path(path) == tmp_path / "file" else real_lexists(path))
    with pytest.raises(FileExistsError):  # a file in the way is still an error
        with run_lock(tmp_path / "file" / "run"):
            pass

# -- 7. no file a user may receive runs code when loaded ------------------------------------------------

class _Payload:
    """Unpickling this writes ``path``: a pickle that runs code."""

    def __init__(self, path):
        self.path = str(path)

    def __reduce__(self):
        return (Path.write_text, (Path(self.path), "ran\n"))


@pytest.mark.parametrize("manifest", ["none", "other run"])
def test_a_planted_state_pkl_is_not_unpickled(manifest, copy, tmp_path, capsys):
    out = tmp_path / "planted"
    if manifest == "none":
        out.mkdir()
    else:
        out = copy("eea")
    marker = tmp_path / "ran.txt"
    (out / "state.pkl").write_bytes(pickle.dumps(_Payload(marker)))
    if manifest == "none":
        fails_safe(_eea(out), capsys, "state.pkl", "config.json")
        fails_safe(["diagnose", out], capsys, str(out))
    else:
        fails_safe(_eea(out, "--seed", "3"), capsys, "seed: 0 -> 3")
    assert not marker.exists()


# -- 8. temporaries of killed writers are removed when the directory is next locked ------------------

def test_leftover_temporaries_are_removed_on_the_next_lock(copy):
    run = copy("gait")
    live = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True, check=True).stdout.strip()
        stale = [run / f".fitness_history.json.{dead}.abcd_123.tmp", run / ".run.json.q1w2e3r4.tmp",
                 run / "checkpoints" / f".neat-checkpoint-1.{dead}.zzzzzzzz.tmp"]
        kept = [run / f".run.json.{live.pid}.abcdefgh.tmp", run / "checkpoints" / "notes.tmp",
                run / "checkpoints" / ".old.a1b2c3d4.tmp"]  # an old-style one below: whose it is is unknown
        for path in [*stale, *kept]:
            path.write_bytes(b"x" * 1000)
        with run_lock(run, command="gait"):
            pass
        assert [p.exists() for p in stale] == [False] * 3
        assert [p.exists() for p in kept] == [True] * 3
    finally:
        live.kill()
        live.wait()


def test_an_interrupted_atomic_write_leaves_a_temporary_the_next_lock_removes(tmp_path, monkeypatch):
    code = textwrap.dedent(f"""
        import os
        from aquafish_gym import files
        def killed(fd):
            os._exit(9)  # as kill -9 between write and rename
        os.fsync = killed
        files.atomic_write({str(tmp_path / 'state.pkl')!r}, b"x" * 100_000)
    """)
    subprocess.run([sys.executable, "-c", code], check=False)
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    with run_lock(tmp_path):
        pass
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


# -- 9. messages --------------------------------------------------------------------------------------

def test_a_full_disk_names_the_file(tmp_path, monkeypatch, capsys):
    def full(fd):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(os, "fsync", full)
    line = fails_safe(_eea(tmp_path / "out"), capsys, "disk is full", str(tmp_path / "out"))
    assert ".aquafish-command" in line or "config.json" in line
    with pytest.raises(OSError) as err:
        atomic_write(tmp_path / "f.json", b"{}")
    assert err.value.filename == str(tmp_path / "f.json") and err.value.errno == errno.ENOSPC


@pytest.mark.parametrize("link, names", [
    ("loop", ["symbolic link that loops"]),
    ("dangling", ["symbolic link to", "does not exist"]),
])
def test_a_looping_or_dangling_link_is_called_what_it_is(link, names, tmp_path, capsys):
    out = tmp_path / "out"
    if link == "loop":
        out.symlink_to(out)
    else:
        out.symlink_to(tmp_path / "gone")
    line = fails_safe(_eea(out), capsys, *names)
    assert "a file" not in line
    line = fails_safe(_eea(out / "run"), capsys, *names)
    assert "a file" not in line


def test_the_memory_refusal_states_what_a_run_may_use(monkeypatch):
    monkeypatch.setattr("aquafish_gym.rundir.available_memory", lambda: 24.4e9)
    with pytest.raises(ValueError) as err:
        check_memory("this", 21.4e9, "lower it")
    assert "more than the 19.5 GB a run may use (80% of the 24.4 GB available)" in str(err.value)


def test_file_error_crosses_processes_unchanged():
    err = pickle.loads(pickle.dumps(FileError("/r/state.pkl", "is truncated", "delete it")))
    assert isinstance(err, FileError) and str(err) == "/r/state.pkl: is truncated; delete it"
    assert (err.path, err.problem, err.fix) == (Path("/r/state.pkl"), "is truncated", "delete it")


def test_a_corrupt_checkpoint_inside_a_study_is_named_through_the_pool(copy, capsys):
    study = copy("study")
    state = next(study.rglob("state.pkl"))
    state.write_bytes(state.read_bytes()[:50])
    (state.parent / "rounds.csv").unlink()  # unfinished: the study resumes it from its checkpoint
    fails_safe(["study", *TINY_STUDY, "--processes", "2", "--out", study], capsys, str(state), "truncated")


def test_ctrl_c_ends_pool_workers_without_a_traceback(tmp_path):
    code = textwrap.dedent("""
        import os, signal, sys, time
        from concurrent.futures import ProcessPoolExecutor
        from aquafish_gym.rundir import die_with_parent
        with ProcessPoolExecutor(2, initializer=die_with_parent, initargs=(os.getpid(),)) as pool:
            futures = [pool.submit(time.sleep, 30) for _ in range(2)]
            time.sleep(2)
            for pid in list(pool._processes):
                os.kill(pid, signal.SIGINT)
            try:
                [f.result() for f in futures]
            except Exception as err:
                print(type(err).__name__)
    """)
    start = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert time.perf_counter() - start < 25  # the workers ended at once
    assert "Traceback" not in done.stderr and "KeyboardInterrupt" not in done.stderr, done.stderr
    assert done.stdout.strip() == "BrokenProcessPool"


def test_a_spawn_pool_started_now_outlives_the_thread_that_first_used_it(tmp_path):
    # Linux's parent-death signal follows the thread that started a worker: a pool whose workers
    # were started by a short-lived thread breaks when that thread ends; start_now=True starts
    # them from the constructing thread, so the pool keeps working
    code = textwrap.dedent("""
        import threading, time
        from concurrent.futures.process import BrokenProcessPool
        from aquafish_gym.rundir import spawn_pool
        for start_now in (False, True):
            with spawn_pool(2, start_now=start_now) as pool:
                assert pool._mp_context.get_start_method() == "spawn"
                if start_now:
                    assert len(pool._processes) == 2
                thread = threading.Thread(target=lambda: list(pool.map(abs, [-1, -2])))
                thread.start(); thread.join(); time.sleep(1.0)
                try:
                    print(start_now, list(pool.map(abs, [-3, -4])))
                except BrokenProcessPool:
                    print(start_now, "broken")
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.split("\n")
    if sys.platform.startswith("linux"):
        assert lines[0] == "False broken"
    assert lines[1] == "True [3, 4]"
