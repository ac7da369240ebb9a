"""Where does the time of a default sweep scene go? (profile)

Profiles one threshold scene (default config: gamma = 1, H = 0.8, L/lambda_r = 4,
eps_f = 1/16, 4 points per lambda_s, bisection tol 0.004, 4 seeds) and one ladder scene
(flow_isotropic: L/lambda_r = 8, 4 points per lambda_s, elastic, 10 contact areas) with
cProfile, then writing the dataset to netCDF. Own time (tottime) of every function is
attributed to a stage by the file it lives in: surface, contact, labelling (percolation),
flow (incl. pyamg / scipy.sparse), theory, I/O (xarray / netCDF), fft (pyFFTW calls made
by any stage, mostly contact), other. Builtins and numpy code inherit the stage of their
main caller (the caller with the largest cumulative time).

Writes ``results/benchmarks/profile_sweep.md`` / ``.csv`` and a bar chart
``profile_sweep.png``. Reproduce::

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/profile_sweep.py
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

STAGES = (
    ("surface", ("roughflow/surface.py",)),
    ("contact", ("roughflow/contact/",)),
    ("labelling", ("roughflow/percolation/", "scipy/ndimage")),
    ("flow", ("roughflow/flow/", "pyamg/", "scipy/sparse")),
    ("theory", ("roughflow/theory/",)),
    ("I/O", ("xarray/", "netCDF4", "h5netcdf", "roughflow/io.py", "roughflow/datasets/")),
    ("fft", ("roughflow/fft.py", "pyfftw")),
)


def _stage(filename: str, funcname: str) -> str:
    f = filename.replace("\\", "/")
    for name, keys in STAGES:
        if any(k in f for k in keys):
            return name
    if "pyfftw" in funcname or "FFTW" in funcname:
        return "fft"
    return "other"


def profile_call(fn, *args, **kw):
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    out = fn(*args, **kw)
    prof.disable()
    wall = time.perf_counter() - t0
    st = pstats.Stats(prof)
    memo: dict = {}

    def stage_of(key, depth=0) -> str:
        """Stage of a function; library/builtin code inherits its callers' stage."""
        if key in memo:
            return memo[key]
        s = _stage(key[0], key[2])
        if s == "other" and depth < 6:
            callers = st.stats[key][4]
            if callers:
                best = max(callers.items(), key=lambda kv: kv[1][3])[0]
                if best in st.stats:
                    s = stage_of(best, depth + 1)
        memo[key] = s
        return s

    per_stage: dict[str, float] = {}
    per_func: list[tuple[float, str]] = []
    for key, (_cc, _nc, tt, _ct, _callers) in st.stats.items():
        filename, line, func = key
        s = stage_of(key)
        per_stage[s] = per_stage.get(s, 0.0) + tt
        per_func.append((tt, f"{Path(filename).name}:{line}({func}) [{s}]"))
    per_func.sort(reverse=True)
    return out, wall, per_stage, per_func[:12]


def compare_tolerances(seeds, ppl: float, repeats: int = 3) -> list[tuple]:
    """Wall time of the threshold search (all seeds) before/after the recommended tolerances.

    Medians of ``repeats`` runs, interleaved so that machine load hits both alike.
    """
    import numpy as np

    from roughflow.search import SearchOptions, threshold
    from roughflow.surface import SurfaceSpec, generate

    settings = {
        "tol 0.004, contact tol 1e-5": dict(tol=0.004, options=SearchOptions(contact_tol=1e-5)),
        "tol 0.008, contact tol 1e-4": dict(tol=0.008, options=SearchOptions(contact_tol=1e-4)),
    }
    surfs = [generate(SurfaceSpec.from_sweep(points_per_lambda_s=ppl, seed=s)) for s in seeds]
    times = {k: [] for k in settings}
    values = {k: [] for k in settings}
    for _ in range(repeats):
        for k, kw in settings.items():
            t0 = time.perf_counter()
            res = [threshold(su, axis=None, **kw) for su in surfs]
            times[k].append(time.perf_counter() - t0)
            values[k] = [r[ax].a_c_star for r in res for ax in (0, 1)]
    ref = np.asarray(values[next(iter(settings))])
    out = []
    for k in settings:
        d = np.abs(np.asarray(values[k]) - ref)
        out.append((k, float(np.median(times[k])), float(d.max())))
    return out


