"""The RS set-up with our interpolation kernel against pyamg's, side by side.

Bearing-model gaps (as ``bench_flow.py``: an isotropic H = 0.8 surface, L / lambda_r = 4,
n / 64 points per lambda_s; the top fraction a_c of cells in contact), flow along x. For
each case, ``roughflow.flow.amg.rs_hierarchy`` is built ``--repeats`` times with each
interpolation kernel, alternated: ours (``amg._classical_weights``) and pyamg's
``rs_classical_interpolation_pass2``. Reported: median set-up time of each, the median time
of the weights' kernel alone on the finest level, the largest relative difference of the
two hierarchies' weights, and the levels.

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_rs_setup.py --sizes 512 1024

Writes results/benchmarks/bench_rs_setup{tag}.md.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from roughflow.flow import amg  # noqa: E402
from roughflow.flow.core import flowing_cells, reynolds_system  # noqa: E402
from roughflow.reynolds import cubic_law  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def pyamg_weights(ap, aj, ax, cp, cj, cx, splitting, pp):
    """pyamg's kernel in place of ours (same arguments and results)."""
    from pyamg import amg_core

    pj, px = np.empty(pp[-1], dtype=pp.dtype), np.empty(pp[-1], dtype=ax.dtype)
    amg_core.rs_classical_interpolation_pass2(splitting.size, ap, aj, ax, cp, cj, cx,
                                              splitting, pp, pj, px, True)
    return pj, px


class Timed:
    """A weights kernel that records the time of each call."""

    def __init__(self, kernel):
        self.kernel, self.times = kernel, []

    def __call__(self, *args):
        t0 = time.perf_counter()
        out = self.kernel(*args)
        self.times.append(time.perf_counter() - t0)
        return out


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024],
                    help="grid sizes n, each >= 128 (n / 64 points per lambda_s, at least 2)")
    ap.add_argument("--ac", type=float, nargs="+", default=[0.05, 0.2, 0.35])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    ours_kernel = amg._classical_weights
    h0 = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1)).heights
    s0 = cubic_law(np.maximum(np.quantile(h0, 0.8) - h0, 0.0))
    amg.rs_hierarchy(reynolds_system(s0, flowing_cells(s0, 0), 0, lx=1.0, ly=1.0).matrix)
    lines = ["| n | a_c | unknowns | levels | set-up, pyamg's weights [s] | set-up, ours [s] | "
             "ratio | finest weights, pyamg [ms] | ours [ms] | largest weight difference |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for n in args.sizes:
        h = generate(SurfaceSpec.from_sweep(points_per_lambda_s=n / 64, seed=0)).heights
        for a_c in args.ac:
            gap = np.maximum(np.quantile(h, 1.0 - a_c) - h, 0.0)
            s = cubic_law(gap)
            a = reynolds_system(s, flowing_cells(s, 0), 0, lx=1.0, ly=1.0).matrix
            timed = {"pyamg": Timed(pyamg_weights), "ours": Timed(ours_kernel)}
            total = {k: [] for k in timed}
            built = {}
            try:
                for _ in range(args.repeats):
                    for name, kernel in timed.items():
                        amg._classical_weights = kernel
                        first = len(kernel.times)
                        t0 = time.perf_counter()
                        built[name] = amg.rs_hierarchy(a)
                        total[name].append(time.perf_counter() - t0)
                        kernel.times[first + 1:] = []  # keep the finest level's call
            finally:
                amg._classical_weights = ours_kernel
            diff = 0.0
            for mine, theirs in zip(built["ours"].levels[:-1], built["pyamg"].levels[:-1],
                                    strict=True):
                p, q = mine.P.tocsr(), theirs.P.tocsr()
                p.sort_indices()
                q.sort_indices()
                diff = max(diff, float(np.max(np.abs(p.data - q.data) / np.abs(q.data))))
            tp, to = statistics.median(total["pyamg"]), statistics.median(total["ours"])
            kp = statistics.median(timed["pyamg"].times) * 1e3
            ko = statistics.median(timed["ours"].times) * 1e3
            row = (f"| {n} | {a_c} | {a.shape[0]} | {len(built['ours'].levels)} | {tp:.3f} | "
                   f"{to:.3f} | {to / tp:.2f} | {kp:.1f} | {ko:.1f} | {diff:.1e} |")
            print(row, flush=True)
            lines.append(row)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"bench_rs_setup{args.tag}.md").write_text(
        f"# RS set-up: our interpolation kernel against pyamg's (median of {args.repeats}, "
        "alternated)\n\n" + "\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
