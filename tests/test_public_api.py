"""The public API surface: every ``__all__`` names roughflow's own objects.

``help(module)``, ``dir()`` and ``from module import *`` show ``__all__``; a helper imported
into a module (``dataclass``, ``Path``, ``np``, another stage's ``solve``) is no API of it.
Imports only: nothing is computed.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import inspect
from pathlib import Path

import pytest

#: Modules whose ``__all__`` lists the names defined in them.
MODULES = ("surface", "leak", "scan", "accuracy", "fits", "io", "units", "boundary", "reynolds",
           "aggregate", "citation", "provenance", "resources", "slurm", "errors")
#: Packages whose ``__all__`` re-exports their submodules' names.
PACKAGES = ("contact", "search", "percolation", "flow", "theory", "datasets", "figures")

ALL = [f"roughflow.{m}" for m in (*MODULES, *PACKAGES)]


def _source(name: str) -> str:
    return Path(importlib.util.find_spec(name).origin).read_text(encoding="utf-8")


def _module(name: str):
    return importlib.import_module(name)


def _bindings(tree: ast.Module) -> tuple[dict[str, str], set[str]]:
    """Names bound by module-level imports (also under ``if``/``try``; not those inside
    functions) -> the module they come from (``"."`` for a relative import), and names bound
    by top-level assignments."""
    imported, assigned = {}, set()
    nodes = list(tree.body)
    while nodes:
        node = nodes.pop()
        if isinstance(node, (ast.If, ast.Try, ast.ExceptHandler, ast.With)):
            nodes.extend(ast.iter_child_nodes(node))
        elif isinstance(node, ast.Import):
            for a in node.names:
                imported[a.asname or a.name.partition(".")[0]] = a.name
        elif isinstance(node, ast.ImportFrom):
            source = "." if node.level else (node.module or "")
            for a in node.names:
                imported[a.asname or a.name] = source
    for node in tree.body:
        targets = (node.targets if isinstance(node, ast.Assign)
                   else [node.target] if isinstance(node, ast.AnnAssign) else [])
        assigned |= {t.id for t in targets if isinstance(t, ast.Name)}
    return imported, assigned


def _is_roughflow(module: str) -> bool:
    return module == "." or module.split(".")[0] == "roughflow"


@pytest.mark.parametrize("name", ALL)
def test_all_is_a_list_of_unique_strings(name):
    mod = _module(name)
    assert hasattr(mod, "__all__"), f"{name} has no __all__"
    names = mod.__all__
    assert isinstance(names, (list, tuple)), f"{name}.__all__ is a {type(names).__name__}"
    assert all(isinstance(n, str) for n in names), f"{name}.__all__ holds a non-string"
    dupes = sorted({n for n in names if names.count(n) > 1})
    assert not dupes, f"{name}.__all__ names {dupes} twice"


@pytest.mark.parametrize("name", ALL)
def test_all_names_exist_and_are_public(name):
    mod = _module(name)
    missing = [n for n in mod.__all__ if not hasattr(mod, n)]
    assert not missing, f"{name}.__all__ names {missing}, which the module lacks"
    private = [n for n in mod.__all__ if n.startswith("_")]
    assert not private, f"{name}.__all__ names private {private}"


@pytest.mark.parametrize("name", ALL)
def test_all_holds_no_foreign_import(name):
    """No name in ``__all__`` is a standard-library or third-party object: a class, function
    or module must come from roughflow (a deliberate re-export of a roughflow object
    defined elsewhere is fine), and a constant must not be imported from outside. A value
    assigned in the module (a tuple of names, a ``Path``, a type alias) is its own."""
    mod = _module(name)
    imported, assigned = _bindings(ast.parse(_source(name)))
    foreign = []
    for n in mod.__all__:
        if not hasattr(mod, n):
            continue  # test_all_names_exist_and_are_public reports it
        obj = getattr(mod, n)
        if n in imported and not _is_roughflow(imported[n]):
            foreign.append(f"{n} (imported from {imported[n]})")
        elif inspect.ismodule(obj):
            if not _is_roughflow(obj.__name__):
                foreign.append(f"{n} (module {obj.__name__})")
        elif inspect.isclass(obj) or inspect.isroutine(obj) or (callable(obj)
                                                              and n not in assigned):
            origin = getattr(obj, "__module__", "") or ""
            if not _is_roughflow(origin):
                foreign.append(f"{n} (from {origin or 'an unknown module'})")
    assert not foreign, f"{name}.__all__ names objects from outside roughflow: {foreign}"


@pytest.mark.parametrize("name", ALL)
def test_star_import_gives_all(name):
    mod = _module(name)
    namespace: dict = {}
    exec(f"from {name} import *", namespace)
    assert set(namespace) - {"__builtins__"} == set(mod.__all__)


@pytest.mark.parametrize(("name", "helpers"), [
    ("roughflow.leak", ("solve", "threshold", "dataclass", "field", "np", "Surface")),
    ("roughflow.surface", ("asdict", "dataclass", "np", "math", "InputError")),
    ("roughflow.scan", ("Path", "np", "Surface", "ScanInfo", "rms_gradient")),
    ("roughflow.io", ("Path", "np", "xr", "Provenance", "Surface", "fields")),
])
def test_imported_helpers_are_not_api(name, helpers):
    """The helpers the API audit found in ``help()`` of these modules stay out of it."""
    mod = importlib.import_module(name)
    assert hasattr(mod, "__all__"), f"{name} has no __all__"
    listed = sorted(set(helpers) & set(mod.__all__))
    assert not listed, f"{name}.__all__ names imported helpers {listed}"
