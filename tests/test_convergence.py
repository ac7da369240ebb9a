"""roughflow.convergence: the accuracy study's values, not only its files.

Two kinds of tests. The report functions get hand-built records whose errors are exactly
first order in the spacing (value = A + B / ppl), so the Richardson reference of two grids
is A exactly and every error, corrected value and fitted constant is known in closed form.
The measurements run on the smallest grids (32^2, 48 x 96) and are checked against
independent solver calls and the formulas of docs/accuracy.md.
"""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest

from roughflow import accuracy, contact, flow
from roughflow.cli import main
from roughflow.convergence import measure
from roughflow.convergence.anisotropic import write_anisotropic_report
from roughflow.convergence.dataset import write_records_dataset
from roughflow.convergence.options import (
    TARGETS,
    ResolutionOptions,
    ToleranceOptions,
    study_specs,
)
from roughflow.convergence.records import load_records, resolution_file, tolerance_file
from roughflow.convergence.report import write_report
from roughflow.defaults import A_C_STAR_PAPER
from roughflow.errors import InputError
from roughflow.search import SearchOptions, threshold
from roughflow.surface import SurfaceSpec, generate

#: the elastic exponent of Eq. 16 (sigma ~ (a_c* - a_c)^(69/20), docs/physics.md Sect. 5)
BETA = 69 / 20
#: the contact law's perimeter constant the anisotropic tables correct with (docs/accuracy.md)
C0 = 0.105


def _write(path, records):
    """The record log ``path`` and the dataset a completed run writes from it (what the
    reports read)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in records))
    study = "tolerance" if path.name == tolerance_file("").name else "resolution"
    write_records_dataset(path, study=study)


def _csv(path) -> list[list[str]]:
    """The rows of a report's CSV, without its header."""
    with path.open(newline="") as f:
        return list(csv.reader(f))[1:]


def _table(md: str, heading: str) -> list[list[str]]:
    """The body rows of the markdown table under the section starting with ``heading``."""
    lines = md[md.index(heading):].splitlines()[1:]
    start = next(i for i, line in enumerate(lines) if line.startswith("|"))
    rows = []
    for line in lines[start + 2:]:  # header and separator
        if not line.startswith("|"):
            break
        rows.append([c.strip() for c in line.strip("|").split("|")])
    return rows


# ---------------------------------------------------------------------------------------
# the isotropic report on hand-built records
# ---------------------------------------------------------------------------------------

SEEDS, PPLS = (0, 1, 2), (2, 4, 8)
#: each seed's own perimeter constant: the fixed-load areas are a_inf + C * P exactly
C_SEED = {0: 0.1, 1: 0.2, 2: 0.6}
#: the constant fitted on the other seeds: every group has the same perimeter steps, so the
#: least-squares c is the mean of the other seeds' constants
C_LOO = {0: 0.4, 1: 0.35, 2: 0.15}
PERIM = {0: 0.3, 1: 0.5}  # perim_{axis} * ppl of the threshold records


def _a_star(s: int, ax: int, p: int) -> float:
    return (0.40 + 0.01 * s + 0.08 / p) if ax == 0 else (0.44 + 0.01 * s - 0.04 / p)


def _a_star_ref(s: int, ax: int) -> float:
    return 0.40 + 0.01 * s if ax == 0 else 0.44 + 0.01 * s


def _ln_sigma_inf(s: int, t: float) -> float:
    return -2.0 - 3.0 * t - 0.1 * s


def _sigma_rec(s: int, p: int, t: float) -> dict:
    perim_fixed = 0.2 / p
    return dict(kind="sigma", seed=s, ppl=p, target=t, p_fixed=0.1,
                a_fixed=t + 0.01 * s + C_SEED[s] * perim_fixed, gap_fixed=0.06,
                perim_fixed=perim_fixed, a=t + 0.001 * (s - 1), perim=0.25 / p,
                sigma_raw=1.01 * math.exp(_ln_sigma_inf(s, t) + 0.4 / p),
                sigma=math.exp(_ln_sigma_inf(s, t) + 0.4 / p), mean_gap=0.05,
                time_contact=0.1, time_flow=0.05)


