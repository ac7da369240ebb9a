"""Stress test of the Reynolds solver on whole contact ladders: which flow solves converge.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/stress_flow.py \
        [--l-over-lambda-r 4] [--eps-f 0.0625] [--models elastic bearing adhesive] \
        [--gammas 1 2] [--hursts 0.8 0.3] [--seeds 0 1 2 3] [--areas 0.01 ... 0.44] \
        [--no-reference] [--tag NAME]

Each case (model, gamma, H, seed) is a surface with 8 points per lambda_s and L/lambda_r
times max(sqrt(gamma), 1/sqrt(gamma)), as in the paper's cells (L/lambda_r 4 and eps_f
1/16: 512^2 at gamma 1, 512 x 1024 at gamma 2; 8 and 1/16: 1024^2), walked along an area
ladder exactly as the ladder scene does (:func:`roughflow.scenes.ladder.contact_ladder`).
At every state and axis where the fluid percolates, ``flow.solve`` runs with its default
method (``auto``: RS-AMG CG or the direct solver, ``roughflow.flow.linsolve.choose``) and,
unless ``--no-reference``, with the other of the two as the reference for sigma. A row records
the outcome (``converged``, converged after falling back to the direct solver, or the
ConvergenceError's residual), the method, CG iterations, residual, flux imbalance and what
round-off alone leaves of it (``FlowResult.imbalance_floor``), the time of each solve, sigma,
the upper bound on its error (``FlowResult.sigma_error``), its relative difference from the
reference, whether the two intervals [sigma (1 - error), sigma] overlap (each sigma is an
upper bound on the exact one, so they must), and the decades spanned by the flowing cells'
u^3. The gap of a failed solve is kept in ``results/benchmarks/stress_flow_gaps/`` to
reproduce it (``NAME.npy``, with the cell lengths lx, ly and the surface spec in
``NAME.json``: the grid alone does not give them, gamma != 1 cells have non-square pixels).
Rows are appended as they come (an interrupted run keeps its rows). Writes
results/benchmarks/stress_flow[_TAG].{csv,md}; docs/flow.md quotes it.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from roughflow import flow, percolation
from roughflow.errors import ConvergenceError
from roughflow.scenes.jobs import LadderJob, SurfaceParams
from roughflow.scenes.ladder import contact_ladder
from roughflow.surface import generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT  # noqa: E402

#: the paper's ladder and three steps past the elastic a_c* (about 0.42), where the flowing
#: clusters are thinnest
AREAS = (0.01, 0.03, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.33, 0.36, 0.38, 0.4, 0.42, 0.44)


def _solve(gap, ax, lx, ly, method):
    """(FlowResult or None, seconds, residual reached, error text)."""
    t0 = time.perf_counter()
    try:
        res = flow.solve(gap, ax, lx=lx, ly=ly, method=method)
    except ConvergenceError as exc:
        return None, time.perf_counter() - t0, exc.residual, str(exc)
    return res, time.perf_counter() - t0, res.residual, ""


#: the outcome of a solve that AMG did not converge and ``auto`` retried with the direct solver
FELL_BACK = "converged (fell back to direct)"


def _outcome(res) -> str:
    """``converged``, ``failed`` or :data:`FELL_BACK` (a direct solve that counts AMG
    iterations: those spent before the fallback)."""
    if res is None:
        return "failed"
    if res.method == "direct" and res.iterations > 0:
        return FELL_BACK
    return "converged"


def _decades(gap: np.ndarray, ax: int) -> float:
    """log10 of max/min u^3 over the cells that connect the reservoirs."""
    active = percolation.spanning_cells(gap > 0, ax)
    u3 = gap[active] ** 3
    u3 = u3[u3 > 0]
    return float(np.log10(u3.max() / u3.min())) if u3.size else math.nan


def run_case(size: float, eps_f: float, model: str, gamma: float, hurst: float, seed: int,
             areas, reference: bool, gaps_dir: Path, keep_above: float | None = None):
    """Yield one row per (state, axis) of one ladder; ``size`` is L/lambda_r of the isotropic
    surface, scaled by max(sqrt(gamma), 1/sqrt(gamma)) as in the paper's anisotropic cells.
    The gap of a failed solve is kept in ``gaps_dir``, and so is one whose flux imbalance (by
    either solver) exceeds ``keep_above``."""
    params = SurfaceParams(gamma=gamma, hurst=hurst, eps_f=eps_f, points_per_lambda_s=8,
                           l_over_lambda_r=size * max(math.sqrt(gamma), 1 / math.sqrt(gamma)))
    job = LadderJob(surface=params, model=model, seeds=(seed,), area_fractions=tuple(areas))
    surface = generate(params.spec(seed))
    lx, ly = surface.lx, surface.ly
    n = "x".join(str(k) for k in surface.shape)
    for target, c, _ in contact_ladder(surface, job, 1):
        open_mask = ~np.asarray(c.contact, dtype=bool)
        for ax in (0, 1):
            if not percolation.percolates(open_mask, ax):
                continue
            res, t, residual, error = _solve(c.gap, ax, lx, ly, None)
            row = {"n": n, "model": model, "gamma": gamma, "hurst": hurst, "seed": seed,
                   "target": target, "a_c": float(c.area_fraction), "axis": "xy"[ax],
                   "outcome": _outcome(res),
                   "method": res.method if res is not None else "-",
                   "iterations": res.iterations if res is not None else -1,
                   "residual": residual,
                   "imbalance": res.flux_imbalance if res is not None else math.nan,
                   "imbalance_floor": res.imbalance_floor if res is not None else math.nan,
                   "sigma_error": res.sigma_error if res is not None else math.nan,
                   "seconds": t, "sigma": res.sigma if res is not None else math.nan,
                   "flowing_fraction": res.n_active / c.gap.size if res is not None else math.nan,
                   "u3_decades": _decades(c.gap, ax)}
            if reference:
                other = "rs" if row["method"] == "direct" else "direct"
                ref, t_ref, _, ref_error = _solve(c.gap, ax, lx, ly, other)
                row["reference"] = other
                row["seconds_reference"] = t_ref
                row["sigma_reference"] = ref.sigma if ref is not None else math.nan
                row["imbalance_reference"] = ref.flux_imbalance if ref is not None else math.nan
                row["imbalance_floor_reference"] = (ref.imbalance_floor if ref is not None
                                                    else math.nan)
                row["iterations_reference"] = ref.iterations if ref is not None else -1
                row["sigma_error_reference"] = ref.sigma_error if ref is not None else math.nan
                row["sigma_rel_diff"] = (abs(row["sigma"] - ref.sigma) / ref.sigma
                                         if ref is not None and ref.sigma > 0 else math.nan)
                # each sigma is at least the exact one and at most (1 + its error) times it,
                # so the two [sigma (1 - error), sigma] must overlap (both errors are upper
                # bounds that allow for the round-off of the sums forming sigma)
                row["errors_agree"] = (float(
                    ref.sigma >= row["sigma"] * (1 - row["sigma_error"])
                    and row["sigma"] >= ref.sigma * (1 - ref.sigma_error))
                    if ref is not None and res is not None else math.nan)
                if ref_error:
                    row["outcome"] += f" ({other} failed)"
            imbalances = [row["imbalance"], row.get("imbalance_reference", math.nan)]
            if error or (keep_above is not None and max(imbalances) > keep_above):
                gaps_dir.mkdir(parents=True, exist_ok=True)
                name = f"{model}_g{gamma:g}_H{hurst:g}_s{seed}_{n}_a{target:g}_{'xy'[ax]}.npy"
                np.save(gaps_dir / name, c.gap)
                # the cell lengths, which flow_energy_error.py reads back
                (gaps_dir / name).with_suffix(".json").write_text(json.dumps(
                    {"lx": lx, "ly": ly, "spec": surface.spec.as_attrs()}))
                row["gap_file"] = name
            yield row


def _append(path: Path, row: dict, keys: list[str]) -> None:
    def fmt(v):
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    new = not path.exists()
    with path.open("a") as f:
        if new:
            f.write(",".join(keys) + "\n")
        f.write(",".join(fmt(row.get(k, "-")) for k in keys) + "\n")


KEYS = ["n", "model", "gamma", "hurst", "seed", "target", "a_c", "axis", "outcome", "method",
        "iterations", "residual", "imbalance", "seconds", "sigma", "flowing_fraction", "u3_decades",
        "reference", "seconds_reference", "sigma_reference", "sigma_rel_diff",
        "imbalance_reference", "iterations_reference", "gap_file", "imbalance_floor",
        "imbalance_floor_reference", "sigma_error", "sigma_error_reference", "errors_agree"]


def _largest(values) -> float:
    """The largest finite float among ``values`` (NaN if none)."""
    finite = [v for v in values if isinstance(v, float) and math.isfinite(v)]
    return max(finite) if finite else math.nan


def _ratio(row: dict, suffix: str) -> float:
    """A solve's flux imbalance over its round-off floor (NaN where not recorded)."""
    imbalance, floor = row.get("imbalance" + suffix), row.get("imbalance_floor" + suffix)
    if isinstance(imbalance, float) and isinstance(floor, float) and floor > 0:
        return imbalance / floor
    return math.nan


