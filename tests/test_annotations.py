"""Every public function and public-class method of the library core carries type hints."""

from __future__ import annotations

import importlib
import inspect


def _modules() -> list[str]:
    """Every public module of the package (none whose name starts with "_": the numba
    kernels, ``__main__``, which runs the command line on import): a new module is checked
    without being listed here."""
    import pkgutil

    import roughflow

    names = ["roughflow"]
    for info in pkgutil.walk_packages(roughflow.__path__, "roughflow."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    return names


MODULES = _modules()

_SKIPPED_KINDS = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)


def _missing(func, qualname: str) -> list[str]:
    problems = []
    sig = inspect.signature(func)
    for name, param in sig.parameters.items():
        if name in ("self", "cls") or param.kind in _SKIPPED_KINDS:
            continue
        if param.annotation is inspect.Parameter.empty:
            problems.append(f"{qualname}: parameter {name!r}")
    if sig.return_annotation is inspect.Signature.empty:
        problems.append(f"{qualname}: return")
    return problems


def _public_callables(module):
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        obj = inspect.unwrap(obj) if callable(obj) and not inspect.isclass(obj) else obj
        if inspect.isfunction(obj):
            yield f"{module.__name__}.{name}", obj
        elif inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if attr.startswith("_") or isinstance(member, property):
                    continue
                if isinstance(member, (staticmethod, classmethod)):
                    member = member.__func__
                member = inspect.unwrap(member) if callable(member) else member
                if inspect.isfunction(member) and member.__module__ == module.__name__:
                    yield f"{module.__name__}.{name}.{attr}", member


def test_public_api_is_annotated():
    problems = []
    for module_name in MODULES:
        module = importlib.import_module(module_name)
        for qualname, func in _public_callables(module):
            problems.extend(_missing(func, qualname))
    assert not problems, "missing annotations:\n" + "\n".join(problems)
