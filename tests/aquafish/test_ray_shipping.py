"""On Ray, a task's directories come back to the driver and are written there (aquafish.shipping):
no node writes into the driver's output directory, the driver's directory then holds what a
local run writes, finished work is skipped on resume, a lost worker's task is retried and
logged, and a result that fails to arrive leaves nothing half written."""

from __future__ import annotations

import csv
import json
import logging
import os
import pickle
import sys
from pathlib import Path

import pytest

import aquafish.backends
from aquafish.cli import main
from aquafish.recovery import cell_dir, run_recovery
from aquafish.shipping import DirTask, pack_dir, run_dir_tasks, unpack_dir
from aquafish_gym.rundir import COMMAND_FILE, FileError
from test_fail_safe import TINY_STUDY

DAMAGES = ("left_pectoral_half", "reversed_left_pectoral")


def _tree(root: Path) -> dict[str, int]:
    """Every file below ``root`` and its mtime (what a write into ``root`` would change)."""
    return {p.relative_to(root).as_posix(): p.stat().st_mtime_ns for p in sorted(root.rglob("*")) if p.is_file()} \
        if root.exists() else {}


def _files(root: Path) -> set[str]:
    return {p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file()}


# -- unpacking: atomic, never half written -----------------------------------------------------------


def test_unpack_replaces_a_directory_whole_and_a_failed_one_leaves_it_as_it_was(tmp_path, monkeypatch):
    src = tmp_path / "src"
    (src / "sub").mkdir(parents=True)
    (src / "a.json").write_text('{"dir": "/scratch/x/seed0"}')
    (src / "sub" / "b.bin").write_bytes(b"\x80\x81/scratch/x/seed0")
    (src / ".aquafish.lock").write_text("123\n")  # the lock's own file is never shipped
    files = pack_dir(src)
    assert set(files) == {"a.json", "sub/b.bin"}

    target = tmp_path / "out" / "run" / "seed0"
    unpack_dir(files, target, {"/scratch/x/seed0": str(target)})
    assert json.loads((target / "a.json").read_text()) == {"dir": str(target)}  # text: the driver's path
    assert (target / "sub" / "b.bin").read_bytes() == b"\x80\x81/scratch/x/seed0"  # binary: as it came

    # a result that fails half way (the second file) leaves the directory as it was, and no sibling
    (target / "old.txt").write_text("an unfinished run")
    before = {p: (target / p).read_bytes() for p in _files(target)}
    import aquafish.shipping as shipping

    real, calls = shipping.atomic_write, []

    def fails_on_the_second(path, data):
        calls.append(path)
        if len(calls) == 2:
            raise OSError(28, "No space left on device", str(path))
        real(path, data)

    monkeypatch.setattr(shipping, "atomic_write", fails_on_the_second)
    with pytest.raises(OSError, match="No space left"):
        unpack_dir({"x.json": b"{}", "y.json": b"{}"}, target)
    assert {p: (target / p).read_bytes() for p in _files(target)} == before
    assert sorted(os.listdir(target.parent)) == ["seed0"]  # no hidden .part sibling left
    monkeypatch.setattr(shipping, "atomic_write", real)

    # a path that would leave the directory is refused before anything is written
    with pytest.raises(FileError, match="not a relative path"):
        unpack_dir({"ok.txt": b"", "../escape.txt": b""}, tmp_path / "out" / "run" / "seed1")
    assert not (tmp_path / "out" / "run" / "seed1").exists() and not (tmp_path / "out" / "run" / "escape.txt").exists()

    # a finished result replaces the unfinished directory whole; a killed writer's sibling is removed
    dead = target.parent / ".seed0.999999999.abcdefgh.part"
    dead.mkdir()
    unpack_dir({"new.txt": b"finished"}, target)
    assert _files(target) == {"new.txt"} and sorted(os.listdir(target.parent)) == ["seed0"]


# -- recovery on a Ray stand-in: the tasks run in place of a node, in this process ---------------------