def _isotropic_records() -> list[dict]:
    recs = []
    for s in SEEDS:
        for p in PPLS:
            recs.append(dict(kind="threshold", seed=s, ppl=p, time=0.1 * p, time_mid=0.01,
                             n_solves=10, a_star_0=_a_star(s, 0, p), a_star_1=_a_star(s, 1, p),
                             perim_0=PERIM[0] / p, perim_1=PERIM[1] / p,
                             perim_mid=0.5 * (PERIM[0] + PERIM[1]) / p))
            recs += [_sigma_rec(s, p, t) for t in TARGETS]
    # a seed interrupted before its coarser grids: left out of every table
    recs.append(dict(recs[-3], seed=3, a_star_0=0.9, a_star_1=0.9))
    return recs


def _tolerance_records() -> list[dict]:
    recs = []
    for s in (0, 1):
        for t in TARGETS:
            for ctol, loose in ((1e-3, 1), (1e-6, 0)):
                recs.append(dict(kind="contact_tol", seed=s, ppl=2, target=t, p=0.1,
                                 contact_tol=ctol, a=t + 0.01 * s + loose * 0.002 * (s + 1),
                                 mean_gap=0.05 * (1 + loose * 0.01 * (s + 1)),
                                 sigma=1e-3 * (1 + loose * 0.05), iterations=10,
                                 time_contact=0.1, time_flow=0.1))
        for ctol, loose in ((1e-3, 1), (1e-5, 0)):
            recs.append(dict(kind="threshold_contact_tol", seed=s, ppl=2, contact_tol=ctol,
                             bisect_tol=1e-3, time=1.0, n_solves=10,
                             a_star_0=0.40 + 0.05 * s + loose * 0.003,
                             a_star_1=0.42 + 0.05 * s - loose * 0.001))
        for btol, loose in ((0.01, 1), (0.001, 0)):
            recs.append(dict(kind="bisect_tol", seed=s, ppl=2, bisect_tol=btol,
                             contact_tol=1e-5, time=1.0, n_solves=10,
                             a_star_0=0.40 + 0.05 * s + loose * 0.002 * (s + 1),
                             a_star_1=0.46 + 0.05 * s - loose * 0.001, width_0=btol,
                             width_1=btol))
    return recs


@pytest.fixture(scope="module")
def isotropic_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("iso")
    _write(resolution_file(out, 1.0), _isotropic_records())
    _write(tolerance_file(out), _tolerance_records())
    md = write_report(out, fit_min_ppl=4).markdown
    return md, _csv(out / "convergence.csv")


def test_report_a_c_star_rows_against_the_exact_reference(isotropic_report):
    md, csv = isotropic_report
    rows = [r for r in csv if r[0].startswith("a_c_star_")]
    seen = set()
    for quantity, variant, ppl, seed, value, ref, err, _ in rows:
        ax = "xy".index(quantity[-1])
        s = int(seed)
        # the Richardson extrapolation of exact first-order data: A up to round-off
        assert float(ref) == pytest.approx(_a_star_ref(s, ax), abs=1e-12)
        if variant == "richardson":
            assert ppl == "2+4"  # 4+8 is the reference itself: no row
            assert float(err) == pytest.approx(0.0, abs=1e-12)  # exact data, round-off
            continue
        p = int(ppl)
        expected = _a_star(s, ax, p)
        if variant == "perimeter":  # each axis' own faces, c fitted on the other seeds
            expected -= C_LOO[s] * PERIM[ax] / p
        # a few sums and products of O(1) numbers: round-off only
        assert float(value) == pytest.approx(expected, abs=1e-12), (quantity, variant, p, s)
        assert float(err) == pytest.approx(expected - _a_star_ref(s, ax), abs=1e-12)
        seen.add((quantity, variant, p, s))
    assert len(seen) == 2 * 2 * len(PPLS) * len(SEEDS)
    assert {int(r[3]) for r in csv} == set(SEEDS)  # not the incomplete seed 3
    assert "c = 0.3000" in md  # the mean of the three seeds' constants


