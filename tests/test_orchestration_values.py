"""What the orchestration and data layer computes and writes, against independent values:
the threshold search's reported estimate, the ladder's per-seed numbers, the config's
options reaching the jobs, the leak curve on non-periodic scans, and the memory a leak job
asks for. Each test failed under a mutation of the code that the rest of the suite let
through (a hand-mutation audit, 2026-12-07: e.g. a ladder writing seed i's numbers under
seed n-1-i, which a one-seed ladder cannot show). Small grids only."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roughflow import contact, flow
from roughflow.accuracy import PERIMETER_C
from roughflow.boundary import embed
from roughflow.contact.law import ContactLaw
from roughflow.defaults import CONTACT_TOL, THRESHOLD_PRESSURE_RANGE
from roughflow.scenes import LadderJob, SurfaceParams, expand_study, run_ladder
from roughflow.surface import Surface, SurfaceSpec, generate

TINY = SurfaceParams(gamma=1.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)
_LADDER = {"seeds": [0], "points_per_lambda_s": 2, "eps_f": [0.25], "l_over_lambda_r": [4],
           "area_fraction": [0.2, 0.4]}


# --------------------------------------------------------------------------------------
# search/critical.py
# --------------------------------------------------------------------------------------

def _sample(load, area, perimeter, pred, spans, scout=False):
    from roughflow.search.critical import _Sample

    return _Sample(load=load, area=area, spans=spans, perimeter=perimeter,
                   predictor=lambda ax: pred, scout=scout)


def test_corrected_threshold_interpolates_the_perimeter_with_the_estimate_s_weight():
    """a_c*_corrected = a - c P(w), P taken between the two bracket ends with the
    weight w of a_c* itself (Threshold docstring). Predictions f_lo = +0.002, f_hi = -0.008
    put the root at w = 0.2 (not the midpoint, where a swapped weight would not show):
    a = 0.402, P = 0.2 + 0.2 * 0.1 = 0.22. Pure arithmetic on given numbers: rel 1e-12."""
    from roughflow.search.critical import _assemble

    lo = _sample(1.0, 0.400, 0.2, 0.402, {0: True})
    hi = _sample(1.1, 0.410, 0.3, 0.402, {0: False})
    out = _assemble([lo, hi], [lo, hi], (0,), {}, model="elastic", tol=0.02,
                    on_unbracketed="raise", loads_are_pressures=True, interpolate=True)[0]
    assert out.a_c_star == pytest.approx(0.402, rel=1e-12)
    assert out.a_c_star_corrected == pytest.approx(0.402 - PERIMETER_C * 0.22, rel=1e-12)


def test_steepness_is_scaled_through_the_full_end_of_a_bracket():
    """A bracket with one scout end is judged against the contact law passed through its
    full (trusted) end: for a scout lo, the law's slope at hi. Arithmetic: rel 1e-12."""
    from roughflow.search.critical import _steepness

    law = ContactLaw("elastic")
    lo = _sample(0.10, 0.20, 0.0, 0.0, {0: True}, scout=True)
    hi = _sample(0.30, 0.50, 0.0, 0.0, {0: False}, scout=False)
    want = (0.50 - 0.20) / (0.30 - 0.10) / law.slope(0.30, 0.50)
    assert law.slope(0.30, 0.50) != pytest.approx(law.slope(0.10, 0.20), rel=1e-3)
    assert _steepness(lo, hi, law) == pytest.approx(want, rel=1e-12)
    # and the lower end where the upper one is the scout
    hi_s = _sample(0.30, 0.50, 0.0, 0.0, {0: False}, scout=True)
    lo_f = _sample(0.10, 0.20, 0.0, 0.0, {0: True}, scout=False)
    want = (0.50 - 0.20) / (0.30 - 0.10) / law.slope(0.10, 0.20)
    assert _steepness(lo_f, hi_s, law) == pytest.approx(want, rel=1e-12)


