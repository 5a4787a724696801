"""The wheel's package boundary and metadata, read from pyproject.toml (no build).

The wheel installs exactly the four packages (the benchmark scripts are
:mod:`aquafish.benchmarks`, not a top-level ``benchmarks``, which holds only the committed registry
of held-out sets), each with its ``py.typed``
marker (PEP 561). ``.ci/packaging`` builds the wheel itself.
"""

import re
import tomllib
from pathlib import Path

from setuptools import find_packages

ROOT = Path(__file__).parents[1]
PACKAGES = {"aquafish", "aquafish_gym", "eea", "gait"}
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def test_the_wheel_holds_only_the_four_packages():
    found = find_packages(where=str(ROOT), **PYPROJECT["tool"]["setuptools"]["packages"]["find"])
    assert {name.split(".")[0] for name in found} == PACKAGES
    # the top-level benchmarks/ holds the registry of held-out sets (a committed record), no Python
    assert "aquafish.benchmarks" in found and not list((ROOT / "benchmarks").rglob("*.py"))


def test_every_package_ships_its_py_typed_marker():
    package_data = PYPROJECT["tool"]["setuptools"]["package-data"]
    for package in sorted(PACKAGES):
        assert (ROOT / package / "py.typed").is_file(), package
        assert "py.typed" in package_data.get(package, []), package


def test_the_project_names_its_urls_and_version():
    project = PYPROJECT["project"]
    assert {"Homepage", "Documentation", "Issues"} <= set(project["urls"])
    assert project["name"] == "aquafish" and project["version"]


def test_the_packages_and_tests_hold_no_issue_numbers():
    """The code speaks for itself: why a thing is so is said in words or by a docs link, not
    by the number of the tracker issue that asked for it."""
    import re

    pattern = re.compile(r"\bissues? #?\d+", re.IGNORECASE)
    hits = [f"{path.relative_to(ROOT)}:{n}" for top in ("aquafish_gym", "eea", "gait", "aquafish", "tests")
            for path in sorted((ROOT / top).rglob("*.py"))
            for n, line in enumerate(path.read_text().splitlines(), 1) if pattern.search(line)]
    assert not hits, f"issue numbers in: {hits}"


#: A commit hash as the docs cite one: "at eac968c", "commit eed7c8d", "commits 1a2b3c4 and ...".
#: (A digit is required, so that English words such as "at defaced" are not taken for one.)
COMMIT_HASH = re.compile(r"\b(?:at|commits?)\s+(?:commit\s+)?(?=[0-9a-f]*[0-9])[0-9a-f]{7,12}\b")


def test_only_the_compatibility_module_names_commits():
    """Which commit ran a retired variant is history: it is kept with what lets such runs load,
    :mod:`eea.compat`, and in docs/studies/retired_variants.md, not spread through the code."""
    allowed = ROOT / "eea" / "compat.py"
    hits = [f"{path.relative_to(ROOT)}:{n}" for top in ("aquafish_gym", "eea", "gait", "aquafish")
            for path in sorted((ROOT / top).rglob("*.py")) if path != allowed
            for n, line in enumerate(path.read_text().splitlines(), 1) if COMMIT_HASH.search(line)]
    assert not hits, f"commit hashes outside eea/compat.py in: {hits}"