def test_report_richardson_pairs_take_their_own_spacing_ratio(tmp_path):
    # resolutions 2, 5, 10 (each divides the largest): the Richardson variant pairs 5 with 2
    # at ratio 2.5; it assumed 2 (p // 2 with ratio 2), off by 0.2 of the 1/p term here
    recs = []
    for s in SEEDS:
        for p in (2, 5, 10):
            recs.append(dict(kind="threshold", seed=s, ppl=p, time=0.1 * p, time_mid=0.01,
                             n_solves=10, a_star_0=_a_star(s, 0, p), a_star_1=_a_star(s, 1, p),
                             perim_0=PERIM[0] / p, perim_1=PERIM[1] / p,
                             perim_mid=0.5 * (PERIM[0] + PERIM[1]) / p))
            recs += [_sigma_rec(s, p, t) for t in TARGETS]
    _write(resolution_file(tmp_path, 1.0), recs)
    write_report(tmp_path, fit_min_ppl=5)
    rows = [r for r in _csv(tmp_path / "convergence.csv") if r[1] == "richardson"]
    assert {r[2] for r in rows} == {"2+5"} and len(rows) == len(SEEDS) * (2 + len(TARGETS))
    for row in rows:  # exact first-order data: the extrapolation is exact up to round-off
        assert float(row[6]) == pytest.approx(0.0, abs=1e-12), row


def test_report_sigma_rows_follow_eq16_with_the_seed_reference(isotropic_report):
    _, csv = isotropic_report
    rows = [r for r in csv if r[0].startswith("ln_sigma_")]
    n = 0
    for quantity, variant, ppl, seed, value, ref, _, _ in rows:
        t, s = float(quantity.removeprefix("ln_sigma_")), int(seed)
        # exact first-order data: the reference is the continuum value up to round-off
        assert float(ref) == pytest.approx(_ln_sigma_inf(s, t), abs=1e-12)
        if variant != "perimeter":
            continue
        q = _sigma_rec(s, int(ppl), t)
        # Eq. 16 along the load path: d ln sigma / d a_c = -beta / (a_c*(x) - a_c) +
        # 3 d ln(mean gap) / d a_c, with the seed's own a_c* along x; shifted from the
        # perimeter-corrected area a - c P (c fitted on the other seeds) onto the target
        slope = (-BETA / (_a_star_ref(s, 0) - q["a"])
                 + 3 * math.log(q["mean_gap"] / q["gap_fixed"]) / (q["a"] - q["a_fixed"]))
        expected = math.log(q["sigma_raw"]) + slope * (t - (q["a"] - C_LOO[s] * q["perim"]))
        assert float(value) == pytest.approx(expected, abs=1e-12), (t, ppl, s)  # round-off
        n += 1
    assert n == len(TARGETS) * len(PPLS) * len(SEEDS)
    raw = {(r[0], r[2], r[3]): float(r[6]) for r in rows if r[1] == "raw"}
    for (_, ppl, _), err in raw.items():
        # raw: ln of the shifted sigma (the record's "sigma"), error 0.4 / ppl by construction
        assert err == pytest.approx(0.4 / int(ppl), abs=1e-12)  # round-off


def test_report_fixed_load_errors_against_the_extrapolation(isotropic_report):
    md, _ = isotropic_report
    rows = _table(md, "## Contact area and mean gap at fixed load")
    assert len(rows) == len(TARGETS) * len(PPLS)
    mean_c = np.mean(list(C_SEED.values()))
    for _, ppl, err_a, err_c, _ in rows:
        p = int(ppl.split()[0])
        # a_fixed - a_inf = C P with P = 0.2 / ppl (the tables print 4 significant digits)
        assert float(err_a) == pytest.approx(mean_c * 0.2 / p, rel=1e-3)
        # each seed corrected with the others' c: the errors (C_s - C_loo(s)) P sum to 0
        assert abs(float(err_c)) < 1e-12  # round-off of O(0.01) terms