def test_a_walled_search_reports_the_midpoint():
    """The predictions sweep periodically, so with walls across the flow
    (periodic=False, a non-periodic scan) a_c* is the bracket's midpoint (Threshold
    docstring), exactly (one float addition and halving: rel 1e-15)."""
    from roughflow.search import scaled_options, threshold

    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4))
    res = threshold(s, None, tol=0.01, options=scaled_options(s.gbar, periodic=False))
    for t in res.values():
        assert t.bracketed
        assert t.a_c_star == pytest.approx(0.5 * (t.a_lo + t.a_hi), rel=1e-15, abs=0)


def test_bearing_tie_narrower_than_tol_is_a_threshold():
    """Every height appears in exactly two cells (rows duplicated), so the critical
    level is a tie of 2 cells: a bracket of 2/256 = 0.0078 <= tol 0.01 is a threshold to
    tol (not unbracketed), its value the bracket's midpoint."""
    from roughflow.search import threshold

    rng = np.random.default_rng(5)
    h = np.repeat(rng.normal(size=(8, 16)), 2, axis=0)  # 16 x 16, each value twice
    assert np.unique(h).size == h.size // 2
    s = Surface(heights=h, lx=1.0, ly=1.0)
    res = threshold(s, None, model="bearing", tol=0.01)
    for t in res.values():
        assert t.bracketed and t.a_hi - t.a_lo == pytest.approx(2 / 256, abs=1e-12)
        assert t.a_c_star == pytest.approx(0.5 * (t.a_lo + t.a_hi), abs=1e-15)


def test_default_pressure_range_scales_with_the_rms_gradient_at_both_ends():
    """scaled_options: the default range in E* gbar times gbar, both ends (a steep
    surface is capped at CONTACT_PRESSURE_MAX, not a gentle one)."""
    from roughflow.search import scaled_options

    lo, hi = scaled_options(0.01).pressure_range
    assert lo == pytest.approx(0.01 * THRESHOLD_PRESSURE_RANGE[0], rel=1e-12)
    assert hi == pytest.approx(0.01 * THRESHOLD_PRESSURE_RANGE[1], rel=1e-12)


# --------------------------------------------------------------------------------------
# search/load.py
# --------------------------------------------------------------------------------------

def test_load_search_bracket_is_the_nearest_straddling_loads():
    """The bounds of the next solve are narrowed to the loads of the two solves that
    straddle the target: the highest load below it and the lowest above it."""
    from roughflow.search.load import LoadSearch, Point

    search = LoadSearch(lambda p, init: None, ContactLaw("elastic"), bounds=(0.001, 10.0))
    search.points = [Point(load, area) for load, area in
                     ((0.1, 0.1), (0.2, 0.2), (0.3, 0.3), (0.4, 0.4))]
    assert search._bracket(0.25) == (0.2, 0.3)


# --------------------------------------------------------------------------------------
# scenes/ladder.py
# --------------------------------------------------------------------------------------

def test_bearing_ladder_writes_each_seed_s_own_numbers():
    """Two seeds (a one-seed ladder cannot show a seed index written wrong):
    each seed's mean gap is the bearing cut's of its own surface (deterministic, the same
    arithmetic: rel 1e-12), its sigma_ref the conductance of its own max(h) - h (both flow
    solves are proven to FLOW_SIGMA_TOL = 1e-6: rel 2e-6), and the bearing model's
    corrected area is its cell count (unbiased), exactly."""
    from roughflow.defaults import FLOW_SIGMA_TOL

    job = LadderJob(surface=TINY, model="bearing", seeds=(0, 1), area_fractions=(0.1, 0.3))
    ds = run_ladder(job).squeeze(("model", "gamma", "hurst", "eps_t", "eps_f"))
    for seed in (0, 1):
        s = generate(TINY.spec(seed))
        gaps = [contact.solve(s, model="bearing", area_fraction=a).mean_gap for a in (0.1, 0.3)]
        np.testing.assert_allclose(ds["mean_gap"].sel(seed=seed).values, gaps, rtol=1e-12)
        ref = flow.conductance(s.heights.max() - s.heights, None, lx=s.lx, ly=s.ly)
        np.testing.assert_allclose(ds["sigma_ref"].sel(seed=seed).values, list(ref),
                                   rtol=2 * FLOW_SIGMA_TOL)
    np.testing.assert_array_equal(ds["area_fraction_corrected"].values,
                                  ds["area_fraction"].values)
    # the two seeds differ, or the comparison says nothing
    assert not np.allclose(ds["sigma_ref"].sel(seed=0), ds["sigma_ref"].sel(seed=1))


