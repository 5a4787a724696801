"""``aquafish study --backend ray`` fails safe: without Ray, against a token-authenticated
cluster without its token, and when a run fails (one line each, as on the local pool); and
``aquafish recovery`` on a cluster started by address writes the local pool's summary."""

from __future__ import annotations

import json
import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from test_fail_safe import TINY_STUDY, fails_safe

#: The project's root (the cluster's workers import aquafish from it).
ROOT = Path(__file__).resolve().parents[2]


def test_ray_backend_without_ray_names_the_extra_and_creates_nothing(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if it were not installed
    out = tmp_path / "study"
    fails_safe(["study", *TINY_STUDY, "--backend", "ray", "--out", out], capsys, "pip install 'aquafish[cluster]'")
    assert not out.exists()


def test_a_ray_token_is_found_where_ray_looks_for_it(monkeypatch, tmp_path):
    # --address auto leaves token authentication to ray.init when a token is where Ray looks
    from aquafish.backends import _ray_token_available

    for name in ("RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("HOME", str(tmp_path))
    assert not _ray_token_available()
    monkeypatch.setenv("RAY_AUTH_TOKEN_PATH", str(tmp_path / "token"))
    assert not _ray_token_available()  # the path named holds no file
    (tmp_path / "token").write_text("t")
    assert _ray_token_available()
    monkeypatch.delenv("RAY_AUTH_TOKEN_PATH")
    (tmp_path / ".ray").mkdir()
    (tmp_path / ".ray" / "auth_token").write_text("t")
    assert _ray_token_available()
    (tmp_path / ".ray" / "auth_token").unlink()
    monkeypatch.setenv("RAY_AUTH_TOKEN", "t")
    assert _ray_token_available()


@pytest.fixture
def local_ray(monkeypatch):
    """A one-CPU local Ray instance for the test (without token authentication), shut down after."""
    ray = pytest.importorskip("ray")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")  # ray.init would otherwise turn it on and write ~/.ray/auth_token
    ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
    try:
        yield ray
    finally:
        ray.shutdown()


@pytest.mark.cluster
@pytest.mark.slow
def test_a_failing_run_comes_back_from_ray_as_its_one_line(local_ray, tmp_path, capsys):
    study = tmp_path / "study"
    argv = ["study", *TINY_STUDY, "--out", study]
    from aquafish.cli import main

    assert main([str(a) for a in argv]) == 0
    state = next(study.rglob("state.pkl"))
    state.write_bytes(state.read_bytes()[:50])
    (state.parent / "rounds.csv").unlink()  # unfinished: the study resumes it from its checkpoint
    line = fails_safe([*argv, "--backend", "ray"], capsys, str(state), "truncated")
    assert "RayTaskError" not in line and "ray::" not in line


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def token_cluster(tmp_path):
    """A one-CPU Ray head on 127.0.0.1 with token authentication (RAY_AUTH_MODE=token): yields
    ``(address, token)``; the head and everything it started (its process group) are ended after."""
    pytest.importorskip("ray")
    token = secrets.token_hex(32)
    port = _free_port()
    env = {**os.environ, "RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token, "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    log = tmp_path / "head.log"
    temp_dir = tempfile.mkdtemp(prefix="ray", dir="/tmp")  # Ray's socket paths must stay under 108 bytes
    ray_bin = Path(sys.executable).with_name("ray")
    with log.open("w") as out:
        head = subprocess.Popen([str(ray_bin), "start", "--head", "--block", "--port", str(port), "--num-cpus", "1", "--include-dashboard", "false",
                                 "--dashboard-agent-listen-port", str(_free_port()),
                                 "--temp-dir", temp_dir, "--disable-usage-stats"],
                                env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 120  # a guard against a hang, not a timing assertion
        while "block forever" not in log.read_text() and head.poll() is None and time.monotonic() < deadline:
            time.sleep(0.5)
        if "block forever" not in log.read_text():
            pytest.fail(f"the Ray head did not start:\n{log.read_text()[-2000:]}")
        yield f"127.0.0.1:{port}", token
    finally:
        for sig in (signal.SIGTERM, signal.SIGKILL):
            try:
                os.killpg(head.pid, sig)  # the head's own session: only what this fixture started
            except ProcessLookupError:
                break
            try:
                head.wait(timeout=20)
                time.sleep(2)  # its children end after it
            except subprocess.TimeoutExpired:
                pass
        shutil.rmtree(temp_dir, ignore_errors=True)


def _study(address: str, out: Path, env: dict) -> subprocess.CompletedProcess:
    base = {k: v for k, v in os.environ.items() if not k.startswith("RAY_AUTH")}
    return subprocess.run([sys.executable, "-m", "aquafish", "study", *map(str, TINY_STUDY), "--backend", "ray",
                           "--address", address, "--no-progress", "--out", str(out)],
                          env={**base, **env}, capture_output=True, text=True, timeout=300)


@pytest.mark.cluster
@pytest.mark.slow
def test_a_token_authenticated_cluster_needs_its_token_and_says_so_in_one_line(token_cluster, tmp_path):
    address, token = token_cluster
    for env, named in (({}, "requires token authentication"),
                       ({"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": "not-the-token"}, "refused this client's token")):
        out = tmp_path / "refused"
        done = _study(address, out, env)
        lines = [line for line in done.stderr.splitlines() if line.strip()]
        assert done.returncode == 2 and len(lines) == 1, done.stderr  # no 20 retries, each a warning line
        assert lines[0].startswith("aquafish study: error: ") and named in lines[0]
        assert "RAY_AUTH_MODE=token" in lines[0] and "RAY_AUTH_TOKEN" in lines[0]
        assert not out.exists()

    out = tmp_path / "study"
    done = _study(address, out, {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token})
    assert done.returncode == 0, done.stderr
    assert len((next(out.rglob("rounds.csv"))).read_text().splitlines()) == 2  # header and the one round


@pytest.mark.cluster
@pytest.mark.slow
def test_a_recovery_benchmark_on_a_cluster_started_by_address_gives_the_local_pools_summary(token_cluster, tmp_path):
    address, token = token_cluster
    settings = ["--budget", "smoke", "--damages", "reversed_left_pectoral", "--seeds", "0", "--no-progress"]
    base = {k: v for k, v in os.environ.items() if not k.startswith("RAY_AUTH")}
    local, remote = tmp_path / "local", tmp_path / "ray"
    for out, extra, env in ((local, ["--processes", "1"], {}),
                            (remote, ["--backend", "ray", "--address", address],
                             {"RAY_AUTH_MODE": "token", "RAY_AUTH_TOKEN": token})):
        done = subprocess.run([sys.executable, "-m", "aquafish", "recovery", *settings, *extra, "--out", str(out)],
                              env={**base, **env}, capture_output=True, text=True, timeout=1200)
        assert done.returncode == 0, done.stderr
    from test_ray_shipping import _without_times

    summaries = [_without_times(json.loads((out / "summary.json").read_text())) for out in (remote, local)]
    assert (remote / "summary.md").read_text() == (local / "summary.md").read_text()
    assert summaries[0] == summaries[1] and summaries[1]["totals"]["cells"] == 1