def test_report_tolerance_tables(isotropic_report):
    md, _ = isotropic_report
    # tables print 4 significant digits: rel 1e-3 below
    ct = {(r[0], r[1]): [float(v) for v in r[4:]]
          for r in _table(md, "## Contact solver tolerance")}
    for t in ("0.2", "0.35"):
        # against the tightest tol of the same seed: max |d a_c| 0.004, |d gap|/gap 0.02,
        # |d sigma|/sigma 0.05 (seed 1); 0 at the reference itself
        assert ct[(t, "0.001")] == pytest.approx([0.004, 0.02, 0.05], rel=1e-3)
        assert ct[(t, "1e-06")] == [0.0, 0.0, 0.0]
    tct = {r[0]: float(r[2]) for r in _table(md, "## Contact tolerance inside the threshold")}
    assert tct["0.001"] == pytest.approx(0.003, rel=1e-3)  # against the same seed's a_c*
    bt = {r[0]: [float(v) for v in r[3:]] for r in _table(md, "## Bisection tolerance")}
    # errors (x, y per seed) 0.002, -0.001, 0.004, -0.001: rms sqrt(22e-6 / 4), max 0.004
    assert bt["0.01"] == pytest.approx([math.sqrt(22e-6 / 4), 0.004], rel=1e-3)


# ---------------------------------------------------------------------------------------
# the anisotropic report on hand-built records
# ---------------------------------------------------------------------------------------

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


def _jackknife_se_of_mean(values) -> float:
    # the leave-one-out fits are means of the other seeds' constants, whose jackknife
    # standard error is the standard error of the mean
    v = np.asarray(values, dtype=float)
    return float(np.std(v, ddof=1) / math.sqrt(v.size))


def test_anisotropic_pixel_constant_and_its_jackknife(anisotropic_report):
    md, _ = anisotropic_report
    fit = {(r[0], r[1]): r for r in _table(md, "## Perimeter constant fitted")}
    for g, key in ((1.0, "1"), (2.0, "2")):
        c = list(C_ANISO[g].values())
        row = fit[(key, "pixel")]
        # 4 significant digits in the table
        assert float(row[2]) == pytest.approx(np.mean(c), rel=1e-3)
        assert float(row[3]) == pytest.approx(_jackknife_se_of_mean(c), rel=1e-3)
    pooled = [v for g in C_ANISO for v in C_ANISO[g].values()]  # six (gamma, seed) surfaces
    assert float(fit[("pooled", "pixel")][3]) == pytest.approx(
        _jackknife_se_of_mean(pooled), rel=1e-3)  # 4 significant digits


def test_anisotropic_a_c_star_rows(anisotropic_report):
    md, csv = anisotropic_report
    directions = {g: set() for g in ("1.0", "2.0")}
    n = 0
    for g, _, d, variant, ppl, seed, value, ref, _ in csv:
        gamma, s, p = float(g), int(seed), int(ppl)
        directions[g].add(d)
        ax = 0 if "x" in d else 1
        dx, dy = SPACING[gamma]
        tx, ty = (f / p for f in FACES[ax])
        v = _a_star(s, ax, p)
        if variant == "geometric":
            # face length (dy for a face normal to x) times sqrt(dx dy), per cell area
            v -= C0 * (tx * dy + ty * dx) * math.sqrt(dx * dy) / (dx * dy)
        elif variant == "pixel":  # one cell area per face
            v -= C0 * (tx + ty)
        elif variant == "pixel, c fitted":  # c fitted on the other seeds of this gamma
            others = [c for k, c in C_ANISO[gamma].items() if k != s]
            v -= np.mean(others) * (tx + ty)
        assert float(ref) == pytest.approx(_a_star_ref(s, ax), abs=1e-12)  # round-off
        assert float(value) == pytest.approx(v, abs=1e-12), (g, d, variant, p, s)  # round-off
        n += 1
    assert n == 2 * 2 * 4 * len(PPLS) * len(SEEDS)
    # gamma > 1: x is the easy (stretching) direction, as in the paper's figures
    assert directions == {"1.0": {"x", "y"}, "2.0": {"easy (x)", "hard (y)"}}
    fixed = _table(md, "## Fixed-load contact area error")
    for g, _, ppl, raw, *_ in fixed:
        # a_fixed - a_inf = C (tx + ty) = C 0.2 / ppl; 4 significant digits in the table
        assert float(raw) == pytest.approx(
            np.mean(list(C_ANISO[float(g)].values())) * 0.2 / int(ppl.split()[0]), rel=1e-3)


