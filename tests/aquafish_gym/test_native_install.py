"""Installing the compiled step: the PyBullet version guard, the fallback message, `aquafish doctor`.

These run whether or not the step is built (test_native.py needs it built).
"""

import logging
import re
import tomllib
import warnings
from pathlib import Path

import gymnasium as gym
import pytest
from gymnasium.utils.env_checker import check_env

from aquafish.cli import main
from aquafish_gym import BatchWorld, Morphology, native
from aquafish_gym.native import build

ROOT = Path(__file__).resolve().parents[2]
HEADER = Path(native.__file__).with_name("pybullet_abi.h")  # installed with the package


def _header_define(name: str) -> str:
    match = re.search(rf"^#define {name} (\S+)", HEADER.read_text(), re.M)
    assert match, f"{name} not in {HEADER.name}"
    return match.group(1).strip('"')


@pytest.fixture
def fresh(monkeypatch):
    """The module as in a new process: nothing loaded, nothing said yet."""
    monkeypatch.setattr(native, "_lib", None)
    monkeypatch.setattr(native, "_warned", False)
    monkeypatch.delenv("AQUAFISH_NATIVE", raising=False)
    return monkeypatch


@pytest.fixture
def missing(fresh, tmp_path):
    """The compiled step not built."""
    fresh.setattr(native, "LIBRARY", tmp_path / "_aquafish_step.so")
    return fresh


def test_the_supported_range_is_the_one_pyproject_pins():
    if not (ROOT / "pyproject.toml").exists():
        pytest.skip("not run from a checkout (an installed wheel's tests)")
    deps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["dependencies"]
    pin = next(d for d in deps if d.startswith("pybullet"))
    low, below = native.PYBULLET_RANGE
    assert pin.replace(" ", "") == f"pybullet>={low},<{below}"


def test_the_header_declares_the_range_and_the_installed_pybullets_api_version():
    low, below = native.PYBULLET_RANGE
    assert (_header_define("AF_PYBULLET_MIN"), _header_define("AF_PYBULLET_BELOW")) == (low, below)
    # the installed PyBullet (inside the pin) has the API version the header declares
    assert int(_header_define("AF_PYBULLET_API_VERSION")) == native.p.getAPIVersion()


@pytest.mark.parametrize("version", ["3.2.6", "3.2.7", "3.2.10", "3.2.7.post1"])
def test_a_pybullet_inside_the_range_is_accepted(version):
    native.check_pybullet(version)


@pytest.mark.parametrize("version", ["3.2.5", "3.3", "3.3.0", "3.10.1", "4.0", "2.9.9", "unknown"])
def test_a_pybullet_outside_the_range_is_refused_with_a_clear_message(version):
    with pytest.raises(native.NativeUnavailable) as err:
        native.check_pybullet(version)
    message = str(err.value)
    assert f"PyBullet {version} is outside the range" in message
    assert ">=3.2.6,<3.3" in message and 'pip install "pybullet>=3.2.6,<3.3"' in message


def test_the_step_refuses_an_installed_pybullet_outside_the_range(fresh):
    fresh.setattr(native, "pybullet_version", lambda: "3.4.0")
    reason = native.unavailable_reason()
    assert reason is not None and "PyBullet 3.4.0 is outside the range" in reason
    assert not native.available()
    with pytest.raises(ValueError, match="PyBullet 3.4.0 is outside the range"):
        BatchWorld(Morphology.healthy().to_array()[None], native=True)


def test_the_step_refuses_a_pybullet_with_another_api_version(fresh):
    if not native.LIBRARY.exists():
        pytest.skip("compiled step not built")
    fresh.setattr(native.p, "getAPIVersion", lambda: 201001010)
    reason = native.unavailable_reason()
    assert reason is not None and "C API version 201001010" in reason and "install a supported PyBullet" in reason


def test_the_fallback_is_said_once_per_process_and_never_as_a_warning(missing, caplog):
    caplog.set_level(logging.WARNING, logger="aquafish_gym.native")
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # as for a strict check_env: any warning would raise here
        env = gym.make("AquaFish-v0", episode_duration_s=1.0)
        check_env(env.unwrapped)
        env.close()
        for _ in range(2):
            with BatchWorld(Morphology.healthy().to_array()[None]) as world:
                assert not world.native
    said = [r for r in caplog.records if r.name == "aquafish_gym.native"]
    assert len(said) == 1 and said[0].levelno == logging.WARNING
    assert "NumPy path" in said[0].getMessage() and "pip install -e ." in said[0].getMessage()


def test_the_numpy_path_asked_for_is_silent(missing, caplog):
    missing.setenv("AQUAFISH_NATIVE", "0")
    caplog.set_level(logging.DEBUG, logger="aquafish_gym.native")
    with BatchWorld(Morphology.healthy().to_array()[None]) as world:
        assert not world.native
    assert not [r for r in caplog.records if r.name == "aquafish_gym.native"]


def test_doctor_says_the_numpy_path_is_active_why_and_how_to_build(missing, capsys):
    assert main(["doctor"]) == 1
    out = capsys.readouterr().out
    assert out.startswith("simulator step: NumPy path")
    assert "why: the compiled step is not built" in out and "pip install -e ." in out and "C++ compiler:" in out


def test_doctor_names_the_switch_when_the_numpy_path_is_asked_for(fresh, capsys):
    fresh.setenv("AQUAFISH_NATIVE", "0")
    assert main(["doctor"]) == 1
    out = capsys.readouterr().out
    assert "why: switched off by AQUAFISH_NATIVE=0" in out and "unset AQUAFISH_NATIVE" in out


def test_doctor_says_the_compiled_step_is_active(fresh, capsys):
    if not native.LIBRARY.exists():
        pytest.skip("compiled step not built")
    assert main(["doctor"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"simulator step: compiled ({native.LIBRARY})") and "PyBullet 3.2." in out


def test_the_build_without_a_compiler_says_what_to_install(monkeypatch, tmp_path):
    monkeypatch.setenv("CXX", "no-such-compiler-aquafish")
    assert build.find_compiler() is None
    with pytest.raises(build.BuildError, match="no C\\+\\+ compiler .*apt install g\\+\\+"):
        build.compile_library(tmp_path / "step.so")
    assert not list(tmp_path.iterdir())


def test_the_build_uses_only_the_projects_own_header(tmp_path):
    if build.find_compiler() is None:
        pytest.skip("no C++ compiler")
    import ctypes

    out = build.compile_library(tmp_path / "step.so")
    lib = ctypes.CDLL(str(out))
    assert lib.af_pybullet_api_version() == native.p.getAPIVersion()
    assert lib.af_version() == native._VERSION
    assert "-ffp-contract=off" in build.CFLAGS      # bit-for-bit with the NumPy path needs no fused multiply-add
    source = build.SOURCE.read_text()
    assert re.findall(r'^#include "([^"]+)"', source, re.M) == ["pybullet_abi.h"]
