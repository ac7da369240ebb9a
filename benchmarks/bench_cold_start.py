"""Hard-wall GFMD cold start: the law's bearing level against the flat touching the top.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_cold_start.py \
        [--sizes 512] [--seed 2] [--tols 1e-4 1e-6]

Surfaces: H 0.3 and 0.8; gamma 1 and 4; L/lambda_r 1 and 4 (gamma 4 only at 4, where the
stretched lambda_r fits the cell); 4 points per lambda_s; loads from the elastic law for
a_c 0.01, 0.03, 0.15, 0.4, 0.7 and 0.9. Each surface is solved cold twice by
``gfmd.gfmd``: from its default start (the flat at the height whose bearing area is the
law's a_c, docs/contact.md "Cold start") and from ``u0`` = the flat touching the highest
point (the start before it, reproduced exactly). Iterations are deterministic; the times
are single solves (plans warm), for orientation only. Writes
results/benchmarks/cold_start.{csv,md}.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

from roughflow.contact import gfmd as G
from roughflow.contact.law import ContactLaw
from roughflow.surface import SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT, write_csv  # noqa: E402

AREAS = (0.01, 0.03, 0.15, 0.4, 0.7, 0.9)
MAX_ITER = 2000


def cases(n: int, seed: int):
    """(hurst, gamma, L/lambda_r, surface) of the matrix at size ``n``."""
    for hurst, gamma, llr in itertools.product((0.3, 0.8), (1, 4), (1, 4)):
        if gamma == 4 and llr == 1:
            continue
        spec = SurfaceSpec.from_sweep(gamma=gamma, hurst=hurst, l_over_lambda_r=llr,
                                      eps_f=16 / n, points_per_lambda_s=4, seed=seed)
        yield hurst, gamma, llr, generate(spec)


def timed(heights: np.ndarray, load: float, tol: float, u0: np.ndarray | None):
    t0 = time.perf_counter()
    out = G.gfmd(heights, 1.0, 1.0, load, tol=tol, max_iter=MAX_ITER, u0=u0)
    return out, time.perf_counter() - t0


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[512])
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--tols", type=float, nargs="*", default=[1e-4, 1e-6])
    return ap


def main() -> None:
    args = build_parser().parse_args()
    law = ContactLaw("elastic")
    rows = []
    for n in args.sizes:
        for hurst, gamma, llr, surface in cases(n, args.seed):
            h = surface.heights
            top = np.full(h.shape, h.max())
            G.gfmd(h, 1.0, 1.0, 0.2, tol=1e-2, max_iter=MAX_ITER)  # plans and kernels
            for a, tol in itertools.product(AREAS, args.tols):
                load = law.control(a)
                lvl, t_lvl = timed(h, load, tol, None)
                old, t_old = timed(h, load, tol, top)
                row = dict(n=n, hurst=hurst, gamma=gamma, l_over_lambda_r=llr, a_law=a,
                           tol=tol, a_c=float(lvl.contact.mean()),
                           a_c_diff=abs(float(lvl.contact.mean()) - float(old.contact.mean())),
                           iterations_top=old.iterations, iterations_level=lvl.iterations,
                           s_top=round(t_old, 4), s_level=round(t_lvl, 4))
                rows.append(row)
                print(row, flush=True)
    write_csv("cold_start", rows)
    lines = ["| n | tol | solves | iterations, top start | iterations, law's level | change | "
             "solves with more iterations | largest a_c difference |",
             "|---|---|---|---|---|---|---|---|"]
    for n, tol in itertools.product(args.sizes, args.tols):
        sel = [r for r in rows if r["n"] == n and r["tol"] == tol]
        old = sum(r["iterations_top"] for r in sel)
        new = sum(r["iterations_level"] for r in sel)
        worse = sum(r["iterations_level"] > r["iterations_top"] for r in sel)
        diff = max(r["a_c_diff"] for r in sel)
        lines.append(f"| {n} | {tol:g} | {len(sel)} | {old} | {new} | {new / old - 1:+.1%} | "
                     f"{worse} | {diff:.1e} |")
    (OUT / "cold_start.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