def test_anisotropic_csv_rows_have_the_header_columns(anisotropic_report):
    # the variant "pixel, c fitted" holds a comma: quoted, every row still has one field
    # per header column (a spreadsheet or csv.reader reads the rows as written)
    _, rows = anisotropic_report
    assert {len(r) for r in rows} == {9}
    assert {r[3] for r in rows} == {"raw", "geometric", "pixel", "pixel, c fitted"}


def test_anisotropic_two_constants_and_a_spacing_ratio_of_three(tmp_path):
    # a = a_inf(gamma, seed, target) + 0.1 tx + 0.2 ty exactly, on grids 4 and 12 (ratio 3),
    # tx growing with gamma: the fits recover 0.1 / 0.2 only with a_inf per gamma, and the
    # Richardson reference is a_inf only with the true spacing ratio
    faces = {0: (0.3, 0.1), 1: (0.1, 0.4), 2: (0.2, 0.2)}
    for g in (1.0, 2.0):
        recs = []
        for s in SEEDS:
            for p in (4, 12):
                recs.append(dict(kind="threshold", seed=s, ppl=p, gamma=g, dx=0.01, dy=0.01,
                                 a_star_0=0.4, a_star_1=0.4, tx_0=0.1, ty_0=0.1, tx_1=0.1,
                                 ty_1=0.1))
                for t in (0.2, 0.35):
                    tx, ty = g * faces[s][0] / p, faces[s][1] / p
                    recs.append(dict(kind="fixed", seed=s, ppl=p, gamma=g, dx=0.01, dy=0.01,
                                     target=t, tx_fixed=tx, ty_fixed=ty,
                                     a_fixed=t + 0.05 * g + 0.01 * s + 0.1 * tx + 0.2 * ty))
        _write(resolution_file(tmp_path, g), recs)
    md = write_anisotropic_report(tmp_path, fit_min_ppl=4).markdown
    fit = {(r[0], r[1].split(" (")[0]): r[2] for r in _table(md, "## Perimeter constant")}
    assert fit[("pooled", "pixel, c_x and c_y")] == "0.1000 / 0.2000"
    assert fit[("2", "pixel, c_x and c_y")] == "0.1000 / 0.2000"
    for g, _, ppl, raw, *_ in _table(md, "## Fixed-load contact area error"):
        p = int(ppl.split()[0])
        expected = np.mean([(0.1 * float(g) * faces[s][0] + 0.2 * faces[s][1]) / p
                            for s in SEEDS])
        assert float(raw) == pytest.approx(expected, rel=1e-3), (g, p)  # 4 digits printed


# ---------------------------------------------------------------------------------------
# the command line's report and output checks
# ---------------------------------------------------------------------------------------

def test_report_with_anisotropic_records_only(tmp_path, capsys):
    # no gamma 1 file: no isotropic report, the anisotropic one with --fit-min-ppl
    _write(resolution_file(tmp_path, 2.0), _aniso_records(2.0))
    assert main(["accuracy", "report", "--out", str(tmp_path), "--fit-min-ppl", "2"]) == 0
    capsys.readouterr()
    assert not (tmp_path / "convergence.md").exists()
    md = (tmp_path / "convergence_anisotropic.md").read_text()
    assert "ppl >= 2" in md
    # 3 seeds x 2 targets x 3 resolutions in the fit
    assert _table(md, "## Perimeter constant")[0][-1] == "18"


