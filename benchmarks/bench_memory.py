"""Peak memory of every command and scene job against the grid size (calibrates
``roughflow.resources``).

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_memory.py [--sizes 128 256 512 1024]
        [--job-sizes 128 256 512] [--tasks surface contact ...]

Each measurement runs one ``roughflow`` command line in a fresh Python process
(``roughflow.cli.main`` called in the child) and reads the child's peak resident set size
from ``os.wait4`` (``ru_maxrss``: the high-water mark of its physical memory, what the
out-of-memory killer and a SLURM memory limit see). Inputs (surface and contact files)
are made beforehand by separate processes. ``imports`` is a process that imports every
module the commands use and runs a 64 x 64 case: the fixed cost every command pays.

All peaks are in MB = 1e6 bytes (ru_maxrss is in KiB; bench_cost_model.py uses MB too).
Writes results/benchmarks/memory.csv (peak RSS per command and size) and memory.md: per
command the peak at the largest size, the slope in bytes per grid point between the two
largest sizes, and the model of ``roughflow.resources`` there (the table of
docs/workflow.md "Memory").
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
LAMBDA_R = 0.25  # L / lambda_r = 4 for the explicit surfaces


def surface_args(n: int, out: str) -> list[str]:
    # lambda_s = 4 grid spacings: the default resolution of the sweep's surfaces
    return ["surface", "--nx", str(n), "--ny", str(n), "--lambda-r", str(LAMBDA_R),
            "--lambda-s", str(4.0 / n), "-o", out]


def sweep_args(n: int) -> list[str]:
    # L / lambda_r = 4, 4 points per lambda_s: n = 16 / eps_f points per side
    return ["--l-over-lambda-r", "4", "--eps-f", repr(16.0 / n), "--points-per-lambda-s", "4"]


def commands(task: str, n: int, d: str) -> list[str]:
    s, c, o = f"{d}/s.nc", f"{d}/c.nc", f"{d}/out.nc"
    table = {
        "surface": surface_args(n, o),
        "contact": ["contact", s, "--pressure", "0.1", "-o", o],
        "contact_cg": ["contact", s, "--pressure", "0.1", "--method", "cg", "-o", o],
        "bearing": ["contact", s, "--model", "bearing", "--area-fraction", "0.3", "-o", o],
        "threshold": ["threshold", s, "-o", o],
        # the paper's adhesive case (hard wall, gamma_s = 0.1 v_ela^full, rho = 0.8 lambda_s)
        "threshold_adhesive": ["threshold", s, "--model", "adhesive", "-o", o],
        "flow": ["flow", c, "-o", o],
        "theory_gap": ["theory", c, "-o", o],
        "theory_spec": ["theory", "--l-over-lambda-r", "4", "--eps-f", repr(16.0 / n),
                        "--points-per-lambda-s", "4", "-o", o],
        "scene_threshold": ["scene", "threshold", *sweep_args(n), "-o", o],
        "scene_ladder": ["scene", "ladder", *sweep_args(n), "--area-fractions", "0.1", "0.3",
                         "-o", o],
    }
    return table[task]


#: The task of roughflow.resources that models each command.
MODEL_TASK = {"surface": "surface", "contact": "contact", "contact_cg": "contact",
              "bearing": "bearing", "flow": "flow", "theory_gap": "theory",
              "theory_spec": "spectrum", "threshold": "threshold",
              "threshold_adhesive": "threshold_adhesive",
              "scene_threshold": "threshold", "scene_ladder": "ladder"}


def _mb(usage) -> float:
    """Peak RSS in MB (1e6 bytes): Linux reports ru_maxrss in KiB."""
    return usage.ru_maxrss * 1024 / 1e6


def run_child(argv: list[str]) -> tuple[int, float]:
    """(exit status, peak RSS in MB) of ``roughflow argv`` in a fresh process."""
    code = "import sys; from roughflow.cli import main; sys.exit(main(sys.argv[1:]))"
    proc = subprocess.Popen([sys.executable, "-c", code, *argv], stdout=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    return proc.returncode, _mb(usage)


def base_mb() -> float:
    code = ("import numpy, scipy, xarray, pyamg, matplotlib; "
            "from roughflow import contact, flow, search, theory, io, scenes; "
            "from roughflow.surface import SurfaceSpec, generate; "
            "s = generate(SurfaceSpec(nx=64, ny=64, lx=1, ly=1, hurst=0.8, gamma=1, "
            "lambda_r=0.25, lambda_s=1/16, seed=0)); r = contact.solve(s, 0.1); "
            "flow.solve(r.gap, 0)")
    proc = subprocess.Popen([sys.executable, "-c", code])
    _, _, usage = os.wait4(proc.pid, 0)
    return _mb(usage)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[256, 512, 1024])
    ap.add_argument("--job-sizes", type=int, nargs="*", default=[128, 256, 512])
    ap.add_argument("--tasks", nargs="+", default=[
        "surface", "contact", "contact_cg", "bearing", "flow", "theory_gap", "theory_spec",
        "threshold", "threshold_adhesive", "scene_threshold", "scene_ladder"])
    return ap


def main() -> None:
    args = build_parser().parse_args()
    heavy = {"threshold", "threshold_adhesive", "scene_threshold", "scene_ladder"}
    base = base_mb()
    print(f"base (imports + 64^2 case): {base:.0f} MB", flush=True)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for n in sorted(set(args.sizes) | set(args.job_sizes)):
            prepared = False
            for task in args.tasks:
                if n not in (args.job_sizes if task in heavy else args.sizes):
                    continue
                if not prepared:
                    for pre in (surface_args(n, f"{d}/s.nc"),
                                ["contact", f"{d}/s.nc", "--pressure", "0.1", "-o",
                                 f"{d}/c.nc"]):
                        rc, _ = run_child(pre)
                        assert rc == 0, pre
                    prepared = True
                argv = commands(task, n, d)
                rc, peak = run_child(argv)
                rows.append({"task": task, "n": n, "points": n * n, "rc": rc,
                             "peak_mb": round(peak, 1)})
                print(rows[-1] if rc == 0 else f"{rows[-1]}  FAILED", flush=True)
    if not rows:
        raise SystemExit(f"nothing measured: tasks {args.tasks} at --sizes {args.sizes} "
                         f"(commands) and --job-sizes {args.job_sizes} (thresholds, scenes: "
                         f"{sorted(heavy)})")
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "memory.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    (OUT / "memory.md").write_text(table(rows, base) + "\n")
    print(table(rows, base))


def table(rows: list[dict], base: float) -> str:
    """Markdown table: peak at the largest size, slope, model (peaks in MB = 1e6 bytes)."""
    try:
        from roughflow.resources import estimate_bytes
    except ImportError:  # a roughflow without the model: measure only
        estimate_bytes = None
    lines = [f"Base (imports + a 64^2 case): {base:.0f} MB", "",
             "| command | task | n | peak RSS at largest n (MB) | slope (B/point) | "
             "model at largest n (MB) | model / peak |", "|---|---|---|---|---|---|---|"]
    for task in dict.fromkeys(r["task"] for r in rows):
        rs = sorted((r for r in rows if r["task"] == task), key=lambda r: r["points"])
        b = rs[-1]
        peak = b["peak_mb"]
        slope = float("nan")
        if len(rs) > 1:
            a = rs[-2]
            slope = (b["peak_mb"] - a["peak_mb"]) * 1e6 / (b["points"] - a["points"])
        # a failed child's peak is that of a run that stopped early: say so beside the task
        failed = ", ".join(f"n={r['n']} rc={r['rc']}" for r in rs if r["rc"] != 0)
        label = f"{task} (FAILED: {failed})" if failed else task
        model = (estimate_bytes(MODEL_TASK[task], b["points"]) / 1e6 if estimate_bytes
                 else float("nan"))
        lines.append(f"| {label} | {MODEL_TASK[task]} | {', '.join(str(r['n']) for r in rs)} | "
                     f"{peak:.0f} | {slope:.0f} | {model:.0f} | {model / peak:.2f} |")
    return "\n".join(lines)


if __name__ == "__main__":
    main()
