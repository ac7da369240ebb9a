"""Figures of the paper, one module per study; each draws from the aggregated dataset.

``make_figure(study, dataset, output, fit=None)`` writes ``output`` (PNG) and the PDF
next to it and returns the caption. Every module has ``CAPTION`` and
``draw(ds, fit=None) -> matplotlib.figure.Figure``.
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path

from roughflow.defaults import STUDIES
from roughflow.errors import InputError


def module(study: str):
    if study not in STUDIES:
        raise InputError(f"unknown study {study!r}; known: {', '.join(STUDIES)}")
    return importlib.import_module(f"{__name__}.{study}")


def caption(study: str) -> str:
    return module(study).CAPTION


def make_figure(study: str, dataset, output: str | os.PathLike, fit=None) -> str:
    """Draw ``study`` from ``dataset`` (xr.Dataset or path) into PNG + PDF; returns caption."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from roughflow.aggregate import load

    mod = module(study)
    ds = load(dataset) if isinstance(dataset, (str, os.PathLike)) else dataset
    fit_ds = load(fit) if isinstance(fit, (str, os.PathLike)) else fit
    fig = mod.draw(ds, fit=fit_ds)
    out = Path(output)
    out.parent.mkdir(parents=True, exist_ok=True)
    for path in (out.with_suffix(".png"), out.with_suffix(".pdf")):
        tmp = path.with_name(path.stem + ".part" + path.suffix)
        fig.savefig(tmp, dpi=150)
        os.replace(tmp, path)
    plt.close(fig)
    return mod.CAPTION
