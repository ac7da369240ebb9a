"""Surface generation: wall time (median of repeats) and peak memory versus grid size.

Usage: python benchmarks/bench_surface.py [--sizes 1024 2048 4096 8192] [--repeats 3]
Writes results/benchmarks/surface.csv and surface.md.
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc
from pathlib import Path

from roughflow.surface import SurfaceSpec, generate

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def measure(n: int, repeats: int) -> dict:
    spec = SurfaceSpec(nx=n, ny=n, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0,
                       lambda_r=0.25, lambda_s=8.0 / n, seed=0)
    generate(spec)  # plan the FFTs once (plans are cached per shape)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        generate(spec)
        times.append(time.perf_counter() - t0)
    tracemalloc.start()
    surface = generate(spec)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    del surface
    return {"n": n, "median_s": statistics.median(times), "min_s": min(times),
            "peak_MiB": peak / 2**20, "bytes_per_point": peak / n**2}


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--sizes", type=int, nargs="+", default=[1024, 2048, 4096, 8192])
    ap.add_argument("--repeats", type=int, default=3)
    return ap


def main() -> None:
    args = build_parser().parse_args()
    rows = [measure(n, args.repeats) for n in args.sizes]
    OUT.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    (OUT / "surface.csv").write_text(
        "\n".join([",".join(keys)] + [",".join(f"{r[k]:.6g}" for k in keys) for r in rows]) + "\n"
    )
    md = ["| n | median time (s) | min time (s) | peak memory (MiB) | bytes / point |",
          "|---|---|---|---|---|"]
    md += [f"| {r['n']} | {r['median_s']:.3f} | {r['min_s']:.3f} | {r['peak_MiB']:.0f} | "
           f"{r['bytes_per_point']:.0f} |" for r in rows]
    (OUT / "surface.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
