"""Stress test of the elastic threshold search at tight tolerances: which searches close.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/stress_threshold.py \
        [--sizes 256] [--seeds 30] [--gammas 1 4] [--contact-tols 1e-4 3e-4 1e-3] \
        [--tols 2e-3 1e-3 5e-4 2.5e-4] [--tag NAME]

Surfaces: H 0.8, L/lambda_r 4, 4 points per lambda_s (256^2 at eps_f = 1/16), seeds
0 ... seeds-1. Every (size, gamma, contact tol, tol) runs ``search.threshold`` for both axes
on every seed and records whether the search closed or how it failed: ``stalled`` (a
bracket of full solves whose width is the contact solves' own area error: the error says to
tighten contact_tol), ``area_jump`` or ``out_of_solves`` (anything else). Solve and
iteration counts are deterministic; there is no timing. Writes
results/benchmarks/stress_threshold[_TAG].{csv,md}. docs/percolation.md (item 6 of the
search) quotes it.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

from roughflow.errors import ConvergenceError
from roughflow.search import SearchOptions, threshold
from roughflow.search.critical import AREA_JUMP, STALLED_ADVICE
from roughflow.surface import SurfaceSpec, generate

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT, write_csv  # noqa: E402

OUTCOMES = ("closed", "stalled", "area_jump", "out_of_solves")


def outcome(error: ConvergenceError | None) -> str:
    """One of :data:`OUTCOMES` for a search that raised ``error`` (None: it closed)."""
    if error is None:
        return "closed"
    text = str(error)
    if STALLED_ADVICE in text:
        return "stalled"
    return "area_jump" if text.startswith(AREA_JUMP) else "out_of_solves"


def run(n: int, gamma: float, contact_tol: float, tol: float, seeds: int) -> dict:
    """Outcome counts, solves and iterations (closed searches) of one case."""
    counts = dict.fromkeys(OUTCOMES, 0)
    solves = iterations = 0
    for seed in range(seeds):
        surface = generate(SurfaceSpec.from_sweep(
            gamma=gamma, hurst=0.8, l_over_lambda_r=4, eps_f=16 / n, points_per_lambda_s=4,
            seed=seed))
        try:
            res = threshold(surface, tol=tol, options=SearchOptions(contact_tol=contact_tol))
        except ConvergenceError as exc:
            counts[outcome(exc)] += 1
            continue
        counts["closed"] += 1
        solves += res[0].n_solves
        iterations += sum(s.iterations for s in res[0].solves)
    return {"n": n, "gamma": gamma, "contact_tol": contact_tol, "tol": tol, "seeds": seeds,
            **counts, "solves": solves, "iterations": iterations}


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[256])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--gammas", type=float, nargs="+", default=[1.0, 4.0])
    ap.add_argument("--contact-tols", type=float, nargs="+", default=[1e-4, 3e-4, 1e-3])
    ap.add_argument("--tols", type=float, nargs="+", default=[2e-3, 1e-3, 5e-4, 2.5e-4])
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    rows = []
    for n, gamma, ctol, tol in itertools.product(args.sizes, args.gammas, args.contact_tols,
                                                 args.tols):
        rows.append(run(n, gamma, ctol, tol, args.seeds))
        r = rows[-1]
        print(f"n={n} gamma={gamma:g} contact_tol={ctol:g} tol={tol:g}: "
              + ", ".join(f"{k} {r[k]}" for k in OUTCOMES), flush=True)
    stem = OUT / ("stress_threshold" + (f"_{args.tag}" if args.tag else ""))
    write_csv(stem.name, rows)
    lines = ["| n | gamma | contact tol | tol | closed | stalled (says so) | area jump | "
             "out of solves | solves per closed search | iterations per closed search |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        done = max(r["closed"], 1)
        lines.append(f"| {r['n']} | {r['gamma']:g} | {r['contact_tol']:g} | {r['tol']:g} | "
                     f"{r['closed']}/{r['seeds']} | {r['stalled']} | {r['area_jump']} | "
                     f"{r['out_of_solves']} | {r['solves'] / done:.2f} | "
                     f"{r['iterations'] / done:.1f} |")
    stem.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {stem}.csv and .md")


if __name__ == "__main__":
    main()