def test_resolution_checks_its_own_gamma_file(tmp_path, monkeypatch, capsys):
    def no_work(*a, **kw):
        raise AssertionError("work started")

    monkeypatch.setattr(measure, "warm_up", no_work)
    monkeypatch.setattr(measure, "generate", no_work)
    resolution_file(tmp_path, 2.0).mkdir()  # the gamma 2 records' file is a folder
    with pytest.raises(SystemExit) as exc:
        main(["accuracy", "resolution", "--gamma", "2", "--l-over-lambda-r", "2",
              "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "convergence_resolution_g2.jsonl" in err, err


def test_sigma_by_default_for_gamma_one_only():
    assert ResolutionOptions().with_sigma
    aniso = dict(gamma=2.0, l_over_lambda_r=2.0, ppl=(2, 4))
    assert not ResolutionOptions(**aniso).with_sigma
    assert ResolutionOptions(**aniso, sigma=True).with_sigma


def test_resolutions_whose_sweep_grids_do_not_nest_get_a_finest_grid_that_does():
    # gamma 2, L / lambda_r 2: x has 48 and 384 points at 2 and 16 points per lambda_s (8 x);
    # y needs 91 and 725, which the sweep rounds up to the FFT-friendly 96 and 750, not
    # 8 x 96 = 768: the study's finest grid is 768 instead, and every coarser one is whole
    spec = SurfaceSpec.from_sweep(gamma=2.0, l_over_lambda_r=2.0, points_per_lambda_s=16)
    assert (spec.nx, spec.ny) == (384, 750)
    specs = study_specs((2, 4, 8, 16), gamma=2.0, l_over_lambda_r=2.0, seed=3)
    assert {p: (s.nx, s.ny) for p, s in specs.items()} == {
        2: (48, 96), 4: (96, 192), 8: (192, 384), 16: (384, 768)}
    assert all((s.lx, s.ly, s.lambda_s, s.seed) == (spec.lx, spec.ly, spec.lambda_s, 3)
               for s in specs.values())
    assert ResolutionOptions(gamma=2.0, l_over_lambda_r=2.0, ppl=(2, 16)).ppl == (2, 16)
    # ratios 3 and 2 (2, 3, 6 points), gamma 3, L / lambda_r 3: the sweep's y grids are
    # 180, 250 and 500 (500 is 2 x 250 but not 3 x 180); the finest is a multiple of 6
    specs = study_specs((2, 3, 6), gamma=3.0, l_over_lambda_r=3.0)
    assert {p: (s.nx, s.ny) for p, s in specs.items()} == {
        2: (60, 180), 3: (90, 270), 6: (180, 540)}


@pytest.mark.parametrize(("gamma", "l_over_lambda_r"), [(1.0, None), (2.0, None), (4.0, 8.0)])
def test_resolutions_whose_sweep_grids_nest_are_the_sweeps_own(gamma, l_over_lambda_r):
    # the study measures the grids the sweep runs at, wherever they nest
    specs = study_specs((2, 4, 8, 16), gamma=gamma, l_over_lambda_r=l_over_lambda_r)
    for p, s in specs.items():
        assert s == SurfaceSpec.from_sweep(gamma=gamma, l_over_lambda_r=l_over_lambda_r,
                                           points_per_lambda_s=p)


def test_grid_sizes_a_multiple_of_a_given_number():
    # y needs 725 points: 8 x fft_friendly(ceil(725 / 8) = 91) = 8 x 96; x needs 384 = 8 x 48
    spec = SurfaceSpec.from_sweep(gamma=2.0, l_over_lambda_r=2.0, points_per_lambda_s=16,
                                  multiple_of=8)
    assert (spec.nx, spec.ny) == (384, 768)
    with pytest.raises(InputError, match="multiple_of"):
        SurfaceSpec.from_sweep(multiple_of=0)


# ---------------------------------------------------------------------------------------
# the measurements on the smallest grids
# ---------------------------------------------------------------------------------------

def test_sampled_surface_is_the_finest_at_the_coarse_points():
    # gamma 2: 96 x 192 sampled to 48 x 96; the coarse point (i, j) lies at (i dx, j dy)
    # with dx, dy twice the fine spacings, i.e. at the fine point (2 i, 2 j)
    fine = generate(SurfaceSpec.from_sweep(gamma=2.0, l_over_lambda_r=2.0,
                                           points_per_lambda_s=4, seed=1))
    coarse = measure.sampled_surface(fine, 2, 4)
    assert coarse.shape == (48, 96) and (coarse.lx, coarse.ly) == (fine.lx, fine.ly)
    i, j = np.meshgrid(np.arange(48), np.arange(96), indexing="ij")
    np.testing.assert_array_equal(coarse.heights, fine.heights[2 * i, 2 * j])


def _surface(ppl: int = 2, **kw):
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=ppl, seed=0, **kw))


