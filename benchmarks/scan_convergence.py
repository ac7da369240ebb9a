"""Wide-band measured scans: convergence of a_c, sigma and the sealing pressure with the grid
and the contact-solver tolerance (docs/measured.md, "Wide-band scans").

A measured scan's shortest wavelength is its pixel: the grid cannot be refined beyond the
data, only (a) coarsened (block averages: the shortest wavelengths are lost) or (b) refined
by interpolation (bicubic, scipy.ndimage.zoom: the same surface on a finer grid, which
measures the discretisation error of the contact and flow solves at the data's own
resolution). At each grid the leak curve is computed at fixed nominal pressures (in units
of E*) with the default boundary treatment, plus the sealing search; the tolerance study
repeats the native grid with contact tolerances 1e-4, 1e-6 (default) and 1e-8.

Usage:
  ROUGHFLOW_FFT_THREADS=1 python benchmarks/scan_convergence.py SCAN [--size ...]
      [--unit ...] [--pressures 0.015 0.04 0.08] [--coarsen 4 2] [--refine 2] [--no-sealing]
Writes results/benchmarks/scan_convergence.{jsonl,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow.errors import ConvergenceError  # noqa: E402
from roughflow.leak import leak_curve  # noqa: E402
from roughflow.scan import read_scan  # noqa: E402
from roughflow.surface import Surface, rms_gradient  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def regrid(s: Surface, factor: float) -> Surface:
    """Block average (factor < 1: 1/factor cells per block) or bicubic refinement."""
    if factor < 1:
        k = round(1 / factor)
        nx, ny = (n // k * k for n in s.shape)
        h = s.heights[:nx, :ny].reshape(nx // k, k, ny // k, k).mean(axis=(1, 3))
        lx, ly = s.lx * nx / s.shape[0], s.ly * ny / s.shape[1]
    else:
        h = ndimage.zoom(s.heights, factor, order=3, mode="nearest")
        lx, ly = s.lx, s.ly
    g = rms_gradient(h, lx, ly, periodic=False)
    scan = s.scan.__class__(**{**s.scan.as_attrs(), "rms_gradient": g})
    return Surface(heights=h, lx=lx, ly=ly, scan=scan)


def run(s: Surface, p: np.ndarray, label: str, contact_tol: float, sealing: bool) -> dict:
    t0 = time.perf_counter()
    try:
        c = leak_curve(s, p, contact_tol=contact_tol, sealing=sealing)
    except ConvergenceError as exc:
        return {"label": label, "error": str(exc), "residual": exc.residual}
    nan = float("nan")
    th = c.thresholds or {a: None for a in (0, 1)}
    return {"label": label, "shape": list(s.shape), "contact_tol": contact_tol,
            "rms_gradient": c.rms_gradient, "seconds": time.perf_counter() - t0,
            "area": c.area_fraction.tolist(), "sigma_x": c.sigma[:, 0].tolist(),
            "sigma_y": c.sigma[:, 1].tolist(), "iterations": c.iterations.tolist(),
            "a_c_star": [th[a].a_c_star if th[a] else nan for a in (0, 1)],
            "p_seal": [th[a].p_hi if th[a] else nan for a in (0, 1)]}


def table(rows: list[dict], p: np.ndarray) -> str:
    head = ("| grid | tol | gbar | " + " | ".join(f"a_c @ {v:g}" for v in p) + " | "
            + " | ".join(f"sigma_x @ {v:g}" for v in p) + " | a_c* x, y | p_seal x, y (E*) "
            "| GFMD steps | s |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['label']} | did not converge: {r['error']} |")
            continue
        lines.append(
            f"| {r['label']} {r['shape'][0]}x{r['shape'][1]} | {r['contact_tol']:g} | "
            f"{r['rms_gradient']:.3f} | " + " | ".join(f"{a:.4f}" for a in r["area"]) + " | "
            + " | ".join(f"{v:.3e}" for v in r["sigma_x"]) + " | "
            + f"{r['a_c_star'][0]:.4f}, {r['a_c_star'][1]:.4f} | "
            + f"{r['p_seal'][0]:.4g}, {r['p_seal'][1]:.4g} | "
            + f"{'/'.join(str(i) for i in r['iterations'])} | {r['seconds']:.0f} |")
    return "\n".join(lines) + "\n"


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scan")
    ap.add_argument("--size", default=None,
                    help="physical size where the file gives none (a .npy: required), "
                    "e.g. 500nm or 0.126mm,0.094mm")
    ap.add_argument("--unit", default=None,
                    help="length unit of sizes and heights where the file gives none "
                    "(a .npy: required), e.g. nm")
    ap.add_argument("--fill", default="none")
    ap.add_argument("--crop", default=None)
    ap.add_argument("--pressures", type=float, nargs="+", default=[0.015, 0.04, 0.08],
                    help="nominal pressures in units of E*")
    ap.add_argument("--coarsen", type=int, nargs="*", default=[4, 2])
    ap.add_argument("--refine", type=float, nargs="*", default=[2.0])
    ap.add_argument("--tols", type=float, nargs="*", default=[1e-4, 1e-8])
    ap.add_argument("--no-sealing", action="store_true", help="skip the sealing searches")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    native = read_scan(args.scan, size=args.size, unit=args.unit, fill=args.fill,
                       crop=args.crop)
    p = np.array(sorted(args.pressures))
    jobs = [(regrid(native, 1 / k), f"1/{k}", 1e-6) for k in args.coarsen]
    jobs += [(native, "native", 1e-6)]
    jobs += [(regrid(native, f), f"x{f:g}", 1e-6) for f in args.refine]
    jobs += [(native, "native", t) for t in args.tols]
    rows = []
    with (OUT / "scan_convergence.jsonl").open("w") as fh:
        for s, label, tol in jobs:
            r = run(s, p, label, tol, not args.no_sealing)
            rows.append(r)
            fh.write(json.dumps(r) + "\n")
            fh.flush()
            print(json.dumps(r), flush=True)
    text = (f"{Path(args.scan).name}: {native.shape[0]} x {native.shape[1]} points, "
            f"L = {native.scan.length_scale:.4g} m, rms gradient "
            f"{native.scan.rms_gradient:.3f}; nominal pressures in E*.\n\n" + table(rows, p))
    (OUT / "scan_convergence.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
