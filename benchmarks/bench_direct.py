"""Where the direct flow solver's time goes, and how it compares with RS-AMG now that the
sweeps' AMG solves stop at a proven sigma accuracy (``sigma_tol``).

For each size n, a surface (H = ``--hurst``, Peklenik number ``--gamma``, eps_f = 1/16,
8 points per lambda_s, L/lambda_r = n/128 times max(sqrt(gamma), 1/sqrt(gamma)) as in the
paper's cells: n x n at gamma 1, 2048 x 4096 for n = 2048 at gamma 2) is brought by
warm-started elastic contact solves (tol 1e-6, the ladder's) to pressures that give a_c of
about 0.15 - 0.4; the bearing model is cut at each elastic state's area, so both models are
compared at the same areas. Every state and axis is solved by ``method="direct"`` and
``method="rs"``, both with ``sigma_tol`` = ``FLOW_SIGMA_TOL`` as the ladders and ``leak``
run them, ``--repeats`` times, alternated; a row gives the flowing fraction (the unknowns'
share of the cells, which ``auto`` decides by), the method ``auto`` takes with its default
limit, the median times and their ratio, and RS's CG iterations. The states of one model
and axis form a ladder (increasing load), and the direct solve is also timed with the
previous state's elimination order (``flow.solve(ordering=)``, chained as the ladders chain
it: each state reuses the order the one before it used), with its flops over those of a
fresh order. For axis x it also splits the fresh factorisation into the approximate minimum
degree ordering (``ldl.amd_order``) and the rest (permutation, symbolic and numeric
factorisation: ``ldl.factor`` in that order), with the factor's nonzeros.

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_direct.py --sizes 512 1024
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_direct.py --sizes 2048 --gamma 2 \
        --models bearing --pressures 0.113 0.163 0.181 --repeats 1 --tag _g2

Writes results/benchmarks/bench_direct{tag}.{csv,md}; docs/flow.md "Direct solver" quotes it.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow import contact, flow  # noqa: E402
from roughflow.defaults import FLOW_SIGMA_TOL  # noqa: E402
from roughflow.flow import ldl  # noqa: E402
from roughflow.flow.core import flowing_cells, reynolds_system  # noqa: E402
from roughflow.flow.linsolve import choose  # noqa: E402
from roughflow.reynolds import cubic_law  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT, write_csv  # noqa: E402

#: pressures (E* gbar) that give a_c of about 0.15, 0.19, 0.24, 0.28, 0.33, 0.36 on these
#: surfaces (H = 0.8; flowing fractions about 0.85 - 0.6)
PRESSURES = (0.068, 0.09, 0.113, 0.136, 0.163, 0.181)
#: the direct solve ordered afresh, with the previous state's order, and RS
VARIANTS = ("direct", "reused", "rs")
SPLIT_KEYS = ("factor_s", "numeric_s", "ordering_s", "nnz_l")


def factorisation_split(gap, lx: float, ly: float) -> dict:
    """The fresh LDL^T of the x-axis system of ``gap``: the whole factorisation, the part
    after the ordering, the ordering, the factor's nonzeros."""
    sigma_local = cubic_law(gap)
    matrix = reynolds_system(sigma_local, flowing_cells(sigma_local, 0), 0, lx=lx,
                             ly=ly).matrix
    t0 = time.perf_counter()
    order = ldl.amd_order(matrix)
    t1 = time.perf_counter()
    factor = ldl.factor(matrix, order)
    t2 = time.perf_counter()
    return dict(zip(SPLIT_KEYS, (t2 - t0, t2 - t1, t1 - t0, factor.nnz), strict=True))


