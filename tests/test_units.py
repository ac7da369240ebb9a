"""Physical units: quantity parsing, the units strings of every dataset kind, round trips."""

from __future__ import annotations

import numpy as np
import pint
import pytest
import xarray as xr
from dataset_checks import assert_yes_no_variables_are_flagged

from roughflow.cli import main
from roughflow.datasets import units as U
from roughflow.errors import InputError
from roughflow.units import Scales, parse_quantity, parse_range, registry


@pytest.mark.parametrize("text, kind, si", [
    ("200GPa", "pressure", 200e9),
    ("1 MPa", "pressure", 1e6),
    ("30psi", "pressure", 30 * 6894.757293168361),  # 1 psi = 6894.757... Pa (exact def.)
    ("2 bar", "pressure", 2e5),
    ("1mPa.s", "viscosity", 1e-3),  # the SI dot product, refused by pint >= 0.26 itself
    ("1.5 mPa.s", "viscosity", 1.5e-3),
    ("2e-3 N.s/m^2", "viscosity", 2e-3),
    ("1 mPa s", "viscosity", 1e-3),
    ("1cP", "viscosity", 1e-3),  # centipoise
    # a power after a unit name, SI notation that pint reads as an unknown unit "m2"; not a
    # number's exponent ("2e-3", "1.5E+3")
    ("1N.s/m2", "viscosity", 1.0),
    ("1kg.m-1.s-1", "viscosity", 1.0),
    ("1 m2.s-1 kg.m-3", "viscosity", 1.0),  # kinematic viscosity times density
    ("1.5E+3 mPa.s", "viscosity", 1.5),
    ("1e5 N.m-2", "pressure", 1e5),
    ("1 N/mm2", "pressure", 1e6),
    ("1mm2/m", "length", 1e-6),
    ("2mm", "length", 2e-3),
    ("500 nm", "length", 500e-9),
    ("3um", "length", 3e-6),
    (0.5, "length", 0.5),  # a bare number is already in SI units
])
def test_parse_quantity(text, kind, si):
    assert parse_quantity(text, kind, "--x") == pytest.approx(si, rel=1e-12)


@pytest.mark.parametrize("text, kind, match", [
    ("200 GPx", "pressure", "--opt: cannot parse '200 GPx'"),
    ("2mm", "pressure", "'2mm' is not a pressure"),
    ("1MPa", "viscosity", "not a viscosity"),
    ("-1MPa", "pressure", "must be a positive pressure"),
    ("0mm", "length", "must be a positive length"),
    ("12", "pressure", "has no unit"),
    ("", "length", "--opt"),
])
def test_parse_quantity_refusals_name_the_option_and_value(text, kind, match):
    with pytest.raises(InputError, match=match):
        parse_quantity(text, kind, "--opt")


def test_parse_range():
    # values keep SI_DIGITS = 12 significant digits: rounded by at most 5e-12 relative
    np.testing.assert_allclose(parse_range("1MPa:100MPa:20", "pressure", "--p"),
                               np.geomspace(1e6, 1e8, 20), rtol=5e-12)
    np.testing.assert_allclose(parse_range("1MPa, 2MPa,5MPa", "pressure", "--p"),
                               [1e6, 2e6, 5e6])
    with pytest.raises(InputError, match="wrong order"):
        parse_range("100MPa:1MPa:20", "pressure", "--p")
    with pytest.raises(InputError, match="integer >= 2"):
        parse_range("1MPa:100MPa:1", "pressure", "--p")
    with pytest.raises(InputError, match="LO:HI:N"):
        parse_range("1MPa:100MPa", "pressure", "--p")
    with pytest.raises(InputError, match="increase"):
        parse_range("2MPa,1MPa", "pressure", "--p")


def test_reference_units_parse_without_scales_but_do_not_convert():
    ureg = registry({})
    for units in (U.LENGTH_UNITS, U.PRESSURE_UNITS, U.SIGMA_UNITS, U.FLUX_UNITS,
                  U.DIMENSIONLESS, U.SECONDS, U.CONDUCTANCE_SI, U.FLOW_RATE_SI):
        ureg.parse_units(units)
    with pytest.raises(pint.DimensionalityError):
        ureg.Quantity(1.0, U.LENGTH_UNITS).to("m")


def test_scales_round_trip_through_the_registry():
    """Dimensionless values times their units string, defined by the scales' attributes,
    convert to the SI values the Scales conversions give, and back."""
    s = Scales(length=5e-7, modulus=2e11, viscosity=1e-3)
    ureg = registry(s.attrs())
    sigma = 3.7e-4
    q = ureg.Quantity(sigma, U.SIGMA_UNITS)
    assert q.to(U.CONDUCTANCE_SI).magnitude == pytest.approx(
        float(s.conductance_to_si(sigma)), rel=1e-12)
    assert q.to(U.CONDUCTANCE_SI).to(U.SIGMA_UNITS).magnitude == pytest.approx(sigma)
    assert ureg.Quantity(0.02, U.PRESSURE_UNITS).to("MPa").magnitude == pytest.approx(4000.0)
    assert ureg.Quantity(2.0, U.LENGTH_UNITS).to("nm").magnitude == pytest.approx(1000.0)
    assert float(s.length_to_si(2.0)) == pytest.approx(
        ureg.Quantity(2.0, U.LENGTH_UNITS).to("m").magnitude, rel=1e-12)
    assert float(s.pressure_from_si(s.pressure_to_si(0.3))) == pytest.approx(0.3)


