"""Full Reynolds conductance versus Bruggeman theory and the closed form (paper Fig. 4a).

Isotropic elastic contacts (H = 0.8, eps_f = 1/16): for each seed a pressure ladder
(warm-started contact solves), the Reynolds conductance sigma = (sigma_x + sigma_y)/2,
the full isotropic Bruggeman sigma_0 (Eq. 5-6) of the same gap field, the closed form
(Eq. 16, elastic) from its mean gap and contact area, and Persson theory's a_c(p),
mean gap(p) and sigma(p) from the spectrum alone. Writes a CSV, a markdown table and a
PNG under results/benchmarks/.

    ROUGHFLOW_FFT_THREADS=1 .venv/bin/python benchmarks/compare_theory.py \
        --l-over-lambda-r 8 --points-per-lambda-s 2 --seeds 0 1
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from pathlib import Path

import numpy as np

from roughflow import contact, flow
from roughflow.surface import SurfaceSpec, generate
from roughflow.theory import (
    bruggeman,
    closed_form,
    local_conductivity,
    persson_area,
    persson_mean_gap,
)

DEFAULT_PRESSURES = "0.02,0.04,0.06,0.08,0.1,0.12,0.14,0.16,0.18"


def sample_threshold(surface) -> float:
    """Mean of the x and y fluid-percolation thresholds of this sample
    (roughflow.search.threshold)."""
    from roughflow.search import threshold

    th = threshold(surface, axis=None, model="elastic", tol=2e-3)
    return 0.5 * (th[0].a_c_star + th[1].a_c_star)


def run_seed(spec: SurfaceSpec, pressures: np.ndarray, a_star: float) -> list[dict]:
    surface = generate(spec)
    t0 = time.perf_counter()
    a_sample = sample_threshold(surface)
    print(f"seed {spec.seed}: sample a_c* = {a_sample:.4f} ({time.perf_counter() - t0:.1f} s)",
          flush=True)
    rows, prev = [], None
    for p in pressures:
        t0 = time.perf_counter()
        res = contact.solve(surface, float(p), init=prev)
        t1 = time.perf_counter()
        prev = res
        sx, sy = flow.conductance(res.gap, lx=spec.lx, ly=spec.ly)
        t2 = time.perf_counter()
        sig = local_conductivity(res.gap, contact=res.contact)
        brug = bruggeman(sig, a_c_star=a_star)
        brug_s = bruggeman(sig, a_c_star=a_sample)
        a_c = float(res.contact.mean())
        ubar = float(res.gap.mean())
        rows.append({
            "seed": spec.seed, "pressure": float(p), "a_c": a_c, "mean_gap": ubar,
            "sigma_x": sx, "sigma_y": sy, "sigma_reynolds": 0.5 * (sx + sy),
            "sigma_bruggeman": brug.sigma,
            "sigma_closed": closed_form(ubar, a_c, a_c_star=a_star, kind="elastic"),
            "a_c_star_sample": a_sample, "sigma_bruggeman_sample": brug_s.sigma,
            "sigma_closed_sample": closed_form(ubar, a_c, a_c_star=a_sample, kind="elastic"),
            "t_contact_s": t1 - t0, "t_flow_s": t2 - t1,
        })
        print(f"seed {spec.seed} p={p:.3f} a_c={a_c:.4f} ubar={ubar:.3e} "
              f"sigma_R={rows[-1]['sigma_reynolds']:.3e} sigma_B={brug.sigma:.3e} "
              f"sigma_cf={rows[-1]['sigma_closed']:.3e} "
              f"({t1 - t0:.1f} s contact, {t2 - t1:.1f} s flow)", flush=True)
    return rows


def _dev(a: float, b: float) -> float:
    return a / b - 1.0 if b > 0 else math.nan


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--l-over-lambda-r", type=float, default=8.0)
    ap.add_argument("--points-per-lambda-s", type=float, default=2.0)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0])
    ap.add_argument("--pressures", default=DEFAULT_PRESSURES)
    ap.add_argument("--a-c-star", type=float, default=0.415)
    ap.add_argument("--out", default="results/benchmarks")
    ap.add_argument("--from-csv", default=None,
                    help="redo table and plot from a CSV of an earlier run (no simulations)")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    pressures = np.array([float(v) for v in args.pressures.split(",")])
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    if args.from_csv:
        with open(args.from_csv) as fh:
            rows = [{k: (int(v) if k == "seed" else float(v)) for k, v in r.items()}
                    for r in csv.DictReader(fh)]
        pressures = np.array(sorted({r["pressure"] for r in rows}))
        args.seeds = sorted({r["seed"] for r in rows})
    for seed in [] if args.from_csv else args.seeds:
        spec = SurfaceSpec.from_sweep(points_per_lambda_s=args.points_per_lambda_s,
                                      l_over_lambda_r=args.l_over_lambda_r, seed=seed)
        rows += run_seed(spec, pressures, args.a_c_star)
    spec0 = SurfaceSpec.from_sweep(points_per_lambda_s=args.points_per_lambda_s,
                                   l_over_lambda_r=args.l_over_lambda_r)
    a_p = persson_area(pressures)
    u_p = persson_mean_gap(pressures, spec0)
    for r in rows:
        i = int(np.argmin(abs(pressures - r["pressure"])))
        r["a_c_persson"] = float(a_p[i])
        r["mean_gap_persson"] = float(u_p[i])
        r["sigma_persson"] = closed_form(u_p[i], a_p[i], a_c_star=args.a_c_star)
        r["dev_bruggeman"] = _dev(r["sigma_bruggeman"], r["sigma_reynolds"])
        r["dev_closed"] = _dev(r["sigma_closed"], r["sigma_reynolds"])
        r["dev_bruggeman_sample"] = _dev(r["sigma_bruggeman_sample"], r["sigma_reynolds"])
        r["dev_closed_sample"] = _dev(r["sigma_closed_sample"], r["sigma_reynolds"])
    tag = f"L{args.l_over_lambda_r:g}_ppl{args.points_per_lambda_s:g}"
    with open(out / f"compare_theory_{tag}.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)

    # per-pressure means over seeds
    lines = [
        f"# Reynolds vs Bruggeman vs closed form (elastic, H = 0.8, L/lambda_r = "
        f"{args.l_over_lambda_r:g}, eps_f = 1/16, {spec0.nx}^2 grid, seeds {args.seeds}, "
        f"a_c* = {args.a_c_star})", "",
        "| p | a_c | mean gap | sigma_Reynolds | sigma_Bruggeman | sigma_closed | "
        "dev Brug. | dev closed | dev Brug. (sample a_c*) | dev closed (sample a_c*) | "
        "a_c Persson | gap Persson |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for p in pressures:
        sel = [r for r in rows if r["pressure"] == p]
        m = {k: float(np.mean([r[k] for r in sel])) for k in sel[0] if k != "seed"}
        lines.append(
            f"| {p:.3f} | {m['a_c']:.4f} | {m['mean_gap']:.3e} | {m['sigma_reynolds']:.3e} | "
            f"{m['sigma_bruggeman']:.3e} | {m['sigma_closed']:.3e} | "
            f"{100 * m['dev_bruggeman']:+.0f} % | {100 * m['dev_closed']:+.0f} % | "
            f"{100 * m['dev_bruggeman_sample']:+.0f} % | {100 * m['dev_closed_sample']:+.0f} % | "
            f"{m['a_c_persson']:.4f} | {m['mean_gap_persson']:.3e} |")
    t_c = float(np.median([r["t_contact_s"] for r in rows]))
    t_f = float(np.median([r["t_flow_s"] for r in rows]))
    a_s = sorted({r["a_c_star_sample"] for r in rows})
    lines += ["", "sample thresholds a_c* (mean of x and y, roughflow.search.threshold): "
              + ", ".join(f"{a:.4f}" for a in a_s)]
    lines += ["", f"median time per point: contact {t_c:.2f} s, flow (both axes) {t_f:.2f} s",
              "dev = sigma_theory/sigma_Reynolds - 1 (mean over seeds)"]
    (out / f"compare_theory_{tag}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4))
    ref = max(r["sigma_reynolds"] for r in rows)
    ac = np.array([r["a_c"] for r in rows])
    for key, style, label in (("sigma_reynolds", "o", "full Reynolds"),
                              ("sigma_bruggeman", "s", "full Bruggeman (Eq. 5)"),
                              ("sigma_closed", "^", "closed form (Eq. 16)")):
        y = np.array([r[key] for r in rows]) / ref
        ax.semilogy(ac[y > 0], y[y > 0], style, mfc="none", label=label)
    yp = np.array([r["sigma_persson"] for r in rows]) / ref
    ap_ = np.array([r["a_c_persson"] for r in rows])
    ax.semilogy(ap_[yp > 0], yp[yp > 0], "k:", label="Persson a_c, gap + Eq. 16")
    ax.axvline(args.a_c_star, color="gray", lw=0.8)
    ax.set_xlabel("relative contact area a_c")
    ax.set_ylabel("sigma / max sigma_Reynolds")
    ax.legend(fontsize=8)
    for key, style, label in (("sigma_bruggeman", "s", f"Bruggeman, a_c* = {args.a_c_star}"),
                              ("sigma_closed", "^", f"closed form, a_c* = {args.a_c_star}"),
                              ("sigma_bruggeman_sample", "s", "Bruggeman, sample a_c*"),
                              ("sigma_closed_sample", "^", "closed form, sample a_c*")):
        ratio = np.array([r[key] / r["sigma_reynolds"] for r in rows])
        bx.semilogy(ac, ratio, style, mfc=None if "sample" in key else "none", label=label,
                    alpha=0.7)
    for level in (0.8, 1.0, 1.2):
        bx.axhline(level, color="gray", lw=0.8, ls="-" if level == 1 else "--")
    bx.set_xlabel("relative contact area a_c")
    bx.set_ylabel("sigma_theory / sigma_Reynolds")
    bx.set_ylim(1e-2, 3)
    bx.legend(fontsize=8)
    fig.suptitle(f"isotropic elastic contact, H = 0.8, L/lambda_r = {args.l_over_lambda_r:g}")
    fig.tight_layout()
    fig.savefig(out / f"compare_theory_{tag}.png", dpi=120)


if __name__ == "__main__":
    main()
