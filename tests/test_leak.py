"""The leak question: leak rate against a hand calculation, closing pressures, the sealing
bracket, and the command line's refusals (roughflow.leak, `roughflow leak`)."""

from __future__ import annotations

import inspect
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughflow import flow
from roughflow.cli import build_parser, main
from roughflow.datasets import leak_dataset
from roughflow.defaults import BOUNDARY, FLOW_TOL
from roughflow.errors import InputError
from roughflow.leak import LeakCurve, leak_curve
from roughflow.surface import ScanInfo, Surface, SurfaceSpec, generate
from roughflow.units import Scales

DATA = Path(__file__).resolve().parent / "data"


def test_uniform_gap_leak_rate_equals_the_hand_calculation(caplog):
    """A seal of width w = 2 mm (along the flow) and length l = 60 mm (across it) with a
    uniform gap h = 1 um, fluid pressure drop dp = 1 MPa, viscosity eta = 1 mPa s:

        Q = l h^3 dp / (12 eta w)
          = 0.06 m * (1e-6 m)^3 * 1e6 Pa / (12 * 1e-3 Pa s * 2e-3 m)
          = 6e-14 / 2.4e-5 m^3/s = 2.5e-9 m^3/s.

    roughflow: the gap in units of L = 10 um is u = 0.1; the Reynolds solve gives
    sigma = u^3 / 12 (L^3/eta) exactly for a uniform gap (docs/flow.md), the scales convert
    it to m^3/(Pa s), and the leak dataset multiplies by l dp / w.
    """
    w, seal_l, h, dp, eta = 2e-3, 60e-3, 1e-6, 1e6, 1e-3
    q_hand = seal_l * h**3 * dp / (12 * eta * w)
    assert q_hand == pytest.approx(2.5e-9, rel=1e-12)

    L = 10e-6
    gap = np.full((16, 12), h / L)
    sigma = [flow.solve(gap, ax, lx=1.0, ly=0.75).sigma for ax in (0, 1)]
    assert sigma == pytest.approx([(h / L) ** 3 / 12] * 2, rel=1e-12)
    curve = LeakCurve(
        pressure=np.array([1e-3]), area_fraction=np.zeros(1), mean_gap=np.array([h / L]),
        percolating=np.ones((1, 2), bool), sigma=np.array([sigma]),
        iterations=np.zeros(1, int), residual=np.zeros(1), flow_imbalance=np.zeros((1, 2)),
        flow_sigma_error=np.zeros((1, 2)), thresholds={}, boundary="periodic",
        rms_gradient=0.0, window_lx=1.0, window_ly=0.75, window_shape=(16, 12))
    surface = Surface.from_array(np.zeros((16, 12)), lx=1.0, ly=0.75)
    ds = leak_dataset(curve, surface, scales=Scales(length=L, modulus=1e9, viscosity=eta),
                      fluid_pressure=dp, seal_width=w, seal_length=seal_l, name="uniform")
    np.testing.assert_allclose(ds["leak_rate"].values, q_hand, rtol=1e-12)
    np.testing.assert_allclose(ds["conductance"].values, h**3 / (12 * eta), rtol=1e-12)
    # dp = 1 MPa equals the contact pressure 1e-3 E* = 1 MPa: the library itself says that
    # the fluid's load, left out of the model, is not small (not only the command line)
    said = ("the fluid pressure 1e+06 Pa is not small against the lowest contact pressure "
            "1e+06 Pa")
    assert ds.attrs["fluid_pressure_note"].startswith(said)
    assert f"uniform: {said}" in caplog.text


def scan_surface(seed=0) -> Surface:
    """A small non-periodic surface with scan provenance (L = 10 um)."""
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=4, eps_f=0.125, points_per_lambda_s=4,
                                  seed=seed)
    h = generate(spec).heights[:96, :96]
    info = ScanInfo(source="test", reader="test", channel="h", length_scale=1e-5,
                    rms_gradient=1.0, detrend="none", fill="none", filled=0)
    return Surface(heights=h, lx=1.0, ly=1.0, scan=info)


