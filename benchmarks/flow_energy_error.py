"""How far is an AMG-CG iterate's sigma from the exact one, and could CG itself tell?

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/flow_energy_error.py GAP.npy [--iterations 220]

``GAP.npy``: a gap kept by ``stress_flow.py --keep-above`` (its name ends in ``_x`` or ``_y``,
the flow axis). The system is assembled on the cell lx x ly that ``GAP.json`` beside it
records (stress_flow.py writes it); ``--lx``/``--ly`` override it, and without either the cell
is the unit square that stress_flow.py's surfaces have (``SurfaceSpec.from_sweep``: unit
area, aspect lx/ly = 1, so at gamma != 1 the pixels are gamma:1 rectangles, not squares).

sigma comes from the dissipation D(p), and D(p_k) - D(p*) = ||e_k||_A^2 is the energy error
of the CG iterate p_k (docs/flow.md "Flux check"). This script solves the state directly
for D(p*), then runs preconditioned CG with the RS V-cycle from zero and records, every
iteration, the relative residual, the true relative error of sigma (D(p_k) - D(p*)) / D(p*),
and the Hestenes-Stiefel estimate of that error from the next d iterations,
sum_{j=k}^{k+d-1} alpha_j r_j.z_j / D(p*) (exact in exact arithmetic as d grows, a lower
bound otherwise). Writes results/benchmarks/flow_energy_error_<gap name>.md.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from roughflow.flow.core import _dissipation, flowing_cells, reynolds_system
from roughflow.flow.linsolve import prepare
from roughflow.reynolds import cubic_law

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT  # noqa: E402

DELAYS = (5, 10, 20)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("gap", type=Path)
    ap.add_argument("--iterations", type=int, default=220)
    ap.add_argument("--lx", type=float, default=None,
                    help="cell length along x (default: GAP.json's, else 1)")
    ap.add_argument("--ly", type=float, default=None,
                    help="cell length along y (default: GAP.json's, else 1)")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    gap = np.load(args.gap)
    axis = 1 if args.gap.stem.endswith("_y") else 0
    # the cell's lengths set the faces' conductances: the grid's shape alone does not give
    # them (the sweep's gamma != 1 cells are unit squares with rectangular pixels)
    meta = args.gap.with_suffix(".json")
    cell = json.loads(meta.read_text()) if meta.exists() else {"lx": 1.0, "ly": 1.0}
    lx = args.lx if args.lx is not None else cell["lx"]
    ly = args.ly if args.ly is not None else cell["ly"]
    print(f"cell {lx:g} x {ly:g} on {gap.shape[0]} x {gap.shape[1]} points "
          f"({meta.name if meta.exists() else 'no ' + meta.name}"
          f"{', overridden' if args.lx is not None or args.ly is not None else ''})")
    s = cubic_law(gap)
    # the system flow.solve assembles
    system = reynolds_system(s, flowing_cells(s, axis), axis, lx=lx, ly=ly)
    faces, act, cells, a, b = (system.faces, system.active, system.cells, system.matrix,
                               system.rhs)

    def dissipation(x):
        q = np.zeros(act.shape)
        q.ravel()[cells] = x
        return _dissipation(faces, q)

    t0 = time.perf_counter()
    factor = prepare(a, "direct").factor
    exact = factor.solve(b)
    exact += factor.solve(b - a @ exact)
    d_star = dissipation(exact)
    del factor
    print(f"{args.gap.name}: {a.shape[0]} unknowns, D* = {d_star:.6e} "
          f"({time.perf_counter() - t0:.1f} s)", flush=True)

    m = prepare(a, "rs").preconditioner
    x = np.zeros(a.shape[0])
    r = b.copy()
    z = m.matvec(r)
    p = z.copy()
    rz = r @ z
    bnorm = np.linalg.norm(b)
    terms, errors, residuals = [], [], []
    for _ in range(args.iterations):
        errors.append((dissipation(x) - d_star) / d_star)
        residuals.append(np.linalg.norm(b - a @ x) / bnorm)
        ap_ = a @ p
        alpha = rz / (p @ ap_)
        x += alpha * p
        r -= alpha * ap_
        terms.append(alpha * rz / d_star)  # = ||e_k||_A^2 - ||e_k+1||_A^2, relative
        z = m.matvec(r)
        rz_new = r @ z
        p = z + (rz_new / rz) * p
        rz = rz_new
        if residuals[-1] < 1e-15:
            break

    head = ("| iteration | relative residual | true error of sigma | "
            + " | ".join(f"estimate, d = {d}" for d in DELAYS) + " |")
    lines = [f"{args.gap.name}: {a.shape[0]} unknowns, cell {lx:g} x {ly:g}", "", head,
             "|" + "---|" * (3 + len(DELAYS))]
    for k in range(0, len(errors), 5):
        est = [sum(terms[k:k + d]) if k + d <= len(terms) else math.nan for d in DELAYS]
        lines.append(f"| {k} | {residuals[k]:.2e} | {errors[k]:+.2e} | "
                     + " | ".join(f"{e:.2e}" for e in est) + " |")
    text = "\n".join(lines) + "\n"
    print(text)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"flow_energy_error_{args.gap.stem}.md").write_text(text)


if __name__ == "__main__":
    main()