def binned_conductivities(s, bins: int = 4096):
    """Histogram of local conductivities: (bin means, counts) with zeros kept exactly.

    Log-spaced bins between the smallest and largest positive value; each bin is
    represented by the mean of its members, so the EMT sums change only at second order
    in the bin width.
    """
    import numpy as np

    s = np.asarray(s, dtype=np.float64).ravel()
    pos = s[s > 0]
    n_zero = s.size - pos.size
    ls = np.log(pos)
    lo, hi = ls.min(), ls.max()
    idx = np.minimum(((ls - lo) / max(hi - lo, 1e-300) * bins).astype(np.int64), bins - 1)
    cnt = np.bincount(idx, minlength=bins).astype(np.float64)
    tot = np.bincount(idx, weights=pos, minlength=bins)
    keep = cnt > 0
    vals = np.concatenate([[0.0], tot[keep] / cnt[keep]]) if n_zero else tot[keep] / cnt[keep]
    wts = np.concatenate([[float(n_zero)], cnt[keep]]) if n_zero else cnt[keep]
    return vals, wts


def compare_emt(ppl: float, repeats: int = 3) -> list[tuple]:
    """Bruggeman (isotropic + both anisotropic forms) on all cells versus a histogram."""
    import numpy as np

    from roughflow import contact, theory
    from roughflow.surface import SurfaceSpec, generate

    su = generate(SurfaceSpec.from_sweep(l_over_lambda_r=8, points_per_lambda_s=ppl, seed=0))
    r = contact.solve(su, 0.15)
    s = theory.local_conductivity(r.gap, contact=r.contact).ravel()

    def all_forms(vals, w):
        out = [theory.bruggeman(vals, a_c_star=0.415, weights=w).sigma]
        for form in ("corrected", "persson"):
            a = theory.bruggeman_anisotropic(vals, a_c_star=0.415, gamma=1.0, form=form,
                                             weights=w)
            out += [a.sigma_x, a.sigma_y]
        return np.asarray(out)

    res = {}
    for name, fn in (("all cells (current)", lambda: all_forms(s, None)),
                     ("4096-bin histogram", lambda: all_forms(*binned_conductivities(s)))):
        ts = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            v = fn()
            ts.append(time.perf_counter() - t0)
        res[name] = (float(np.median(ts)), v)
    ref = res["all cells (current)"][1]
    return [(k, t, float(np.max(np.abs(v / ref - 1)))) for k, (t, v) in res.items()] + [
        ("cells", su.heights.size, r.area_fraction)]


# the BLAS comparison's scenes: kept here so that its table header reports what ran
BLAS_SEEDS = (0, 1)
BLAS_AREAS = (0.05, 0.2, 0.36)
_CHILD = f"""
import sys, time
from roughflow.scenes import LadderJob, SurfaceParams, ThresholdJob, run_ladder, run_threshold
run_threshold(ThresholdJob(surface=SurfaceParams(points_per_lambda_s=2), seeds=(99,), tol=0.01))
ppl = float(sys.argv[1])
t0 = time.perf_counter()
run_threshold(ThresholdJob(surface=SurfaceParams(points_per_lambda_s=ppl), seeds={BLAS_SEEDS!r},
                           tol=0.004))
t1 = time.perf_counter()
run_ladder(LadderJob(surface=SurfaceParams(l_over_lambda_r=8, points_per_lambda_s=ppl),
                     seeds=(0,), area_fractions={BLAS_AREAS!r}))
t2 = time.perf_counter()
print(t1 - t0, t2 - t1)
"""


