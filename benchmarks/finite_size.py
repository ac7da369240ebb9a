"""Finite-size scaling of a_c*: easy, hard and isotropic extrapolations side by side (issue 20).

Phases (results under ``--out``, default ``results/benchmarks``):

- ``run``: thresholds per (model, gamma, L/lambda_r, aspect, seed): the threshold scene's
  search (same surfaces, tolerances and corrected a_c* as the workflow) plus, for the
  elastic model, the contact-line faces normal to x and y at each axis' threshold
  (``roughflow.convergence.measure.threshold_record``), so that any weighting of the
  perimeter correction can be evaluated afterwards. Every result is appended to
  ``finite_size.jsonl`` and never computed twice: a run can be stopped and resumed, and
  seeds or sizes can be added later.
- ``report``: the fits of :mod:`roughflow.fits` (a_c*(eps) = a_c* + A eps^(1/nu), bootstrap
  over whole seeds) on the default config's design and on everything measured; the
  easy-hard midpoint against the isotropic a_c* at the same mapped size; the correlation of
  one seed's values between sizes and directions. Writes ``finite_size.md`` and
  ``finite_size.png``.

Size variable. An anisotropic surface is an isotropic one in the mapped coordinates
x' = x / sqrt(gamma), y' = y sqrt(gamma) (Eq. 1): an lx x ly cell becomes
(lx / sqrt(gamma)) x (ly sqrt(gamma)). ``eps`` is lambda_r over the SHORTER mapped side;
for square cells (aspect 1) it is the paper's eps_t = max(sqrt(gamma), 1/sqrt(gamma))
lambda_r / L, and for ``--aspect gamma`` cells, whose mapped shape is square, lambda_r / L.

Reproduce the issue-20 numbers (docs/accuracy.md, "Anisotropic finite-size extrapolation";
about 2 h of one core for the elastic runs, minutes for the bearing ones)::

    export ROUGHFLOW_FFT_THREADS=1
    B="python benchmarks/finite_size.py run"
    $B --model elastic --gamma 2 --sizes 5.657 8 11.31 16 --seeds $(seq 0 19)
    $B --model elastic --gamma 1.5 3 4 --sizes 11.31 --seeds $(seq 0 19)
    $B --model elastic --gamma 1 --sizes 4 5.657 8 11.31 16 --seeds $(seq 0 39)
    $B --model elastic --gamma 2 --aspect gamma --sizes 4 8 16 --seeds $(seq 0 9)
    $B --model bearing --gamma 2 --sizes 5.657 8 11.31 16 22.63 32 --seeds $(seq 0 39)
    $B --model bearing --gamma 1.5 3 4 --sizes 11.31 --seeds $(seq 0 39)
    $B --model bearing --gamma 1 --sizes 4 5.657 8 11.31 16 22.63 --seeds $(seq 0 39)
    $B --model bearing --gamma 2 --aspect gamma --sizes 4 8 16 22.63 --seeds $(seq 0 39)
    python benchmarks/finite_size.py report
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow import accuracy, defaults, fits  # noqa: E402
from roughflow.convergence.anisotropic import face_term  # noqa: E402
from roughflow.convergence.measure import threshold_record  # noqa: E402
from roughflow.errors import InputError  # noqa: E402
from roughflow.scenes import SurfaceParams  # noqa: E402
from roughflow.search import SearchOptions, threshold  # noqa: E402
from roughflow.surface import generate  # noqa: E402

FILE = "finite_size.jsonl"
#: L / lambda_r values are matched to 4 significant digits (5.657 = 4 sqrt 2, ...)
SIZE_DIGITS = 4


def _size(v: float) -> float:
    return float(f"{v:.{SIZE_DIGITS}g}")


def exact_size(v: float) -> float:
    """The study's sizes are powers of sqrt(2) (4, 4 sqrt 2, 8, ...): 5.657 -> 4 sqrt(2)
    exactly, as in config/config.yaml, so that the surfaces are the workflow's."""
    k = round(2 * math.log2(v))
    return 2.0 ** (k / 2) if abs(2 * math.log2(v) - k) < 1e-3 else float(v)


def mapped_eps(gamma: float, size: float, aspect: float) -> float:
    """lambda_r over the shorter side of the cell in the mapped (isotropic) coordinates."""
    lx, ly = math.sqrt(aspect), 1.0 / math.sqrt(aspect)  # unit area, L = 1
    g = math.sqrt(gamma)
    return 1.0 / (exact_size(size) * min(lx / g, ly * g))