@pytest.fixture(scope="module")
def curve():
    # up to 30 E*: far beyond full contact
    return leak_curve(scan_surface(), np.geomspace(0.01, 30.0, 7))


def test_closing_every_gap_is_an_answer(curve):
    assert curve.boundary == BOUNDARY
    assert curve.area_fraction[-1] == 1.0 and curve.mean_gap[-1] == 0.0
    assert not curve.percolating[-1].any() and (curve.sigma[-1] == 0).all()
    assert curve.percolating[0].all() and (curve.sigma[0] > 0).all()
    assert (np.diff(curve.area_fraction) >= 0).all()
    assert (np.diff(curve.sigma, axis=0) <= 0).all()
    # each flow solve's diagnostics: the small windows are solved directly, so sigma's error
    # is at round-off (1e-24 - 2e-15 measured on direct solves, docs/flow.md; 1e-12 leaves
    # three decades) and the fluxes balance to the flow tolerance; 0 where no solve ran
    solved = curve.percolating
    assert (curve.flow_sigma_error[solved] < 1e-12).all()
    assert (curve.flow_imbalance[solved] <= FLOW_TOL).all()
    assert (curve.flow_sigma_error[~solved] == 0).all()
    assert (curve.flow_imbalance[~solved] == 0).all()


def test_sealing_bracket_agrees_with_the_curve(curve):
    for ax, t in curve.thresholds.items():
        assert t.bracketed and t.p_lo < t.p_hi and t.a_hi - t.a_lo <= t.tol
        below, above = curve.pressure <= t.p_lo, curve.pressure >= t.p_hi
        assert curve.percolating[below, ax].all() and not curve.percolating[above, ax].any()
        assert (curve.sigma[above, ax] == 0).all()


def test_sealing_search_scales_its_pressures_with_the_rms_gradient():
    """Heights x 100 (gbar 1 -> 100): in linear elasticity the same contact states come at
    100 times the pressure, so the search, whose range (up to MAX_SEARCH_LOAD E* gbar) and
    first pressure are in E* gbar, must still bracket both thresholds, at 100 x the
    pressures. Its pressures scale exactly, so the brackets agree to the contact solver's
    tolerance; asserted to within the unscaled bracket's width (the search's own resolution
    in pressure). Unscaled, the range ends far below the x 100 thresholds."""
    from roughflow.boundary import embed
    from roughflow.leak import sealing_search
    from roughflow.surface import rms_gradient

    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4))
    found = {}
    for k in (1.0, 100.0):
        h = k * s.heights
        gbar = rms_gradient(h, s.lx, s.ly)
        assert gbar == pytest.approx(k, rel=1e-9)  # generated with gbar = 1
        found[k] = sealing_search(embed(Surface(heights=h, lx=s.lx, ly=s.ly), "periodic"),
                                  gbar=gbar)
    for ax, t in found[1.0].items():
        big = found[100.0][ax]
        assert t.bracketed and big.bracketed, ax
        width = t.p_hi - t.p_lo
        assert abs(big.p_hi / 100 - t.p_hi) <= width and abs(big.p_lo / 100 - t.p_lo) <= width
        assert big.a_c_star == pytest.approx(t.a_c_star, abs=t.tol)


def test_periodic_surfaces_are_analysed_as_they_are():
    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4))
    c = leak_curve(s, [0.05], sealing=False)
    assert c.boundary == "periodic" and c.window_shape == s.shape and c.thresholds == {}


@pytest.mark.parametrize("pressures, match", [([0.1, 0.05], "increase"), ([], "non-empty"),
                                              ([0.0, 0.1], "positive")])
def test_bad_pressures_are_refused(pressures, match):
    with pytest.raises(InputError, match=match):
        leak_curve(scan_surface(), pressures)