def compare_blas_threads(ppl: float, repeats: int = 3) -> list[tuple]:
    """Scene wall times with OpenBLAS's default thread count versus one thread.

    Each run is a fresh process (the thread count is fixed when numpy loads OpenBLAS);
    runs are interleaved; medians of ``repeats``.
    """
    import statistics
    import subprocess

    envs = {"OpenBLAS default threads": {},
            "OPENBLAS_NUM_THREADS=1": {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}}
    times = {k: [] for k in envs}
    for _ in range(repeats):
        for k, extra in envs.items():
            env = {kk: v for kk, v in os.environ.items()
                   if kk not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS")}
            env.update(extra)
            out = subprocess.run([sys.executable, "-c", _CHILD, str(ppl)], env=env,
                                 capture_output=True, text=True, check=True)
            times[k].append(tuple(float(v) for v in out.stdout.split()[-2:]))
    return [(k, statistics.median(t[0] for t in v), statistics.median(t[1] for t in v))
            for k, v in times.items()]


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/benchmarks", help="output folder")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3],
                    help="seeds of the threshold scene")
    ap.add_argument("--ladder-seeds", type=int, nargs="+", default=[0],
                    help="seeds of the ladder scene")
    ap.add_argument("--ppl", type=float, default=4.0, help="points per lambda_s")
    return ap


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)

    from roughflow.io import write_dataset
    from roughflow.scenes import (
        LadderJob,
        SurfaceParams,
        ThresholdJob,
        run_ladder,
        run_threshold,
    )

    # warm-up: numba compilation and FFT plans are a one-off per process
    run_threshold(ThresholdJob(surface=SurfaceParams(points_per_lambda_s=2), seeds=(99,),
                               tol=0.01))
    scenes = {
        "threshold": (run_threshold, ThresholdJob(
            surface=SurfaceParams(points_per_lambda_s=args.ppl), seeds=tuple(args.seeds),
            tol=0.004)),
        "ladder": (run_ladder, LadderJob(
            surface=SurfaceParams(l_over_lambda_r=8, points_per_lambda_s=args.ppl),
            seeds=tuple(args.ladder_seeds),
            area_fractions=(0.01, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.33, 0.36, 0.39))),
    }
    names = [s for s, _ in STAGES] + ["other"]
    rows, md = [], ["# Profile of one threshold scene and one ladder scene (cProfile)\n"]
    tops = {}
    for scene, (fn, job) in scenes.items():
        def run_and_write(fn=fn, job=job):
            ds = fn(job)
            with tempfile.TemporaryDirectory() as d:
                write_dataset(ds, Path(d) / "x.nc")
            return ds

        _, wall, per_stage, top = profile_call(run_and_write)
        tot = sum(per_stage.values())
        rows.append((scene, wall, {k: per_stage.get(k, 0.0) for k in names}, tot))
        tops[scene] = top
        print(scene, f"{wall:.2f} s", {k: round(v, 2) for k, v in per_stage.items()},
              flush=True)
    header = "| scene | wall [s] | " + " | ".join(names) + " |"
    md += [header, "|" + "---|" * (len(names) + 2)]
    for scene, wall, st, tot in rows:
        md.append(f"| {scene} | {wall:.2f} | " + " | ".join(
            f"{st[k]:.2f} ({100 * st[k] / tot:.0f} %)" for k in names) + " |")
    md.append("\nOwn time per stage (cProfile tottime, seconds and share of the profiled "
              "total; cProfile adds overhead to Python-heavy code).\n")
    for scene, top in tops.items():
        md.append(f"\n## Top functions by own time: {scene}\n")
        md += [f"- {tt:.2f} s {name}" for tt, name in top]
    cmp = compare_tolerances(args.seeds, args.ppl)
    md.append(f"\n## Threshold search side by side ({len(args.seeds)} seeds, ppl {args.ppl:g}, "
              "median of 3 interleaved repeats)\n")
    # differences are taken against the first (strictest) setting, not the current default
    md.append(f"| setting | wall [s] | max \\|a_c* - a_c*({cmp[0][0]})\\| |")
    md.append("|---|---|---|")
    md += [f"| {k} | {t:.2f} | {d:.2g} |" for k, t, d in cmp]
    blas = compare_blas_threads(args.ppl)
    lad = SurfaceParams(l_over_lambda_r=8, points_per_lambda_s=args.ppl).spec(0)
    md.append(f"\n## OpenBLAS threads side by side (fresh process per run, ppl {args.ppl:g}, "
              f"median of 3 interleaved repeats; threshold scene: {len(BLAS_SEEDS)} seeds, "
              f"ladder scene: {lad.nx} x {lad.ny}, {len(BLAS_AREAS)} areas)\n")
    md.append("| BLAS threads | threshold scene [s] | ladder scene [s] |")
    md.append("|---|---|---|")
    md += [f"| {k} | {a:.2f} | {b:.2f} |" for k, a, b in blas]
    emt = compare_emt(args.ppl)
    (_, n_cells, a_c) = emt.pop()
    md.append(f"\n## Effective-medium theory on one gap field ({n_cells} cells, a_c = {a_c:.3f};"
              " isotropic + anisotropic corrected + Persson; median of 3)\n")
    md.append("| conductivity distribution | wall [s] | max relative change of sigma |")
    md.append("|---|---|---|")
    md += [f"| {k} | {t:.3f} | {d:.2g} |" for k, t, d in emt]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "profile_sweep.md").write_text("\n".join(md) + "\n")
    with (out / "profile_sweep.csv").open("w") as f:
        f.write("scene,wall_s," + ",".join(names) + "\n")
        for scene, wall, st, _ in rows:
            f.write(f"{scene},{wall:.3f}," + ",".join(f"{st[k]:.3f}" for k in names) + "\n")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # one fixed colour per stage: barh would otherwise take the next colour of the cycle,
    # so the second bar's segments would not match the legend
    colours = {k: plt.get_cmap("tab10")(j) for j, k in enumerate(names)}
    fig, ax = plt.subplots(figsize=(7, 3))
    for i, (_scene, _wall, st, _tot) in enumerate(rows):
        left = 0.0
        for k in names:
            ax.barh(i, st[k], left=left, color=colours[k], label=k if i == 0 else None)
            left += st[k]
    ax.set_yticks(range(len(rows)), [r[0] for r in rows])
    ax.set_xlabel("own time [s] (cProfile)")
    ax.legend(fontsize=7, ncol=4)
    fig.tight_layout()
    fig.savefig(out / "profile_sweep.png", dpi=120)
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
