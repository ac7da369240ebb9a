"""Figures of the paper, one module per study; each draws from the aggregated dataset.

``make_figure(study, dataset, output, fit=None)`` writes ``output`` (PNG), the PDF and the
caption (Markdown, ``.md``) next to it and returns the caption. Every module has ``CAPTION`` and
``draw(ds, fit=None) -> matplotlib.figure.Figure``. The figures are made without pyplot,
so the library never selects or switches a matplotlib backend: in a notebook the returned
Figure displays inline, and ``fig.savefig`` renders with Agg or the PDF backend.
``flux.plot_flux`` draws one flow solve's flux over its contact map (``roughflow flow --plot``).
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

__all__ = ["module", "caption", "make_figure", "caption_document", "data_summary"]


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
    """Draw ``study`` from ``dataset`` (xr.Dataset or path) into ``output`` (a .png file),
    the PDF and the caption (:func:`caption_document`, a .md file) next to it, all three or
    none; returns the caption. The dataset must be of the study's kind
    (:data:`roughflow.datasets.kinds.STUDY_KINDS`); ``source`` names it in messages."""
    from roughflow.aggregate import load
    from roughflow.datasets.kinds import STUDY_KINDS, check_kind
    from roughflow.io import check_output, figure_writer, text_writer, write_together

    out = Path(output)
    if out.suffix.lower() != ".png":
        raise InputError(f"the figure is written as PNG (and a PDF next to it): {str(out)!r} "
                         "must end in .png")
    pdf, md = out.with_suffix(".pdf"), out.with_suffix(".md")
    check_output(out, option="figure", suffixes=(".png",))
    check_output(pdf, option="the figure's PDF", suffixes=(".pdf",))
    check_output(md, option="the figure's caption", suffixes=(".md",))
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
    document = caption_document(study, dataset, source, image=out.name)
    write_together([figure_writer(fig, out, dpi=150), figure_writer(fig, pdf, dpi=150),
                    text_writer(document, md)])  # all three or none
    return mod.CAPTION


def caption_document(study: str, dataset: xr.Dataset, source: str, image: str) -> str:
    """The caption file of a figure (Markdown): the figure, its caption, and what it was
    drawn from, so that a results folder read without the docs still says what error bars,
    lines and area scales mean and where the figure departs from the paper."""
    lines = [f"# {study}", "", f"![{study}]({image})", "", caption(study), "",
             f"Drawn from {source}."]
    data = data_summary(dataset)
    if data:  # the caption describes the paper's study; this says what this run holds
        lines.append(f"Its data: {data}.")
    block = dataset.attrs.get("study_config")
    if block:
        lines.append(f"Its study block (config): `{block}`.")
    commit = dataset.attrs.get("roughflow_commit")
    if commit:
        lines.append(f"roughflow commit of the dataset: {commit}.")
    return "\n".join(lines) + "\n"


#: The sweep parameters a caption file states, as (dataset name, label).
_PARAMETERS = (("model", "model"), ("gamma", "gamma"), ("hurst", "H"), ("eps_f", "eps_f"),
               ("l_over_lambda_r", "L/lambda_r"),
               ("points_per_lambda_s", "points per lambda_s"))


def data_summary(dataset: xr.Dataset) -> str:
    """The values of the sweep parameters a study dataset holds, its number of seeds, and
    which a_c* a threshold study's figure shows (perimeter-corrected or raw, by grid); for
    a measured study (leak rates over scans) its scans' sealing pressures and the rows the
    figure draws as not resolved (:func:`roughflow.figures.measured.summary`)."""
    if "leak_rate" in dataset.variables:  # scans, not a sweep: no a_c* of seed means
        from .measured import summary

        return summary(dataset)
    import numpy as np

    from roughflow.defaults import CORRECTION_MIN_POINTS

    parts = []
    for name, label in _PARAMETERS:
        if name not in dataset.variables:
            continue
        values = np.asarray(dataset[name].values).ravel()
        if values.dtype.kind == "f":
            values = values[np.isfinite(values)]
            shown = [f"{v:.4g}" for v in np.unique(values)]
        else:
            shown = [str(v) for v in dict.fromkeys(values.tolist())]
        if shown:
            parts.append(f"{label} {', '.join(shown)}")
    if "seed" in dataset.sizes:
        parts.append(f"{dataset.sizes['seed']} seed{'s' if dataset.sizes['seed'] != 1 else ''}")
    if "a_c_star" in dataset:
        from roughflow.datasets.sweep import corrected_taken

        taken = corrected_taken(dataset)  # over a_c_star's dims, like notnull() below
        counted = (np.zeros(0, bool) if taken is None
                   else taken.values[dataset["a_c_star"].notnull().values])
        if not counted.size:
            parts.append("no a_c* (no search bracketed it)")
        elif not counted.any():
            parts.append("a_c* raw (cell counts)")
        elif counted.all():
            parts.append("a_c* perimeter-corrected")
        else:
            parts.append(f"a_c* perimeter-corrected on grids of >= {CORRECTION_MIN_POINTS:g} "
                         "points per lambda_s, raw on the others")
    return "; ".join(parts)