def summary(rows: list[dict]) -> str:
    """Markdown table: per (n, model, gamma, H) the solves, failures and worst cases."""
    lines = ["| grid | model | gamma | H | ladders | solves | failed | direct (chosen) "
             "| fell back to direct | CG iterations median / max (AMG solves) "
             "| largest sigma difference between RS and direct "
             "| largest flux imbalance, direct / RS "
             "| largest imbalance / round-off floor, direct / RS | largest u^3 span (decades) "
             "| largest sigma error, direct / RS's bound "
             "| pairs whose sigma intervals [sigma (1 - error), sigma] do not overlap |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    groups = {}
    for r in rows:
        groups.setdefault((r["n"], r["model"], r["gamma"], r["hurst"]), []).append(r)
    for (n, model, gamma, hurst), rs in groups.items():
        its = [r["iterations"] for r in rs
               if r["outcome"] == "converged" and r["method"] != "direct"]
        chosen = sum(r["outcome"] == "converged" and r["method"] == "direct" for r in rs)
        fell_back = sum(r["outcome"] == FELL_BACK for r in rs)
        diffs = [d for r in rs if isinstance(d := r.get("sigma_rel_diff"), float)
                 and math.isfinite(d)]
        failed = sum(not r["outcome"].startswith("converged") for r in rs)
        worst = {m: _largest([r["imbalance"] for r in rs if r["method"] == m]
                             + [r.get("imbalance_reference") for r in rs
                                if r.get("reference") == m]) for m in ("direct", "rs")}
        over_floor = {m: _largest([_ratio(r, "") for r in rs if r["method"] == m]
                                  + [_ratio(r, "_reference") for r in rs
                                     if r.get("reference") == m]) for m in ("direct", "rs")}
        error = {m: _largest([r.get("sigma_error") for r in rs if r["method"] == m]
                             + [r.get("sigma_error_reference") for r in rs
                                if r.get("reference") == m]) for m in ("direct", "rs")}
        disagree = sum(r.get("errors_agree") == 0.0 for r in rs)
        lines.append(
            f"| {n} | {model} | {gamma:g} | {hurst:g} | {len({r['seed'] for r in rs})} | "
            f"{len(rs)} | {failed} | {chosen} | {fell_back} | "
            f"{np.median(its) if its else math.nan:.0f} / "
            f"{max(its) if its else -1} | {max(diffs) if diffs else math.nan:.2g} | "
            f"{worst['direct']:.2g} / {worst['rs']:.2g} | "
            f"{over_floor['direct']:.2g} / {over_floor['rs']:.2g} | "
            f"{max(r['u3_decades'] for r in rs):.1f} | "
            f"{error['direct']:.2g} / {error['rs']:.2g} | {disagree} |")
    return "\n".join(lines) + "\n"


def read_rows(path: Path) -> list[dict]:
    """The rows of a csv written by this script (numbers parsed)."""
    lines = path.read_text().splitlines()
    keys = lines[0].split(",")

    def parse(k: str, v: str):
        if k in ("model", "axis", "outcome", "method", "reference", "gap_file", "n") or v == "-":
            return v
        return int(v) if k in ("seed", "iterations", "iterations_reference") else float(v)

    return [{k: parse(k, v) for k, v in zip(keys, line.split(","), strict=True)}
            for line in lines[1:]]


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--l-over-lambda-r", type=float, default=4.0)
    ap.add_argument("--eps-f", type=float, default=0.0625)
    ap.add_argument("--models", nargs="+", default=["elastic", "bearing", "adhesive"])
    ap.add_argument("--gammas", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--hursts", type=float, nargs="+", default=[0.8, 0.3])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--areas", type=float, nargs="+", default=list(AREAS))
    ap.add_argument("--no-reference", action="store_true", help="skip the reference solves")
    ap.add_argument("--tag", default="")
    ap.add_argument("--keep-above", type=float, metavar="IMBALANCE",
                    help="also keep the gaps whose flux imbalance exceeds this")
    ap.add_argument("--summarize", type=Path, nargs="+", metavar="CSV",
                    help="only write the summary table of these csv files (e.g. of runs that "
                         "were stopped) to stress_flow[_TAG].md")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    if args.summarize:
        md = OUT / ("stress_flow" + (f"_{args.tag}" if args.tag else "") + ".md")
        # runs that covered the same ladder count each of its solves once
        unique = {(r["n"], r["model"], r["gamma"], r["hurst"], r["seed"], r["target"],
                   r["axis"]): r for f in args.summarize for r in read_rows(f)}
        md.write_text(summary(list(unique.values())))
        print(f"wrote {md}")
        return
    stem = OUT / ("stress_flow" + (f"_{args.tag}" if args.tag else ""))
    csv = stem.with_suffix(".csv")
    csv.unlink(missing_ok=True)
    rows = []
    for model, gamma, hurst, seed in itertools.product(args.models, args.gammas, args.hursts,
                                                       args.seeds):
        t0 = time.perf_counter()
        for row in run_case(args.l_over_lambda_r, args.eps_f, model, gamma, hurst, seed,
                            args.areas, not args.no_reference, OUT / "stress_flow_gaps",
                            args.keep_above):
            rows.append(row)
            _append(csv, row, KEYS)
            if row["outcome"] != "converged":
                print(f"  {row['outcome']}: {row}", flush=True)
        print(f"{model} gamma={gamma:g} H={hurst:g} seed={seed}: {time.perf_counter() - t0:.0f} s",
              flush=True)
    stem.with_suffix(".md").write_text(summary(rows))
    print(f"wrote {csv} and .md")


if __name__ == "__main__":
    main()
