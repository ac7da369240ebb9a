"""Stress test of the flow solver on small random fields with deep pockets, against an exact
reference: is every sigma it returns within its error bound, and is every zero a true zero.

Usage:
    python benchmarks/stress_lump.py [--fields 300] [--seed 2026] [--tag NAME]

Each field is 6-16 cells a side: lognormal gaps (sd 0.5 in ln u), the same with a third of
the cells closed, or one or two straight channels of gap 1; then 1-3 rectangular pockets of
1 x 1 to 4 x 4 cells with gap 10^2 - 10^8 anywhere (the inlet and outlet rows included), and
in 3 of 10 fields one near-contact cell (gap 1e-4 - 1e-8); cells of aspect 0.1 - 1e3;
periodic or not; flow along x or y. The reference solves the same finite-volume system in
80-digit arithmetic with every open cell (tests/flow_reference.py). A row records the
outcome: "flows" (sigma within its bound of the reference), "zero" (sigma 0 and the reference
0), "zero by the floor" (sigma 0 where every path runs through a cell below the unresolved-gap
floor: the reference is below 1e-12 of the median open cell's u^3 / 12), "wrong zero",
"raised" (ConvergenceError) or "outside its bound". Writes
results/benchmarks/stress_lump[_TAG].md; docs/flow.md "Unresolved gaps" quotes it.
"""

from __future__ import annotations

import argparse
import collections
import logging
import sys
from pathlib import Path

import numpy as np

from roughflow import flow
from roughflow.errors import ConvergenceError

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
from flow_reference import reference_sigma  # noqa: E402


def random_field(rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """One field and its solve's arguments (axis, lx, ly, periodic)."""
    n0, n1 = (int(v) for v in rng.integers(6, 17, 2))
    kind = rng.integers(3)
    if kind == 0:
        g = np.exp(rng.normal(0, 0.5, (n0, n1)))
    elif kind == 1:
        g = np.exp(rng.normal(0, 0.5, (n0, n1))) * (rng.random((n0, n1)) > 0.35)
    else:
        g = np.zeros((n0, n1))
        g[:, rng.integers(n1)] = 1.0
        if rng.random() < 0.5:
            g[rng.integers(n0), :] = 1.0
    for _ in range(rng.integers(1, 4)):
        h, w = rng.integers(1, 5, 2)
        i, j = rng.integers(0, n0), rng.integers(0, n1)
        g[i:i + h, j:j + w] = 10 ** rng.uniform(2, 8)
    if rng.random() < 0.3:
        g[rng.integers(0, n0), rng.integers(0, n1)] = 10 ** -rng.uniform(4, 8)
    aspect = [1.0, 1.0, 0.1, 10.0, 1e3][rng.integers(5)]
    kw = {"axis": int(rng.integers(2)), "lx": 1.0, "ly": n1 / n0 / aspect,
          "periodic": bool(rng.random() < 0.7)}
    return g, kw


def outcome(g: np.ndarray, kw: dict) -> str:
    exact = reference_sigma(g, kw["axis"], lx=kw["lx"], ly=kw["ly"], periodic=kw["periodic"])
    try:
        r = flow.solve(g, kw["axis"], lx=kw["lx"], ly=kw["ly"], periodic=kw["periodic"])
    except ConvergenceError:
        return "raised"
    if r.sigma == 0:
        if exact == 0:
            return "zero"
        # the unresolved-gap floor closes cells whose u^3 is 1e-16 of the largest: where
        # every path runs through one, sigma is some 1e-15 of the open cells' or less
        typical = float(np.median(g[g > 0] ** 3 / 12.0))
        return "zero by the floor" if exact <= 1e-12 * typical else "wrong zero"
    # sigma_error bounds (sigma - exact) / sigma (sigma is an upper bound)
    if exact > 0 and abs(r.sigma - exact) <= max(r.sigma_error, 1e-14) * r.sigma:
        return "flows"
    return "outside its bound"


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fields", type=int, default=300)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    logging.disable(logging.CRITICAL)  # the fallback's notes, thousands of them
    rng = np.random.default_rng(args.seed)
    counts: collections.Counter[str] = collections.Counter()
    for _ in range(args.fields):
        counts[outcome(*random_field(rng))] += 1
    lines = ["| outcome | fields |", "|---|---|"]
    lines += [f"| {k} | {v} |" for k, v in sorted(counts.items())]
    out = ROOT / "results" / "benchmarks" / f"stress_lump{'_' + args.tag if args.tag else ''}.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(f"{args.fields} random fields, seed {args.seed}\n\n" + "\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
