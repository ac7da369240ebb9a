"""Helpers of the conductance figures (Fig. 5-7).

A flow study may sweep gamma, H, L / lambda_r and eps_f: its figure then draws one row of
panels per setting (:func:`rows`, by the planner's rule
:func:`roughflow.scenes.expand.flow_rows`), each row titled with its values; with one
setting it is the paper's figure, one row without a title.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import xarray as xr

from roughflow.datasets.sweep import PARAM_DIMS, rnd
from roughflow.defaults import PAPER_SIZE_FACTOR
from roughflow.errors import InputError
from roughflow.scenes.expand import (
    FLOW_FIGURE_MAX_ROWS,
    FLOW_ROW_LABELS,
    FLOW_ROW_PARAMS,
    flow_row_names,
    flow_rows,
)
from roughflow.surface import paper_l_over_lambda_r

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure, SubFigure

#: The parameter dimensions of a flow dataset that settings differ in (all but model).
_SETTING_DIMS = tuple(d for d in PARAM_DIMS if d != "model")


@dataclass
class Row:
    """One row of a flow figure: its values of the parameters the rows differ in (label,
    value; empty for a single row) and each model's ladder at them (models that did not run
    them are missing)."""

    values: tuple[tuple[str, float], ...]
    ladders: dict[str, xr.Dataset]

    def title(self) -> str:
        """``gamma = 2, H = 0.5``: the row's values (eps_f as 1/n, as the panels' captions)."""
        return ", ".join(f"eps_f = 1/{1 / v:.3g}" if label == "eps_f" else f"{label} = {v:.4g}"
                         for label, v in self.values)


def _settings(sub: xr.Dataset) -> list[tuple[dict, tuple]]:
    """(index along the setting dims, values of FLOW_ROW_PARAMS) of every setting of one
    model's part of the dataset that holds data; the first setting where none does (the
    panel then says so)."""
    dims = [d for d in _SETTING_DIMS if d in sub["area_fraction"].dims]
    other = [d for d in sub["area_fraction"].dims if d not in dims]
    ran = sub["area_fraction"].notnull().any(other).transpose(*dims).values
    found = np.argwhere(ran) if ran.any() else np.zeros((1, len(dims)), int)
    out = []
    for idx in found:
        at = dict(zip(dims, (int(i) for i in idx), strict=True))
        one = sub.isel(at)
        values = []
        for name in FLOW_ROW_PARAMS:
            if name == "l_over_lambda_r" and name not in one:
                # a dataset without the size variable: L / lambda_r from its dimension,
                # eps_t = max(sqrt(gamma), 1/sqrt(gamma)) lambda_r / L
                stretch = paper_l_over_lambda_r(float(one["gamma"])) / PAPER_SIZE_FACTOR
                v = stretch / np.asarray(one["eps_t"].values, dtype=float)
            else:
                v = one[name].values if name in one else np.nan
            values.append(rnd(float(np.nanmax(v))) if np.isfinite(v).any() else np.nan)
        out.append((at, tuple(values)))
    return out


def rows(ds: xr.Dataset, models: list[str]) -> list[Row]:
    """The figure's rows: each model's ladder (its setting dims dropped) at each setting
    the rows differ in (:func:`roughflow.scenes.expand.flow_rows`). InputError beyond
    :data:`roughflow.scenes.expand.FLOW_FIGURE_MAX_ROWS` rows, as the planner."""
    found = {m: _settings(ds.sel(model=m)) for m in models}
    params, keys = flow_rows({m: [v for _, v in s] for m, s in found.items()})
    if len(keys) > FLOW_FIGURE_MAX_ROWS:
        raise InputError(f"the flow figures draw at most {FLOW_FIGURE_MAX_ROWS} rows of "
                         f"panels, one per combination of "
                         f"{flow_row_names(params)}; the dataset has "
                         f"{len(keys)}: select fewer values (ds.sel) to draw it")
    out = []
    for key in keys:
        ladders = {}
        for model, settings in found.items():
            for at, values in settings:
                if tuple(values[i] for i in params) == key:
                    ladders[model] = ds.sel(model=model).isel(at)
        out.append(Row(tuple((FLOW_ROW_LABELS[i], v) for i, v in zip(params, key, strict=True)),
                       ladders))
    return out


def grid(fig: Figure, table: list[Row], ncols: int) -> list[list[Axes]]:
    """The panels, a row of ``ncols`` per row of ``table``: the paper's single row on
    ``fig`` itself; several rows on subfigures titled with their values, each column's
    panels sharing their axes so that the rows compare at a glance."""
    if len(table) == 1:
        return [list(fig.subplots(1, ncols, squeeze=False)[0])]
    out: list[list[Axes]] = []
    subfigs: list[SubFigure] = list(np.atleast_1d(fig.subfigures(len(table), 1)))
    for sub, row in zip(subfigs, table, strict=True):
        sub.suptitle(row.title(), fontsize=11, fontweight="bold")
        axes = list(sub.subplots(1, ncols, squeeze=False)[0])
        for col, ax in enumerate(axes):
            if out:
                ax.sharex(out[0][col])
                ax.sharey(out[0][col])
        out.append(axes)
    return out


def tag(col: int, row: int, nrows: int) -> str:
    """A panel's tag: (a), (b), ... in a single row; (a1), (b1), ... (a2) with several."""
    return f"({'abcdefgh'[col]}{row + 1 if nrows > 1 else ''})"


