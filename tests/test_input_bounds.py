"""Bounds on the inputs of contact solves and leak questions: the seal's numbers and a scan's
length scale (leak.check_seal), pressures in pascals passed as units of E*
(contact.check_pressure_scale), contact tolerances below round-off (contact.check_contact_tol),
and the bearing model's missing pressure."""

from __future__ import annotations

import re

import numpy as np
import pytest
import xarray as xr
from cli_checks import refused

from roughflow import defaults
from roughflow.cli import main
from roughflow.contact import solve
from roughflow.contact.adhesion import adhesion_for
from roughflow.datasets import leak_dataset
from roughflow.errors import InputError
from roughflow.leak import LeakCurve, leak_curve
from roughflow.surface import ScanInfo, Surface, SurfaceSpec, generate
from roughflow.units import Scales

L_SCAN = 1e-5  # m: the physical side of the test scans


def small_surface(seed: int = 0) -> Surface:
    """A generated 128^2 surface (rms gradient 1)."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=seed))


def scan_surface(slope: float = 1.0) -> Surface:
    """A 64^2 non-periodic scan of side L_SCAN; ``slope`` multiplies its heights."""
    h = small_surface().heights[:64, :64] * slope
    info = ScanInfo(source="test", reader="test", channel="h", length_scale=L_SCAN,
                    rms_gradient=slope, detrend="none", fill="none", filled=0)
    return Surface(heights=h, lx=1.0, ly=1.0, scan=info)


def synthetic_curve() -> LeakCurve:
    """A two-pressure leak curve without solves (the leak dataset only converts it)."""
    return LeakCurve(
        pressure=np.array([1e-4, 1e-3]), area_fraction=np.array([0.1, 0.3]),
        mean_gap=np.array([0.05, 0.02]), percolating=np.ones((2, 2), bool),
        sigma=np.array([[2e-3, 1e-3], [1e-4, 5e-5]]), iterations=np.full(2, 7),
        residual=np.full(2, 1e-7), flow_imbalance=np.zeros((2, 2)),
        flow_sigma_error=np.zeros((2, 2)), thresholds={}, boundary="window",
        rms_gradient=1.0, window_lx=0.75, window_ly=0.75, window_shape=(48, 48))


SCALES = Scales(length=L_SCAN, modulus=2e11, viscosity=1e-3)
SEAL = {"fluid_pressure": 1e5, "seal_width": 2e-3, "seal_length": 60e-3}


# --- the seal's numbers and the scan's length scale (leak.check_seal) ----------------------

@pytest.mark.parametrize(("key", "value"), [
    ("fluid_pressure", -1e6), ("fluid_pressure", 0.0), ("fluid_pressure", np.inf),
    ("seal_width", 0.0), ("seal_width", -2e-3), ("seal_length", np.nan)])
def test_leak_dataset_refuses_a_bad_seal(key, value):
    # these came out as leak rates of -9.3e-17, 0, inf or NaN m^3/s (width 0: a numpy warning)
    with pytest.raises(InputError, match=rf"{key} \((Pa|m)\) must be"):
        leak_dataset(synthetic_curve(), scan_surface(), scales=SCALES, name="s",
                     **{**SEAL, key: value})


def test_leak_dataset_refuses_a_length_scale_the_scan_contradicts():
    # Scales(length=1.0) for a scan of side 1e-5 m gave leak rates 1e15 times too high and a
    # file whose ref_length_m (1) contradicted its own scan_length_scale
    with pytest.raises(InputError, match=r"length scale 1\.0 m contradicts the scan's own L"):
        leak_dataset(synthetic_curve(), scan_surface(), name="s",
                     scales=Scales(length=1.0, modulus=2e11, viscosity=1e-3), **SEAL)
    # the scan's own L, also as a float an ulp off (another unit's conversion), is taken ...
    same = Scales(length=float(np.nextafter(L_SCAN, 1.0)), modulus=2e11, viscosity=1e-3)
    ds = leak_dataset(synthetic_curve(), scan_surface(), scales=same, name="s", **SEAL)
    assert ds.attrs["ref_length_m"] == pytest.approx(L_SCAN, rel=1e-12)
    # ... and a surface without a physical size takes any
    generated = Surface.from_array(np.zeros((48, 48)), lx=1.0, ly=1.0)
    leak_dataset(synthetic_curve(), generated, scales=Scales(length=1.0, modulus=2e11,
                                                             viscosity=1e-3), name="g", **SEAL)


def test_the_leak_command_checks_the_seal_with_the_library(tmp_path, capsys, monkeypatch):
    """`roughflow leak` asks leak.check_seal, before any solve, as leak_dataset does."""
    import roughflow.leak as leak

    np.save(tmp_path / "h.npy", small_surface().heights[:64, :64])
    scan = tmp_path / "scan.nc"
    assert main(["import", str(tmp_path / "h.npy"), "--size", "10um", "--unit", "um",
                 "-o", str(scan)]) in (0, None)

    def refuse(*args, **kwargs):
        raise InputError("refused by check_seal")

    monkeypatch.setattr(leak, "check_seal", refuse)
    monkeypatch.setattr(leak, "leak_curve", lambda *a, **k: pytest.fail("a solve ran"))
    refused(["leak", str(scan), "--modulus", "200GPa", "--pressures", "10MPa:1GPa:3",
             "--fluid-pressure", "0.1MPa", "--viscosity", "1mPa.s", "--seal-width", "2mm",
             "--seal-length", "60mm", "-o", str(tmp_path / "L.nc")], capsys,
            "refused by check_seal")


# --- pressures beyond any linear-elastic contact (contact.check_pressure_scale) -------------

def test_contact_solve_refuses_pressures_beyond_any_elastic_contact():
    s = small_surface()
    top = defaults.CONTACT_PRESSURE_MAX
    with pytest.raises(InputError, match=r"pressure 1e\+06 E\* is above 100 E\*, beyond any "
                                         r"linear-elastic contact"):
        solve(s, 1e6)
    with pytest.raises(InputError, match="pressure 101 E"):
        solve(s, 1.01 * top, method="cg")
    assert solve(s, top).area_fraction == 1.0  # full contact at the bound is an answer
    # adhesive loads are held to it either way (a tension, too); max_iter 5: the old code
    # ran the solver here and failed at its cap
    ad = adhesion_for(s.heights, s.lx, s.ly,
                      gamma_over_v_full=defaults.ADHESION_SURFACE_ENERGY_RATIO,
                      range=defaults.ADHESION_RANGE_OVER_LAMBDA_S["hard"] * s.spec.lambda_s)
    for load, said in ((1e6, "above 100"), (-1e6, "below -100")):
        with pytest.raises(InputError, match=re.escape(f"pressure {load:g} E* is {said} E*")):
            solve(s, load, model="adhesive", adhesion=ad, max_iter=5)


def test_a_load_below_what_the_grid_resolves_is_refused():
    # an API audit: p = 1e-14 on 128^2 ran gfmd's 50,000 iterations (10 s) and failed; below
    # about one cell the contact is that cell whatever the load (defaults.CONTACT_MIN_CELLS)
    s = small_surface()
    floor = defaults.CONTACT_MIN_CELLS / s.heights.size / 2.0  # the law's slope 2, gbar 1
    with pytest.raises(InputError, match=r"pressure 1e-14 E\* is below what a 128 x 128 grid "
                                         r"resolves \(3.05e-08 E\*"):
        solve(s, 1e-14)
    with pytest.raises(InputError, match="below what"):
        solve(s, 0.99 * floor, method="cg")
    # at the floor the solve converges, with one cell in contact
    assert solve(s, floor).area_fraction == 1 / s.heights.size
    # the floor follows the surface's rms gradient: the same problem scaled by 1e-3 passes
    scaled = Surface.from_array(s.heights * 1e-3, lx=s.lx, ly=s.ly)
    assert solve(scaled, 1e-3 * floor).area_fraction == 1 / s.heights.size


def test_a_tension_beyond_the_adhesions_largest_is_refused():
    # a pull of 300 times what every cell together can hold ran 50,000 iterations (24 s)
    s = small_surface()
    ad = adhesion_for(s.heights, s.lx, s.ly,
                      gamma_over_v_full=defaults.ADHESION_SURFACE_ENERGY_RATIO,
                      range=defaults.ADHESION_RANGE_OVER_LAMBDA_S["hard"] * s.spec.lambda_s)
    with pytest.raises(InputError, match=r"beyond the adhesion's largest tension .*no "
                                         r"equilibrium"):
        solve(s, -1.0001 * ad.max_tension, model="adhesive", adhesion=ad, max_iter=5)


def test_persson_theory_refuses_a_pressure_in_pascals():
    # predict_conductance(spec, [1e6]) gave a_c = 1 and sigma = 0 without a word (an API
    # audit); with the modulus in pascals the same pressure is an answer
    from roughflow.theory import persson_mean_gap, predict_conductance

    spec = SurfaceSpec.from_sweep()
    with pytest.raises(InputError, match=r"pressure 1e\+06 E\* is above 100 E\*"):
        predict_conductance(spec, [1e-2, 1e6], a_c_star=0.4)
    with pytest.raises(InputError, match="above 100"):
        persson_mean_gap(1e6, spec)
    pa = predict_conductance(spec, [1e6], a_c_star=0.4, modulus=2e6).area_fraction
    assert pa == pytest.approx(predict_conductance(spec, [0.5], a_c_star=0.4).area_fraction,
                               rel=1e-12)


def test_the_bearing_model_refuses_a_pressure():
    # it cuts the heights at an area and has no load: a pressure given was ignored silently
    with pytest.raises(InputError, match="pressure=1000000.0 is not for model='bearing'"):
        solve(small_surface(), 1e6, model="bearing", area_fraction=0.3)


def test_contact_command_refuses_a_pressure_in_pascals(cli_surface_file, tmp_path, capsys):
    # --pressure 1e6 (pascals typed for E*) gave exit 0 with a_c = 1 and mean gap 0
    refused(["contact", str(cli_surface_file), "--pressure", "1e6", "-o", str(tmp_path / "m.nc")],
            capsys, "pressure 1e+06 E* is above 100 E*", "units of the contact modulus")
    assert not (tmp_path / "m.nc").exists()


# --- contact tolerances below round-off (contact.check_contact_tol) ------------------------

@pytest.mark.parametrize("method", ["gfmd", "cg"])
def test_contact_tolerances_below_the_floor_are_refused(method):
    floor = defaults.CONTACT_TOL_MIN
    s = small_surface()
    with pytest.raises(InputError, match=rf"tol must be at least {floor:g}.*got 1e-16"):
        solve(s, 0.1, tol=1e-16, method=method, max_iter=20)
    with pytest.raises(InputError, match="tol must be at least"):
        solve(s, 0.1, tol=0.5 * floor, method=method, max_iter=20)


@pytest.mark.parametrize(("method", "load"), [("gfmd", 1e-4), ("gfmd", 0.1), ("cg", 1e-4)])
def test_the_floor_is_reached_at_small_loads(method, load):
    # small loads are where round-off stops the solvers first (defaults.CONTACT_TOL_MIN):
    # at 1e-4 E* gbar (a_c 5e-4, 8 contact cells) gfmd stalled at 5e-13 on this surface
    r = solve(small_surface(), load, tol=defaults.CONTACT_TOL_MIN, method=method)
    assert r.residual <= defaults.CONTACT_TOL_MIN and r.iterations < 500


def test_the_adhesive_model_reaches_the_floor():
    s = small_surface()
    for repulsion in defaults.ADHESION_REPULSIONS:
        ad = adhesion_for(s.heights, s.lx, s.ly,
                          gamma_over_v_full=defaults.ADHESION_SURFACE_ENERGY_RATIO,
                          range=defaults.ADHESION_RANGE_OVER_LAMBDA_S[repulsion] * s.spec.lambda_s,
                          repulsion=repulsion)
        r = solve(s, 0.0, model="adhesive", adhesion=ad, tol=defaults.CONTACT_TOL_MIN)
        assert r.residual <= defaults.CONTACT_TOL_MIN, repulsion


def test_leak_curve_refuses_contact_tolerances_before_any_solve(monkeypatch):
    import roughflow.leak as leak

    monkeypatch.setattr(leak, "solve", lambda *a, **k: pytest.fail("a contact solve ran"))
    for key in ("contact_tol", "threshold_contact_tol"):
        with pytest.raises(InputError, match=rf"{key} must be at least"):
            leak_curve(scan_surface(), [1e-3], **{key: 1e-16})


def test_contact_command_refuses_a_tolerance_below_round_off(cli_surface_file, tmp_path, capsys):
    # --tol 1e-16 ran 50000 iterations, then exit 3 (--max-iter 20 here: the old code exits 3)
    refused(["contact", str(cli_surface_file), "--pressure", "0.1", "--tol", "1e-16",
             "--max-iter", "20", "-o", str(tmp_path / "t.nc")], capsys, "tol must be at least")


# --- the sealing search stays within the solver's bound ------------------------------------

def test_sealing_search_of_a_steep_scan_stays_below_the_pressure_bound():
    # gbar 1000 (a scan's heights read in the wrong unit): the search's first pressure,
    # 0.22 E* gbar, is 218 E*, which contact.solve refuses; kept to 100 E*, the seal comes
    # out unbracketed, with its message, instead of an error after the pressure curve
    c = leak_curve(scan_surface(slope=1000.0), [1.0], boundary="periodic")
    top = defaults.CONTACT_PRESSURE_MAX
    for t in c.thresholds.values():
        assert not t.bracketed and t.p_lo == top
        assert f"highest allowed pressure {top:g}" in t.message


# --- the bearing model has no pressure ------------------------------------------------------

def test_bearing_contact_file_claims_no_pressure(cli_surface_file, tmp_path, capsys):
    """A bearing contact file held pressure = NaN and the command printed "p = nan"; flow,
    theory and threshold still read the file."""
    out = tmp_path / "bear.nc"
    capsys.readouterr()
    assert main(["contact", str(cli_surface_file), "--model", "bearing", "--area-fraction", "0.3",
                 "-o", str(out)]) in (0, None)
    printed = capsys.readouterr().out
    assert "bearing contact: a_c = 0.29" in printed and "nan" not in printed
    with xr.open_dataset(out) as ds:
        assert "pressure" not in ds.attrs and ds.attrs["model"] == "bearing"
        assert "contact_pressure" not in ds  # it held zeros, a load of none
    assert main(["flow", str(out), "-o", str(tmp_path / "f.nc")]) in (0, None)
    with xr.open_dataset(tmp_path / "f.nc") as ds:
        assert not any(np.isnan(v) for v in ds.attrs.values() if isinstance(v, float))
    assert main(["theory", str(out), "-o", str(tmp_path / "t.nc")]) in (0, None)
    assert main(["threshold", str(out), "--model", "bearing", "-o",
                 str(tmp_path / "c.nc")]) in (0, None)


def test_a_bearing_result_reports_no_pressure():
    # the result's own field stays NaN (it has none); its scalars, the file's attributes,
    # leave it out, and an elastic result keeps its load
    r = solve(small_surface(), model="bearing", area_fraction=0.3)
    assert np.isnan(r.pressure) and "pressure" not in r.scalars()
    assert solve(small_surface(), 0.1).scalars()["pressure"] == 0.1


def test_a_study_below_the_contact_tolerance_floor_is_refused_at_planning():
    # the sweep job's check is the solver's (contact.check_contact_tol): before, a config
    # with contact_tol 1e-12 passed the planning and stalled at its first solve
    from roughflow.scenes import expand_study

    block = {"gamma": [1], "l_over_lambda_r": [1], "eps_f": [0.25], "seeds": [0],
             "points_per_lambda_s": 4, "contact_tol": 1e-12}
    with pytest.raises(InputError, match=r"contact_tol must be at least 1e-10"):
        expand_study("threshold_vs_gamma", block)
