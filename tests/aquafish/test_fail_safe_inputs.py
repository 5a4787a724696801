"""Every input fails safe: files, controllers, interrupts, messages, litter and Ray addresses.

One regression test (or parametrised family) per root cause:

9. a FIFO, a device or an oversized file given as a fault, config, controller or record is
   refused unread, naming it (:func:`aquafish_gym.files.read_input`);
10. crafted controllers: a huge genome, an unknown activation, NaN weights, SB3 models whose
    policy, algorithm or ``policy_kwargs`` do not fit, a zip bomb;
11. JSON (and TOML) nested deeply anywhere is one line, not a ``RecursionError``;
14. interrupts: the line after Ctrl-C says what continues the command; workers of a parent that
    ignores SIGINT ignore it too;
15. messages: odd digits, numbers of more than 4300 digits, NUL bytes and huge values;
16. nothing left outside ``--out``: SB3's logger directory, Ray tasks' staged copies; a full
    disk names SB3's monitor file;
17. Ray addresses: a bad ``--address`` or ``RAY_ADDRESS`` named as what it is, ``--address``
    with the local backend refused;
20. ``--config`` given twice.

(The Gymnasium corners, cause 19, are tests/aquafish_gym/test_fail_safe_gym.py.)
"""

from __future__ import annotations

import copy
import errno
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

import pytest

from aquafish.cli import main
from test_fail_safe import TINY_GAIT, TINY_PPO, TINY_STUDY, _alive, _children, fails_safe

#: The healthy gait of docs/results (a NEAT controller of 4 nodes and 9 connections).
CONTROLLER = Path(__file__).resolve().parents[2] / "docs" / "results" / "damage_monitor" / "best_controller.json"
#: A swim of a tenth of a second: the quickest command that reads a fault.
SWIM = ["swim", "--episode-duration-s", "0.1"]


@pytest.fixture
def no_hang():
    """Fail a test that blocks (a FIFO opened for reading waits for a writer) instead of hanging."""
    def alarm(signum, frame):
        raise TimeoutError("blocked reading an input")

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, old)


# -- 9. only regular files of a bounded size are read ---------------------------------------------------------

def _special(tmp_path: Path, kind: str, name: str) -> Path:
    """A FIFO, a link to /dev/zero (endless) or a file of 256 MiB, named ``name``."""
    path = tmp_path / name
    if kind == "fifo":
        os.mkfifo(path)
    elif kind == "endless":
        path.symlink_to("/dev/zero")
    else:
        with open(path, "wb") as f:  # sparse: no disk is used; more than aquafish_gym.files.MAX_INPUT_BYTES
            f.truncate(256 * 2**20)
    return path


@pytest.mark.parametrize("kind, problem", [("fifo", "FIFO"), ("endless", "character device"),
                                           ("oversized", "larger than")])
@pytest.mark.parametrize("what", ["fault", "config", "fields", "controller", "neat config", "mission record"])
def test_a_fifo_or_an_endless_file_is_refused_unread(what, kind, problem, tmp_path, capsys, no_hang):
    name = {"config": "run.toml", "neat config": "neat.ini", "mission record": "mission.json"}.get(what, "input.json")
    path = _special(tmp_path, kind, name)
    argv = {"fault": [*SWIM, "--damages", path, "--out", tmp_path / "out"],
            "config": ["gait", "--config", path],
            "fields": ["case-study", "--self-model-fields", path, "--out", tmp_path / "out"],
            "controller": ["transfer", "--controller", path, "--target", "healthy", "--out", tmp_path / "out"],
            "neat config": ["gait", *TINY_GAIT, "--neat-config", path, "--out", tmp_path / "out"],
            "mission record": ["mission-table", tmp_path]}[what]
    if what in ("controller", "neat config") and kind != "oversized":
        problem = ""  # refused as no file at all, before anything is opened
    fails_safe(argv, capsys, path.name, problem)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("kind, problem", [("fifo", "FIFO"), ("endless", "character device"),
                                           ("oversized", "larger than")])
def test_a_record_read_back_is_a_regular_file_of_a_bounded_size(kind, problem, tmp_path, no_hang):
    from aquafish_gym.rundir import FileError, read_json

    path = _special(tmp_path, kind, "report.json")
    with pytest.raises(FileError, match=problem) as err:
        read_json(path)
    assert err.value.path == path


# -- 10. crafted controllers --------------------------------------------------------------------------------

