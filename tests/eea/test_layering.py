"""The layering of :mod:`eea`, checked by parsing every module's imports with ``ast``.

The layout (the map is in ``eea/__init__.py``)::

    eea/*.py          the paper's core (CORE) and the run and its I/O (RUN_IO)
    eea/search/       the model searches: protocol and registry, model GA, CMA-ES, hypotheses,
                      lineages
    eea/inference/    the context inference: interface, the paper's strategies, profile,
                      registry, the equal angle fit (selection)
    eea/analysis/     studies of finished runs

The rules:

1. Nothing outside :mod:`eea.analysis` imports it, except the command-line front ends
   (``eea/cli.py``, ``aquafish/studies_cli.py``), and only inside a function (lazily, to run an
   analysis command), and the scripts (:data:`SCRIPTS`: the examples and the study probes).
2. The algorithm (the core, :mod:`eea.search`, :mod:`eea.inference`) imports only the
   algorithm: no analysis, and no run, checkpoint, record, replay or command-line module, with
   one named exception (:data:`ALLOWED_EXTRA`).
3. The core imports a subpackage only through its face, the package itself (``from eea.search
   import ...``, ``from eea.inference import ...``: the registries, the interfaces, the
   classes), never a module inside it, except :data:`CORE_DEEP_IMPORTS` (the round builds its
   estimation phase from :mod:`eea.search.lineages`, which the face cannot re-export without an
   import cycle: the lineages build on :mod:`eea.estimation`, which imports the face).
   Depth: core -> subpackage face -> subpackage module -> core, nothing deeper.
4. :mod:`eea.inference` imports nothing of :mod:`eea.search`; :mod:`eea.search` imports
   :mod:`eea.inference` only in :mod:`eea.search.lineages` (each lineage has its own strategy,
   and the round's selection is :func:`eea.inference.selection.select_model`) and in
   :mod:`eea.search.hypotheses` (its candidates are the fault check's,
   :func:`eea.inference.selection.fault_hypotheses`).
5. A module inside a subpackage imports its siblings by their module path, never its own
   package's face (which would import it back half-initialised).
6. No relative imports (rules 1-5 only see absolute ones), and every module is placed in a
   layer, so a new module (or a shim left at an old path) must be placed here first.
7. A module that defines a section of :class:`eea.config.EEAConfig` (its component's frozen
   settings: ``eea.config.SECTIONS`` and the variants of ``eea.config.VARIANT_SLOTS``) never
   imports :mod:`eea.config`, directly or through another module, not even inside a function:
   the config imports the sections.
"""

import ast
from pathlib import Path

ROOT = Path(__file__).parents[2]
EEA = ROOT / "eea"
#: The paper's core (and its configuration, and :mod:`eea.compat`, which lets the configs and
#: checkpoints of earlier versions load and imports nothing of eea), at the top of eea/.
CORE = {"arc", "behaviour", "compat", "config", "diversity", "encoding", "estimation", "evaluation", "experiment", "exploration",
        "fitness", "ga", "identification", "methods", "round", "target"}
#: The run and its I/O, at the top of eea/.
RUN_IO = {"__init__", "checkpoint", "cli", "fault_check", "record", "replay", "run"}
#: The subpackages of the algorithm and their modules.
SEARCH = {"search", "search.registry", "search.model_ga", "search.cma", "search.hypotheses", "search.lineages"}
INFERENCE = {"inference", "inference.strategy", "inference.paper", "inference.profile", "inference.registry",
             "inference.selection"}
