"""Contact solvers: wall time against error for gfmd, cg and Tamaas, warm starts, memory.

Usage:
    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_contact.py \
        [--sizes 256 512 1024] [--repeats 3] [--big 2048] [--ladder-n 512]

Surfaces: H = 0.8, L/lambda_r = 4, lambda_r/lambda_s = 16, n x n, seed 0; loads 0.045 and
0.2 E* gbar (a_c about 0.1 and 0.4). For each method and tolerance the median wall time
of ``--repeats`` runs (FFT plans warmed up first), the iterations and the errors of a_c
and mean gap against a reference (gfmd, tol 1e-10) are written to
results/benchmarks/contact_time_error.{csv,md}; ``--big`` sizes run once per method at the
tightest tolerance only (a_c about 0.4). The warm-start ladder (10 loads 0.1 ... 0.2)
goes to contact_ladder.{csv,md}, peak memory (RSS of a fresh process, and tracemalloc for
our solvers) to contact_memory.{csv,md}, and the plot to contact_time_error.png.
Tamaas (PolonskyKeerRey, serial C++) runs in the same process; its tolerance is its own
error measure, its iterations are parsed from its log.
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import tracemalloc
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np

from roughflow import fft
from roughflow.contact import solve
from roughflow.surface import Surface, SurfaceSpec, generate

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"
LOADS = {"0.1": 0.045, "0.4": 0.2}
OUR_TOLS = (1e-4, 1e-6, 1e-8)
TAMAAS_TOLS = (1e-4, 1e-6, 1e-8)
REF_TOL = 1e-10


def surface(n: int) -> Surface:
    return generate(SurfaceSpec(nx=n, ny=n, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0,
                                lambda_r=0.25, lambda_s=1 / 64, seed=0))


@contextmanager
def captured_fd1():
    """Capture what Tamaas logs (file descriptors 1 and 2 and Python's streams)."""
    sys.stdout.flush()
    sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    buf = io.StringIO()
    py = io.StringIO()
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            with redirect_stdout(py), redirect_stderr(py):
                yield buf
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            os.close(saved[0])
            os.close(saved[1])
            tmp.seek(0)
            buf.write(tmp.read().decode(errors="replace"))
            buf.write(py.getvalue())


def run_tamaas(s: Surface, pressure: float, tol: float) -> dict:
    import tamaas as tm

    nx, ny = s.shape
    t0 = time.perf_counter()
    with captured_fd1() as log:
        model = tm.ModelFactory.createModel(tm.model_type.basic_2d, [s.lx, s.ly], [nx, ny])
        model.E, model.nu = 1.0, 0.0
        solver = tm.PolonskyKeerRey(model, np.array(s.heights), tol)  # writable
        solver.max_iter = 100000
        solver.solve(pressure)
    wall = time.perf_counter() - t0
    lines = [ln.split() for ln in log.getvalue().splitlines() if ln.strip()]
    iters = [int(p[0]) for p in lines if p and p[0].isdigit()]
    traction = np.array(model.traction).reshape(nx, ny)
    gap = np.array(model["gap"]).reshape(nx, ny)
    return {"wall": wall, "iterations": iters[-1] if iters else -1,
            "contact": traction > 0, "mean_gap": float(np.maximum(gap, 0).mean())}


def run_ours(s: Surface, pressure: float, method: str, tol: float, init=None) -> dict:
    t0 = time.perf_counter()
    r = solve(s, pressure, method=method, tol=tol, init=init, max_iter=100000)
    wall = time.perf_counter() - t0
    return {"wall": wall, "iterations": r.iterations, "contact": r.contact,
            "mean_gap": r.mean_gap, "result": r}


def time_error(sizes: list[int], repeats: int, big: list[int]) -> list[dict]:
    rows = []
    for n in sizes + big:
        s = surface(n)
        loads = LOADS if n not in big else {"0.4": LOADS["0.4"]}
        reps = repeats if n not in big else 1
        for label, p in loads.items():
            ref = solve(s, p, method="gfmd", tol=REF_TOL, max_iter=100000)  # also warms plans
            cases = [("gfmd", t) for t in OUR_TOLS] + [("cg", t) for t in OUR_TOLS]
            cases += [("tamaas", t) for t in TAMAAS_TOLS]
            if n in big:  # cg costs about as much as Tamaas here (same algorithm)
                cases = [("gfmd", 1e-6), ("gfmd", 1e-8), ("tamaas", 1e-8)]
            for method, tol in cases:
                runs = []
                for _ in range(reps):
                    if method == "tamaas":
                        runs.append(run_tamaas(s, p, tol))
                    else:
                        runs.append(run_ours(s, p, method, tol))
                last = runs[-1]
                a = float(last["contact"].mean())
                row = {
                    "n": n, "a_c_target": label, "pressure": p, "method": method, "tol": tol,
                    "repeats": reps,
                    "median_s": statistics.median(r["wall"] for r in runs),
                    "iterations": last["iterations"],
                    "a_c": a,
                    "err_a_c": abs(a / ref.area_fraction - 1),
                    "err_mean_gap": abs(last["mean_gap"] / ref.mean_gap - 1),
                    "pixels_differing": int((last["contact"] != ref.contact).sum()),
                }
                rows.append(row)
                print(json.dumps(row), flush=True)
    return rows


def ladder(n: int, repeats: int) -> list[dict]:
    s = surface(n)
    loads = np.linspace(0.1, 0.2, 10)
    rows = []
    solve(s, 0.1)
    for method in ("gfmd", "cg"):
        for mode in ("cold", "warm"):
            walls, iters = [], 0
            for _ in range(repeats):
                prev, it, t0 = None, 0, time.perf_counter()
                for p in loads:
                    r = solve(s, float(p), method=method, init=prev if mode == "warm" else None)
                    prev, it = r, it + r.iterations
                walls.append(time.perf_counter() - t0)
                iters = it
            row = {"n": n, "method": method, "start": mode, "solves": len(loads),
                   "iterations": iters, "median_s": statistics.median(walls)}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


_RSS_SCRIPT = """
import resource, numpy as np
h = np.load({path!r})
n = h.shape[0]
method = {method!r}
if method == "tamaas":
    import tamaas as tm
    tm.set_log_level(tm.LogLevel.error)
else:
    from roughflow.contact import solve
    from roughflow.contact._kernels import warm_up
    from roughflow.surface import Surface
    warm_up()
    s = Surface(heights=h, lx=1.0, ly=1.0)
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
if method == "tamaas":
    m = tm.ModelFactory.createModel(tm.model_type.basic_2d, [1.0, 1.0], [n, n])
    m.E, m.nu = 1.0, 0.0
    sol = tm.PolonskyKeerRey(m, np.ascontiguousarray(h), 1e-6)
    sol.max_iter = 30  # the peak is reached in the first iterations
    sol.solve(0.2)
else:
    try:
        solve(s, 0.2, method=method, max_iter=30)
    except Exception:
        pass
print((resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - base) * 1024)
"""


def memory(n: int) -> list[dict]:
    """Peak resident memory added by one solve (fresh process; heights loaded before the
    baseline; 30 iterations) and, for our solvers, the peak of numpy allocations over a
    full solve at n = 512 (tracemalloc; FFT plans and kernel caches included).
    RSS is only meaningful when the arrays dwarf the import-time peak (n >= 2048)."""
    rows = []
    s = surface(n)
    with tempfile.TemporaryDirectory() as tmp:
        path = str(Path(tmp) / "h.npy")
        np.save(path, s.heights)
        for method in ("gfmd", "cg", "tamaas"):
            code = _RSS_SCRIPT.format(path=path, method=method)
            out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                 check=True)
            rss = int(out.stdout.strip().splitlines()[-1])
            traced = float("nan")
            if method != "tamaas":
                small = surface(512)
                fft.plan.cache_clear()
                tracemalloc.start()
                solve(small, 0.2, method=method)
                traced = tracemalloc.get_traced_memory()[1] / small.heights.size
                tracemalloc.stop()
            row = {"n": n, "method": method, "rss_bytes_per_point": rss / n**2,
                   "traced_bytes_per_point_n512": traced}
            rows.append(row)
            print(json.dumps(row), flush=True)
    return rows


