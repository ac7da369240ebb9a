"""Why the FIRE step count of the hard-wall GFMD grows with n and bandwidth (issue 14).

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/gfmd_growth.py [--cases 512/4 1024/4 1024/1 2048/4]

Cases n/L_over_lambda_r: H = 0.8, 4 points per lambda_s (lambda_r/lambda_s = n / (4 L/lambda_r)),
seed 0, p = 0.2 (a_c about 0.4), tol 1e-6. Each candidate cause is switched off or measured
in isolation with an instrumented numpy copy of the FIRE loop of ``roughflow.contact.fire``
(same constants, masses, active set and residual; it reproduces the library's step counts):

- max-norm residual: max |G r| / rms |G r| along the run, and the steps to reach the
  tolerance in the rms norm instead;
- FIRE schedule: restarts (f.v < 0), the final dt, and the steps of a heavy ball with
  fixed step and momentum from the measured spectrum (2 / (sqrt(l_max) + sqrt(l_min)),
  ((sqrt(kappa) - 1) / (sqrt(kappa) + 1))^2, no restarts);
- active-set chatter: the last step at which the active set changes, and the steps with the
  final active set frozen from the start (a linear problem, no chatter possible);
- FFT round-off against the 1e-12 contact tolerance: steps with that tolerance 0 and 1e-9;
- q = 0 mass: steps with z = 1 and 10 (3 is the default);
- spectrum: largest and smallest eigenvalue of the preconditioned operator restricted to
  the free points of the solution, P M^-1 P K P (ARPACK), for z = 3 and 10.

The last column is the iteration count of the hard-wall CG that replaced FIRE. Writes
results/benchmarks/gfmd_growth.{csv,md}.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as sla

from roughflow import fft
from roughflow.contact import fire as F
from roughflow.contact import gfmd as G
from roughflow.contact.elastic import compliance, stiffness
from roughflow.surface import Surface, SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import write_table  # noqa: E402

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
LOAD = 0.2
TOL = 1e-6


def surface(n: int, l_over_lambda_r: float) -> Surface:
    return generate(SurfaceSpec.from_sweep(gamma=1, hurst=0.8, l_over_lambda_r=l_over_lambda_r,
                                           eps_f=4 * l_over_lambda_r / n,
                                           points_per_lambda_s=4, seed=0))


def fire_trace(h2: np.ndarray, *, z: float = G.Z_MASS, eps_rel: float = 1e-12,
               frozen: np.ndarray | None = None, heavy_ball: tuple[float, float] | None = None,
               stop: str = "max", max_iter: int = 1000) -> tuple[list[dict], np.ndarray]:
    """The FIRE loop of ``fire.fire`` (hard wall) in numpy, every quantity every step.

    ``frozen``: hold this active set (u = h on it) instead of the wall; ``heavy_ball``:
    (dt, momentum) instead of FIRE; ``stop``: "max" (the library's residual, checked every
    5 steps) or "rms" (rms |G r| instead of the maximum, every step).
    Returns the per-step records and the final active set.
    """
    shape, size = h2.shape, h2.size
    plan = fft.plan(shape, 1)
    k = stiffness(shape, 1.0, 1.0)
    kmin = float(k[k > 0].min())
    comp = compliance(shape, 1.0, 1.0)
    inv_m = 1.0 / np.hypot(z * kmin, k)
    h = (h2 - h2.mean()).ravel()
    hs = math.sqrt(float(np.mean(h * h)))
    load_scale = min(kmin * hs, LOAD)
    eps = eps_rel * hs
    u = np.full(size, h.max())
    if frozen is not None:
        u[frozen] = h[frozen]
    v = np.zeros(size)

    def inv(c: np.ndarray) -> np.ndarray:
        return plan.inverse(c).ravel().copy()

    def forces(u: np.ndarray):
        fi = inv(plan.forward(u.reshape(shape)) * -k) - LOAD
        active = ((u <= h + eps) & (fi < 0)) if frozen is None else frozen
        f = np.where(active, 0.0, fi)
        ft = plan.forward(f.reshape(shape)).copy()
        return f, inv(ft * inv_m), active, inv(ft * comp), abs(ft[0, 0].real) / size / load_scale

    dt, alpha, n_pos = F.DT0, F.ALPHA0, 0
    f, a, active, gf, imb = forces(u)
    prev = active.copy()
    hist = []
    it = 0
    while True:
        rmax = float(np.abs(gf).max()) / hs
        rrms = math.sqrt(float(np.mean(gf * gf))) / hs
        hist.append({"it": it, "res": max(rmax, imb), "rmax": rmax, "rrms": rrms, "dt": dt,
                     "flips": int((active ^ prev).sum()), "uphill": False})
        done = (max(rmax, imb) <= TOL and it % 5 == 0) if stop == "max" else max(rrms, imb) <= TOL
        if done or it >= max_iter:
            break
        it += 1
        prev = active
        a[active] = 0.0
        v[active] = 0.0
        fv = float(f @ v)
        if heavy_ball is not None:
            dt_hb, mom = heavy_ball
            v = mom * v + dt_hb * a
            u = u + dt_hb * v
        else:
            vv, va, aa = float(v @ v), float(v @ a), float(a @ a)
            if fv > 0 or vv == 0.0:
                keep = 1.0
                n_pos += 1
                if n_pos > F.N_MIN:
                    dt = min(dt * F.F_INC, F.DT_MAX)
                    alpha *= F.F_ALPHA
            else:
                keep, n_pos, alpha = 0.0, 0, F.ALPHA0
                dt *= F.F_DEC
                hist[-1]["uphill"] = True
            vnew = math.sqrt(max(keep * vv + 2 * keep * dt * va + dt * dt * aa, 0.0))
            mix = alpha * vnew / math.sqrt(aa) if aa > 0 else 0.0
            v = (1 - alpha) * keep * v + ((1 - alpha) * dt + mix) * a
            u = u + dt * v
        if frozen is None:
            below = u < h
            u[below] = h[below]
            v[below] = 0.0
        f, a, active, gf, imb = forces(u)
    return hist, active


def spectrum(shape: tuple[int, int], free: np.ndarray, z: float) -> tuple[float, float]:
    """Largest and smallest eigenvalue of P M^-1 P K P on the free points (ARPACK)."""
    plan = fft.plan(shape, 1)
    k = stiffness(shape, 1.0, 1.0)
    kmin = float(k[k > 0].min())
    inv_m = 1.0 / np.hypot(z * kmin, k)
    idx = np.flatnonzero(free.ravel())
    full = np.zeros(free.size)

    def op(x: np.ndarray) -> np.ndarray:
        full[:] = 0.0
        full[idx] = x.ravel()
        y = plan.inverse(plan.forward(full.reshape(shape)) * k).ravel()
        full[:] = 0.0
        full[idx] = y[idx]
        return plan.inverse(plan.forward(full.reshape(shape)) * inv_m).ravel()[idx].copy()

    n = idx.size
    a = sla.LinearOperator((n, n), matvec=op, dtype=float)
    lmax = float(np.real(sla.eigs(a, k=1, which="LM", tol=1e-3, return_eigenvectors=False)[0]))
    sig = 1.05 * lmax
    b = sla.LinearOperator((n, n), matvec=lambda x: sig * x - op(x), dtype=float)
    mu = float(np.real(sla.eigs(b, k=1, which="LR", tol=1e-3, return_eigenvectors=False)[0]))
    return lmax, sig - mu


def first(hist: list[dict], key: str) -> int:
    return next(r["it"] for r in hist if r[key] <= TOL)


def case(n: int, l_over_lambda_r: float) -> dict:
    s = surface(n, l_over_lambda_r)
    t0 = time.perf_counter()
    lib = G.gfmd(s.heights, s.lx, s.ly, LOAD, tol=TOL, max_iter=5000, minimizer="fire")
    hist, active = fire_trace(s.heights)
    rms, _ = fire_trace(s.heights, stop="rms")
    frozen, _ = fire_trace(s.heights, frozen=active)
    lmax3, lmin3 = spectrum(s.shape, ~active.reshape(s.shape), 3.0)
    lmax10, lmin10 = spectrum(s.shape, ~active.reshape(s.shape), 10.0)
    sk = math.sqrt(lmax3 / lmin3)
    hb = (2 / (math.sqrt(lmax3) + math.sqrt(lmin3)), ((sk - 1) / (sk + 1)) ** 2)
    heavy, _ = fire_trace(s.heights, heavy_ball=hb)
    cg = G.gfmd(s.heights, s.lx, s.ly, LOAD, tol=TOL, max_iter=5000)
    row = {
        "n": n, "L_over_lambda_r": l_over_lambda_r,
        "lambda_r_over_lambda_s": n / (4 * l_over_lambda_r),
        "fire_steps": lib.iterations, "traced_steps": hist[-1]["it"],
        "max_over_rms_median": float(np.median([r["rmax"] / r["rrms"] for r in hist[10:]])),
        "steps_rms_norm": first(rms, "rrms"),
        "restarts": sum(r["uphill"] for r in hist), "dt_final": hist[-1]["dt"],
        "last_active_change": max([r["it"] for r in hist if r["flips"]] + [0]),
        "steps_frozen_active_set": frozen[-1]["it"],
        "steps_eps_0": fire_trace(s.heights, eps_rel=0.0)[0][-1]["it"],
        "steps_eps_1e-9": fire_trace(s.heights, eps_rel=1e-9)[0][-1]["it"],
        "steps_z1": fire_trace(s.heights, z=1.0)[0][-1]["it"],
        "steps_z10": fire_trace(s.heights, z=10.0)[0][-1]["it"],
        "lmax_z3": lmax3, "lmin_z3": lmin3, "lmax_z10": lmax10, "lmin_z10": lmin10,
        "steps_heavy_ball": heavy[-1]["it"],
        "cg_iterations": cg.iterations,
        "seconds": time.perf_counter() - t0,
    }
    print(json.dumps(row), flush=True)
    return row


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", nargs="*", default=["512/4", "1024/4", "1024/1", "2048/4"],
                    help="n/L_over_lambda_r")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    rows = [case(int(c.split("/")[0]), float(c.split("/")[1])) for c in args.cases]
    write_table("gfmd_growth", rows)


if __name__ == "__main__":
    main()
