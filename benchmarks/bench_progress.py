"""Cost of the progress logging in the contact solvers' loops (GFMD and CG step times).

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_progress.py [--n 512] [--repeats 7]
        [--before-src /path/to/other/checkout/src]

Each configuration runs in its own process: a 512^2 surface (H = 0.8, lambda_r/lambda_s
= 16), one warm-up solve, then ``--repeats`` cold solves at p = 0.1 per method, timing the
wall time per solver step (seconds / iterations). Configurations: this checkout with
logging at WARNING (the default: the DEBUG lines are skipped) and at DEBUG (a line every
SOLVER_LOG_EVERY steps, to a null stream), and, with ``--before-src``, another checkout
(e.g. ``git worktree add /tmp/before 478ed34``) at WARNING. The processes are interleaved
(A B C A B C ...) so that the load of the shared machine hits all alike; the table gives
medians and their ratios to the first configuration. Writes
results/benchmarks/progress.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"

CHILD = """
import io, json, logging, sys, time
level, n, repeats = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
logging.basicConfig(level=getattr(logging, level), stream=io.StringIO())
from roughflow import contact
from roughflow.surface import SurfaceSpec, generate
s = generate(SurfaceSpec(nx=n, ny=n, lx=1, ly=1, hurst=0.8, gamma=1, lambda_r=0.25,
                         lambda_s=1 / 64, seed=0))
out = {}
for method in ("gfmd", "cg"):
    contact.solve(s, 0.1, method=method)  # warm-up: FFT plans, numba compilation
    per = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        r = contact.solve(s, 0.1, method=method)
        per.append((time.perf_counter() - t0) / r.iterations)
    out[method] = per
print(json.dumps(out))
"""


def run(src: str | None, level: str, n: int, repeats: int) -> dict:
    env = dict(os.environ)
    if src:
        env["PYTHONPATH"] = src
    res = subprocess.run([sys.executable, "-c", CHILD, level, str(n), str(repeats)], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=512,
                    help="grid size, >= 128 (lambda_s = L/64 needs 2 points)")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds of processes")
    ap.add_argument("--before-src", default=None)
    return ap


def main() -> None:
    args = build_parser().parse_args()
    configs = [("this, WARNING", None, "WARNING"), ("this, DEBUG", None, "DEBUG")]
    if args.before_src:
        configs.insert(0, ("before, WARNING", args.before_src, "WARNING"))
    times: dict[str, dict[str, list[float]]] = {c[0]: {"gfmd": [], "cg": []} for c in configs}
    for _ in range(args.rounds):
        for name, src, level in configs:
            for method, per in run(src, level, args.n, args.repeats).items():
                times[name][method] += per
    ref = configs[0][0]
    lines = [f"{args.n}^2 grid, {args.rounds} x {args.repeats} solves per configuration "
             "(median of the seconds per step; ratio to the first row)", "",
             "| configuration | gfmd ms/step | ratio | cg ms/step | ratio |",
             "|---|---|---|---|---|"]
    for name, _, _ in configs:
        row = f"| {name} |"
        for method in ("gfmd", "cg"):
            med = statistics.median(times[name][method])
            row += f" {1e3 * med:.3f} | {med / statistics.median(times[ref][method]):.3f} |"
        lines.append(row)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "progress.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