def test_elastic_ladder_theory_uses_the_corrected_area_and_stores_the_residual(monkeypatch):
    """The theory lines of an elastic step take the perimeter-corrected area (the
    continuum estimate the thresholds refer to), exactly the stored one; the stored
    contact_residual is the solve's residual: within (0, CONTACT_TOL] (an iteration count
    or any other number is >= 1)."""
    from roughflow import theory

    seen = []
    real = theory.gap_theory

    def spy(*args, **kwargs):
        seen.append(kwargs["area_fraction"])
        return real(*args, **kwargs)

    monkeypatch.setattr(theory, "gap_theory", spy)
    job = LadderJob(surface=TINY, model="elastic", seeds=(0,), area_fractions=(0.2,))
    ds = run_ladder(job)
    corrected = ds["area_fraction_corrected"].values.ravel()
    assert len(seen) == 1 and seen[0] == pytest.approx(corrected[0], rel=1e-15)
    assert corrected[0] < ds["area_fraction"].values.ravel()[0]  # the two differ
    res = ds["contact_residual"].values.ravel()
    assert np.all(res > 0) and np.all(res <= CONTACT_TOL)


# --------------------------------------------------------------------------------------
# scenes/expand.py
# --------------------------------------------------------------------------------------

def test_a_config_a_c_star_reaches_the_ladder_jobs():
    """A study's a_c_star for a model replaces the default theory value."""
    jobs = expand_study("flow_isotropic", {**_LADDER, "a_c_star": {"elastic": 0.37}})
    assert {j.a_c_star for j in jobs.values()} == {0.37}


def test_a_config_area_ladder_in_any_order_is_sorted():
    """The config's ladder in any order gives the increasing ladder."""
    jobs = expand_study("flow_isotropic", {**_LADDER, "area_fraction": [0.4, 0.2]})
    assert {j.area_fractions for j in jobs.values()} == {(0.2, 0.4)}


# --------------------------------------------------------------------------------------
# datasets/leak.py
# --------------------------------------------------------------------------------------

def test_leak_dataset_keeps_the_axis_of_each_percolation_flag():
    """A curve leaking along x only: percolating is 1 at x and 0 at y, with the
    conductance, exactly as given."""
    from roughflow.datasets import leak_dataset
    from roughflow.leak import LeakCurve
    from roughflow.units import Scales

    curve = LeakCurve(
        pressure=np.array([1e-3, 2e-3]), area_fraction=np.array([0.3, 0.4]),
        mean_gap=np.array([0.05, 0.04]), percolating=np.array([[True, False]] * 2),
        sigma=np.array([[1e-3, 0.0], [5e-4, 0.0]]), iterations=np.zeros(2, int),
        residual=np.zeros(2), flow_imbalance=np.zeros((2, 2)),
        flow_sigma_error=np.zeros((2, 2)), thresholds={}, boundary="periodic",
        rms_gradient=1.0, window_lx=1.0, window_ly=1.0, window_shape=(8, 8))
    ds = leak_dataset(curve, Surface.from_array(np.zeros((8, 8))),
                      scales=Scales(length=1e-5, modulus=1e9, viscosity=1e-3),
                      fluid_pressure=1e5, seal_width=1e-3, seal_length=1e-2, name="x_only")
    perc = ds["percolating"].isel(scan=0)
    assert (perc.sel(axis="x") == 1).all() and (perc.sel(axis="y") == 0).all()
    assert (ds["sigma"].isel(scan=0).sel(axis="y") == 0).all()