def _neat(tmp_path: Path, edit) -> Path:
    data = json.loads(CONTROLLER.read_text())
    edit(data["genome"])
    path = tmp_path / "crafted.json"
    path.write_text(json.dumps(data))
    return path


def _many_nodes(genome):
    node = genome["nodes"][-1]
    genome["nodes"] += [dict(node, key=100 + i) for i in range(300_000)]


@pytest.mark.parametrize("edit, names", [
    (_many_nodes, ["genome.nodes has 300004 genes", "at most 500"]),
    (lambda g: g["nodes"][1].update(activation="no_such_function"), ["genome.nodes[1].activation", "no_such_function"]),
    (lambda g: g["nodes"][0].update(aggregation="os.system"), ["genome.nodes[0].aggregation", "os.system"]),
    (lambda g: g["connections"][2].update(weight=float("nan")), ["genome.connections[2].weight", "not a finite"]),
    (lambda g: g["nodes"][0].update(bias=float("inf")), ["genome.nodes[0].bias", "not a finite"]),
    (lambda g: g["connections"][0].update(key=[-99, 0]), ["genome.connections[0].key", "node the genome does not"]),
], ids=["300k nodes", "activation", "aggregation", "NaN weight", "infinite bias", "dangling connection"])
def test_a_crafted_neat_controller_is_one_line_naming_the_field(edit, names, tmp_path, capsys):
    path = _neat(tmp_path, edit)
    start = time.monotonic()
    fails_safe(["transfer", "--controller", path, "--target", "healthy", "--out", tmp_path / "out"], capsys,
               path.name, *names)
    assert time.monotonic() - start < 30
    assert not (tmp_path / "out").exists()


@pytest.fixture(scope="module")
def ppo_model(tmp_path_factory):
    """A PPO model trained for 32 steps (``aquafish rl``), and a SAC model of as few."""
    pytest.importorskip("stable_baselines3")
    root = tmp_path_factory.mktemp("sb3")
    hp = root / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO | {"sac": {"AquaFish-v0": {
        "n_timesteps": 32, "policy": "MlpPolicy", "n_envs": 1, "learning_starts": 8, "batch_size": 8,
        "policy_kwargs": {"net_arch": [8]}}}}))
    for algo in ("ppo", "sac"):
        assert main(["rl", "--algo", algo, "--hyperparams", str(hp), "--episode-duration-s", "0.5", "--timesteps", "32",
                     "--no-progress", "--out", str(root / algo)]) == 0
    return root


def _sb3(root: Path, tmp_path: Path, algo: str = "ppo", data=None, meta=None, extra=None) -> Path:
    """A copy of the ``algo`` model, its zip's data JSON and its model.json edited."""
    out = tmp_path / "model"
    out.mkdir()
    with zipfile.ZipFile(root / algo / "model.zip") as z:
        entries = {n: z.read(n) for n in z.namelist()}
    if data is not None:
        content = json.loads(entries["data"])
        data(content)
        entries["data"] = json.dumps(content).encode()
    with zipfile.ZipFile(out / "model.zip", "w", compression=zipfile.ZIP_DEFLATED) as z:
        for name, content in entries.items():
            z.writestr(name, content)
        if extra is not None:
            extra(z)
    sidecar = json.loads((root / algo / "model.json").read_text())
    if meta is not None:
        meta(sidecar)
    (out / "model.json").write_text(json.dumps(sidecar))
    return out / "model.zip"


def _policy(name):
    return lambda m: m["fingerprint"]["hyperparams"].update(policy=name)


def _zip_bomb(z):
    z.writestr("padding", b"\0" * (300 * 2**20))  # 300 MB that compress to 300 kB