def _datasets(tmp_path) -> dict[str, xr.Dataset]:
    """One dataset of every kind the command line writes (tiny sizes); the scene and study
    datasets are checked on the workflow's output (tests/test_workflow.py)."""
    t = str(tmp_path)
    runs = {
        "surface": ["surface", "--l-over-lambda-r", "2", "--eps-f", "0.25",
                    "--points-per-lambda-s", "4", "-o", f"{t}/surface.nc"],
        "contact": ["contact", f"{t}/surface.nc", "--pressure", "0.1", "-o", f"{t}/contact.nc"],
        "threshold": ["threshold", f"{t}/surface.nc", "--tol", "0.02",
                      "-o", f"{t}/threshold.nc"],
        "flow": ["flow", f"{t}/contact.nc", "-o", f"{t}/flow.nc"],
        "theory": ["theory", f"{t}/contact.nc", "--flow", f"{t}/flow.nc",
                   "-o", f"{t}/theory.nc"],
        "persson": ["theory", "--hurst", "0.8", "--l-over-lambda-r", "4",
                    "--pressures", "0.01,0.1", "-o", f"{t}/persson.nc"],
        "leak": ["leak", f"{t}/surface.nc", "--length-scale", "10um", "--modulus", "1GPa",
                 "--pressures", "10MPa:1GPa:3", "--fluid-pressure", "1bar",
                 "--viscosity", "1mPa.s", "--seal-width", "1mm", "--seal-length", "10mm",
                 "-o", f"{t}/leak.nc"],
    }
    out = {}
    for name, argv in runs.items():
        assert main(argv) == 0, name
        with xr.open_dataset(argv[-1]) as ds:
            out[name] = ds.load()
    return out


def test_every_units_attribute_of_every_cli_dataset_parses(tmp_path, capsys):
    for kind, ds in _datasets(tmp_path).items():
        ureg = registry(ds.attrs)
        assert_yes_no_variables_are_flagged(ds.encoding["source"])
        for name, v in ds.variables.items():
            if "units" not in v.attrs:
                assert v.dtype.kind not in "fi" or name in ds.dims or name == "axis", \
                    (kind, name)
                continue
            try:
                ureg.parse_units(v.attrs["units"])
            except Exception as exc:  # any pint error is a failure naming the variable
                pytest.fail(f"{kind}: {name} units {v.attrs['units']!r} do not parse: {exc}")
    capsys.readouterr()


def test_leak_dataset_converts_to_physical_numbers(tmp_path, capsys):
    ds = _datasets(tmp_path)["leak"]
    ureg = registry(ds.attrs)
    assert ds.attrs["ref_length_m"] == pytest.approx(1e-5)

    def si(name: str, unit: str) -> np.ndarray:
        return ureg.Quantity(ds[name].values, ds[name].attrs["units"]).to(unit).magnitude

    np.testing.assert_allclose(si("sigma", "m^3/(Pa*s)"), ds["conductance"].values,
                               rtol=1e-12)
    np.testing.assert_allclose(si("pressure_dimensionless", "Pa"),
                               np.broadcast_to(ds["pressure"].values, (1, 3)), rtol=1e-12)
    np.testing.assert_allclose(si("mean_gap", "um"), ds["mean_gap"].values * 10.0,
                               rtol=1e-12)
    capsys.readouterr()


def test_one_quantity_in_other_units_is_one_float():
    """"0.125um" and "125nm", or "4.1GPa" and "4100MPa", converted to floats an ulp apart:
    aggregating leak files made with them split the pressure axis and found the scans'
    length scales to "differ (1.25e-07 - 1.25e-07)". Conversions keep SI_DIGITS digits."""
    from roughflow.units import parse_quantity, parse_range

    assert parse_quantity("0.125um", "length", "s") == parse_quantity("125nm", "length", "s")
    assert parse_quantity("125nm", "length", "s") == 1.25e-7
    assert parse_quantity("4.1GPa", "pressure", "p") == parse_quantity("4100MPa", "pressure",
                                                                        "p") == 4.1e9
    listed = parse_range("1MPa,10MPa,100MPa", "pressure", "p")
    assert (parse_range("1MPa:0.1GPa:3", "pressure", "p") == listed).all()
    assert (parse_range("1e6Pa:1e8Pa:3", "pressure", "p") == listed).all()


def test_a_scan_has_one_size_whatever_the_units(tmp_path):
    from roughflow.scan import read_scan

    h = np.random.default_rng(0).normal(size=(16, 16)) * 1e-3
    np.save(tmp_path / "h.npy", h)
    a = read_scan(tmp_path / "h.npy", size="0.125um", unit="um")
    b = read_scan(tmp_path / "h.npy", size="125nm", height_unit="um")
    assert a.scan.length_scale == b.scan.length_scale == 1.25e-7


def test_the_scales_of_a_scan_take_its_own_length_and_quantities_with_units():
    # Scales(length=...) had to repeat the scan's own L, the only one leak_dataset accepts
    from roughflow.surface import ScanInfo, Surface

    info = ScanInfo(source="s.opd", reader="test", channel="h", length_scale=1.26e-4,
                    rms_gradient=0.02, detrend="plane", fill="none", filled=0,
                    crop="0:16,0:16")
    scan = Surface(heights=np.zeros((16, 16)), lx=1.0, ly=1.0, scan=info)
    scales = Scales.of_scan(scan, modulus="200GPa", viscosity="1mPa.s")
    assert (scales.length, scales.modulus, scales.viscosity) == (1.26e-4, 200e9, 1e-3)
    assert Scales.of_scan(scan, modulus=2e11, viscosity=1e-3) == scales
    with pytest.raises(InputError, match="needs an imported scan"):
        Scales.of_scan(Surface(heights=np.zeros((16, 16)), lx=1.0, ly=1.0),
                       modulus="200GPa", viscosity="1mPa.s")
    with pytest.raises(InputError, match="modulus"):
        Scales.of_scan(scan, modulus="200mm", viscosity="1mPa.s")