# --------------------------------------------------------------------------------------
# leak.py / boundary.py
# --------------------------------------------------------------------------------------

def _scan():
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4)
    h = generate(spec).heights[:32, :28]  # a non-periodic piece
    return Surface(heights=h, lx=1.0, ly=28 / 32)


@pytest.mark.parametrize("boundary", ["window", "pad"])
def test_leak_curve_is_the_window_s_contact_and_walled_flow(boundary):
    """One nominal pressure (cold solves on both sides: the same arithmetic,
    rel 1e-12): the curve's area, gap and sigma are those of the analysed window of a
    contact solved at the embedding's cell pressure (nominal x load factor, 1/4 for pad),
    with walls across the flow (periodic=False) for every non-periodic treatment."""
    from roughflow.leak import leak_curve

    s, p = _scan(), 0.05
    curve = leak_curve(s, [p], boundary=boundary, sealing=False)
    emb = embed(s, boundary)
    seen = emb.observe(contact.solve(emb.surface, p * (0.25 if boundary == "pad" else 1.0),
                                     tol=CONTACT_TOL))
    assert curve.area_fraction[0] == pytest.approx(seen.area_fraction, rel=1e-12)
    assert curve.mean_gap[0] == pytest.approx(seen.mean_gap, rel=1e-12)
    flows = flow.flow_both_axes(seen.gap, ~seen.contact, lx=emb.lx, ly=emb.ly, periodic=False)
    want = [f.sigma for f in flows]
    assert all(w > 0 for w in want)
    np.testing.assert_allclose(curve.sigma[0], want, rtol=1e-9)


def test_pad_sealing_pressures_are_nominal():
    """The sealing search solves the padded cell at cell pressures (its solve log); the
    bracket it reports is in nominal pressures on the scan: the cell pressures / 1/4."""
    from roughflow.leak import sealing_search

    s = _scan()
    emb = embed(s, "pad")
    res = sealing_search(emb, gbar=s.gbar, tol=0.01)
    for t in res.values():
        assert t.bracketed
        cell = [r.pressure for r in t.solves]
        assert any(c == pytest.approx(0.25 * t.p_hi, rel=1e-12) for c in cell)
        assert any(c == pytest.approx(0.25 * t.p_lo, rel=1e-12) for c in cell)


# --------------------------------------------------------------------------------------
# scenes/requests.py
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize("boundary", ["mirror", "pad"])
def test_leak_memory_request_counts_the_embedded_cell(tmp_path, monkeypatch, boundary):
    """A leak job is a pressure ladder (task "ladder") on the embedded cell, which
    mirror and pad make 2 nx x 2 ny: mem_mb = 200 + ceil(estimate("ladder", 4 nx ny) / 1e6).
    Integer arithmetic: exact."""
    from roughflow.io import surface_to_dataset, write_dataset
    from roughflow.resources import estimate_bytes
    from roughflow.scenes.requests import WRAPPER_MB, leak_mem_mb

    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    (job,) = expand_study("measured", {
        "modulus": "200GPa", "pressures": "100MPa:20GPa:5", "fluid_pressure": "1MPa",
        "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
        "boundary": boundary, "scans": [{"file": "scan.npy", "size": "1um"}]}).values()
    assert job.boundary == boundary
    imported = tmp_path / "surface.nc"
    heights = np.random.default_rng(0).normal(size=(300, 200))
    write_dataset(surface_to_dataset(Surface.from_array(heights, lx=1.5, ly=1.0)), imported)
    want = WRAPPER_MB + math.ceil(estimate_bytes("ladder", 4 * 300 * 200) / 1e6)
    assert leak_mem_mb(job, imported) == want