def test_pressures_in_pascals_are_refused_before_any_solve(monkeypatch):
    """leak_curve takes pressures in E*. 1 MPa passed as 1e6 came out "sealed" at every
    pressure; anything above CONTACT_PRESSURE_MAX E* (no linear-elastic contact) is refused,
    naming the value and the unit. Full contact itself is an answer (a_c = 1, sigma = 0),
    also far above a smooth scan's 4 E* gbar: one study's pressures serve every scan."""
    import roughflow.leak as leak
    from roughflow.defaults import CONTACT_PRESSURE_MAX

    s = scan_surface()
    monkeypatch.setattr(leak, "solve", lambda *a, **k: pytest.fail("a contact solve ran"))
    with pytest.raises(InputError, match=r"pressure 1e\+06 E\* .*units of the contact modulus"):
        leak_curve(s, [1e5, 1e6])
    with pytest.raises(InputError, match="pressure 101 E"):
        leak_curve(s, [1.01 * CONTACT_PRESSURE_MAX])
    monkeypatch.undo()
    p = 10 * s.scan.rms_gradient  # two and a half times full contact
    c = leak_curve(s, [p], sealing=False)
    assert c.area_fraction[0] == 1.0 and (c.sigma == 0).all()


def test_a_bad_flow_sigma_tol_is_refused_before_any_solve(monkeypatch):
    import roughflow.leak as leak

    monkeypatch.setattr(leak, "solve", lambda *a, **k: pytest.fail("a contact solve ran"))
    with pytest.raises(InputError, match="sigma_tol"):
        leak_curve(scan_surface(), [0.1], flow_sigma_tol=0.5)


LEAK = ["--modulus", "200GPa", "--pressures", "1MPa:100GPa:4", "--fluid-pressure", "1MPa",
        "--viscosity", "1mPa.s", "--seal-width", "2mm", "--seal-length", "60mm"]


@pytest.fixture(scope="module")
def imported(tmp_path_factory):
    out = tmp_path_factory.mktemp("leak") / "afm.nc"
    assert main(["import", str(DATA / "afm-64.npy"), "--size", "500nm", "--unit", "nm",
                 "-o", str(out)]) == 0
    return out