def _key(r: dict) -> tuple:
    return (r["model"], r["gamma"], r["size"], r["aspect"], r["ppl"], r["tol"],
            r["contact_tol"], r["seed"])


def _load(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def phase_run(args) -> None:
    out = Path(args.out) / FILE
    out.parent.mkdir(parents=True, exist_ok=True)
    done = {_key(r) for r in _load(out)}
    for gamma in args.gamma:
        aspect = gamma if args.aspect == "gamma" else float(args.aspect)
        for size in args.sizes:
            params = SurfaceParams(gamma=gamma, hurst=args.hurst,
                                   l_over_lambda_r=exact_size(size),
                                   eps_f=args.eps_f, points_per_lambda_s=args.ppl,
                                   aspect=aspect)
            tol = args.tol if args.model != "bearing" else defaults.THRESHOLD_TOL
            base = dict(model=args.model, gamma=gamma, size=_size(size), aspect=aspect,
                        ppl=args.ppl, tol=tol, contact_tol=args.contact_tol)
            for seed in args.seeds:
                rec = dict(base, seed=seed)
                if _key(rec) in done:
                    continue
                t0 = time.perf_counter()
                surf = generate(params.spec(seed))
                rec.update(nx=surf.shape[0], ny=surf.shape[1], dx=surf.dx, dy=surf.dy,
                           eps=mapped_eps(gamma, size, aspect), hurst=args.hurst,
                           eps_f=args.eps_f, perimeter_c=accuracy.PERIMETER_C)
                if args.model == "elastic":
                    # the threshold scene's search plus the contact-line faces at each
                    # axis' threshold (any weighting of the perimeter term afterwards)
                    t = threshold_record(surf, tol=tol, contact_tol=args.contact_tol,
                                         on_unbracketed="nan")
                    for k, ax in enumerate("xy"):
                        rec[f"a_{ax}"] = t[f"a_star_{k}"]
                        rec[f"ac_{ax}"] = t[f"a_star_corrected_{k}"]
                        for q in ("a_mid", "tx", "ty"):
                            rec[f"{q}_{ax}"] = t[f"{q}_{k}"]
                else:
                    th = threshold(surf, axis=None, model="bearing", tol=tol,
                                   options=SearchOptions(on_unbracketed="nan"))
                    for k, ax in enumerate("xy"):
                        rec[f"a_{ax}"] = rec[f"ac_{ax}"] = th[k].a_c_star
                rec["time"] = time.perf_counter() - t0
                with out.open("a") as f:
                    f.write(json.dumps(rec) + "\n")
                print(json.dumps(rec), flush=True)


# ---------------------------------------------------------------------------------------
# report
# ---------------------------------------------------------------------------------------

#: The default config's threshold_vs_size design (config/config.yaml): gamma = 2 series,
#: other gamma at 11.3, isotropic series; 10 seeds.
DEFAULT_DESIGN = {
    "aniso": [(2.0, s) for s in (5.657, 8.0, 11.31, 16.0)]
    + [(g, 11.31) for g in (1.5, 3.0, 4.0)],
    "iso": [4.0, 8.0, 16.0],
    "seeds": list(range(10)),
}


#: a_c* variants: raw; as the threshold search corrected it when the record was made ("ac":
#: the workflow's value, per-face perimeter term of both bracketing states); corrected from
#: the stored faces at the bracket midpoint with accuracy.PERIMETER_C and either face
#: weighting ("pixel" = per face, the current term, equal to "ac" within 1e-5; "geometric"
#: = the pre-issue-20 weighting: roughflow.convergence.anisotropic.face_term)
FIELDS = {"a": "raw", "ac": "corrected (workflow)",
          "geometric": "corrected, pre-issue-20 geometric weighting",
          "pixel": "corrected, pixel weighting"}


def _value(r: dict, field: str, ax: str) -> float:
    if field in ("a", "ac"):
        return r[f"{field}_{ax}"]
    return r[f"a_{ax}"] - accuracy.PERIMETER_C * face_term(r, f"_{ax}", field)


def _values(recs: list[dict], gamma: float, size: float, aspect: float, seeds, field: str):
    """(n_seeds, 2) array of a_c* along x and y (NaN where not run)."""
    by_seed = {r["seed"]: r for r in recs if r["gamma"] == gamma and r["size"] == _size(size)
               and r["aspect"] == aspect}
    out = np.full((len(seeds), 2), np.nan)
    for i, s in enumerate(seeds):
        if s in by_seed:
            out[i] = _value(by_seed[s], field, "x"), _value(by_seed[s], field, "y")
    return out


def _points(recs, design: dict, field: str, aspect_of=lambda g: 1.0):
    """fits.bootstrap_fit inputs: eps and per-seed values per direction."""
    seeds = design["seeds"]
    eps, vals = {}, {}

    def add(d, e, col):
        if np.isfinite(col).any():
            eps.setdefault(d, []).append(e)
            vals.setdefault(d, []).append(col)

    for g, size in design.get("aniso", []):
        asp = aspect_of(g)
        v = _values(recs, g, size, asp, seeds, field)
        names = fits.direction_names(g)
        for k, ax in enumerate("xy"):
            add(names[ax], mapped_eps(g, size, asp), v[:, k])
    for size in design.get("iso", []):
        v = _values(recs, 1.0, size, 1.0, seeds, field)
        for k in range(2):
            add("both", mapped_eps(1.0, size, 1.0), v[:, k])
    return ({d: np.asarray(e) for d, e in eps.items()},
            {d: np.stack(v, axis=1) for d, v in vals.items()})


def _fit(eps, vals, dirs, nu, n_boot):
    if any(d not in eps for d in dirs):
        return None
    try:
        return fits.bootstrap_fit({d: eps[d] for d in dirs}, {d: vals[d] for d in dirs}, nu=nu,
                                  n_boot=n_boot, rng=0)
    except InputError:
        return None


def _fmt_fit(f) -> list:
    if f is None:
        return ["-", "-", "-"]
    nu = f"{f.nu:.2f} +- {f.nu_err:.2f}" if f.nu_free else "4/3"
    amps = ", ".join(f"{d} {a:+.3f}" for d, a in f.amplitude.items())
    return [f"{f.a_star:.4f} +- {f.a_star_err:.4f}", nu, amps]


def fit_table(recs, design, field, n_boot, aspect_of=lambda g: 1.0) -> tuple[list, dict]:
    eps, vals = _points(recs, design, field, aspect_of)
    nu0 = defaults.NU_PERCOLATION
    rows, res = [], {}
    for name, dirs, nu in (("anisotropic joint, nu = 4/3", ("easy", "hard"), nu0),
                           ("anisotropic joint, nu free", ("easy", "hard"), None),
                           ("easy alone, nu = 4/3", ("easy",), nu0),
                           ("hard alone, nu = 4/3", ("hard",), nu0),
                           ("isotropic, nu = 4/3", ("both",), nu0),
                           ("isotropic, nu free", ("both",), None)):
        f = _fit(eps, vals, dirs, nu, n_boot)
        res[name] = f
        rows.append([name, *_fmt_fit(f), f.n_points if f else 0])
    a, b = res["anisotropic joint, nu = 4/3"], res["isotropic, nu = 4/3"]
    if a is not None and b is not None:
        d = a.a_star - b.a_star
        e = math.hypot(a.a_star_err, b.a_star_err)
        rows.append(["difference aniso joint - iso (nu = 4/3)", f"{d:+.4f} +- {e:.4f}",
                     f"{abs(d) / e:.1f} sigma", "", ""])
    return rows, res


#: Candidate designs of the default config's threshold_vs_size study (issue 20, item 4):
#: same seeds, compared by cost and by the errors of the fits.
CANDIDATES = {
    "default (config.yaml before issue 20)": DEFAULT_DESIGN,
    "isotropic at the gamma = 2 series' eps: 4, 5.657, 8, 11.31":
        dict(DEFAULT_DESIGN, iso=[4.0, 5.657, 8.0, 11.31]),
    "isotropic 4, 5.657, 8, 11.31, 16": dict(DEFAULT_DESIGN, iso=[4.0, 5.657, 8.0, 11.31, 16.0]),
    "gamma = 2 series and isotropic only (no other gamma)":
        dict(DEFAULT_DESIGN, aniso=DEFAULT_DESIGN["aniso"][:4]),
}


def design_costs(recs, field, n_boot) -> str:
    """Cost per seed (median measured time of each run, one core) and fit errors of the
    candidate designs on the seeds that every candidate has, scaled to 10 seeds (error x
    sqrt(n / 10))."""
    med, have = {}, {}
    for r in recs:
        med.setdefault((r["gamma"], r["size"]), []).append(r["time"])
        have.setdefault((r["gamma"], r["size"]), set()).add(r["seed"])
    med = {k: float(np.median(v)) for k, v in med.items()}
    runs = {name: [(g, _size(s)) for g, s in d["aniso"]] + [(1.0, _size(s)) for s in d["iso"]]
            for name, d in CANDIDATES.items()}
    runs = {n: r for n, r in runs.items() if all(k in med for k in r)}
    if not runs:
        return ""
    seeds = sorted(set.intersection(*[have[k] for r in runs.values() for k in r]))
    rows = []
    for name, design in CANDIDATES.items():
        if name not in runs or len(seeds) < 2:
            continue
        _, res = fit_table(recs, dict(design, seeds=seeds), field, n_boot)
        a, i = res["anisotropic joint, nu = 4/3"], res["isotropic, nu = 4/3"]
        if a is None or i is None:
            continue
        k = math.sqrt(len(seeds) / 10)
        err = math.hypot(a.a_star_err, i.a_star_err) * k
        rows.append([name, f"{sum(med[r] for r in runs[name]):.0f}", f"{a.a_star:.4f}",
                     f"{a.a_star_err * k:.4f}", f"{i.a_star:.4f}", f"{i.a_star_err * k:.4f}",
                     f"{a.a_star - i.a_star:+.4f} +- {err:.4f}"])
    return (f"## elastic: candidate designs ({FIELDS[field]} a_c*, seeds {seeds[0]}-{seeds[-1]}; "
            "errors scaled to 10 seeds)\n\n"
            + _md_table(["design", "cost per seed [s, one core]", "aniso joint", "error",
                         "isotropic", "error", "difference"], rows) + "\n")


def _md_table(header, rows) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        lines.append("| " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v)
                                       for v in r) + " |")
    return "\n".join(lines)


