"""roughflow.convergence: a resumed resolution study and the anisotropic report's CSV."""

from __future__ import annotations

import csv
import json

import pytest

from roughflow.convergence import measure
from roughflow.convergence.anisotropic import write_anisotropic_report
from roughflow.convergence.options import TARGETS, ResolutionOptions
from roughflow.convergence.records import load_records, resolution_file


def _write(path, records):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in records))


def _csv(path) -> list[list[str]]:
    """The rows of a report's CSV, without its header."""
    with path.open(newline="") as f:
        return list(csv.reader(f))[1:]


SEEDS, PPLS = (0, 1, 2), (2, 4, 8)


def _a_star(s: int, ax: int, p: int) -> float:
    return (0.40 + 0.01 * s + 0.08 / p) if ax == 0 else (0.44 + 0.01 * s - 0.04 / p)


#: per gamma and seed the fixed-load areas are a_inf + C (tx + ty) exactly
C_ANISO = {1.0: {0: 0.1, 1: 0.2, 2: 0.6}, 2.0: {0: 0.3, 1: 0.0, 2: 0.15}}

SPACING = {1.0: (0.01, 0.01), 2.0: (0.02, 0.01)}  # (dx, dy): gamma:1 cells

FACES = {0: (0.3, 0.1), 1: (0.05, 0.25)}  # (tx, ty) * ppl at each axis' threshold


def _aniso_records(g: float) -> list[dict]:
    dx, dy = SPACING[g]
    recs = []
    for s in SEEDS:
        for p in PPLS:
            recs.append(dict(kind="threshold", seed=s, ppl=p, gamma=g, dx=dx, dy=dy,
                             a_star_0=_a_star(s, 0, p), a_star_1=_a_star(s, 1, p),
                             **{f"t{xy}_{ax}": FACES[ax][i] / p
                                for ax in (0, 1) for i, xy in enumerate("xy")}))
            for t in (0.2, 0.35):
                tx, ty = 0.12 / p, 0.08 / p
                recs.append(dict(kind="fixed", seed=s, ppl=p, gamma=g, dx=dx, dy=dy,
                                 target=t, a_fixed=t + 0.01 * s + C_ANISO[g][s] * (tx + ty),
                                 tx_fixed=tx, ty_fixed=ty))
    return recs


@pytest.fixture(scope="module")
def anisotropic_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("aniso")
    for g in C_ANISO:
        _write(resolution_file(out, g), _aniso_records(g))
    md = write_anisotropic_report(out, fit_min_ppl=4).markdown
    return md, _csv(out / "convergence_anisotropic.csv")


def test_anisotropic_csv_rows_have_the_header_columns(anisotropic_report):
    # the variant "pixel, c fitted" holds a comma: quoted, every row still has one field
    # per header column (a spreadsheet or csv.reader reads the rows as written)
    _, rows = anisotropic_report
    assert {len(r) for r in rows} == {9}
    assert {r[3] for r in rows} == {"raw", "geometric", "pixel", "pixel, c fitted"}


SIGMA_OPTS = dict(seeds=(0,), ppl=(2,), l_over_lambda_r=1.0, bisect_tol=4e-3,
                  threshold_contact_tol=1e-4, contact_tol=1e-3)


@pytest.fixture(scope="module")
def sigma_records(tmp_path_factory):
    """The resolution study at 32^2 with sigma and tols other than the defaults."""
    out = tmp_path_factory.mktemp("sigma")
    return load_records(measure.measure_resolution(out, ResolutionOptions(**SIGMA_OPTS),
                                                   warm=False))


def test_resolution_with_sigma_resumes_an_interrupted_seed(sigma_records, tmp_path):
    # a run stopped behind the threshold, or between the two sigma targets, is completed
    # by a rerun: the missing targets are computed, nothing is computed twice
    thr, sig0, _ = sigma_records
    opts = ResolutionOptions(**SIGMA_OPTS)
    path = resolution_file(tmp_path, 1.0)
    expected = [("threshold", None), ("sigma", TARGETS[0]), ("sigma", TARGETS[1])]
    for kept in ([thr, sig0], [thr]):
        _write(path, kept)
        measure.measure_resolution(tmp_path, opts, warm=False)
        recs = load_records(path)
        assert [(r["kind"], r.get("target")) for r in recs] == expected
        assert recs[:len(kept)] == kept
        # the search from a cold start: within the area tolerance, or a pixel, of the target
        assert recs[2]["a"] == pytest.approx(TARGETS[1], abs=max(3e-4, 1 / 32**2))
