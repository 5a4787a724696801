"""PyBullet is imported without its build banner; other output of the import is kept."""

import subprocess
import sys

import pytest

from aquafish_gym.bullet import import_quietly


@pytest.mark.parametrize("code", [
    "import aquafish_gym.simulator",
    "from aquafish.cli import main\ntry:\n    main(['swim', '--help'])\nexcept SystemExit:\n    pass",
])
def test_no_pybullet_banner(code):
    code += "\nimport sys\nprint('PYBULLET', 'pybullet' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "pybullet build time" not in done.stdout + done.stderr
    assert done.stdout.endswith("PYBULLET True\n")  # pybullet was imported


def test_pybullet_imported_directly_prints_the_banner():
    """The banner the project hides really exists (else the test above proves nothing)."""
    done = subprocess.run([sys.executable, "-c", "import pybullet"], capture_output=True, text=True, check=True)
    assert "pybullet build time" in done.stdout + done.stderr


def test_import_quietly_keeps_other_output(tmp_path, monkeypatch):
    (tmp_path / "noisy_module.py").write_text(
        "import os\nos.write(1, b'pybullet build time: today\\nkeep out\\n')\nos.write(2, b'keep err\\n')\nVALUE = 7\n")
    code = (f"import sys; sys.path.insert(0, {str(tmp_path)!r}); from aquafish_gym.bullet import import_quietly; "
            "print('before', flush=True); m = import_quietly('noisy_module'); print('after', m.VALUE)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout == "before\nkeep out\nafter 7\n"
    assert done.stderr == "keep err\n"


def test_import_quietly_returns_a_loaded_module():
    assert import_quietly("sys") is sys
