"""Time of the effective-medium theory a ladder evaluates on each contact state
(``roughflow.theory.gap_theory``: isotropic Bruggeman at a_c* and at a second threshold,
both anisotropic forms, the closed form), against its grid size and the Peklenik number.

For each size n and gamma, a surface as in the paper's cells (H = 0.8, eps_f = 1/16, 8 points
per lambda_s, L/lambda_r = n/128 times max(sqrt(gamma), 1/sqrt(gamma)): n x n at gamma 1,
n x 2n at gamma 2) is brought by warm-started elastic contact solves (tol 1e-6) to the
``--pressures`` (a_c about 0.1 - 0.35); ``gap_theory`` of each state is timed ``--repeats``
times (median) with the ladder's arguments (a_c* 0.4, second threshold 0.5, the surface's
gamma, the state's contact area). The rows also give the predictions, so that two versions
of the code can be compared value for value: run it once with each on ``PYTHONPATH``, side
by side, and compare the tables (it uses only what both have).

    ROUGHFLOW_FFT_THREADS=1 python benchmarks/bench_theory.py --sizes 512 1024 --gammas 1 2

Writes results/benchmarks/bench_theory{tag}.{csv,md}; docs/theory.md quotes it.
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")

from roughflow import contact, theory  # noqa: E402
from roughflow.surface import SurfaceSpec, generate  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_contact import OUT, write_csv  # noqa: E402

#: pressures (E* gbar) that give a_c of about 0.1, 0.19, 0.28, 0.36 on these surfaces
PRESSURES = (0.045, 0.09, 0.136, 0.181)
#: the ladder's thresholds (config/paper.yaml, elastic)
A_C_STAR, A_C_STAR_ALT = 0.4, 0.5


def time_state(state, gamma: float, repeats: int) -> dict:
    """Median wall time of ``gap_theory`` on one contact state, and its predictions."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        t = theory.gap_theory(state.gap, contact=state.contact, a_c_star=A_C_STAR,
                              gamma=gamma, a_c_star_alt=A_C_STAR_ALT,
                              area_fraction=state.area_fraction)
        times.append(time.perf_counter() - t0)
    return dict(theory_s=statistics.median(times), sigma_isotropic=t.sigma_isotropic,
                sigma_alt=t.sigma_alt, sigma_x_corrected=t.corrected.sigma_x,
                sigma_y_corrected=t.corrected.sigma_y, sigma_x_persson=t.persson.sigma_x,
                sigma_y_persson=t.persson.sigma_y, residual=t.residual)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 1024],
                    help="grid sizes n, each >= 128 (L/lambda_r = n/128 must be >= 1)")
    ap.add_argument("--gammas", type=float, nargs="+", default=[1.0, 2.0])
    ap.add_argument("--pressures", type=float, nargs="+", default=list(PRESSURES))
    ap.add_argument("--seed", type=int, default=9)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--tag", default="")
    return ap


def main() -> None:
    args = build_parser().parse_args()
    logging.disable(logging.WARNING)
    rows = []
    for gamma in args.gammas:
        stretch = max(math.sqrt(gamma), 1 / math.sqrt(gamma))
        for n in args.sizes:
            spec = SurfaceSpec.from_sweep(hurst=0.8, gamma=gamma, eps_f=1 / 16,
                                          points_per_lambda_s=8, seed=args.seed,
                                          l_over_lambda_r=n / 128 * stretch)
            s = generate(spec)
            state = None
            for p in args.pressures:
                state = contact.solve(s, p, tol=1e-6, init=state)
                row = dict(grid="x".join(map(str, s.shape)), gamma=gamma, pressure=p,
                           a_c=round(state.area_fraction, 4),
                           **time_state(state, gamma, args.repeats))
                rows.append(row)
                print(row, flush=True)
                write_csv(f"bench_theory{args.tag}", rows)  # kept if interrupted
    keys, cells = write_csv(f"bench_theory{args.tag}", rows)
    lines = [f"# gap_theory per contact state (H = 0.8, seed {args.seed}, median of "
             f"{args.repeats}, one thread)", "", "| " + " | ".join(keys) + " |",
             "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(c) + " |" for c in cells]
    (OUT / f"bench_theory{args.tag}.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT / f'bench_theory{args.tag}'}.csv and .md")


if __name__ == "__main__":
    main()
