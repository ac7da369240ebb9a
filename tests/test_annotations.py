"""Every public function and public-class method of the library core carries type hints."""

from __future__ import annotations

import importlib
import inspect

MODULES = [
    "roughflow.figures",
    "roughflow.scenes",
    "roughflow.cli",
    "roughflow.surface",
    "roughflow.scan",
    "roughflow.units",
    "roughflow.errors",
    "roughflow.accuracy",
    "roughflow.gpu",
    "roughflow.leak",
    "roughflow.io",
    "roughflow.provenance",
    "roughflow.resources",
    "roughflow.fft",
    "roughflow.boundary",
    "roughflow.fits",
    "roughflow.aggregate",
    "roughflow.contact.adhesion",
    "roughflow.contact.adhesive_cg",
    "roughflow.contact.bearing",
    "roughflow.contact.cg",
    "roughflow.contact.elastic",
    "roughflow.contact.gfmd",
    "roughflow.contact.law",
    "roughflow.contact.solve",
    "roughflow.percolation.clusters",
    "roughflow.percolation.labels",
    "roughflow.percolation.spanning",
    "roughflow.percolation.sweep",
    "roughflow.flow.amg",
    "roughflow.flow.assembly",
    "roughflow.flow.bound",
    "roughflow.flow.core",
    "roughflow.flow.ldl",
    "roughflow.flow.linsolve",
    "roughflow.flow.plot",
    "roughflow.theory.closed_form",
    "roughflow.theory.effective_medium",
    "roughflow.theory.gap",
    "roughflow.theory.peklenik",
    "roughflow.theory.persson",
    "roughflow.search.critical",
    "roughflow.search.load",
    "roughflow.search.warmup",
    "roughflow.datasets.kinds",
    "roughflow.datasets.leak",
    "roughflow.datasets.results",
    "roughflow.datasets.sweep",
    "roughflow.datasets.units",
    "roughflow.cli.aggregate",
    "roughflow.cli.cite",
    "roughflow.cli.contact",
    "roughflow.cli.figure",
    "roughflow.cli.fit",
    "roughflow.cli.flow",
    "roughflow.cli.import_scan",
    "roughflow.cli.leak",
    "roughflow.cli.scene",
    "roughflow.cli.surface",
    "roughflow.cli.theory",
    "roughflow.cli.threshold",
    "roughflow.figures.captions",
    "roughflow.figures.channels",
    "roughflow.figures.flow_anisotropic",
    "roughflow.figures.flow_isotropic",
    "roughflow.figures.measured",
    "roughflow.figures.threshold_vs_gamma",
    "roughflow.figures.threshold_vs_hurst",
    "roughflow.figures.threshold_vs_size",
    "roughflow.scenes.channels",
    "roughflow.scenes.config_file",
    "roughflow.scenes.jobs",
    "roughflow.scenes.ladder",
    "roughflow.scenes.threshold",
    "roughflow.citation",
    "roughflow.progress",
    "roughflow.wisdom",
    "roughflow.defaults",
]

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
