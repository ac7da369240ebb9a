"""FFTW's planner effort: FFTW_ESTIMATE against FFTW_MEASURE with the wisdom file.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_fft_effort.py \
        [--shapes 512x512 1024x1024 2048x2048 4096x4096 2048x16384] \
        [--sizes 1024 2048] [--seeds 4] [--reps 2]

Transforms (one fresh process per effort and shape): the time to make the float32 and the
float64 plan pair of ``roughflow.fft`` with no wisdom, the time to make them again in a new
process that reads the wisdom file (FFTW_MEASURE only), and the median time of an FFT pair in
each precision.

Solves (``--sizes``, the surfaces of bench_scaling.py's threshold rows, seeds 0 ...): per effort
in its own process, the two alternated ``--reps`` times, with plans made before the clock
starts: per seed the median of 3 cold solves at a_c about 0.4 (contact tol 1e-4) and one
threshold pair (tol 2e-3); the table gives the medians over seeds and runs, their ratios
MEASURE / ESTIMATE, and the largest change of a seed's a_c* (x or y) between the two.

Writes results/benchmarks/fft_effort_{transforms,solves}.{csv,md}.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import write_table  # noqa: E402
from bench_scaling import surface  # noqa: E402

EFFORTS = ("FFTW_ESTIMATE", "FFTW_MEASURE")


def transforms_worker(nx: int, ny: int) -> dict:
    from roughflow import fft

    t0 = time.perf_counter()
    plans = {"single": fft.plan((nx, ny), single=True), "double": fft.plan((nx, ny))}
    out = {"plan_s": time.perf_counter() - t0}
    for name, p in plans.items():
        p.real_in[...] = np.random.default_rng(0).random((nx, ny))
        times = []
        for _ in range(9):
            t0 = time.perf_counter()
            p.execute_forward()
            np.copyto(p.spectral_in, p.spectral_out)
            p.execute_inverse()
            times.append(time.perf_counter() - t0)
        out[f"{name}_pair_ms"] = 1e3 * statistics.median(times)
    return out


def solves_worker(n: int, seeds: int) -> dict:
    from roughflow import fft
    from roughflow.contact import solve
    from roughflow.search import threshold
    from roughflow.search.critical import first_pressure

    t0 = time.perf_counter()
    fft.plan((n, n))
    fft.plan((n, n), single=True)
    plan_s = time.perf_counter() - t0
    colds, pairs, a_c = [], [], []
    for seed in range(seeds):
        s = surface(n, 4.0, seed)
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            solve(s, first_pressure(), tol=1e-4)
            times.append(time.perf_counter() - t0)
        colds.append(statistics.median(times))
        t0 = time.perf_counter()
        res = threshold(s, tol=2e-3)
        pairs.append(time.perf_counter() - t0)
        a_c.append([res[0].a_c_star, res[1].a_c_star])
    return {"plan_s": plan_s, "cold_s": colds, "pair_s": pairs, "a_c": a_c}


def worker(effort: str, wisdom_dir: str, *args: str) -> dict:
    env = {**os.environ, "ROUGHFLOW_FFTW_EFFORT": effort, "ROUGHFLOW_FFTW_WISDOM": wisdom_dir}
    out = subprocess.run([sys.executable, __file__, "--worker", *args], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])


def transforms(shapes: list[str]) -> list[dict]:
    rows = []
    for shape in shapes:
        nx, ny = (int(v) for v in shape.split("x"))
        for effort in EFFORTS:
            with tempfile.TemporaryDirectory() as wisdom_dir:
                r = worker(effort, wisdom_dir, "transforms", str(nx), str(ny))
                row = {"shape": shape, "effort": effort, "plan_s": r["plan_s"]}
                if effort != "FFTW_ESTIMATE":
                    row["plan_from_file_s"] = worker(effort, wisdom_dir, "transforms", str(nx),
                                                     str(ny))["plan_s"]
                row.update(single_pair_ms=r["single_pair_ms"], double_pair_ms=r["double_pair_ms"])
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def solves(sizes: list[int], seeds: int, reps: int) -> list[dict]:
    rows = []
    for n in sizes:
        runs: dict[str, list[dict]] = {e: [] for e in EFFORTS}
        with tempfile.TemporaryDirectory() as wisdom_dir:
            for _ in range(reps):
                for effort in EFFORTS:  # alternated: the machine's drift hits both
                    runs[effort].append(worker(effort, wisdom_dir, "solves", str(n), str(seeds)))
        med = {e: {k: statistics.median(v for r in runs[e] for v in r[k])
                   for k in ("cold_s", "pair_s")} for e in EFFORTS}
        shift = max(abs(a - b) for r0, r1 in zip(runs[EFFORTS[0]], runs[EFFORTS[1]], strict=True)
                    for s0, s1 in zip(r0["a_c"], r1["a_c"], strict=True)
                    for a, b in zip(s0, s1, strict=True))
        for e in EFFORTS:
            row = {"n": n, "effort": e, "seeds": seeds, "runs": reps,
                   "first_plan_s": runs[e][0]["plan_s"], **med[e],
                   "cold_vs_estimate": med[e]["cold_s"] / med[EFFORTS[0]]["cold_s"],
                   "pair_vs_estimate": med[e]["pair_s"] / med[EFFORTS[0]]["pair_s"],
                   "max_a_c_change": shift if e != EFFORTS[0] else 0.0}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--shapes", nargs="*",
                    default=["512x512", "1024x1024", "2048x2048", "4096x4096", "2048x16384"])
    ap.add_argument("--sizes", type=int, nargs="*", default=[1024, 2048])
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--reps", type=int, default=2)
    return ap


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        kind, *args = sys.argv[2:]
        r = transforms_worker(*map(int, args)) if kind == "transforms" else \
            solves_worker(*map(int, args))
        print(json.dumps(r))
        return
    args = build_parser().parse_args()
    if args.shapes:
        write_table("fft_effort_transforms", transforms(args.shapes))
    if args.sizes:
        write_table("fft_effort_solves", solves(args.sizes, args.seeds, args.reps))


if __name__ == "__main__":
    main()