def test_threshold_record_per_axis():
    surf = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1, l_over_lambda_r=1.0))
    rec = measure.threshold_record(surf, tol=2e-3, contact_tol=1e-5)
    th = threshold(surf, axis=None, tol=2e-3, options=SearchOptions(contact_tol=1e-5))
    init = None
    for ax in (0, 1):  # the solves below repeat the search's exactly: equal, not close
        assert (rec[f"a_star_{ax}"], rec[f"a_star_corrected_{ax}"]) == (
            th[ax].a_c_star, th[ax].a_c_star_corrected)
        # one solve at the bracket's mid-pressure (warm-started from the other axis')
        r = contact.solve(surf, (th[ax].p_lo + th[ax].p_hi) / 2, tol=1e-5, init=init)
        init = r
        tx, ty = accuracy.contact_faces(r.contact)
        assert rec[f"a_mid_{ax}"] == r.area_fraction
        assert (rec[f"tx_{ax}"], rec[f"ty_{ax}"]) == (tx / r.contact.size, ty / r.contact.size)
        assert rec[f"perim_{ax}"] == accuracy.perimeter_term(r.contact)
    assert rec["perim_mid"] == pytest.approx((rec["perim_0"] + rec["perim_1"]) / 2)
    # else a swap of tx and ty, or one axis' term for both, would go unseen
    assert rec["tx_0"] != rec["ty_0"] and rec["perim_0"] != rec["perim_1"]


SIGMA_OPTS = dict(seeds=(0,), ppl=(2,), l_over_lambda_r=1.0, bisect_tol=4e-3,
                  threshold_contact_tol=1e-4, contact_tol=1e-3)


@pytest.fixture(scope="module")
def sigma_records(tmp_path_factory):
    """The resolution study at 32^2 with sigma and tols other than the defaults."""
    out = tmp_path_factory.mktemp("sigma")
    return load_records(measure.measure_resolution(out, ResolutionOptions(**SIGMA_OPTS),
                                                   warm=False))


def test_resolution_sigma_records_and_options(sigma_records):
    thr, *sig = sigma_records
    surf = _surface(l_over_lambda_r=1.0)
    # the threshold with the study's bisection and contact tols (the same call: equal)
    th = threshold(surf, axis=None, tol=4e-3, options=SearchOptions(contact_tol=1e-4))
    assert (thr["a_star_0"], thr["a_star_1"]) == (th[0].a_c_star, th[1].a_c_star)
    assert [(r["kind"], r["target"]) for r in sig] == [("sigma", t) for t in TARGETS]
    law = contact.ContactLaw()
    first = contact.solve(surf, law.control(TARGETS[0]), tol=1e-3)  # cold, as the search's
    assert sig[0]["gap_fixed"] == first.mean_gap and sig[0]["a_fixed"] == first.area_fraction
    for r in sig:
        assert r["p_fixed"] == law.control(r["target"])  # the law's load, as every grid
        # moved from a onto the target with Eq. 16's slope at the paper's a_c*; a few
        # floating-point operations: round-off
        assert r["sigma"] == pytest.approx(r["sigma_raw"] * math.exp(
            -BETA / (A_C_STAR_PAPER - r["a"]) * (r["target"] - r["a"])), rel=1e-12)
        assert r["a"] != r["target"]  # else the shift would be 0 whatever its slope


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


