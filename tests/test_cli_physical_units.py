"""Physical units and scan options of `roughflow threshold` and `roughflow flow`, as
`roughflow contact` and `roughflow leak` take them: threshold --modulus (p_lo, p_hi in Pa,
pressure options with their unit) and --boundary (leak's sealing search on the analysed
window); flow --viscosity (sigma in m^3/(Pa s) for a contact of a scan)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from cli_checks import refused

from roughflow.cli import main
from roughflow.units import registry

DATA = Path(__file__).parent / "data"
#: The contact modulus of the tests (Pa), and a nominal pressure near a_c = 0.2 on the scan.
MODULUS, PRESSURE = "200GPa", "5GPa"
E_STAR = 2e11
SEAL = ["--fluid-pressure", "1MPa", "--viscosity", "1mPa.s", "--seal-width", "2mm",
        "--seal-length", "60mm"]


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """The 64^2 AFM test scan (500 nm, not periodic, gbar 0.3), its contact at 5 GPa with
    E* = 200 GPa, and the contact of a generated surface recorded with the same modulus."""
    d = tmp_path_factory.mktemp("units")
    paths = {k: d / f"{k}.nc" for k in ("scan", "contact", "gen", "gen_contact")}
    assert main(["-q", "import", str(DATA / "afm-64.npy"), "--size", "500nm", "--unit", "nm",
                 "-o", str(paths["scan"])]) == 0
    assert main(["-q", "contact", str(paths["scan"]), "--pressure", PRESSURE, "--modulus",
                 MODULUS, "-o", str(paths["contact"])]) == 0
    assert main(["-q", "surface", "--nx", "64", "--ny", "64", "--lambda-r", "0.5",
                 "--lambda-s", "0.125", "-o", str(paths["gen"])]) == 0
    assert main(["-q", "contact", str(paths["gen"]), "--pressure", "100GPa", "--modulus",
                 MODULUS, "-o", str(paths["gen_contact"])]) == 0
    return paths


def _no_work(monkeypatch) -> None:
    """Make any threshold search or flow solve fail: a refusal must come before them."""
    import roughflow.flow
    import roughflow.leak
    import roughflow.search

    def started(*args, **kwargs):
        raise AssertionError("work started before the input was refused")

    for module, name in ((roughflow.search, "threshold"), (roughflow.leak, "sealing_search"),
                         (roughflow.flow, "solve")):
        monkeypatch.setattr(module, name, started)


# --- threshold --modulus ------------------------------------------------------------------

def test_threshold_pressures_with_units_are_the_same_search_in_e_star(files, tmp_path,
                                                                      capsys):
    """--p-min 2GPa --p-max 100GPa --p-guess 20GPa with E* = 200 GPa is the search with
    0.01, 0.5, 0.1 E* (each quotient exact in floating point: the same solves, bit for bit);
    the file records E*, so units.registry gives p_lo, p_hi in Pa = E* times their value
    (a unit conversion: to round-off, rtol 1e-12), and the summary prints them."""
    si, plain = tmp_path / "si.nc", tmp_path / "plain.nc"
    assert main(["threshold", str(files["scan"]), "--modulus", MODULUS, "--p-min", "2GPa",
                 "--p-max", "100GPa", "--p-guess", "20GPa", "-o", str(si)]) == 0
    printed = capsys.readouterr().out
    assert main(["threshold", str(files["scan"]), "--p-min", "0.01", "--p-max", "0.5",
                 "--p-guess", "0.1", "-o", str(plain)]) == 0
    with xr.open_dataset(si) as a, xr.open_dataset(plain) as b:
        assert float(a["solve_pressure"][0]) == 0.1  # the first solve is --p-guess
        for name in ("a_c_star", "a_lo", "a_hi", "p_lo", "p_hi", "solve_pressure"):
            np.testing.assert_array_equal(a[name].values, b[name].values, err_msg=name)
        assert a.attrs["ref_pressure_Pa"] == E_STAR and "ref_pressure_Pa" not in b.attrs
        ureg = registry(a.attrs)
        for name in ("p_lo", "p_hi"):
            pa = ureg.Quantity(a[name].values, a[name].attrs["units"]).to("Pa").magnitude
            np.testing.assert_allclose(pa, E_STAR * a[name].values, rtol=1e-12)
        lo_x, hi_x = (E_STAR * float(a[v][0]) for v in ("p_lo", "p_hi"))
    assert f"p_lo, p_hi in Pa: x [{lo_x:.4g}, {hi_x:.4g}]" in printed


@pytest.mark.parametrize(("argv", "names"), [
    (["--p-min", "50MPa"], ["--p-min '50MPa' has a unit", "--modulus"]),
    (["--modulus", MODULUS, "--p-max", "0.5"], ["--p-max 0.5 is a number in E*"]),
    (["--modulus", "200"], ["--modulus", "'200' has no unit"]),
    (["--modulus", MODULUS, "--p-guess", "5kg"], ["--p-guess", "'5kg' is not a pressure"]),
    (["--modulus", MODULUS, "--p-min", "1GPa", "--p-max", "500MPa"],
     ["--p-min 1GPa is not below --p-max 500MPa"]),
    (["--modulus", MODULUS, "--p-min=-1GPa"], ["--p-min -1GPa is not a positive"]),
    (["--model", "bearing", "--modulus", MODULUS], ["--modulus 200GPa", "--model bearing"]),
    (["--boundary", "window", "--p-min", "0.01"], ["--p-min 0.01", "--boundary window"]),
    (["--boundary", "mirror", "--model", "bearing"], ["--model bearing", "--boundary mirror"]),
    (["--boundary", "pad", "--strategy", "bisect"], ["--strategy bisect", "--boundary pad"]),
])
def test_threshold_refuses_bad_units_and_options_before_any_solve(files, tmp_path, capsys,
                                                                  monkeypatch, argv, names):
    _no_work(monkeypatch)
    out = tmp_path / "t.nc"
    err = refused(["threshold", str(files["scan"]), *argv, "-o", str(out)], capsys, *names)
    assert "unrecognized" not in err and "invalid float" not in err
    assert not out.exists()


# --- threshold --boundary -----------------------------------------------------------------

@pytest.mark.parametrize("boundary", ["window", "mirror"])
def test_threshold_boundary_is_leaks_sealing_search(files, tmp_path, capsys, boundary):
    """--boundary treats a non-periodic scan as `roughflow leak` does before its sealing
    search, by the same function: a_c* and the bracket are leak's to the bit, and p_lo,
    p_hi in Pa (with --modulus) are leak's sealing pressures (leak stores SI values to 12
    digits, units.canonical: rtol 1e-11)."""
    t, leak = tmp_path / "t.nc", tmp_path / "leak.nc"
    assert main(["threshold", str(files["scan"]), "--boundary", boundary, "--modulus",
                 MODULUS, "-o", str(t)]) == 0
    assert f"boundary {boundary}" in capsys.readouterr().out
    assert main(["-q", "leak", str(files["scan"]), "--modulus", MODULUS, "--pressures",
                 PRESSURE, *SEAL, "--boundary", boundary, "-o", str(leak)]) == 0
    with xr.open_dataset(t) as th, xr.open_dataset(leak) as lk:
        d = lk.isel(scan=0)
        assert th.attrs["boundary"] == boundary == lk.attrs["boundary"]
        np.testing.assert_array_equal(th["a_c_star"].values, d["a_c_star"].values)
        ureg = registry(th.attrs)
        for ours, theirs in (("p_lo", "sealing_pressure_lo"), ("p_hi", "sealing_pressure")):
            pa = ureg.Quantity(th[ours].values, th[ours].attrs["units"]).to("Pa").magnitude
            np.testing.assert_allclose(pa, d[theirs].values, rtol=1e-11)


def test_threshold_boundary_one_axis_and_the_periodic_default(files, tmp_path, capsys):
    """--axis y with --boundary gives leak's y threshold alone; without --boundary the scan
    is solved periodic as before, with a warning that now names --boundary, and an explicit
    --boundary periodic is a choice: no warning (bearing model: an exact sweep, fast)."""
    both, y = tmp_path / "both.nc", tmp_path / "y.nc"
    assert main(["-q", "threshold", str(files["scan"]), "--boundary", "window",
                 "-o", str(both)]) == 0
    assert main(["-q", "threshold", str(files["scan"]), "--boundary", "window", "--axis", "y",
                 "-o", str(y)]) == 0
    with xr.open_dataset(both) as a, xr.open_dataset(y) as b:
        assert list(b["axis"].values) == ["y"]
        assert float(b["a_c_star"][0]) == float(a["a_c_star"].sel(axis="y"))
    capsys.readouterr()
    assert main(["threshold", str(files["scan"]), "--model", "bearing",
                 "-o", str(tmp_path / "b.nc")]) == 0
    err = capsys.readouterr().err
    assert "solves it as a periodic cell" in err and "threshold --boundary window" in err
    assert main(["threshold", str(files["scan"]), "--model", "bearing", "--boundary",
                 "periodic", "-o", str(tmp_path / "b2.nc")]) == 0
    assert "non-periodic" not in capsys.readouterr().err
    with xr.open_dataset(tmp_path / "b2.nc") as ds:
        assert ds.attrs["boundary"] == "periodic"


# --- flow --viscosity ---------------------------------------------------------------------

def test_flow_viscosity_gives_sigma_in_si_as_leak_does(files, tmp_path, capsys):
    """--viscosity 1mPa.s on the contact of a scan: the solve's eta is 1 in units of the
    given viscosity, so sigma (L^3/eta) is the --eta 1 value to the bit; the file records
    ref_viscosity_Pa_s, so units.registry gives sigma in m^3/(Pa s) = sigma L^3 / eta (a
    unit conversion, rtol 1e-12). `roughflow leak --boundary periodic` at the same pressure
    solves the same contact and flow (the flow by a direct solve on this grid, error
    ~1e-14) and stores its conductance to 12 digits: rtol 1e-9."""
    si, plain, leak = tmp_path / "si.nc", tmp_path / "plain.nc", tmp_path / "leak.nc"
    assert main(["flow", str(files["contact"]), "--viscosity", "1mPa.s", "-o", str(si)]) == 0
    printed = capsys.readouterr().out
    assert main(["-q", "flow", str(files["contact"]), "-o", str(plain)]) == 0
    assert main(["-q", "leak", str(files["scan"]), "--modulus", MODULUS, "--pressures",
                 PRESSURE, *SEAL, "--boundary", "periodic", "--no-sealing",
                 "-o", str(leak)]) == 0
    with xr.open_dataset(si) as a, xr.open_dataset(plain) as b, xr.open_dataset(leak) as lk:
        assert a.attrs["ref_viscosity_Pa_s"] == 1e-3 and a.attrs["eta"] == 1.0
        length = a.attrs["ref_length_m"]
        assert length == 5e-7
        ureg = registry(a.attrs)
        got = []
        for name in ("sigma_x", "sigma_y"):
            assert float(a[name]) == float(b[name]) > 0
            got.append(ureg.Quantity(float(a[name]), a[name].attrs["units"])
                       .to("m^3/(Pa*s)").magnitude)
            assert got[-1] == pytest.approx(float(a[name]) * length**3 / 1e-3, rel=1e-12)
        np.testing.assert_allclose(got, lk["conductance"].values.ravel(), rtol=1e-9)
    assert f"sigma_x = {got[0]:.6e}, sigma_y = {got[1]:.6e} m^3/(Pa s)" in printed


@pytest.mark.parametrize(("source", "argv", "names"), [
    # a generated surface's contact records E* (ref_pressure_Pa) but no L in metres
    ("gen_contact", ["--viscosity", "1mPa.s"], ["--viscosity '1mPa.s'", "gen_contact.nc",
                                                 "ref_length_m", "--eta"]),
    ("contact", ["--viscosity", "1mPa.s", "--eta", "2"], ["--eta 2", "--viscosity '1mPa.s'"]),
    ("contact", ["--viscosity", "0.001"], ["--viscosity", "'0.001' has no unit"]),
    ("contact", ["--viscosity", "1Pa"], ["--viscosity", "'1Pa' is not a viscosity"]),
])
def test_flow_viscosity_refused_where_it_has_no_si_meaning(files, tmp_path, capsys,
                                                           monkeypatch, source, argv, names):
    _no_work(monkeypatch)
    out = tmp_path / "f.nc"
    err = refused(["flow", str(files[source]), *argv, "-o", str(out)], capsys, *names)
    assert "unrecognized" not in err
    assert not out.exists()
