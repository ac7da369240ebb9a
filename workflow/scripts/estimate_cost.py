"""Core-hours of a config from the cost model ``roughflow.scenes.requests.estimated_seconds``.

    python workflow/scripts/estimate_cost.py config/paper.yaml

With ``--benchmarks results/benchmarks/workflow`` it also prints, for every finished
scene job of the current config, the measured CPU time next to the model's estimate
(Snakemake's cpu_time samples the process tree and reads about 30 % low).
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections import defaultdict
from pathlib import Path

import yaml

from roughflow.resources import describe
from roughflow.scenes import estimated_memory, expand_studies, grid_points
from roughflow.scenes.requests import estimated_seconds


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("config", nargs="?", default="config/paper.yaml")
    ap.add_argument("--benchmarks", default=None, help="compare with a finished run")
    args = ap.parse_args()
    # a mistyped folder must not pass as "no finished jobs"
    if args.benchmarks and not Path(args.benchmarks).is_dir():
        ap.error(f"--benchmarks {args.benchmarks}: no such folder")
    jobs = expand_studies(yaml.safe_load(open(args.config))["studies"])
    leaks = [j for j in jobs.values() if j.kind == "leak"]
    if leaks:  # their cost depends on the scans' grids, known only after the import
        print(f"{len(leaks)} measured-scan jobs not estimated (cost set by each scan's grid, "
              "docs/measured.md)")
        jobs = {k: j for k, j in jobs.items() if j.kind != "leak"}
    total = defaultdict(float)
    for job in jobs.values():
        total[(job.kind, getattr(job, "model", ""))] += estimated_seconds(job)
    for (kind, model), sec in sorted(total.items()):
        print(f"{kind:9s} {model:8s} {sec / 3600:8.2f} core-hours")
    largest = max(jobs.values(), key=estimated_seconds)
    print(f"total {sum(total.values()) / 3600:.1f} core-hours for {len(jobs)} jobs; largest "
          f"job {largest.job_id}: {estimated_seconds(largest) / 3600:.1f} h, "
          f"{grid_points(largest)} grid points, {describe(estimated_memory(largest))}; "
          f"most memory: {describe(max(map(estimated_memory, jobs.values())))}")
    if args.benchmarks:
        tsvs = sorted(Path(args.benchmarks).glob("jobs/*/*.tsv"))
        if not tsvs:
            print(f"warning: no jobs/*/*.tsv under {args.benchmarks}: nothing to compare",
                  file=sys.stderr)
        elif not any(t.stem in jobs for t in tsvs):
            print(f"warning: none of the {len(tsvs)} tsv files under {args.benchmarks} is a "
                  f"job of {args.config}", file=sys.stderr)
        for tsv in tsvs:
            job = jobs.get(tsv.stem)
            if job is None:
                continue
            with tsv.open() as fh:
                row = next(csv.DictReader(fh, delimiter="\t"))
            print(f"{tsv.stem}: measured cpu {float(row['cpu_time']):.1f} s, "
                  f"model {estimated_seconds(job):.1f} s")


if __name__ == "__main__":
    main()