@pytest.fixture
def node_stand_in(monkeypatch):
    """``backend="ray"`` without a cluster: each task runs in this process, as a Ray worker would,
    and fails the test if it changes the driver's output directory (``OUT``, set by the test)."""
    driver = {}
    submitted = []

    def run_tasks(tasks, *, backend="local", processes=1, address=None, labels=None):
        assert backend == "ray"
        submitted.extend(tasks)
        for fn, args in tasks:
            assert str(driver["out"]) not in pickle.dumps(args).decode("latin-1")  # no driver path travels
            before = _tree(driver["out"])
            value = fn(*args)
            assert _tree(driver["out"]) == before, "a task wrote into the driver's output directory"
            yield value

    monkeypatch.setattr(aquafish.backends, "connect_ray", lambda address=None: None)
    monkeypatch.setattr(aquafish.backends, "run_tasks", run_tasks)
    monkeypatch.setattr("aquafish.case_study._rl_available", lambda: False)  # no PPO rows: faster
    return driver, submitted


def _without_times(summary: dict) -> dict:
    return {**summary, "cells": [{k: v for k, v in c.items() if k != "wall_seconds"} for c in summary["cells"]]}


@pytest.mark.slow
def test_recovery_on_ray_writes_on_the_driver_the_files_and_summary_of_a_local_run(tmp_path, node_stand_in):
    driver, submitted = node_stand_in
    local = run_recovery(tmp_path / "local", preset="smoke", damages=DAMAGES, seeds=[0], workers=1, progress=False)
    out = driver["out"] = tmp_path / "ray"
    summary = run_recovery(out, preset="smoke", damages=DAMAGES, seeds=[0], backend="ray", progress=False)
    # one shared-rows task for the seed, then one task per cell
    assert [args[1].__name__ for _, args in submitted] == ["_train_shared", "_run_cell", "_run_cell"]
    assert _without_times(summary) == _without_times(local)
    assert _without_times(json.loads((out / "summary.json").read_text())) == _without_times(local)
    assert (out / "summary.md").read_text() == (tmp_path / "local" / "summary.md").read_text()
    assert _files(out) == _files(tmp_path / "local")  # the same files, markers included
    assert (out / COMMAND_FILE).read_text() == "recovery\n"
    for damage in DAMAGES:
        report = json.loads((cell_dir(out, damage, 0) / "report.json").read_text())
        assert report["shared_dir"] == str(out / "shared" / "seed0")  # the driver's, not the node's
        assert (cell_dir(out, damage, 0) / COMMAND_FILE).read_text() == "case-study\n"

    # resume: every cell is finished on the driver, nothing is sent
    stamps = _tree(out / "cells")
    submitted.clear()
    assert _without_times(run_recovery(out, preset="smoke", damages=DAMAGES, seeds=[0], backend="ray",
                                       progress=False)) == _without_times(summary)
    assert submitted == [] and _tree(out / "cells") == stamps


# -- a real local Ray instance -------------------------------------------------------------------------


@pytest.fixture
def local_ray(monkeypatch):
    """A one-CPU local Ray instance on 127.0.0.1 for the test (without token authentication), shut
    down after; this module's functions travel to its workers by value."""
    ray = pytest.importorskip("ray")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # ray.init would otherwise turn it on and write ~/.ray/auth_token
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1")
    try:
        yield ray
    finally:
        ray.shutdown()
        ray.cloudpickle.unregister_pickle_by_value(sys.modules[__name__])


def _rows(run_dir: Path) -> list[dict]:
    with (run_dir / "rounds.csv").open() as f:
        return [{k: v for k, v in row.items() if k != "wall_seconds"} for row in csv.DictReader(f)]