def _series_stats(recs, gamma, aspect, field, seeds):
    """Per size: mean and SE of x, y and the midpoint over the seeds present."""
    sizes = sorted({r["size"] for r in recs if r["gamma"] == gamma and r["aspect"] == aspect})
    out = []
    for size in sizes:
        v = _values(recs, gamma, size, aspect, seeds, field)
        ok = np.isfinite(v).all(axis=1)
        if ok.sum() < 2:
            continue
        v = v[ok]
        mid = v.mean(axis=1)
        se = v.std(axis=0, ddof=1) / math.sqrt(len(v))
        out.append(dict(size=size, eps=mapped_eps(gamma, size, aspect), n=len(v),
                        x=v[:, 0].mean(), y=v[:, 1].mean(), se_x=se[0], se_y=se[1],
                        mid=mid.mean(), se_mid=mid.std(ddof=1) / math.sqrt(len(v)),
                        per_seed=v))
    return out


def report(args) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    outdir = Path(args.out)
    recs = _load(outdir / FILE)
    md = ["# Finite-size scaling of a_c* (benchmarks/finite_size.py report)\n",
          "eps = lambda_r over the shorter side of the cell in mapped (isotropic) coordinates "
          "(= the paper's eps_t for square cells). Fits a_c*(eps) = a_c* + A eps^(1/nu) to "
          "the seed means, errors = bootstrap over whole seeds (" f"{args.bootstrap}"
          " resamples). 'corrected' = perimeter-corrected a_c* as the workflow analyses it.\n"]
    fig, axs = plt.subplots(1, 2, figsize=(12, 4.8))
    for mi, model in enumerate(("elastic", "bearing")):
        mrec = [r for r in recs if r["model"] == model and r["aspect"] == 1.0]
        if not mrec:
            continue
        fields = args.fields if model == "elastic" else ("a",)
        all_seeds = sorted({r["seed"] for r in mrec})
        g2_sizes = sorted({r["size"] for r in mrec if r["gamma"] == 2.0})
        iso_sizes = sorted({r["size"] for r in mrec if r["gamma"] == 1.0})
        other = sorted({(r["gamma"], r["size"]) for r in mrec
                        if r["gamma"] not in (1.0, 2.0)})
        designs = {
            "default design (config.yaml: sizes and seeds 0-9)": DEFAULT_DESIGN,
            f"default design's sizes, all seeds ({len(all_seeds)})": dict(DEFAULT_DESIGN,
                                                                         seeds=all_seeds),
            f"all sizes, all seeds ({len(all_seeds)})": {
                "aniso": [(2.0, s) for s in g2_sizes] + other, "iso": iso_sizes,
                "seeds": all_seeds},
            "gamma = 2 and isotropic only, all sizes and seeds": {
                "aniso": [(2.0, s) for s in g2_sizes], "iso": iso_sizes, "seeds": all_seeds},
            # corrections to scaling: the same without the smallest size of each series
            "gamma = 2 and isotropic only, without the smallest size of each": {
                "aniso": [(2.0, s) for s in g2_sizes[1:]], "iso": iso_sizes[1:],
                "seeds": all_seeds},
        }
        for fi, field in enumerate(fields):
            what = FIELDS[field]
            # the other variants (raw, the old weighting) only on the default design's sizes:
            # they show what the correction and its fix change, and the fits are slow
            for dname, design in list(designs.items())[:None if fi == 0 else 2]:
                rows, _ = fit_table(mrec, design, field, args.bootstrap)
                md.append(f"## {model}, {what} a_c*: {dname}\n")
                md.append(f"gamma = 2 sizes {[s for g, s in design['aniso'] if g == 2.0]}, "
                          f"other gamma {[gs for gs in design['aniso'] if gs[0] != 2.0]}, "
                          f"isotropic sizes {design['iso']}.\n")
                md.append(_md_table(["fit", "a_c*(0)", "nu", "amplitudes", "points"], rows)
                          + "\n")
            # how much the default design's answer scatters: the same fits on disjoint
            # blocks of 10 seeds
            blocks = [all_seeds[i:i + 10] for i in range(0, len(all_seeds) - 9, 10)] * (fi == 0)
            diffs = []
            for b in blocks:
                _, res = fit_table(mrec, dict(DEFAULT_DESIGN, seeds=b), field, args.bootstrap)
                a, i = res["anisotropic joint, nu = 4/3"], res["isotropic, nu = 4/3"]
                if a is not None and i is not None:
                    diffs.append((b[0], b[-1], a.a_star, i.a_star, a.a_star - i.a_star,
                                  math.hypot(a.a_star_err, i.a_star_err)))
            if len(diffs) > 1:
                md.append(f"Default design on disjoint blocks of 10 seeds ({model}, {what}): "
                          + "; ".join(f"seeds {b0}-{b1}: aniso {a:.4f}, iso {i:.4f}, "
                                      f"difference {d:+.4f} +- {e:.4f}"
                                      for b0, b1, a, i, d, e in diffs)
                          + f". Spread (sd) of the difference over blocks: "
                          f"{np.std([d[4] for d in diffs], ddof=1):.4f}.\n")
        # per-size table: gamma = 2 easy, hard, midpoint; isotropic at the same eps
        field = fields[0]
        g2 = _series_stats(mrec, 2.0, 1.0, field, all_seeds)
        iso = {round(s["eps"], 4): s for s in _series_stats(mrec, 1.0, 1.0, field, all_seeds)}
        rows, diffs = [], []
        for s in g2:
            i = iso.get(round(s["eps"], 4))
            if i:
                diffs.append((s["mid"] - i["mid"], math.hypot(s["se_mid"], i["se_mid"])))
            rows.append([f"{s['size']:g}", f"{s['eps']:.4f}", s["n"],
                         f"{s['x']:.4f} +- {s['se_x']:.4f}", f"{s['y']:.4f} +- {s['se_y']:.4f}",
                         f"{s['mid']:.4f} +- {s['se_mid']:.4f}",
                         f"{i['mid']:.4f} +- {i['se_mid']:.4f} ({i['n']})" if i else "-",
                         f"{s['mid'] - i['mid']:+.4f} +- {math.hypot(s['se_mid'], i['se_mid']):.4f}"
                         if i else "-"])
        md.append(f"## {model}: gamma = 2 per size against the isotropic square of the same "
                  f"eps ({FIELDS[field]} a_c*)\n")
        md.append(_md_table(["L/lambda_r", "eps", "seeds", "easy (x)", "hard (y)", "midpoint",
                             "isotropic (seeds)", "midpoint - isotropic"], rows) + "\n")
        if diffs:
            d, e = np.array(diffs).T
            w = 1 / e**2
            md.append(f"Midpoint - isotropic, inverse-variance mean over the {len(d)} matched "
                      f"sizes: {np.sum(w * d) / np.sum(w):+.4f} +- {1 / math.sqrt(np.sum(w)):.4f}"
                      f" (chi2 {np.sum(w * (d - np.sum(w * d) / np.sum(w))**2):.1f} for "
                      f"{len(d) - 1} degrees of freedom).\n")
        if model == "elastic":
            md.append(design_costs(mrec, field, args.bootstrap))
        # correlations between sizes (same seed) and between directions
        if len(g2) > 1:
            cs = []
            for a, b in zip(g2[:-1], g2[1:], strict=True):
                n = min(len(a["per_seed"]), len(b["per_seed"]))
                cs.append(np.corrcoef(a["per_seed"][:n, 0], b["per_seed"][:n, 0])[0, 1])
            cd = [np.corrcoef(s["per_seed"][:, 0], s["per_seed"][:, 1])[0, 1] for s in g2]
            md.append(f"Seed correlations ({model}, gamma = 2): easy direction between "
                      f"consecutive sizes {', '.join(f'{c:+.2f}' for c in cs)}; easy with hard "
                      f"of the same surface {', '.join(f'{c:+.2f}' for c in cd)}.\n")
        ax = axs[mi]
        x = lambda e: np.asarray(e) ** (1 / defaults.NU_PERCOLATION)  # noqa: E731
        for key, col, lab in (("x", "C0", "gamma 2 easy"), ("y", "C3", "gamma 2 hard"),
                              ("mid", "C2", "gamma 2 midpoint")):
            ax.errorbar(x([s["eps"] for s in g2]), [s[key] for s in g2],
                        yerr=[s[f"se_{key}"] for s in g2], color=col, marker="o", capsize=2,
                        label=lab)
        isos = sorted(iso.values(), key=lambda s: s["eps"])
        ax.errorbar(x([s["eps"] for s in isos]), [s["mid"] for s in isos],
                    yerr=[s["se_mid"] for s in isos], color="k", marker="x", capsize=2,
                    label="isotropic (x, y mean)")
        sq = _series_stats([r for r in recs if r["model"] == model], 2.0, 2.0, field,
                           all_seeds)
        if sq:
            ax.errorbar(x([s["eps"] for s in sq]), [s["mid"] for s in sq],
                        yerr=[s["se_mid"] for s in sq], color="C1", marker="s", capsize=2,
                        mfc="none", label="gamma 2, mapped-square cell (aspect 2), midpoint")
        ax.set_xlim(left=0)
        ax.set_xlabel("eps^(3/4)  (eps = lambda_r / shorter mapped side)")
        ax.set_ylabel(f"a_c* ({FIELDS[field]})")
        ax.set_title(f"{model} model")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(outdir / "finite_size.png", dpi=120)
    plt.close(fig)
    (outdir / "finite_size.md").write_text("\n".join(md))
    print("\n".join(md))


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("phase", choices=("run", "report"))
    ap.add_argument("--out", default="results/benchmarks", help="output folder")
    ap.add_argument("--model", default="elastic", choices=("elastic", "bearing"))
    ap.add_argument("--gamma", type=float, nargs="+", default=[2.0])
    ap.add_argument("--sizes", type=float, nargs="+", default=[5.657, 8, 11.31, 16],
                    help="L / lambda_r (matched to 4 significant digits)")
    ap.add_argument("--aspect", default="1", help="lx / ly, or 'gamma' (mapped-square cell)")
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    ap.add_argument("--ppl", type=float, default=4.0,
                    help="points per lambda_s along each axis (config.yaml: 4)")
    ap.add_argument("--hurst", type=float, default=defaults.HURST)
    ap.add_argument("--eps-f", type=float, default=defaults.EPS_F)
    ap.add_argument("--tol", type=float, default=0.008, help="bisection tol (config.yaml)")
    ap.add_argument("--contact-tol", type=float, default=1e-4, help="as config.yaml")
    ap.add_argument("--bootstrap", type=int, default=300,
                    help="resamples (the nu-free fits make 1000 slow; errors to ~4 %%)")
    ap.add_argument("--fields", nargs="+", default=["ac", "geometric", "a"],
                    choices=list(FIELDS), help="elastic a_c* variants to report (first: "
                    "per-size table and figure)")
    return ap


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    if args.phase == "run":
        phase_run(args)
    else:
        report(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
