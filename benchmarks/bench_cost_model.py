"""CPU time and peak memory of a config's scene jobs against the cost and memory models
(calibrates ``roughflow.scenes.requests.estimated_seconds``).

Usage:
    python benchmarks/bench_cost_model.py [config/paper.yaml] [--max-points 4200000]
        [--jobs JOB_ID ...] [--tag _paper]

Picks one job of every (kind, model, grid, bandwidth) of the config (the first by job id;
``--jobs`` names them instead), runs each through ``roughflow scene`` in a fresh process
with one thread, as the workflow does, and reads the child's CPU time and peak resident
set size from ``os.wait4``. Jobs with more grid points than ``--max-points`` are left out
(the paper's largest takes 11 GB and minutes to hours).

Writes results/benchmarks/cost_model{tag}.csv and .md: per job its grid, seeds, measured CPU
seconds, the model's estimate, their ratio, and peak memory against
``roughflow.scenes.estimated_memory`` (the table of docs/workflow.md "Cost").
"""

from __future__ import annotations

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

from roughflow.scenes import estimated_memory, expand_studies, grid_points
from roughflow.scenes.requests import estimated_seconds

OUT = Path(__file__).resolve().parents[1] / "results" / "benchmarks"


def one_per_class(jobs: dict) -> list:
    """The first job (by id) of every kind, model, grid and bandwidth eps_f."""
    picked = {}
    for job_id in sorted(jobs):
        job = jobs[job_id]
        s = getattr(job, "surface", None)
        key = (job.kind, getattr(job, "model", ""), grid_points(job),
               getattr(s, "eps_f", None), len(getattr(job, "seeds", ())))
        picked.setdefault(key, job)
    return sorted(picked.values(), key=grid_points)


def run(job, directory: str) -> tuple[float, float, int]:
    """CPU seconds, wall seconds and peak RSS (bytes) of ``roughflow scene`` on ``job``."""
    env = dict(os.environ, ROUGHFLOW_FFT_THREADS="1")
    args = [sys.executable, "-m", "roughflow", "scene", *job.cli_args(), "--threads", "1",
            "-o", f"{directory}/{job.job_id}.nc"]
    t0 = time.perf_counter()
    log = Path(directory) / f"{job.job_id}.log"
    with log.open("w") as err:
        child = subprocess.Popen(args, env=env, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{job.job_id} failed:\n{log.read_text()}")
    return usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss * 1024


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("config", nargs="?", default="config/paper.yaml")
    ap.add_argument("--max-points", type=int, default=4_200_000)
    ap.add_argument("--jobs", nargs="*", default=None, help="job ids instead of one per class")
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    jobs = {k: j for k, j in expand_studies(yaml.safe_load(open(args.config))["studies"]).items()
            if j.kind != "leak"}  # a leak job's grid is its scan's
    if args.jobs:
        unknown = [j for j in args.jobs if j not in jobs]
        if unknown:
            raise SystemExit(f"no job {unknown[0]!r} in {args.config}")
        chosen = [jobs[j] for j in args.jobs]
    else:
        chosen = [j for j in one_per_class(jobs) if grid_points(j) <= args.max_points]
    if not chosen:  # stop before writing anything (rows[0] below needs a row)
        smallest = min((grid_points(j) for j in jobs.values()), default=None)
        raise SystemExit(f"nothing to measure: no scene job of {args.config} has at most "
                         f"--max-points {args.max_points} grid points (the smallest has "
                         f"{smallest}); raise --max-points or name --jobs")
    OUT.mkdir(parents=True, exist_ok=True)
    rows = []
    with tempfile.TemporaryDirectory() as d:
        for job in chosen:
            cpu, wall, rss = run(job, d)
            model = estimated_seconds(job)
            row = {"job": job.job_id, "kind": job.kind, "model": getattr(job, "model", ""),
                   "points": grid_points(job), "seeds": len(getattr(job, "seeds", ())),
                   "cpu_s": round(cpu, 1), "wall_s": round(wall, 1),
                   "estimate_s": round(model, 1), "cpu_over_estimate": round(cpu / model, 3),
                   "peak_mb": round(rss / 1e6), "memory_estimate_mb":
                   round(estimated_memory(job) / 1e6)}
            print("\t".join(str(v) for v in row.values()), flush=True)
            rows.append(row)
    stem = OUT / f"cost_model{args.tag}"
    with open(f"{stem}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    with open(f"{stem}.md", "w") as fh:
        fh.write(f"Scene jobs of {args.config}, one thread each (`{' '.join(sys.argv)}`)\n\n")
        fh.write("| job | points | seeds | CPU s | estimate s | CPU / estimate | peak MB "
                 "| memory estimate MB |\n|---|---|---|---|---|---|---|---|\n")
        for r in rows:
            fh.write(f"| {r['job']} | {r['points']} | {r['seeds']} | {r['cpu_s']} | "
                     f"{r['estimate_s']} | {r['cpu_over_estimate']} | {r['peak_mb']} | "
                     f"{r['memory_estimate_mb']} |\n")
    print(f"wrote {stem}.csv and .md")


if __name__ == "__main__":
    main()