def write_csv(name: str, rows: list[dict]) -> tuple[list[str], list[list[str]]]:
    """csv table ``OUT/name.csv`` over the union of the rows' keys ("-" where absent);
    returns the header and the formatted cells."""
    keys = list(dict.fromkeys(k for r in rows for k in r))

    def fmt(v):
        return f"{v:.4g}" if isinstance(v, float) else str(v)

    cells = [[fmt(r[k]) if k in r else "-" for k in keys] for r in rows]
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / f"{name}.csv").write_text("\n".join(",".join(c) for c in [keys, *cells]) + "\n")
    return keys, cells


def format_row(row: dict) -> str:
    """A row as ``key=value`` pairs with plain numbers (a dict's repr shows np.float64(...))."""
    return " ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}"
                    for k, v in row.items())


def write_table(name: str, rows: list[dict]) -> None:
    """csv and markdown tables over the union of the rows' keys ("-" where absent)."""
    keys, cells = write_csv(name, rows)
    md = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    md += ["| " + " | ".join(c) + " |" for c in cells]
    (OUT / f"{name}.md").write_text("\n".join(md) + "\n")


def plot(rows: list[dict], name: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=True)
    colors = {"gfmd": "C0", "cg": "C1", "tamaas": "C3"}
    markers = {256: "o", 512: "s", 1024: "^", 2048: "D", 4096: "v"}
    for ax, label in zip(axes, ("0.1", "0.4"), strict=True):
        for method in colors:
            for n in sorted({r["n"] for r in rows}):
                sel = [r for r in rows if r["method"] == method and r["n"] == n
                       and r["a_c_target"] == label]
                if not sel:
                    continue
                t = [r["median_s"] for r in sel]
                e = [max(r["err_mean_gap"], 1e-12) for r in sel]
                ax.loglog(t, e, "-", marker=markers.get(n, "x"), color=colors[method],
                          label=f"{method} n={n}")
        ax.set_xlabel("wall time (s, median, 1 thread)")
        ax.set_title(f"a_c about {label}")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("relative error of the mean gap")
    axes[1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(OUT / name, dpi=120)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    # every grid holds lambda_s = L/64, which needs >= 2 points: n >= 128 for every size below
    ap.add_argument("--sizes", type=int, nargs="*", default=[256, 512, 1024],
                    help="grid sizes n, each >= 128")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--big", type=int, nargs="*", default=[],
                    help="sizes run once, a_c 0.4, tightest tolerance only (e.g. 2048; >= 128)")
    ap.add_argument("--ladder-n", type=int, default=512, help="grid of the ladder, >= 128")
    ap.add_argument("--memory-n", type=int, default=2048, help="grid of the memory run, >= 128")
    ap.add_argument("--skip", nargs="*", default=[], choices=["time", "ladder", "memory"])
    ap.add_argument("--tag", default="", help="suffix of the time/error output files")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    OUT.mkdir(parents=True, exist_ok=True)
    try:
        import tamaas as tm

        tm.set_log_level(tm.LogLevel.info)
    except ImportError:
        raise SystemExit("this benchmark compares with Tamaas: install the 'peers' extra") from None
    if "ladder" not in args.skip:
        write_table("contact_ladder", ladder(args.ladder_n, args.repeats))
    if "memory" not in args.skip:
        write_table("contact_memory", memory(args.memory_n))
    if "time" not in args.skip:
        rows = time_error(args.sizes, args.repeats, args.big)
        write_table(f"contact_time_error{args.tag}", rows)
        plot(rows, f"contact_time_error{args.tag}.png")


if __name__ == "__main__":
    main()