ALGORITHM = CORE | SEARCH | INFERENCE
#: What an algorithm module may import besides the algorithm: the lineage record (the lineages
#: write ``lineages.csv`` with :func:`eea.record.write_csv`).
ALLOWED_EXTRA = {("search.lineages", "eea.record")}
#: Modules inside a subpackage that a core module may import directly.
CORE_DEEP_IMPORTS = {("round", "eea.search.lineages")}
#: Front ends that may import eea.analysis, lazily (the README tables render study records as
#: ``aquafish compare`` does).
FRONT_ENDS = {"eea/cli.py", "aquafish/studies_cli.py", "aquafish/tables.py"}  # tables: the README's study table
#: Folders of scripts (not modules of the packages), which may import eea.analysis at the top.
SCRIPTS = ("examples", "docs/studies/probes")


def _imports(path: Path):
    """``(module, top_level)`` of every ``eea...`` import of a file (top_level: not inside a function)."""
    tree = ast.parse(path.read_text())
    lazy = {id(n) for f in ast.walk(tree) if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef))
            for n in ast.walk(f)}
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names if node.module == "eea"]
        for name in names:
            if name == "eea" or name.startswith("eea."):
                yield name, id(node) not in lazy


def _python_files():
    for folder in ("eea", "aquafish", "aquafish_gym", "gait", *SCRIPTS):  # aquafish/ holds aquafish/benchmarks/
        yield from sorted((ROOT / folder).rglob("*.py"))


def _path(module: str) -> Path:
    """The file of an eea module named as in the layer sets (``"search"`` is its ``__init__``)."""
    parts = module.split(".")
    if (EEA.joinpath(*parts) / "__init__.py").exists():
        return EEA.joinpath(*parts) / "__init__.py"
    return EEA.joinpath(*parts[:-1]) / f"{parts[-1]}.py"


def _eea_name(name: str) -> str:
    """An imported ``eea.x.y`` as a layer-set name: the module (``"search.cma"``), or the package
    when a name is imported from ``eea`` itself (``eea.EEAConfig`` -> ``"__init__"``)."""
    parts = name.split(".")[1:]
    while parts and ".".join(parts) not in ALGORITHM | RUN_IO | {"analysis"} and parts[0] != "analysis":
        parts = parts[:-1]
    return ".".join(parts) if parts else "__init__"


def test_only_the_analysis_package_and_the_front_ends_import_it():
    offenders = []
    for path in _python_files():
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("eea/analysis/") or any(rel.startswith(f"{folder}/") for folder in SCRIPTS):
            continue
        for name, top_level in _imports(path):
            if name == "eea.analysis" or name.startswith("eea.analysis."):
                if rel not in FRONT_ENDS or top_level:
                    offenders.append(f"{rel} imports {name}")
    assert not offenders, offenders


def test_the_algorithm_imports_only_the_algorithm():
    offenders = []
    for module in sorted(ALGORITHM):
        for name, _ in _imports(_path(module)):
            target = _eea_name(name)
            if target in ALGORITHM or (module, f"eea.{target}") in ALLOWED_EXTRA:
                continue
            offenders.append(f"eea.{module} imports {name}")
    assert not offenders, offenders


def test_the_core_imports_a_subpackage_only_through_its_face():
    offenders = []
    for module in sorted(CORE):
        for name, _ in _imports(_path(module)):
            target = _eea_name(name)
            if target in (SEARCH | INFERENCE) - {"search", "inference"} and (module, f"eea.{target}") not in CORE_DEEP_IMPORTS:
                offenders.append(f"eea.{module} imports {name}, not the face eea.{target.split('.')[0]}")
    assert not offenders, offenders


def test_search_and_inference_import_each_other_only_where_justified():
    offenders = []
    for module in sorted(INFERENCE):
        offenders += [f"eea.{module} imports {name}" for name, _ in _imports(_path(module))
                      if _eea_name(name).split(".")[0] == "search"]
    for module in sorted(SEARCH - {"search.lineages", "search.hypotheses"}):
        offenders += [f"eea.{module} imports {name}" for name, _ in _imports(_path(module))
                      if _eea_name(name).split(".")[0] == "inference"]
    assert not offenders, offenders