def compare(gap, axis: int, lx: float, ly: float, repeats: int,
            previous: flow.CellOrdering | None) -> dict | None:
    """Both solvers on ``gap``, the direct one also with ``previous`` (the last state's order
    along ``axis``; None: none yet, so no reused time)."""
    times = {v: [] for v in VARIANTS}
    out = {}
    for _ in range(repeats):
        for v in VARIANTS:
            if v == "reused" and previous is None:
                continue
            t0 = time.perf_counter()
            out[v] = flow.solve(gap, axis, lx=lx, ly=ly, sigma_tol=FLOW_SIGMA_TOL,
                                method="rs" if v == "rs" else "direct",
                                ordering=previous if v == "reused" else None)
            times[v].append(time.perf_counter() - t0)
    rs, direct = out["rs"], out["direct"]
    if not rs.percolating:
        return None
    fraction = rs.n_active / gap.size
    td, tr = statistics.median(times["direct"]), statistics.median(times["rs"])
    reused = out.get("reused", direct)
    tu = statistics.median(times["reused"]) if times["reused"] else float("nan")
    return dict(unknowns=rs.n_active, flowing_fraction=fraction,
                auto=choose("auto", rs.n_active, fraction), direct_s=td, rs_s=tr,
                direct_over_rs=td / tr, reused_s=tu, reused_over_rs=tu / tr,
                reused_over_direct=tu / td,
                flops_ratio=reused.ordering.flops / direct.ordering.flops,
                rs_iterations=rs.iterations,
                sigma_distance=abs(rs.sigma - direct.sigma) / direct.sigma,
                reused_sigma_distance=abs(reused.sigma - direct.sigma) / direct.sigma,
                ordering=reused.ordering)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024],
                    help="grid sizes n, each >= 128 (L/lambda_r = n/128 must be >= 1)")
    ap.add_argument("--pressures", type=float, nargs="+", default=list(PRESSURES))
    ap.add_argument("--models", nargs="+", default=["elastic", "bearing"],
                    choices=("elastic", "bearing"))
    ap.add_argument("--hurst", type=float, default=0.8)
    ap.add_argument("--gamma", type=float, default=1.0)
    ap.add_argument("--seed", type=int, default=9)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    logging.disable(logging.WARNING)
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    stretch = max(math.sqrt(args.gamma), 1 / math.sqrt(args.gamma))
    for n in args.sizes:
        spec = SurfaceSpec.from_sweep(hurst=args.hurst, gamma=args.gamma, eps_f=1 / 16,
                                      points_per_lambda_s=8, seed=args.seed,
                                      l_over_lambda_r=n / 128 * stretch)
        s = generate(spec)
        grid = "x".join(map(str, s.shape))
        state = None
        previous: dict[tuple[str, int], flow.CellOrdering | None] = {}
        for p in args.pressures:
            state = contact.solve(s, p, tol=1e-6, init=state)
            gaps = {"elastic": state.gap}
            if "bearing" in args.models:
                gaps["bearing"] = contact.solve(s, model="bearing",
                                                area_fraction=state.area_fraction).gap
            for model in args.models:
                for axis in (0, 1):
                    res = compare(gaps[model], axis, s.lx, s.ly, args.repeats,
                                  previous.get((model, axis)))
                    if res is None:  # not percolating: no system to solve or factorise
                        continue
                    previous[(model, axis)] = res.pop("ordering")
                    row = dict(grid=grid, gamma=args.gamma, model=model,
                               a_c=round(state.area_fraction, 4), axis="xy"[axis], **res,
                               repeats=args.repeats)
                    split = (factorisation_split(gaps[model], s.lx, s.ly) if axis == 0
                             else dict.fromkeys(SPLIT_KEYS, ""))
                    row.update(split)
                    rows.append(row)
                    print(row, flush=True)
                    write_csv(f"bench_direct{args.tag}", rows)  # kept if interrupted
    write_markdown(rows, OUT / f"bench_direct{args.tag}.md", args)


def write_markdown(rows: list[dict], path: Path, args) -> None:
    lines = [f"# Direct (QDLDL) against RS-AMG, both to sigma_tol = {FLOW_SIGMA_TOL:g} (H = "
             f"{args.hurst}, seed {args.seed}, median of {args.repeats}, alternated)", "",
             "reused: the direct solve with the previous state's elimination order (chained); "
             "flops: its factorisation's over a fresh order's.", "",
             "| grid | gamma | model | a_c | axis | flowing fraction | auto | direct [s] | "
             "reused [s] | RS [s] | direct / RS | reused / RS | reused / direct | flops | "
             "RS iterations | AMD ordering [s] | the rest [s] | nnz(L) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        split = (f"{r['ordering_s']:.2f} | {r['numeric_s']:.2f} | {r['nnz_l']:.2e}"
                 if r["ordering_s"] != "" else " | | ")
        lines.append(
            f"| {r['grid']} | {r['gamma']:g} | {r['model']} | {r['a_c']:.3f} | {r['axis']} | "
            f"{r['flowing_fraction']:.3f} | {r['auto']} | {r['direct_s']:.2f} | "
            f"{r['reused_s']:.2f} | {r['rs_s']:.2f} | {r['direct_over_rs']:.2f} | "
            f"{r['reused_over_rs']:.2f} | {r['reused_over_direct']:.2f} | "
            f"{r['flops_ratio']:.2f} | {r['rs_iterations']} | {split} |")
    path.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