def not_run(ax: Axes, model: str) -> None:
    """An empty panel: ``model`` did not run the row's values."""
    ax.text(0.5, 0.5, f"{model}: not run\nat these values", ha="center", va="center",
            transform=ax.transAxes, color="gray")
    ax.set_axis_off()  # not set_xticks([]): the column's panels share their tickers


def sigma_ref(sub: xr.Dataset) -> float:
    """Full Reynolds conductance at a_c -> 0+, averaged over seeds and directions."""
    return float(sub["sigma_ref"].mean(skipna=True))


def curve(a_c: xr.DataArray, y: xr.DataArray) -> tuple[np.ndarray, np.ndarray]:
    """Seed-averaged (a_c, y) along the ladder, positive y only (for log axes)."""
    x = a_c.mean("seed", skipna=True).values
    v = y.mean("seed", skipna=True).values
    ok = np.isfinite(x) & np.isfinite(v) & (v > 0)
    return x[ok], v[ok]


def points(a_c: xr.DataArray, y: xr.DataArray) -> tuple[np.ndarray, np.ndarray]:
    """Every seed's (a_c, y), positive y only."""
    x, v = np.broadcast_arrays(a_c.values, y.values)
    x, v = x.ravel(), v.ravel()
    ok = np.isfinite(x) & np.isfinite(v) & (v > 0)
    return x[ok], v[ok]


def sealed(a_c: xr.DataArray, sigma: xr.DataArray) -> np.ndarray:
    """The a_c of every seed and step whose conductance is exactly 0: the fluid no longer
    percolates (the flow solver returns 0 without a solve there), which a log axis cannot
    show."""
    x, v = np.broadcast_arrays(a_c.values, sigma.values)
    x, v = x.ravel(), v.ravel()
    return x[np.isfinite(x) & (v == 0)]


def mark_edge(ax: Axes, x: np.ndarray, *, color: str, label: str, top: bool = False) -> None:
    """Triangles on the bottom (``top``: the top) edge of ``ax`` at ``x``: values off its
    log scale (a conductance of 0, a ratio over 0), said in the legend instead of dropped
    without a word."""
    if not len(x):
        return
    ax.plot(x, np.full(len(x), 1.0 if top else 0.0), "^" if top else "v", color=color,
            mfc=color, ms=5, clip_on=False, transform=ax.get_xaxis_transform(), label=label)