def test_subpackage_modules_import_their_siblings_not_their_face():
    offenders = []
    for module in sorted((SEARCH | INFERENCE) - {"search", "inference"}):
        package = module.split(".")[0]
        offenders += [f"eea.{module} imports {name}" for name, _ in _imports(_path(module))
                      if _eea_name(name) == package]
    assert not offenders, offenders


def test_no_relative_imports_in_eea():
    offenders = []
    for path in sorted(EEA.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.level:
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not offenders, offenders


def test_every_eea_module_is_placed():
    """A new module must be placed in a layer: the core, the run and its I/O, a subpackage of
    the algorithm, or analysis. No module is left at a path it moved from (no shims)."""
    top = {p.stem for p in EEA.glob("*.py")}
    assert top == CORE | RUN_IO, sorted(top ^ (CORE | RUN_IO))
    packages = {p.name for p in EEA.iterdir() if (p / "__init__.py").exists()}
    assert packages == {"analysis", "inference", "search"}, sorted(packages)
    for package, modules in (("search", SEARCH), ("inference", INFERENCE)):
        found = {package if p.stem == "__init__" else f"{package}.{p.stem}" for p in (EEA / package).glob("*.py")}
        assert found == modules, sorted(found ^ modules)
    nested = [p for package in ("search", "inference") for p in (EEA / package).iterdir()
              if p.is_dir() and p.name != "__pycache__"]
    assert not nested, nested


def test_the_layer_sets_resolve():
    """Every module the rules name exists (a rule about a missing module checks nothing)."""
    for module in ALGORITHM | RUN_IO:
        assert _path(module).exists(), module
    for module, name in ALLOWED_EXTRA | CORE_DEEP_IMPORTS:
        assert module in ALGORITHM and _path(name.split(".", 1)[1]).exists(), (module, name)


#: The modules that define a section of :class:`eea.config.EEAConfig` (``eea.config.SECTIONS``
#: and the variants of ``eea.config.VARIANT_SLOTS``): the config imports them, so they must not
#: import it back.
SECTION_MODULES = {"ga", "exploration", "estimation", "evaluation", "search.model_ga", "search.cma", "search.hypotheses",
                   "inference.paper", "inference.profile"}


def _closure(module: str) -> set[str]:
    """Every algorithm module ``module`` imports, at its top or inside a function, directly or
    through others (a module inside a
    subpackage also runs its package's face; ``eea`` itself, which imports everything, is left
    out: importing any eea module runs it, but it is not a dependency of the module's code)."""
    seen, todo = set(), [module] + ([module.split(".")[0]] if "." in module else [])
    while todo:
        current = todo.pop()
        for name, _ in _imports(_path(current)):
            target = _eea_name(name)
            found = [target] + ([target.split(".")[0]] if "." in target else [])
            for t in found:
                if t != "__init__" and t not in seen and (t in ALGORITHM or t in RUN_IO):
                    seen.add(t)
                    todo.append(t)
    return seen


def test_the_config_sections_do_not_import_the_config():
    """Each component's settings section lives next to its code and
    validates itself; :mod:`eea.config` imports the sections, never the other way round."""
    from eea.config import SECTIONS, VARIANT_SLOTS

    sections = [*SECTIONS.values(), *(cls for _, classes in VARIANT_SLOTS.values() for cls in classes.values())]
    assert {section.__module__.removeprefix("eea.") for section in sections} == SECTION_MODULES
    offenders = {module: sorted(_closure(module) & {"config", "round", "run", "cli", "record"})
                 for module in sorted(SECTION_MODULES)}
    assert not any(offenders.values()), offenders


def test_the_compatibility_module_imports_nothing_of_eea():
    """:mod:`eea.compat` is imported by the config, the checkpoint, the estimation and the CMA
    search: it imports nothing of eea, not even inside a function, so it closes no import cycle
    (the flat fields it brings up to date are nested by :mod:`eea.config`)."""
    assert list(_imports(_path("compat"))) == []
