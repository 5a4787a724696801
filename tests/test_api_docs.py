"""The API reference (``make docs``, mkdocs.yml) documents every public module.

The public modules are found on disk, not listed here: every module of the four packages except
the private ones (a ``_`` name), the command-line plumbing and the scripts in :data:`NOT_API`.
Each must be named by a ``::: module`` directive of a page in ``docs/api/``, so a new public
module fails here until it is documented (or is added to :data:`NOT_API`, with its reason).
Nothing here runs mkdocs (CI does: ``make docs`` builds the site with ``--strict``); this reads
the files only.
"""

import ast
import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).parents[1]
PACKAGES = ("aquafish_gym", "eea", "gait", "aquafish")
API = ROOT / "docs" / "api"
DIRECTIVE = re.compile(r"^::: *([\w.]+) *$", flags=re.M)


def _is_cli(module: str) -> bool:
    """The command line's modules: ``cli`` and ``*_cli`` (``aquafish --help`` documents them)."""
    last = module.rsplit(".", 1)[-1]
    return last == "cli" or last.endswith("_cli")


#: Public by name but not the API, with the reason (the ``cli`` modules are left out by name).
NOT_API = {
    "aquafish_gym.argtypes": "argparse types of the command lines",
    "aquafish.config_file": "the command line's --config files (docs/main_job.md, Config files)",
    "aquafish_gym.native.build": "the build script of the compiled step (setup.py runs it)",
    "aquafish.benchmarks": "benchmark scripts, run as python -m aquafish.benchmarks.<name>",
}


def _modules(package: str) -> list[str]:
    """Every module of ``package`` (dotted names; a package is its ``__init__``)."""
    found = []
    for path in sorted((ROOT / package).rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        found.append(".".join(parts[:-1] if parts[-1] == "__init__" else parts))
    return found


def _public(module: str) -> bool:
    if any(part.startswith("_") for part in module.split(".")) or _is_cli(module):
        return False
    return not any(module == m or module.startswith(m + ".") for m in NOT_API)


def _documented() -> dict[str, str]:
    """Module or object named by a ``:::`` directive -> the page that names it."""
    named = {}
    for page in sorted(API.glob("*.md")):
        for name in DIRECTIVE.findall(page.read_text()):
            assert name not in named, f"{name} is documented twice: {named[name]} and {page.name}"
            named[name] = page.name
    return named


PUBLIC = [m for package in PACKAGES for m in _modules(package) if _public(m)]


def test_the_module_list_is_not_empty():
    # the discovery above finds the modules the reference is built around (not a vacuous pass)
    assert {"aquafish_gym.simulator", "eea.run", "eea.search.cma", "gait.controller", "aquafish.case_study"} <= set(PUBLIC)
    assert not {"aquafish.cli", "gait.cli", "aquafish.mission_cli", "aquafish.__main__"} & set(PUBLIC)
    assert len(_documented()) >= len(PUBLIC)


@pytest.mark.parametrize("module", PUBLIC)
def test_every_public_module_is_in_the_api_reference(module):
    assert module in _documented(), (f"{module} is a public module without a '::: {module}' directive in "
                                     f"docs/api/{module.split('.')[0]}.md (or add it to NOT_API with a reason)")


def test_every_directive_names_a_module_of_the_four_packages():
    modules = {m for package in PACKAGES for m in _modules(package)}
    for name, page in _documented().items():
        assert name in modules, f"docs/api/{page}: '::: {name}' names no module"
        assert page == f"{name.split('.')[0]}.md", f"{name} is documented in docs/api/{page}, not its package's page"


@pytest.mark.parametrize("package", PACKAGES)
def test_every_name_a_package_exports_comes_from_a_documented_module(package):
    """``from package import X``: X's module is documented, or X (defined in ``__init__``) is on the page."""
    tree = ast.parse((ROOT / package / "__init__.py").read_text())
    documented = _documented()
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == package:
            names = [a.asname or a.name for a in node.names if not (a.asname or a.name).startswith("_")]
            if names:
                assert node.module in documented, f"{package} exports {names} from undocumented {node.module}"
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            defined = [t.id for t in targets if isinstance(t, ast.Name) and not t.id.startswith("_")]
            page = (API / f"{package}.md").read_text()
            for name in defined:
                if name != "__all__":
                    assert re.search(rf"\b{name}\b", page), f"{package}.{name} is not on docs/api/{package}.md"


def test_every_api_page_is_in_the_nav():
    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text())["nav"]

    def pages(entry):
        if isinstance(entry, str):
            yield entry
        elif isinstance(entry, dict):
            for value in entry.values():
                yield from pages(value)
        else:
            for item in entry:
                yield from pages(item)

    listed = set(pages(nav))
    assert {f"api/{package}.md" for package in PACKAGES} <= listed
    # every page of docs/ (run data in results/ is not part of the site: exclude_docs)
    on_disk = {p.relative_to(ROOT / "docs").as_posix() for p in (ROOT / "docs").rglob("*.md")
               if p.relative_to(ROOT / "docs").parts[0] != "results"}
    assert on_disk - listed == set(), "pages missing from mkdocs.yml's nav"
    assert listed - on_disk == set(), "mkdocs.yml's nav names missing pages"


def test_sphinx_roles_become_optional_cross_references():
    """docs/api/sphinx_roles.py (the reference's griffe extension) resolves a role in its scope."""
    griffe = pytest.importorskip("griffe")  # the [docs] extra
    import importlib.util

    spec = importlib.util.spec_from_file_location("sphinx_roles", API / "sphinx_roles.py")
    roles = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(roles)
    module = griffe.temporary_visited_module("from aquafish_gym.simulator import BatchWorld\ndef f(): pass\n")
    with module as mod:
        text = roles.rewrite(mod["f"], "a :class:`~BatchWorld`, :func:`eea.run.run` and ``:class:``.")
    assert text == ('a <autoref identifier="aquafish_gym.simulator.BatchWorld" optional><code>BatchWorld</code></autoref>, '
                    '<autoref identifier="eea.run.run" optional><code>eea.run.run</code></autoref> and ``:class:``.')