def test_resolution_fixed_loads_anisotropic_and_resumed(tmp_path):
    kw = dict(seeds=(0,), ppl=(2,), gamma=2.0, l_over_lambda_r=2.0, contact_tol=1e-4)
    path = measure.measure_resolution(
        tmp_path, ResolutionOptions(fixed_targets=(0.2, 0.35), **kw), warm=False)
    assert path.name == "convergence_resolution_g2.jsonl"
    thr, *fixed = load_records(path)
    spec = SurfaceSpec.from_sweep(gamma=2.0, l_over_lambda_r=2.0, points_per_lambda_s=2)
    # the record's grid and spacings: 48 x 96 cells of 1/48 x 1/96 (gamma:1 rectangles)
    for r in (thr, *fixed):
        assert (r["n"], r["ny"]) == (spec.nx, spec.ny) == (48, 96)
        assert (r["dx"], r["dy"]) == pytest.approx((spec.lx / spec.nx, spec.ly / spec.ny))
    surf = generate(SurfaceSpec.from_sweep(gamma=2.0, l_over_lambda_r=2.0,
                                           points_per_lambda_s=2, seed=0))
    r0 = contact.solve(surf, contact.ContactLaw().control(0.2), tol=1e-4)  # cold, the same
    tx, ty = accuracy.contact_faces(r0.contact)
    assert (fixed[0]["a_fixed"], fixed[0]["tx_fixed"], fixed[0]["ty_fixed"]) == (
        r0.area_fraction, tx / r0.contact.size, ty / r0.contact.size)
    # one more target: only it is computed
    measure.measure_resolution(
        tmp_path, ResolutionOptions(fixed_targets=(0.2, 0.35, 0.42), **kw), warm=False)
    recs = load_records(path)
    assert [(r["kind"], r.get("target")) for r in recs] == [
        ("threshold", None), ("fixed", 0.2), ("fixed", 0.35), ("fixed", 0.42)]


def test_tolerance_records_use_each_tolerance(tmp_path):
    opts = ToleranceOptions(seeds=(0,), ppl=2, contact_tols=(1e-2, 1e-6),
                            threshold_contact_tols=(1e-3, 1e-5), threshold_bisect_tol=4e-3,
                            bisect_tols=(0.01, 0.002), threshold_contact_tol=1e-4)
    recs = load_records(measure.measure_tolerances(tmp_path, opts, warm=False))
    surf = _surface()  # the tolerance grid: 2 points per lambda_s, the paper's cell
    law = contact.ContactLaw()
    # each record against the same solve made here (deterministic: equal, not close)
    ct = [r for r in recs if r["kind"] == "contact_tol"]
    assert [(r["target"], r["contact_tol"]) for r in ct] == [
        (t, c) for t in TARGETS for c in (1e-2, 1e-6)]
    for r in ct:
        c = contact.solve(surf, law.control(r["target"]), tol=r["contact_tol"])
        assert (r["a"], r["mean_gap"]) == (c.area_fraction, c.mean_gap)
        assert r["sigma"] == flow.solve(c.gap, 0, lx=surf.lx, ly=surf.ly).sigma
    for r in recs:
        if r["kind"] == "threshold_contact_tol":
            th = threshold(surf, axis=None, tol=4e-3, options=SearchOptions(
                contact_tol=r["contact_tol"], max_solves=80))
        elif r["kind"] == "bisect_tol":
            th = threshold(surf, axis=None, tol=r["bisect_tol"], options=SearchOptions(
                contact_tol=1e-4, max_solves=80))
        else:
            continue
        assert (r["a_star_0"], r["a_star_1"]) == (th[0].a_c_star, th[1].a_c_star), r
