"""The layering of :mod:`eea` (issue 40), checked by parsing every module's imports with ``ast``.

* Nothing outside :mod:`eea.analysis` imports it, except the command-line front ends
  (``eea/cli.py``, ``aquafish/studies_cli.py``), and only inside a function (lazily, to run an
  analysis command).
* The algorithm's modules import only the algorithm: no analysis, and no run, checkpoint,
  replay or command-line module (``eea.record`` only for ``lineages.csv``, which
  :mod:`eea.lineages` writes).
"""

import ast
from pathlib import Path

ROOT = Path(__file__).parents[2]
#: The algorithm: the paper's core, the searches, the inference strategies and the lineages.
ALGORITHM = {"arc", "behaviour", "cma_search", "config", "diversity", "encoding", "estimation", "evaluation",
             "experiment", "exploration", "fitness", "ga", "inference", "lineages", "methods", "model_search", "profile",
             "round", "selection", "strategy", "target"}
#: What an algorithm module may import besides the algorithm (one file: the lineage record).
ALLOWED_EXTRA = {("lineages", "eea.record")}
#: Front ends that may import eea.analysis, lazily.
FRONT_ENDS = {"eea/cli.py", "aquafish/studies_cli.py"}


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
    for folder in ("eea", "aquafish", "aquafish_gym", "gait", "examples", "benchmarks"):
        yield from sorted((ROOT / folder).rglob("*.py"))


def test_only_the_analysis_package_and_the_front_ends_import_it():
    offenders = []
    for path in _python_files():
        rel = path.relative_to(ROOT).as_posix()
        if rel.startswith("eea/analysis/") or rel.startswith("examples/"):
            continue
        for name, top_level in _imports(path):
            if name == "eea.analysis" or name.startswith("eea.analysis."):
                if rel not in FRONT_ENDS or top_level:
                    offenders.append(f"{rel} imports {name}")
    assert not offenders, offenders


def test_the_algorithm_imports_only_the_algorithm():
    offenders = []
    for module in sorted(ALGORITHM):
        for name, _ in _imports(ROOT / "eea" / f"{module}.py"):
            parts = name.split(".")
            if len(parts) < 2 or parts[1] in ALGORITHM or (module, ".".join(parts[:2])) in ALLOWED_EXTRA:
                continue
            offenders.append(f"eea/{module}.py imports {name}")
    assert not offenders, offenders


def test_every_eea_module_is_placed():
    """A new module must be placed in a layer: the algorithm, the run and its I/O, or analysis."""
    run_and_io = {"__init__", "checkpoint", "cli", "record", "replay", "run"}
    top = {p.stem for p in (ROOT / "eea").glob("*.py")}
    assert top == ALGORITHM | run_and_io, sorted(top ^ (ALGORITHM | run_and_io))
