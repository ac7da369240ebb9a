"""Hard-wall GFMD on a GPU (``backend="cupy"``) against the CPU, side by side in one run.

Usage (on a machine with CuPy and a CUDA GPU; ``benchmarks/gpu_on_device.sh`` runs it on
the project's device machine):
    python benchmarks/bench_gpu.py [--sizes 1024 2048 4096 8192 16384] [--repeats 3] \
        [--cpu-max-n 4096] [--cpu-threads 1 16] [--variants cuda twins] \
        [--threshold-sizes 512 1024 2048 4096] [--threshold-cpu-max-n 2048]

Surfaces: ``bench_scaling.surface(n, 4)`` (H 0.8, gamma 1, 4 points per lambda_s, L/lambda_r
4, seed 0); load 0.2 E* gbar (a_c about 0.4), tol 1e-6, as ``bench_scaling.py``. Per size:

- GPU, for each of ``--variants`` (``cuda``: the fused CUDA kernels, the default solve;
  ``twins``: the kernels' array-module twins, ``gfmd(..., use_numba=False)``): iterations
  and wall time of ``gfmd(..., backend="cupy")`` (median of ``--repeats`` solves after one
  untimed solve that creates the cuFFT plans and compiles the kernels; the time includes the
  copies to the GPU and of the result back, not the set-up ``hard_wall_setup`` (on the
  solve's backend), built once per surface and given to every solve, whose time is
  ``setup_s``; for
  n > ``--cpu-max-n`` with FFTW_ESTIMATE plans, which skip FFTW's minutes of timing at these
  sizes), time per iteration in
  units of a single-precision cuFFT pair, the peak of CuPy's memory pool; and the median
  time of a cuFFT pair (forward + inverse, float32 and float64) of the same size;
- CPU, for n <= ``--cpu-max-n``, at each of ``--cpu-threads`` FFT threads: the same solve
  (median of ``--repeats``, after an untimed one), and the largest |gap_gpu - gap_cpu| in
  units of the rms height and the contact areas of both.

``--threshold-sizes``: the two-axis threshold search (``search.threshold``, bisection tol
``--threshold-tol``, contact tol 1e-4 as in the workflow) on both backends (the CPU up to
``--threshold-cpu-max-n``, at each of ``--cpu-threads``): its wall time (median of
``--repeats``, after a cold solve that creates the plans), the same in cold-solve
equivalents (over the median of 3 cold solves at the search's first pressure and contact
tolerance, on the same backend), the time inside the minimizer and outside it (the search's
own work: spanning tests, warm starts, predictions, all on the CPU), the solves, and a_c*
per axis.

Writes results/benchmarks/bench_gpu.{csv,md} and bench_gpu_threshold.{csv,md}, a row at a
time, and prints each row as JSON.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from roughflow import fft, gpu
from roughflow.contact import gfmd as G
from roughflow.contact import solve
from roughflow.defaults import THRESHOLD_CONTACT_TOL
from roughflow.search import first_pressure, warm_up

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import write_table  # noqa: E402
from bench_scaling import LOAD, TOL, surface, threshold_cost  # noqa: E402


def _sync() -> None:
    gpu.cupy().cuda.Device().synchronize()


def cufft_pair_ms(n: int, single: bool, reps: int = 20) -> float:
    """Median time of a cuFFT forward + inverse of an n x n real array (ms)."""
    cp = gpu.cupy()
    plan = gpu.plan((n, n), single)
    plan.real_in[...] = cp.random.standard_normal((n, n))
    times = []
    for _ in range(reps + 2):
        _sync()
        t0 = time.perf_counter()
        plan.spectral_in[...] = plan.execute_forward()
        plan.execute_inverse()
        _sync()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times[2:])


def timed(s, setup, repeats: int, **kwargs):
    """(median wall time, last result) of ``repeats`` solves after an untimed one."""

    def run():
        out = G.gfmd(s.heights, s.lx, s.ly, LOAD, tol=TOL, max_iter=1000, setup=setup,
                     **kwargs)
        if not out.converged:
            raise RuntimeError(f"no convergence: residual {out.residual:.2e}")
        return out

    run()
    times, result = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def threshold_row(s, tol: float, repeats: int, **kwargs) -> dict:
    """The threshold pair's cost on one backend (module docstring): medians of
    ``bench_scaling.threshold_cost`` over ``repeats`` runs."""
    solve(s, first_pressure(), tol=THRESHOLD_CONTACT_TOL, **kwargs)  # plans, kernels
    runs = [threshold_cost(s, "cg", tol, **kwargs) for _ in range(repeats)]

    def median(key: str) -> float:
        return statistics.median(r[key] for r in runs)

    return {"cold_s": round(median("cold_s"), 4), "cold_iterations": runs[-1]["cold_iterations"],
            "pair_s": round(median("pair_s"), 4),
            "pair_cold_equivalents": round(median("pair_cold_equivalents"), 2),
            # the search's own work (percolation, warm starts, predictions: on the CPU)
            "solver_s": round(median("solver_s"), 4),
            "outside_solver_s": round(median("outside_solver_s"), 4),
            "solves": runs[-1]["solves"], "a_x": round(runs[-1]["a_x"], 6),
            "a_y": round(runs[-1]["a_y"], 6)}


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048, 4096, 8192, 16384])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cpu-max-n", type=int, default=4096)
    ap.add_argument("--cpu-threads", type=int, nargs="+", default=[1])
    ap.add_argument("--variants", nargs="+", choices=["cuda", "twins"], default=["cuda"])
    ap.add_argument("--threshold-sizes", type=int, nargs="*", default=[])
    ap.add_argument("--threshold-cpu-max-n", type=int, default=2048)
    ap.add_argument("--threshold-tol", type=float, default=2e-3)
    return ap


def main() -> None:
    args = build_parser().parse_args()
    cp = gpu.cupy()
    pool = cp.get_default_memory_pool()
    warm_up()
    rows: list[dict] = []
    effort = os.environ.get("ROUGHFLOW_FFTW_EFFORT", fft.DEFAULT_EFFORT)

    def emit(row: dict) -> None:
        rows.append(row)
        print(json.dumps(row), flush=True)
        write_table("bench_gpu", rows)

    for n in args.sizes:
        if n > args.cpu_max_n:  # no CPU solves at this size: plans without FFTW's timing
            os.environ["ROUGHFLOW_FFTW_EFFORT"] = "FFTW_ESTIMATE"
        s = surface(n, 4.0)
        hrms = float(s.heights.std())
        setups, setup_s = {}, {}
        for backend in ("cupy", "cpu"):  # the CPU's at this size also for the GPU rows' table
            t0 = time.perf_counter()
            setups[backend] = G.hard_wall_setup(s.heights, s.lx, s.ly, backend=backend)
            setup_s[backend] = round(time.perf_counter() - t0, 3)
        f32, f64 = cufft_pair_ms(n, True), cufft_pair_ms(n, False)
        g = None
        for variant in args.variants:
            pool.free_all_blocks()
            t_v, out = timed(s, setups["cupy"], args.repeats, backend="cupy",
                             use_numba=variant == "cuda")
            peak = pool.total_bytes() / 2**30
            ms_it = 1e3 * t_v / max(out.iterations, 1)
            if g is None:
                t_gpu, g = t_v, out
            emit({"n": n, "backend": f"cupy-{variant}", "threads": "",
                  "iterations": out.iterations, "time_s": round(t_v, 4),
                  "ms_per_iteration": round(ms_it, 3), "fft_pair_ms_f32": round(f32, 3),
                  "fft_pair_ms_f64": round(f64, 3),
                  "fft_pairs_per_iteration": round(ms_it / f32, 2),
                  "gpu_pool_gib": round(peak, 2),
                  "area_fraction": round(float(out.contact.mean()), 6),
                  "max_gap_diff_rel": f"{float(np.abs(out.gap - g.gap).max()) / hrms:.2e}",
                  "speedup_vs_cpu": "", "setup_s": setup_s["cupy"]})
            del out
        if n > args.cpu_max_n:
            continue
        for threads in args.cpu_threads:
            t_cpu, c = timed(s, setups["cpu"], args.repeats, threads=threads)
            diff = float(np.abs(g.gap - c.gap).max()) / hrms
            emit({"n": n, "backend": "cpu", "threads": threads, "iterations": c.iterations,
                  "time_s": round(t_cpu, 4),
                  "ms_per_iteration": round(1e3 * t_cpu / max(c.iterations, 1), 3),
                  "fft_pair_ms_f32": "", "fft_pair_ms_f64": "",
                  "fft_pairs_per_iteration": "", "gpu_pool_gib": "",
                  "area_fraction": round(float(c.contact.mean()), 6),
                  "max_gap_diff_rel": f"{diff:.2e}",
                  "speedup_vs_cpu": round(t_cpu / t_gpu, 1), "setup_s": setup_s["cpu"]})

    thr_rows: list[dict] = []
    for n in args.threshold_sizes:
        os.environ["ROUGHFLOW_FFTW_EFFORT"] = effort
        s = surface(n, 4.0)
        gpu_row = {"n": n, "backend": "cupy", "threads": "",
                   **threshold_row(s, args.threshold_tol, args.repeats, backend="cupy")}
        thr_rows.append(gpu_row)
        print(json.dumps(gpu_row), flush=True)
        write_table("bench_gpu_threshold", thr_rows)
        if n > args.threshold_cpu_max_n:
            continue
        for threads in args.cpu_threads:
            row = {"n": n, "backend": "cpu", "threads": threads,
                   **threshold_row(s, args.threshold_tol, args.repeats, threads=threads)}
            row["gpu_speedup"] = round(row["pair_s"] / gpu_row["pair_s"], 1)
            thr_rows.append(row)
            print(json.dumps(row), flush=True)
            write_table("bench_gpu_threshold", thr_rows)


if __name__ == "__main__":
    main()
