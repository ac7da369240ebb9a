"""The anisotropic report (issue 20): a_c* per direction over every gamma with a resolution
file, and the face weighting of the perimeter term: ``convergence_anisotropic.md``,
``.csv`` and ``.png``.

Two weightings of the contact/non-contact faces are computed from the stored face counts
per cell (tx: faces normal to x, ty: normal to y) and the spacings, so that records written
with any version of :func:`roughflow.accuracy.perimeter_term` compare alike.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from roughflow import accuracy
from roughflow.defaults import A_C_STAR_ERROR_BUDGET

from .dataset import read_records
from .options import FIT_MIN_PPL
from .records import ANISOTROPIC_STEM, RESOLUTION_GLOB
from .tables import (
    EXTRAP_NOTE,
    ReportDraft,
    ReportFiles,
    a_star_references,
    md_table,
    ppl_cell,
    publish_reports,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

#: "geometric": face length times the geometric-mean spacing sqrt(dx dy) (the form calibrated
#: on square cells before issue 20); "pixel": face length times the spacing normal to the
#: face, i.e. one cell area per face whatever the cell's aspect ratio. Both are (tx + ty) on
#: square cells.
FORMS = ("geometric", "pixel")

#: the first line of convergence_anisotropic.md
TITLE = "# Anisotropic resolution study (roughflow accuracy report)\n"


def face_term(r: dict, suffix: str, form: str) -> float:
    """The perimeter term of record ``r`` (face counts ``tx{suffix}``, ``ty{suffix}``) in
    the weighting ``form`` (:data:`FORMS`)."""
    tx, ty = r[f"tx{suffix}"], r[f"ty{suffix}"]
    if form == "pixel":
        return tx + ty
    q = math.sqrt(r["dy"] / r["dx"])
    return tx * q + ty / q


@dataclass(frozen=True)
class GroupFit:
    """A least-squares fit a = a_inf(group) + terms @ c: the constants ``c`` and the rms
    residual."""

    c: np.ndarray
    rms: float


def fit_groups(groups: list, a: np.ndarray, terms: np.ndarray) -> GroupFit:
    """a = a_inf(group) + terms @ c with several constants
    (:func:`roughflow.accuracy.fit_perimeter_constant` is the one-constant case)."""
    labels = sorted(set(groups), key=str)
    idx = {lab: i for i, lab in enumerate(labels)}
    design = np.zeros((a.size, len(labels) + terms.shape[1]))
    for k, lab in enumerate(groups):
        design[k, idx[lab]] = 1.0
    design[:, len(labels):] = terms
    coef, *_ = np.linalg.lstsq(design, a, rcond=None)
    return GroupFit(coef[len(labels):], float(np.sqrt(np.mean((a - design @ coef) ** 2))))


def _fit_form(pts: list[dict], form: str, exclude_seed: int | None = None
              ) -> accuracy.PerimeterFit:
    pts = [r for r in pts if r["seed"] != exclude_seed]
    return accuracy.fit_perimeter_constant(
        [(r["gamma"], r["seed"], r["target"]) for r in pts], [r["a_fixed"] for r in pts],
        [face_term(r, "_fixed", form) for r in pts])


def _jackknife_c(pts: list[dict], form: str) -> float:
    """Leave-one-seed-out (jackknife) standard error of the fitted constant."""
    seeds = sorted({(r["gamma"], r["seed"]) for r in pts})
    if len(seeds) < 3:
        return float("nan")
    cs = np.array([_fit_form([r for r in pts if (r["gamma"], r["seed"]) != gs], form).c
                   for gs in seeds])
    return float(np.sqrt((len(cs) - 1) / len(cs) * np.sum((cs - cs.mean()) ** 2)))


def _csv_line(*fields) -> str:
    """One CSV line of ``fields``, quoted where one holds a comma (the variant
    "pixel, c fitted")."""
    buf = io.StringIO()
    csv.writer(buf, lineterminator="").writerow(fields)
    return buf.getvalue()


def _direction(gamma: float, ax: int) -> str:
    if gamma == 1.0:
        return "x" if ax == 0 else "y"
    return ("easy (x)" if ax == 0 else "hard (y)") if gamma > 1 else (
        "hard (x)" if ax == 0 else "easy (y)")


@dataclass
class _Rows:
    """The tables and the CSV the gammas add to."""

    fit: list[list]
    fixed: list[list]
    thr: list[list]
    csv: list[str]


def _gamma_section(recs: list[dict], g: float, fit_min_ppl: int, rows: _Rows,
                   ax_: Axes) -> list[dict]:
    """One gamma: the perimeter constant fitted on its fixed-load areas, the fixed-load area
    errors and a_c* per direction (table rows, CSV, one plot); returns the fixed-load
    records it fitted (none where its resolutions are incomplete)."""
    c0 = accuracy.PERIMETER_C
    rg = [r for r in recs if r["gamma"] == g]
    thr = [r for r in rg if r["kind"] == "threshold"]
    fixed = [r for r in rg if r["kind"] in ("sigma", "fixed") and "tx_fixed" in r]
    ppls = sorted({r["ppl"] for r in thr})
    seeds = sorted(s for s in {r["seed"] for r in thr}
                   if all(any(r["seed"] == s and r["ppl"] == p for r in thr) for p in ppls))
    fit_ppls = [p for p in ppls if p >= fit_min_ppl]
    if len(fit_ppls) < 2 or not seeds:  # nothing complete yet
        return []
    f0, f1 = ppls[-2], ppls[-1]
    pts = [r for r in fixed if r["ppl"] in fit_ppls and r["seed"] in seeds]
    cfit = {}
    for form in FORMS:
        f = _fit_form(pts, form)
        cfit[form] = f
        rows.fit.append([g, form, f.c, _jackknife_c(pts, form), f.rms, f.n])
    tx_ty = np.mean([r["tx_fixed"] / r["ty_fixed"] for r in pts])
    xy = fit_groups([(r["seed"], r["target"]) for r in pts],
                    np.array([r["a_fixed"] for r in pts]),
                    np.array([[r["tx_fixed"], r["ty_fixed"]] for r in pts]))
    rows.fit.append([g, f"pixel, c_x and c_y (tx/ty = {tx_ty:.2f}: nearly collinear)",
                     f"{xy.c[0]:.4f} / {xy.c[1]:.4f}", "", xy.rms, len(pts)])
    # fixed-load areas against resolution
    for target in sorted({r["target"] for r in fixed}):
        for p in ppls:
            e = {k: [] for k in ("raw", *FORMS)}
            for s in seeds:
                rr = {q["ppl"]: q for q in fixed if q["seed"] == s and q["target"] == target}
                if p not in rr or f0 not in rr or f1 not in rr:
                    continue
                ref = accuracy.richardson(rr[f0]["a_fixed"], rr[f1]["a_fixed"],
                                          ratio=f1 / f0)
                e["raw"].append(rr[p]["a_fixed"] - ref)
                for form in FORMS:
                    e[form].append(rr[p]["a_fixed"] - c0 * face_term(rr[p], "_fixed", form)
                                   - ref)
            if e["raw"]:
                rows.fixed.append([g, target, ppl_cell(p, (f0, f1)),
                                   *[float(np.mean(e[k])) for k in e]])
    # a_c* per direction
    refs = a_star_references(thr, seeds, (f0, f1))
    for ax in (0, 1):
        d = _direction(g, ax)
        # the constant that would remove the first-order error of a_c* itself, fitted
        # on this direction's thresholds at the two finest grids (at 4 points per
        # lambda_s the percolation jitter, sd ~0.014, swamps it); jackknife over seeds
        tp = [dict(q, gamma=g, target=None, a_fixed=q[f"a_star_{ax}"],
                   tx_fixed=q[f"tx_{ax}"], ty_fixed=q[f"ty_{ax}"])
              for q in thr if q["ppl"] in (f0, f1) and q["seed"] in seeds]
        if len(seeds) > 2:
            ft = _fit_form(tp, "pixel")
            rows.fit.append([g, f"pixel, fitted on a_c* {d} (ppl {f0}, {f1})", ft.c,
                             _jackknife_c(tp, "pixel"), ft.rms, ft.n])
        curves = {k: [] for k in ("raw", *FORMS, "pixel, c fitted")}
        for p in ppls:
            e = {k: [] for k in curves}
            for s in seeds:
                q = next(r for r in thr if r["seed"] == s and r["ppl"] == p)
                v, ref = q[f"a_star_{ax}"], refs[(s, ax)]
                vals = {"raw": v}
                for form in FORMS:
                    vals[form] = v - c0 * face_term(q, f"_{ax}", form)
                c_loo = _fit_form(pts, "pixel", exclude_seed=s).c if len(seeds) > 1 \
                    else cfit["pixel"].c
                vals["pixel, c fitted"] = v - c_loo * face_term(q, f"_{ax}", "pixel")
                for k, val in vals.items():
                    e[k].append(val - ref)
                    rows.csv.append(_csv_line(g, "a_c_star", d, k, p, s, val, ref, val - ref))
            for k in curves:
                ea = np.asarray(e[k])
                sd = float(np.std(ea, ddof=1)) if ea.size > 1 else float("nan")
                curves[k].append((p, float(np.mean(ea)), sd / math.sqrt(ea.size)))
                rows.thr.append([g, d, k, ppl_cell(p, (f0, f1)), float(np.mean(ea)),
                                 sd / math.sqrt(ea.size),
                                 sd, len(ea)])
        for k, col in zip(curves, ("k", "C0", "C3", "C2"), strict=True):
            xs = [p for p, *_ in curves[k]]
            ax_.errorbar(xs, [m for _, m, _ in curves[k]],
                         yerr=[se for *_, se in curves[k]], color=col, capsize=2,
                         ls="-" if ax == 0 else "--", marker="o" if ax == 0 else "s",
                         label=f"{d}: {k}")
    ax_.axhline(0, color="gray", lw=0.8)
    ax_.axhspan(-A_C_STAR_ERROR_BUDGET, A_C_STAR_ERROR_BUDGET, color="gray", alpha=0.15, lw=0)
    ax_.set_xscale("log", base=2)
    ax_.set_xlabel("points per lambda_s (each axis)")
    ax_.set_ylabel("a_c* error (mean over seeds +- SE)")
    ax_.set_title(f"gamma = {g:g} ({len(seeds)} seeds, c = {c0})")
    ax_.legend(fontsize=6)
    return pts


def _pooled_fits(fixed_all: list[dict], rows: _Rows) -> None:
    """The constants fitted on the fixed-load areas of every gamma together."""
    for form in FORMS:
        f = _fit_form(fixed_all, form)
        rows.fit.append(["pooled", form, f.c, _jackknife_c(fixed_all, form), f.rms, f.n])
    xy = fit_groups([(r["gamma"], r["seed"], r["target"]) for r in fixed_all],
                    np.array([r["a_fixed"] for r in fixed_all]),
                    np.array([[r["tx_fixed"], r["ty_fixed"]] for r in fixed_all]))
    rows.fit.append(["pooled", "pixel, c_x and c_y", f"{xy.c[0]:.4f} / {xy.c[1]:.4f}", "",
                     xy.rms, len(fixed_all)])


def write_anisotropic_report(out: str | os.PathLike, *, fit_min_ppl: int = FIT_MIN_PPL
                             ) -> ReportFiles | None:
    """The anisotropic report (:func:`anisotropic_draft`) written under ``out``; None
    (nothing written) where there is none."""
    draft = anisotropic_draft(out, fit_min_ppl=fit_min_ppl)
    return None if draft is None else publish_reports(out, [draft])[0]


def anisotropic_draft(out: str | os.PathLike, *, fit_min_ppl: int = FIT_MIN_PPL
                      ) -> ReportDraft | None:
    """The anisotropic report from every resolution dataset under ``out``
    (:func:`anisotropic_records_draft`)."""
    files = sorted(Path(out).glob(RESOLUTION_GLOB))
    return anisotropic_records_draft([r for f in files for r in read_records(f)],
                                     fit_min_ppl=fit_min_ppl)


def anisotropic_records_draft(records: list[dict], *, fit_min_ppl: int = FIT_MIN_PPL
                              ) -> ReportDraft | None:
    """The anisotropic report from the resolution records (of every gamma) with face counts;
    None where there is none. Draws without pyplot."""
    from matplotlib.figure import Figure

    recs = [dict(r) for r in records]  # the caller's records keep their fields
    for r in recs:
        r.setdefault("gamma", 1.0)
    recs = [r for r in recs if "tx_0" in r or "tx_fixed" in r]  # face counts stored
    gammas = sorted({r["gamma"] for r in recs})
    if not gammas:
        return None
    c0 = accuracy.PERIMETER_C
    md = [TITLE,
          "Same physical surface at every resolution (generated at the finest grid, sampled "
          "h[::k, ::k]); ppl = points per shortest wavelength along each axis, so cells are "
          "gamma:1 rectangles. Reference: first-order Richardson extrapolation of the two "
          "finest grids per seed (and axis). Face terms: tx, ty = contact/non-contact faces "
          "normal to x, y per cell; 'geometric' = tx sqrt(dy/dx) + ty sqrt(dx/dy) (the "
          f"pre-issue-20 perimeter_term), 'pixel' = tx + ty. {EXTRAP_NOTE}\n"]
    rows = _Rows([], [], [], ["gamma,quantity,direction,variant,ppl,seed,value,reference,error"])
    fig = Figure(figsize=(5 * len(gammas), 4.2))
    axs = fig.subplots(1, len(gammas), squeeze=False)
    fixed_all = []
    for gi, g in enumerate(gammas):
        fixed_all += _gamma_section(recs, g, fit_min_ppl, rows, axs[0, gi])
    if len({r["gamma"] for r in fixed_all}) > 1:
        _pooled_fits(fixed_all, rows)
    md.append(f"## Perimeter constant fitted on fixed-load areas (ppl >= {fit_min_ppl})\n")
    md.append(md_table(["gamma", "face weighting", "c", "jackknife SE over seeds",
                        "rms residual", "points"], rows.fit)
              + "\n")
    md.append(f"## Fixed-load contact area error (mean over seeds; corrections with c = {c0})\n")
    md.append(md_table(["gamma", "a_c target (law)", "ppl", "raw", "geometric", "pixel"],
                       rows.fixed) + "\n")
    md.append(f"## a_c* error per direction (raw; corrected with c = {c0} and each face "
              "weighting; pixel with c fitted on the other seeds of this gamma)\n")
    md.append(md_table(["gamma", "direction", "variant", "ppl", "bias", "SE of bias",
                        "sd over seeds", "seeds"], rows.thr) + "\n")
    return ReportDraft.of(ANISOTROPIC_STEM, md, rows.csv, {f"{ANISOTROPIC_STEM}.png": fig})