@pytest.mark.parametrize("algo, edits, names", [
    ("ppo", dict(data=lambda d: d.update(policy_kwargs={"net_arch": [16]})), ["size mismatch"]),
    ("ppo", dict(data=lambda d: d.update(policy_kwargs={"net_arch": "wide"})), ["data.policy_kwargs.net_arch"]),
    ("ppo", dict(data=lambda d: d.update(policy_kwargs={"net_arch": [10**9]})), ["data.policy_kwargs.net_arch"]),
    ("ppo", dict(data=lambda d: d.update(policy_kwargs={"no_such_setting": 1})),
     ["data.policy_kwargs.no_such_setting"]),
    ("ppo", dict(data=lambda d: d.update(policy_kwargs={"activation_fn": "os.system"})),
     ["data.policy_kwargs.activation_fn"]),
    ("ppo", dict(data=lambda d: d.update(policy_kwargs=[8])), ["data.policy_kwargs"]),
    ("ppo", dict(meta=lambda m: m.update(algo="sac")), ["data.policy_class", "SACPolicy"]),
    ("sac", dict(meta=lambda m: m.update(algo="ppo")), ["data.policy_class", "ActorCriticPolicy"]),
    ("ppo", dict(meta=_policy("CnnPolicy")), ["data.policy_class", "ActorCriticCnnPolicy"]),
    ("ppo", dict(meta=_policy("MultiInputPolicy")), ["data.policy_class"]),
    ("ppo", dict(meta=_policy(["MlpPolicy"])), ["model.json", "fingerprint.hyperparams.policy"]),
    ("ppo", dict(meta=lambda m: m.update(env_id="AquaFishHeading-v0")), ["data.observation_space", "[16]"]),
    ("ppo", dict(extra=_zip_bomb), ["unpack to", "not unpacked"]),
], ids=["net_arch mismatch", "net_arch text", "net_arch huge", "unknown policy_kwargs", "activation_fn text",
        "policy_kwargs list", "algorithm sac", "algorithm ppo", "CnnPolicy", "MultiInputPolicy", "policy list",
        "another task", "zip bomb"])
def test_a_crafted_sb3_model_is_one_line_naming_the_file_and_field(algo, edits, names, ppo_model, tmp_path, capsys):
    path = _sb3(ppo_model, tmp_path, algo, **edits)
    fails_safe(["transfer", "--controller", path, "--target", "healthy", "--out", tmp_path / "out"], capsys,
               str(path.parent), *names)


def test_an_sb3_model_with_nan_weights_is_refused(ppo_model, tmp_path, capsys):
    import io

    import torch

    path = _sb3(ppo_model, tmp_path)
    with zipfile.ZipFile(path) as z:
        entries = {n: z.read(n) for n in z.namelist()}
    weights = torch.load(io.BytesIO(entries["policy.pth"]), weights_only=True)
    first = next(k for k, v in weights.items() if v.is_floating_point())
    weights[first].view(-1)[0] = float("nan")
    buffer = io.BytesIO()
    torch.save(weights, buffer)
    entries["policy.pth"] = buffer.getvalue()
    with zipfile.ZipFile(path, "w") as z:
        for name, content in entries.items():
            z.writestr(name, content)
    fails_safe(["transfer", "--controller", path, "--target", "healthy", "--out", tmp_path / "out"], capsys,
               str(path), "policy.pth", first, "not all finite")


# -- 11. deeply nested JSON (and TOML) is one line ------------------------------------------------------------

DEEP = "[" * 100_000 + "]" * 100_000


@pytest.mark.parametrize("what", ["inline fault", "fault file", "fields file", "controller", "config",
                                  "mission record"])
def test_deeply_nested_input_is_one_line(what, tmp_path, capsys):
    path = tmp_path / {"config": "run.toml", "mission record": "mission.json"}.get(what, "deep.json")
    path.write_text(f"a = {DEEP}\n" if what == "config" else '{"gains": ' + DEEP + "}")
    argv = {"inline fault": [*SWIM, "--damages", '{"gains": ' + "[" * 10_000 + "]" * 10_000 + "}",
                             "--out", tmp_path / "out"],
            "fault file": [*SWIM, "--damages", path, "--out", tmp_path / "out"],
            "fields file": ["case-study", "--self-model-fields", path, "--out", tmp_path / "out"],
            "controller": ["transfer", "--controller", path, "--target", "healthy", "--out", tmp_path / "out"],
            "config": ["gait", "--config", path],
            "mission record": ["mission-table", tmp_path]}[what]
    fails_safe(argv, capsys, "nested", *([] if what == "inline fault" else [path.name]))


def test_a_deeply_nested_record_names_the_file(tmp_path):
    from aquafish_gym.rundir import FileError, read_json

    path = tmp_path / "report.json"
    path.write_text('{"a": ' + DEEP + "}")
    with pytest.raises(FileError, match="nested more than 100 levels") as err:
        read_json(path)
    assert err.value.path == path
    path.write_text(json.dumps({"a": json.loads("[" * 100 + "]" * 100)[0]}))  # 100 deep: read
    assert read_json(path)


# -- 14. interrupts ---------------------------------------------------------------------------------------