@pytest.mark.cluster
def test_a_study_on_ray_sends_no_driver_path_and_the_driver_writes_a_local_runs_files(local_ray, tmp_path,
                                                                                        monkeypatch):
    real, sent = aquafish.backends.run_tasks, []

    def spy(tasks, **kwargs):
        sent.extend(tasks)
        return real(tasks, **kwargs)

    monkeypatch.setattr(aquafish.backends, "run_tasks", spy)
    argv = ["study", *TINY_STUDY, "--durations", "0.16,0.32", "--no-progress"]
    assert main([str(a) for a in [*argv, "--out", tmp_path / "local"]]) == 0
    sent.clear()
    out = tmp_path / "ray"
    assert main([str(a) for a in [*argv, "--backend", "ray", "--out", out]]) == 0
    assert len(sent) == 2 and all(str(out).encode() not in pickle.dumps(args) for _, args in sent)
    assert _files(out) == _files(tmp_path / "local")
    assert (out / "study.json").read_text() == (tmp_path / "local" / "study.json").read_text()
    for run in ("known/0.16s/seed0", "known/0.32s/seed0"):
        for name in ("config.json", COMMAND_FILE):
            assert (out / run / name).read_text() == (tmp_path / "local" / run / name).read_text()
        assert _rows(out / run) == _rows(tmp_path / "local" / run)

    # resume: a finished run is not sent again and its files are not touched
    stamps = _tree(out)
    sent.clear()
    assert main([str(a) for a in [*argv, "--backend", "ray", "--out", out]]) == 0
    assert sent == [] and {k: v for k, v in _tree(out).items() if k != "study.json"} == \
        {k: v for k, v in stamps.items() if k != "study.json"}


def _dies_on_its_first_try(out: str) -> str:
    """A task whose first try loses its worker process (as a killed node would)."""
    from aquafish.shipping import _attempt

    if _attempt() == 0:
        os._exit(1)
    (Path(out) / "done.txt").write_text("finished on a retry")
    return out


def _always_dies(out: str) -> str:
    os._exit(1)


@pytest.mark.cluster
def test_a_lost_workers_task_is_retried_and_logged_and_one_lost_on_every_try_is_logged(local_ray, tmp_path, caplog):
    caplog.set_level(logging.WARNING)
    out = tmp_path / "out"
    tasks = [DirTask(_dies_on_its_first_try, (str(out / "a"),), outputs=(0,), label="cell a"),
             DirTask(_always_dies, (str(out / "b"),), outputs=(0,), label="cell b")]
    values = list(run_dir_tasks(tasks, backend="ray"))
    assert values == [str(out / "a")]  # the driver's path, not the node's
    assert (out / "a" / "done.txt").read_text() == "finished on a retry"
    assert not (out / "b").exists()  # nothing of the lost task is written
    lines = [r.getMessage() for r in caplog.records]
    assert [line for line in lines if line.startswith("cell a:")] == \
        ["cell a: its Ray worker was lost; finished on try 2"]
    lost = [line for line in lines if line.startswith("cell b:")]
    assert len(lost) == 1 and "lost on the Ray cluster after 4 tries" in lost[0] and "run the command again" in lost[0]


def _without_rl() -> None:
    """A Ray worker's setup: no PPO rows (faster), as ``_rl_available`` patched in the driver."""
    import aquafish.case_study

    aquafish.case_study._rl_available = lambda: False


@pytest.mark.cluster
@pytest.mark.slow
def test_recovery_on_a_local_ray_cluster_matches_a_local_run_and_resumes(tmp_path, monkeypatch):
    ray = pytest.importorskip("ray")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    monkeypatch.setattr("aquafish.case_study._rl_available", lambda: False)
    local = run_recovery(tmp_path / "local", preset="smoke", damages=DAMAGES[:1], seeds=[0], workers=1, progress=False)
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False, _node_ip_address="127.0.0.1",
             runtime_env={"worker_process_setup_hook": _without_rl})
    try:
        out = tmp_path / "ray"
        summary = run_recovery(out, preset="smoke", damages=DAMAGES[:1], seeds=[0], backend="ray", progress=False)
        assert _without_times(summary) == _without_times(local)
        assert (out / "summary.md").read_text() == (tmp_path / "local" / "summary.md").read_text()
        assert _files(out) == _files(tmp_path / "local")
        report = json.loads((cell_dir(out, DAMAGES[0], 0) / "report.json").read_text())
        assert report["shared_dir"] == str(out / "shared" / "seed0")
        stamps = _tree(out / "cells")
        assert _without_times(run_recovery(out, preset="smoke", damages=DAMAGES[:1], seeds=[0], backend="ray",
                                           progress=False)) == _without_times(summary)
        assert _tree(out / "cells") == stamps  # the finished cell was read back, not run again
    finally:
        ray.shutdown()
        ray.cloudpickle.unregister_pickle_by_value(sys.modules[__name__])