def test_cli_leak_prints_and_writes_the_curve(imported, tmp_path, capsys):
    out = tmp_path / "leak.nc"
    capsys.readouterr()
    assert main(["leak", str(imported), *LEAK, "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"boundary {BOUNDARY}" in text and "sealing pressure along y: between" in text
    with xr.open_dataset(out) as ds:
        assert ds.attrs["boundary"] == BOUNDARY and ds.attrs["scan_filled"] == 0
        np.testing.assert_allclose(ds["pressure"], np.geomspace(1e6, 1e11, 4), rtol=1e-12)
        assert ds.attrs["ref_length_m"] == pytest.approx(500e-9)
        assert ds.sizes == {"scan": 1, "pressure": 4, "axis": 2}
        for name in ("flow_imbalance", "flow_sigma_error"):
            assert ds[name].dims == ("scan", "pressure", "axis") and ds[name].attrs["long_name"]
        # the table's numbers are the dataset's
        q = ds["leak_rate"].isel(scan=0, pressure=0).values
        assert f"{q[0]:10.3e}" in text and f"{q[1]:10.3e}" in text


def test_cli_leak_warns_where_the_fluid_pressure_is_not_small(imported, tmp_path, capsys):
    """The Reynolds flow leaves the fluid's load on the surfaces out (dp << p): a fluid
    pressure of 100 GPa against contact pressures from 1 MPa ran without a word."""
    argv = list(LEAK)
    argv[argv.index("--pressures") + 1] = "10MPa:100MPa:2"
    capsys.readouterr()
    assert main(["leak", str(imported), *argv, "-o", str(tmp_path / "a.nc")]) == 0
    assert "fluid pressure" not in capsys.readouterr().err
    argv[argv.index("--fluid-pressure") + 1] = "20MPa"
    assert main(["leak", str(imported), *argv, "-o", str(tmp_path / "b.nc")]) == 0
    out, err = capsys.readouterr()
    said = ("the fluid pressure 2e+07 Pa is not small against the lowest contact pressure "
            "1e+07 Pa")
    assert said in err
    # the table (the workflow's result; its log may go unread) and the dataset say it too
    assert f"note: {said}" in out and out.count(said) == 1
    assert xr.open_dataset(tmp_path / "b.nc").attrs["fluid_pressure_note"].startswith(said)
    assert xr.open_dataset(tmp_path / "a.nc").attrs["fluid_pressure_note"] == ""
    # equal to the lowest contact pressure (the README's example: 1 MPa against 1MPa:...):
    # not below it, although the round trip through E* leaves the lowest one ulp above
    # (1e6 / 2e11 * 2e11 = 1000000.0000000001)
    argv[argv.index("--pressures") + 1] = "1MPa:100MPa:2"
    argv[argv.index("--fluid-pressure") + 1] = "1MPa"
    assert main(["leak", str(imported), *argv, "-o", str(tmp_path / "c.nc")]) == 0
    assert "is not small against the lowest contact pressure 1e+06 Pa" in capsys.readouterr().err


@pytest.mark.parametrize("change, match", [
    ({"--modulus": "200 GPx"}, "--modulus: cannot parse '200 GPx'"),
    ({"--pressures": "100MPa:1MPa:5"}, "wrong order"),
    ({"--seal-width": "0mm"}, "--seal-width must be a positive length"),
    ({"--viscosity": "1MPa"}, "not a viscosity"),
    ({"--seal-length": "-60mm"}, "--seal-length must be a positive length"),
])
def test_cli_leak_refuses_bad_quantities_before_any_solve(imported, tmp_path, capsys,
                                                          change, match):
    argv = list(LEAK)
    for k, v in change.items():  # "--opt=value": argparse takes "-60mm" for an option
        i = argv.index(k)
        argv[i:i + 2] = [f"{k}={v}"]
    with pytest.raises(SystemExit) as exc:
        main(["leak", str(imported), *argv, "-o", str(tmp_path / "leak.nc")])
    assert exc.value.code == 2 and match in capsys.readouterr().err
    assert not (tmp_path / "leak.nc").exists()


def test_cli_leak_refuses_files_without_physical_length(tmp_path, capsys):
    assert main(["surface", "--l-over-lambda-r", "2", "--eps-f", "0.25",
                 "--points-per-lambda-s", "4", "-o", str(tmp_path / "s.nc")]) == 0
    (tmp_path / "junk.nc").write_text("not netcdf")
    for path, match in ((tmp_path / "s.nc", "--length-scale"),
                        (tmp_path / "junk.nc", "roughflow import"),
                        (tmp_path / "none.nc", "does not exist")):
        with pytest.raises(SystemExit) as exc:
            main(["leak", str(path), *LEAK, "-o", str(tmp_path / "leak.nc")])
        assert exc.value.code == 2 and match in capsys.readouterr().err


def test_cli_defaults_are_the_library_defaults():
    from roughflow.scan import read_scan

    got = vars(build_parser().parse_args(["leak", "s.nc", *LEAK, "-o", "l.nc"]))
    params = inspect.signature(leak_curve).parameters
    assert got["contact_tol"] == params["contact_tol"].default
    assert got["threshold_tol"] == params["threshold_tol"].default
    got = vars(build_parser().parse_args(["import", "s.di", "-o", "s.nc"]))
    params = inspect.signature(read_scan).parameters
    assert got["detrend"] == params["detrend_mode"].default
    assert got["fill"] == params["fill"].default


def test_a_seal_closing_only_near_full_contact_gets_a_note(imported, tmp_path, capsys):
    """An AFM scan sealed along x only at a_c* = 0.99 (one scan line 4 nm below the
    others); the table says what such a value usually means and which import to compare."""
    from roughflow.cli.leak import format_table

    out = tmp_path / "leak.nc"
    assert main(["leak", str(imported), *LEAK, "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        ds = ds.load()
    ds["a_c_star"][0, :] = 0.5  # this 64^2 AFM window seals along x at 0.81 (0.73 levelled)
    assert "lines-x" not in format_table(ds)
    ds["a_c_star"][0, 0] = 0.95
    text = format_table(ds)
    assert "note: along x the seal closes only at a_c* = 0.950" in text and "lines-x" in text
    assert "along y the seal closes only" not in text


def test_the_import_s_warnings_reach_the_leak_table(tmp_path, capsys):
    """In the workflow the import's warnings (rectangular pixels, a large fill, an rms
    gradient that suggests a unit mix-up) went to its log only; the surface file keeps them
    (scan_warnings) and the leak table repeats them."""
    h = np.load(DATA / "afm-64.npy")
    np.save(tmp_path / "rect.npy", h[:, :48])
    surf = tmp_path / "rect.nc"
    assert main(["import", str(tmp_path / "rect.npy"), "--size", "500nm", "--unit", "nm",
                 "-o", str(surf)]) == 0
    with xr.open_dataset(surf) as ds:
        assert "the pixels are" in ds.attrs["scan_warnings"]
        old = ds.load()
    # a surface file written before scan_warnings existed still reads (no warnings)
    del old.attrs["scan_warnings"]
    old.to_netcdf(tmp_path / "old.nc")
    from roughflow.io import read_surface

    assert read_surface(tmp_path / "old.nc").scan.warnings == ""
    capsys.readouterr()
    assert main(["leak", str(surf), *LEAK, "-o", str(tmp_path / "l.nc")]) == 0
    # (one size for the 64 x 48 grid: taken for both sides, rectangular pixels)
    assert ("note: the import warned: one size ('500nm') was given for the 64 x 48 grid"
            in capsys.readouterr().out)
    with xr.open_dataset(tmp_path / "l.nc") as ds:
        assert "the pixels are" in ds.attrs["scan_warnings"]


@pytest.mark.parametrize(("boundary", "cells"), [("mirror", 256), ("window", 144)])
def test_a_sealing_tolerance_below_one_window_cell_is_refused_first(monkeypatch, boundary,
                                                                    cells):
    """The threshold's tolerance was checked against the solver cell (4 times the scan for
    mirror), so a 16 x 16 scan ran its pressure curve and 40 sealing solves and then failed
    with a ConvergenceError (exit 3). It is checked against the analysed window (12 x 12
    for window), before any solve."""
    import roughflow.leak as leak

    s = scan_surface()
    h = s.heights[:16, :16]
    small = Surface(heights=h, lx=s.lx * 16 / s.shape[0], ly=s.ly * 16 / s.shape[1],
                    scan=s.scan)
    monkeypatch.setattr(leak, "solve", lambda *a, **k: pytest.fail("a contact solve ran"))
    with pytest.raises(InputError, match=f"1/{cells} "):
        leak_curve(small, [0.05], boundary=boundary)


def test_cli_leak_rate_is_the_conductance_over_the_given_seal(imported, tmp_path):
    """The command passed the seal's width and length to the dataset swapped: the leak rates
    were off by (l / w)^2 = 900 while the table looked plausible. Q = sigma l dp / w by hand
    from the command's own inputs (w = 2 mm along the flow, l = 60 mm across it, dp = 1 MPa);
    rtol 1e-12: the same three products in floating point, a few ulp at most."""
    out = tmp_path / "leak.nc"
    assert main(["leak", str(imported), *LEAK, "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["seal_width_m"] == pytest.approx(2e-3, rel=1e-15)
        assert ds.attrs["seal_length_m"] == pytest.approx(60e-3, rel=1e-15)
        assert ds.attrs["fluid_pressure_Pa"] == pytest.approx(1e6, rel=1e-15)
        sigma = ds["conductance"].values
        assert np.any(sigma > 0)  # an open seal somewhere, or the check says nothing
        np.testing.assert_allclose(ds["leak_rate"].values, sigma * 60e-3 * 1e6 / 2e-3,
                                   rtol=1e-12, atol=0)


@pytest.mark.parametrize("boundary", ["mirror", "periodic"])
def test_cli_leak_boundary_reaches_the_curve(imported, tmp_path, boundary):
    """--boundary was once dropped on the way to leak_curve: the scan went through the
    default window treatment and the file recorded it. A non-default choice is recorded."""
    assert boundary != BOUNDARY
    argv = list(LEAK)
    argv[argv.index("--pressures") + 1] = "1MPa:100GPa:2"
    out = tmp_path / "leak.nc"
    assert main(["leak", str(imported), *argv, "--boundary", boundary, "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["boundary"] == boundary


@pytest.fixture(scope="module")
def leak_table_ds(imported, tmp_path_factory):
    """The leak dataset of the test scan (LEAK), loaded, for format_table."""
    out = tmp_path_factory.mktemp("table") / "leak.nc"
    assert main(["leak", str(imported), *LEAK, "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        return ds.load()


def test_the_table_tells_a_tiny_contact_area_from_none(leak_table_ds):
    """a_c was printed with 4 decimals: 1e-5 and exactly 0 both read 0.0000."""
    from roughflow.cli.leak import format_table

    ds = leak_table_ds.copy(deep=True)
    ds["area_fraction"][0, :2] = [0.0, 1.234e-5]
    rows = format_table(ds).splitlines()[3:5]
    # (exactly 0: a window without contact, marked "*"; 1.234e-5 of its 48 x 48 cells, less
    # than one: contact too sparse to resolve, marked "~", tests/test_leak_units_flags.py;
    # the first row's 1 MPa is also the fluid pressure, "!", tests/test_leak_validity_flags.py)
    assert [r.split()[1] for r in rows] == ["0*!", "1.234e-05~"]


def test_a_sealing_pressure_below_the_fluid_pressure_gets_a_caveat(leak_table_ds):
    """An elastomer-like case printed "sealing pressure along x: between 2.362e+04 Pa and
    2.376e+04 Pa" under a fluid pressure of 1e5 Pa, which would lift the faces apart."""
    from roughflow.cli.leak import format_table

    ds = leak_table_ds.copy(deep=True)
    fluid = ds.attrs["fluid_pressure_Pa"]
    ds["sealing_pressure_lo"][0, :] = [0.2 * fluid, 10 * fluid]
    ds["sealing_pressure"][0, :] = [0.3 * fluid, 11 * fluid]
    lines = [line for line in format_table(ds).splitlines() if line.startswith("sealing")]
    caveat = "not above the fluid pressure 1e+06 Pa, which would lift the faces apart"
    assert caveat in lines[0] and "outside the model's assumptions" in lines[0]
    assert caveat not in lines[1]


def test_cli_leak_skips_the_sealing_search_on_request(imported, tmp_path, capsys,
                                                      monkeypatch):
    """The library could skip the sealing search (sealing=False), often most of a run's
    time; the command line could not."""
    import roughflow.leak as leak

    monkeypatch.setattr(leak, "sealing_search", lambda *a, **k: pytest.fail("it searched"))
    out = tmp_path / "leak.nc"
    capsys.readouterr()
    assert main(["leak", str(imported), *LEAK, "--no-sealing", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "sealing pressure: not searched (--no-sealing)" in text
    assert "between" not in text
    with xr.open_dataset(out) as ds:
        assert ds.attrs["sealing_searched"] == 0 and "threshold_tol" not in ds.attrs
        assert np.isnan(ds["sealing_pressure"].values).all()
        assert ds["leak_rate"].sizes["pressure"] == 4


def test_the_mean_gap_is_given_in_metres_too(leak_table_ds):
    """The gap in nm is the first thing a seal engineer checks; it was only in units of L,
    to be converted through units.registry by hand."""
    from roughflow.cli.leak import format_table

    ds = leak_table_ds
    np.testing.assert_allclose(ds["mean_gap_si"], ds["mean_gap"] * ds.attrs["ref_length_m"],
                               rtol=1e-15)
    assert ds["mean_gap_si"].attrs["units"] == "m"
    rows = format_table(ds).splitlines()
    assert rows[1].split()[:4] == ["p", "[Pa]", "a_c", "gap"] and rows[2].split()[0] == "m"
    first = float(ds["mean_gap_si"].values[0, 0])
    assert rows[3].split()[2] == f"{first:.3e}"


def test_the_table_states_the_pressure_the_contacts_carry(leak_table_ds):
    """The model is purely elastic and the documented examples reach GPa on the contacts,
    beyond most metals' hardness, without a word on it."""
    from roughflow.cli.leak import format_table

    ds = leak_table_ds
    p = ds["pressure"].values
    a = ds["area_fraction"].values[0]
    held = p[a > 0] / a[a > 0]
    [line] = [ln for ln in format_table(ds).splitlines() if ln.startswith("mean pressure")]
    assert f"p/a_c: {held.min():.3g} - {held.max():.3g} Pa" in line and "hardness" in line