def test_an_interrupted_gait_says_what_continues_it(tmp_path, capsys, monkeypatch):
    from gait.neat_progress import QuietCheckpointer

    save = QuietCheckpointer.save_checkpoint

    def save_then_interrupt(self, *args):
        save(self, *args)
        raise KeyboardInterrupt

    argv = ["gait", *TINY_GAIT[2:], "--generations", "2", "--out", str(tmp_path / "g")]
    monkeypatch.setattr(QuietCheckpointer, "save_checkpoint", save_then_interrupt)
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 130
    line = capsys.readouterr().err.strip()
    assert "interrupted" in line and "run the same command with --resume latest to continue" in line, line
    monkeypatch.setattr(QuietCheckpointer, "save_checkpoint", save)
    fails_safe(argv, capsys, "--resume latest")  # the same command without it is refused, as the line said
    assert main([*argv, "--resume", "latest"]) == 0
    assert (tmp_path / "g" / "run.json").is_file()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_the_workers_of_a_parent_that_ignores_sigint_ignore_it_too(tmp_path):
    argv = ["study", *TINY_STUDY, "--replicates", "2", "--rounds", "6", "--processes", "2", "--out", str(tmp_path / "s")]
    parent = subprocess.Popen([sys.executable, "-c", f"from aquafish.cli import main; main({argv!r})"],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True,
                              preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        deadline = time.monotonic() + 60
        workers = []
        while time.monotonic() < deadline and len(workers) < 2 and parent.poll() is None:
            time.sleep(0.2)
            workers = [p for p in _children(parent.pid) if _alive(p)]
        assert len(workers) >= 2, "the pool did not start"
        time.sleep(1.0)  # the workers' initializer has run
        os.killpg(parent.pid, signal.SIGINT)  # what Ctrl-C sends: the parent and its workers alike
        _, err = parent.communicate(timeout=120)
    finally:
        if parent.poll() is None:
            parent.kill()
    assert parent.returncode == 0, err
    assert "worker process died" not in err


# -- 15. messages -----------------------------------------------------------------------------------------

def test_odd_digits_long_numbers_nul_bytes_and_huge_values_are_short_clear_lines(tmp_path, capsys):
    out = ["--out", tmp_path / "out"]
    fails_safe([*SWIM, "--damages", "sampled:\u00b2", *out], capsys, "sampled:SEED", "the digits 0-9")
    line = fails_safe([*SWIM, "--damages", "sampled:" + "7" * 5000, *out], capsys, "at most 4300 digits")
    assert "Exceeds the limit" not in line
    line = fails_safe(["gait", "--generations", "9" * 5000, *out], capsys, "--generations", "5000 characters")
    assert len(line) < 400
    gains = tmp_path / "gains.json"
    gains.write_text(json.dumps({"gains": [1] * 2_000_000}))
    line = fails_safe([*SWIM, "--damages", gains, *out], capsys, "gains must be 3 numbers", "2000000 items")
    assert len(line) < 400
    digits = tmp_path / "digits.json"
    digits.write_text('{"gains": [1' + "0" * 5000 + ", 1, 1]}")
    fails_safe([*SWIM, "--damages", digits, *out], capsys, "digits.json", "more than 4300 digits")
    big = tmp_path / "big.toml"
    big.write_text(f"seed = {'1' * 5000}\n")
    fails_safe(["gait", "--config", big], capsys, "big.toml", "more than 4300 digits")
    nul = tmp_path / "nul.toml"
    nul.write_text('out = "a\\u0000b"\n')
    line = fails_safe(["gait", "--config", nul], capsys, "nul.toml", "--out", "NUL byte")
    assert "\0" not in line and "embedded null byte" not in line
    nul.write_text('damage = "a\\u0000.json"\n')
    line = fails_safe(["gait", *TINY_GAIT, "--config", nul, *out], capsys, "NUL byte")
    assert "\0" not in line
    assert not (tmp_path / "out").exists()


def test_no_error_line_is_longer_than_the_limit(tmp_path, capsys):
    line = fails_safe([*SWIM, "--damages", "x" * 100_000, "--out", tmp_path / "out"], capsys, "unknown damage",
                      "sampled:SEED")  # its end, what to do, is kept
    assert len(line) <= 1100

# -- 16. nothing outside --out ----------------------------------------------------------------------------

def test_ppo_training_leaves_nothing_in_the_temporary_folder(tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    temp = tmp_path / "tmp"
    temp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temp))
    hp = tmp_path / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO))
    for verbose in ("0", "1"):
        assert main(["rl", "--hyperparams", str(hp), "--episode-duration-s", "0.5", "--timesteps", "32",
                     "--no-progress", "--verbose", verbose, "--out", str(tmp_path / f"rl{verbose}")]) == 0
    assert list(temp.iterdir()) == []


