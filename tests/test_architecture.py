"""Data flows one way through the package: no module imports one of a higher layer (imports
for type hints only, under ``if TYPE_CHECKING:``, are not imports at run time)."""

from __future__ import annotations

import ast
from pathlib import Path

import roughflow

PACKAGE = Path(roughflow.__file__).resolve().parent

#: Layers, lowest first: each top-level module or subpackage of roughflow may import its own
#: layer and those below. The physics stages in the paper's order, then the orchestration
#: of solves, the datasets, the sweep side (the accuracy study, convergence, runs searches,
#: contact and flow solves and writes through io) and the command line.
LAYERS = (
    {"defaults", "errors", "files", "progress", "units", "resources", "slurm", "wisdom", "fft",
     "gpu", "citation", "provenance", "reynolds", "_jit", "_repr"},
    {"surface", "scan"},
    {"contact"},
    {"accuracy"},
    {"percolation"},
    {"flow"},
    {"theory"},
    {"search", "boundary", "leak"},
    {"datasets", "io", "aggregate"},
    {"scenes"},
    {"fits"},
    {"figures"},
    {"convergence"},
    {"cli", "__main__"},
)


def _layer(top: str) -> int:
    if top == "":  # the package's __init__: imports only from the lowest layer
        return 0
    for i, names in enumerate(LAYERS):
        if top in names:
            return i
    raise AssertionError(f"roughflow.{top} has no layer in tests/test_architecture.py")


def _top(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def _runtime_imports(path: Path, module: str) -> list[tuple[str, int]]:
    """(imported roughflow module, line) of every import outside ``if TYPE_CHECKING:``,
    function-level imports included."""
    tree = ast.parse(path.read_text())
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
    package = module.split(".") if path.name == "__init__.py" else module.split(".")[:-1]
    found = []
    for node in ast.walk(tree):
        if id(node) in typing_only:
            continue
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[:len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [target] if node.module or not node.level else [
                f"{target}.{a.name}" for a in node.names]
            found += [(t, node.lineno) for t in names if t.startswith("roughflow")]
        elif isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names
                      if a.name.startswith("roughflow")]
    return found


def test_no_module_imports_a_higher_layer():
    upward = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        module = ".".join(rel.parts[:-1] if rel.name == "__init__" else rel.parts)
        here = _layer(_top(module))
        for target, line in _runtime_imports(path, module):
            if _layer(_top(target)) > here:
                upward.append(f"{path.relative_to(PACKAGE)}:{line} imports {target}")
    assert not upward, "\n".join(upward)


def test_the_check_sees_an_upward_import(tmp_path):
    # the parser above must find a function-level import and skip a TYPE_CHECKING one
    src = tmp_path / "roughflow" / "contact"
    src.mkdir(parents=True)
    path = src / "solver.py"
    path.write_text("from typing import TYPE_CHECKING\n"
                    "if TYPE_CHECKING:\n    from roughflow.cli import main\n"
                    "def f():\n    from roughflow.search import threshold\n"
                    "from . import law\n")
    found = sorted(_runtime_imports(path, "roughflow.contact.solver"), key=lambda t: t[1])
    assert found == [("roughflow.search", 5), ("roughflow.contact.law", 6)]
