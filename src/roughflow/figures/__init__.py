"""Figures of the paper, one module per study; each draws from the aggregated dataset.

``make_figure(study, dataset, output, fit=None)`` writes ``output`` (PNG) and the PDF
next to it and returns the caption. Every module has ``CAPTION`` and
``draw(ds, fit=None) -> matplotlib.figure.Figure``. The figures are made without pyplot,
so the library never selects or switches a matplotlib backend: in a notebook the returned
Figure displays inline, and ``fig.savefig`` renders with Agg or the PDF backend.
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from typing import TYPE_CHECKING

from roughflow.defaults import STUDIES
from roughflow.errors import InputError

if TYPE_CHECKING:
    from types import ModuleType

    import xarray as xr


def module(study: str) -> ModuleType:
    if study not in STUDIES:
        raise InputError(f"unknown study {study!r}; known: {', '.join(STUDIES)}")
    return importlib.import_module(f"{__name__}.{study}")


def caption(study: str) -> str:
    """The caption of ``study``'s figure (without loading matplotlib)."""
    from .captions import CAPTIONS

    if study not in CAPTIONS:
        raise InputError(f"unknown study {study!r}; known: {', '.join(STUDIES)}")
    return CAPTIONS[study]


def make_figure(study: str, dataset: xr.Dataset | str | os.PathLike,
                output: str | os.PathLike, fit: xr.Dataset | str | os.PathLike | None = None, *,
                source: str = "the dataset") -> str:
    """Draw ``study`` from ``dataset`` (xr.Dataset or path) into ``output`` (a .png file) and
    the PDF next to it; returns the caption. The dataset must be of the study's kind
    (:data:`roughflow.datasets.kinds.STUDY_KINDS`); ``source`` names it in messages."""
    from roughflow.aggregate import load
    from roughflow.datasets.kinds import STUDY_KINDS, check_kind
    from roughflow.io import check_output, save_figure

    out = Path(output)
    if out.suffix.lower() != ".png":
        raise InputError(f"the figure is written as PNG (and a PDF next to it): {str(out)!r} "
                         "must end in .png")
    pdf = out.with_suffix(".pdf")
    check_output(out, option="figure", suffixes=(".png",))
    check_output(pdf, option="the figure's PDF", suffixes=(".pdf",))
    mod = module(study)
    if isinstance(dataset, (str, os.PathLike)):
        source = f"study dataset {str(dataset)!r}"
        dataset = load(dataset)
    check_kind(dataset, STUDY_KINDS[study], source)
    made_for = dataset.attrs.get("study")  # roughflow aggregate --study
    if made_for is not None and str(made_for) != study:
        raise InputError(f"{source} is the {made_for!r} study (its 'study' attribute): draw it "
                         f"as {made_for}, not {study}")
    fit_ds = load(fit, "fit") if isinstance(fit, (str, os.PathLike)) else fit
    fig = mod.draw(dataset, fit=fit_ds)
    save_figure(fig, out, pdf, dpi=150)  # both or neither
    return mod.CAPTION