def test_a_full_disk_while_ppo_writes_its_monitor_file_names_it(tmp_path, capsys, monkeypatch):
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.monitor import ResultsWriter

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(ResultsWriter, "write_row", full)
    hp = tmp_path / "hp.yml"
    hp.write_text(json.dumps(TINY_PPO))
    fails_safe(["rl", "--hyperparams", hp, "--episode-duration-s", "0.5", "--timesteps", "32", "--no-progress",
                "--out", tmp_path / "rl"], capsys, str(tmp_path / "rl" / "monitor" / "monitor.csv"), "disk is full")


def test_staged_copies_of_killed_ray_tasks_are_removed_by_the_next_task(tmp_path, monkeypatch):
    from aquafish.shipping import _in_scratch

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    dead = subprocess.Popen(["true"])
    dead.wait()
    stale = tmp_path / f"aquafish-task-{dead.pid}-abcd_123"  # a killed worker's
    (stale / "arg0" / "cell").mkdir(parents=True)
    running = tmp_path / f"aquafish-task-{os.getppid()}-efgh_456"  # a running one's
    running.mkdir()
    seen = []
    _, value, outputs, scratch, _ = _in_scratch(0, _record_dir, ("out", seen), {0: {"a.txt": b"x"}}, (0,))
    assert not stale.exists() and running.is_dir()
    assert Path(scratch[0]).parent.parent.name.startswith(f"aquafish-task-{os.getpid()}-")
    assert not Path(scratch[0]).exists() and outputs == {0: {"a.txt": b"x", "b.txt": b"y"}}


def _record_dir(directory, seen):
    (Path(directory) / "b.txt").write_bytes(b"y")
    return directory


# -- 17. Ray addresses ------------------------------------------------------------------------------------

def _study(out, *flags):
    return ["study", *TINY_STUDY, *flags, "--out", out]


def test_address_with_the_local_backend_is_refused(tmp_path, capsys):
    fails_safe(_study(tmp_path / "s", "--address", "auto"), capsys, "--address auto", "--backend local",
               "--backend ray")
    fails_safe(["recovery", "--budget", "smoke", "--address", "auto", "--out", tmp_path / "r"], capsys,
               "--address auto", "--backend ray")
    assert not (tmp_path / "s").exists() and not (tmp_path / "r").exists()


@pytest.mark.cluster
@pytest.mark.parametrize("address", ["foo", "foo:bar", "", "http://head:6379", "head:99999"])
def test_a_bad_address_is_one_line_naming_the_flag(address, tmp_path, capsys, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    fails_safe(_study(tmp_path / "s", "--backend", "ray", "--address", address), capsys, "--address",
               "is not a Ray cluster address")
    assert not (tmp_path / "s").exists()


@pytest.mark.cluster
@pytest.mark.parametrize("address, problem", [("foo", "is not a Ray cluster address"),
                                              ("127.0.0.1:1", "no Ray cluster answers")])
def test_a_bad_ray_address_variable_is_blamed_as_itself(address, problem, tmp_path, capsys, monkeypatch):
    pytest.importorskip("ray")
    monkeypatch.setenv("RAY_ADDRESS", address)
    line = fails_safe(_study(tmp_path / "s", "--backend", "ray"), capsys, f"RAY_ADDRESS {address}", problem)
    assert "--address" not in line


# -- 20. --config twice -----------------------------------------------------------------------------------

@pytest.mark.parametrize("spelling", [["--config", "{b}"], ["--config={b}"]])
def test_config_given_twice_is_refused(spelling, tmp_path, capsys):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    tiny = "generations = 1\npopulation_size = 4\nepisode_duration_s = 0.5\nworkers = 1\nno_progress = true\n"
    a.write_text(tiny + "seed = 1\n")
    b.write_text(tiny + "seed = 2\n")
    fails_safe(["gait", "--config", a, *[s.format(b=b) for s in spelling], "--out", tmp_path / "g"], capsys,
               "--config is given 2 times", "a.toml", "b.toml")
    assert not (tmp_path / "g").exists()
