"""Non-periodic scans: which boundary treatment changes a_c, a_c* and sigma least?

Truth by construction: a periodic random-phase surface (gamma = 1, H = 0.8) on a cell of
side 2 W is solved as it is; a window of side W cut from it is a non-periodic "scan" with
its wrap-around cut open. The truth for the window is the big cell's solution seen through
the window (contact area, percolation and Reynolds flow of the window with walls across
the flow, and the window's percolation threshold from a threshold search on the big cell):
the window's surface as it sits among its real surroundings. Each method of
:mod:`roughflow.boundary` (periodic, mirror, pad, window) then analyses the window's heights
alone, and the differences to the truth (same analysed cells, same nominal pressures) are
the method's error. Two windows per seed (diagonal quadrants share the big solve).

Usage:
  ROUGHFLOW_FFT_THREADS=1 python benchmarks/nonperiodic.py [--seeds 10] [--size 8]
      [--eps-f 0.125] [--ppl 4] [--pressures 0.02 0.05 0.1]
Writes results/benchmarks/nonperiodic.{jsonl,md} (one line per window and method, and the
summary table).
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow.boundary import Embedding, embed  # noqa: E402
from roughflow.defaults import BOUNDARY_METHODS  # noqa: E402
from roughflow.leak import pressure_curve, sealing_search  # noqa: E402
from roughflow.surface import Surface, SurfaceSpec, generate  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def _offset(win: tuple[slice, slice], inner: tuple[slice, slice], shape) -> tuple[slice, slice]:
    """``inner`` (slices of the window) as slices of the big cell."""
    out = []
    for w, i, n in zip(win, inner, shape, strict=True):
        start, stop, _ = i.indices(n)
        out.append(slice(w.start + start, w.start + stop))
    return tuple(out)


def summary(rows: list[dict], pressures: list[float]) -> str:
    lines = ["| method | windows | d a_c (mean +- sd) | d a_c* x,y (mean +- sd) | "
             "rms d a_c* | d ln sigma (mean +- sd) | rms d ln sigma | wall s (median) |",
             "|---|---|---|---|---|---|---|---|"]
    for m in BOUNDARY_METHODS:
        rs = [r for r in rows if r["method"] == m]
        if not rs:
            continue
        da = np.array([r["d_area"] for r in rs]).ravel()
        ds = np.array([r["d_star"] for r in rs], dtype=float).ravel()
        ls = np.array([r["d_lnsigma"] for r in rs], dtype=float).ravel()
        ls = ls[np.isfinite(ls)]
        ds = ds[np.isfinite(ds)]
        t = np.median([r["seconds"] for r in rs])
        lines.append(
            f"| {m} | {len(rs)} | {da.mean():+.4f} +- {da.std(ddof=1):.4f} | "
            f"{ds.mean():+.4f} +- {ds.std(ddof=1):.4f} | {np.sqrt(np.mean(ds**2)):.4f} | "
            f"{ls.mean():+.3f} +- {ls.std(ddof=1):.3f} | {np.sqrt(np.mean(ls**2)):.3f} | "
            f"{t:.1f} |")
    per_p = ["", "d a_c per nominal pressure (mean +- sd over windows):", "",
             "| method | " + " | ".join(f"p = {p:g}" for p in pressures) + " |",
             "|---|" + "---|" * len(pressures)]
    for m in BOUNDARY_METHODS:
        rs = [r for r in rows if r["method"] == m]
        if not rs:
            continue
        da = np.array([r["d_area"] for r in rs])
        cells = [f"{da[:, k].mean():+.4f} +- {da[:, k].std(ddof=1):.4f}"
                 for k in range(len(pressures))]
        per_p.append(f"| {m} | " + " | ".join(cells) + " |")
    return "\n".join(lines + per_p) + "\n"


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--size", type=float, default=8.0,
                    help="L / lambda_r of the big cell; its grid, ppl * size / eps_f a side, "
                    "must be >= 64 (size >= 2 at the default --ppl and --eps-f): smaller "
                    "windows are too coarse for their threshold search's tol 0.002")
    ap.add_argument("--eps-f", type=float, default=0.125)
    ap.add_argument("--ppl", type=float, default=4.0, help="points per lambda_s")
    ap.add_argument("--pressures", type=float, nargs="+", default=[0.02, 0.05, 0.1],
                    help="nominal pressures (E* gbar)")
    ap.add_argument("--methods", nargs="+", default=list(BOUNDARY_METHODS))
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    out = OUT / f"nonperiodic{args.tag}.jsonl"
    p = np.array(sorted(args.pressures))
    rows = []
    with out.open("w") as fh:
        for seed in range(args.seeds):
            spec = SurfaceSpec.from_sweep(l_over_lambda_r=args.size, eps_f=args.eps_f,
                                          points_per_lambda_s=args.ppl, seed=seed)
            big = generate(spec)
            n0, n1 = big.shape
            for w, win in enumerate([(slice(0, n0 // 2), slice(0, n1 // 2)),
                                     (slice(n0 // 2, n0), slice(n1 // 2, n1))]):
                scan = Surface(heights=big.heights[win].copy(), lx=big.lx / 2, ly=big.ly / 2)
                truths: dict = {}  # analysed region -> truth (mirror, pad, periodic share one)
                for m in args.methods:
                    t0 = time.perf_counter()
                    emb = embed(scan, m)
                    got = pressure_curve(emb, p)
                    th = sealing_search(emb, gbar=1.0)
                    seconds = time.perf_counter() - t0
                    # the truth on the same analysed cells of the big cell, with walls
                    region = _offset(win, emb.window, scan.shape)
                    key = tuple((r.start, r.stop) for r in region)
                    if key not in truths:
                        truth_emb = Embedding("truth", big, region, 1.0, False)
                        truths[key] = (pressure_curve(truth_emb, p),
                                       sealing_search(truth_emb, gbar=1.0))
                    truth, tth = truths[key]
                    with np.errstate(divide="ignore", invalid="ignore"):
                        dls = np.log(got["sigma"]) - np.log(truth["sigma"])
                    dls[~np.isfinite(dls)] = np.nan
                    row = {
                        "seed": seed, "window": w, "method": m, "seconds": seconds,
                        "pressures": p.tolist(),
                        "area": got["area_fraction"].tolist(),
                        "area_truth": truth["area_fraction"].tolist(),
                        "d_area": (got["area_fraction"] - truth["area_fraction"]).tolist(),
                        "star": [th[a].a_c_star for a in (0, 1)],
                        "star_truth": [tth[a].a_c_star for a in (0, 1)],
                        "d_star": [th[a].a_c_star - tth[a].a_c_star for a in (0, 1)],
                        "d_lnsigma": [None if np.isnan(v) else float(v) for v in dls.ravel()],
                    }
                    rows.append(row)
                    fh.write(json.dumps(row) + "\n")
                    fh.flush()
                    print(f"seed {seed} window {w} {m:8s} d_a {np.round(row['d_area'], 4)} "
                          f"d_a* {np.round(row['d_star'], 4)} "
                          f"d_lns {np.round(dls.ravel(), 3)} {seconds:.1f} s", flush=True)
    text = (f"Windows of side W cut from periodic cells of side 2W (L/lambda_r = {args.size:g} "
            f"of the big cell, eps_f = {args.eps_f:g}, {args.ppl:g} points per lambda_s, "
            f"H = 0.8, gamma = 1), {args.seeds} seeds x 2 windows; nominal pressures "
            f"{', '.join(f'{v:g}' for v in p)} E* gbar. Differences method - truth.\n\n"
            + summary(rows, list(p)))
    (OUT / f"nonperiodic{args.tag}.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
