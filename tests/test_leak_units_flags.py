"""The leak table's rate unit and its flag for contact on too few cells (roughflow.units,
roughflow.leak, `roughflow leak`): a seal engineer reads leak rates in mL/min or uL/h, not
m^3/s; and at low load the whole contact of a measured scan's analysed window can be a
handful of grid cells, whose a_c and leak rate the table printed like any other row."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.cli.leak import format_table
from roughflow.datasets import leak_dataset
from roughflow.defaults import LEAK_MIN_CONTACT_CELLS
from roughflow.errors import InputError
from roughflow.leak import (
    LeakCurve,
    contact_cells,
    empty_window_pressures,
    few_cell_pressures,
    few_cell_rows,
    leak_curve,
)
from roughflow.surface import ScanInfo, Surface
from roughflow.units import RATE_UNITS, Scales, parse_rate_unit

#: parse_quantity keeps SI_DIGITS = 12 significant digits: at most 5e-12 relative.
SI_RTOL = 1e-11
#: The table prints 4 significant digits: at most half a unit of the 4th, 5e-4 relative.
TABLE_RTOL = 5e-4


@pytest.mark.parametrize("text, si", [
    ("m^3/s", 1.0),
    ("mm^3/s", 1e-9),
    ("mm3/s", 1e-9),  # the SI power notation
    ("cm^3/min", 1e-6 / 60),
    ("L/min", 1e-3 / 60),
    ("L/h", 1e-3 / 3600),
    ("mL/min", 1e-6 / 60),
    ("ml/min", 1e-6 / 60),
    ("mL/h", 1e-6 / 3600),
    ("uL/min", 1e-9 / 60),
    (" uL/h ", 1e-9 / 3600),
])
def test_rate_units_convert_as_by_hand(text, si):
    assert parse_rate_unit(text) == pytest.approx(si, rel=SI_RTOL)


@pytest.mark.parametrize("text, match", [
    ("xyz/min", "cannot parse 'xyz/min'"),
    ("mL", "'mL' is not a volume rate"),
    ("kg/s", "'kg/s' is not a volume rate"),  # a mass rate: out of scope
    ("2mL/min", "'2mL/min' is not a unit alone"),  # would scale every rate by 1/2
    ("", "'' is not a unit alone"),
])
def test_other_rate_units_are_refused_naming_them_and_the_accepted_ones(text, match):
    with pytest.raises(InputError, match="--rate-unit") as exc:
        parse_rate_unit(text, "--rate-unit")
    said = str(exc.value)
    assert match in said and all(u in said for u in RATE_UNITS)


def test_few_contact_cells_are_told_from_none_and_from_enough():
    shape = (24, 24)  # a_c of k cells is k / 576
    area = np.array([0.0, 1, 15, 16, 576]) / 576
    p = np.array([1.0, 2, 3, 4, 5])
    assert contact_cells(area, shape).tolist() == [0, 1, 15, 16, 576]
    assert LEAK_MIN_CONTACT_CELLS == 16
    # none is the empty window's case (its own flag), not an under-resolved one
    assert few_cell_rows(area, shape).tolist() == [False, True, True, False, False]
    assert few_cell_pressures(p, area, shape).tolist() == [2.0, 3.0]
    assert empty_window_pressures(p, area).tolist() == [1.0]
    assert few_cell_pressures(p, area, shape, min_cells=2).tolist() == [2.0]
    # an a_c below one cell (not from a solve) still has contact: flagged, not dropped
    assert few_cell_rows([1e-5], shape).tolist() == [True]
    with pytest.raises(InputError, match="min_cells"):
        few_cell_rows(area, shape, min_cells=0)


def table_dataset(cells: list[int]) -> xr.Dataset:
    """A leak dataset (no solve) of rows whose 24 x 24 window holds ``cells`` contact cells,
    uniform gap 0.1 L = 1 um: Q = l h^3 dp / (12 eta w) = 2.5e-9 m^3/s (tests/test_leak.py)."""
    n = len(cells)
    sigma = 0.1**3 / 12
    curve = LeakCurve(
        pressure=np.geomspace(1e-4, 1e-2, n), area_fraction=np.array(cells) / 576,
        mean_gap=np.full(n, 0.1), percolating=np.ones((n, 2), bool),
        sigma=np.full((n, 2), sigma), iterations=np.zeros(n, int), residual=np.zeros(n),
        flow_imbalance=np.zeros((n, 2)), flow_sigma_error=np.zeros((n, 2)), thresholds={},
        boundary="window", rms_gradient=1.0, window_lx=0.75, window_ly=0.75,
        window_shape=(24, 24))
    surface = Surface.from_array(np.zeros((32, 32)), lx=1.0, ly=1.0)
    return leak_dataset(curve, surface, scales=Scales(length=10e-6, modulus=1e9,
                                                      viscosity=1e-3),
                        fluid_pressure=1e3, seal_width=2e-3, seal_length=60e-3, name="t")


def rows_of(text: str, n: int) -> list[list[str]]:
    return [line.split() for line in text.splitlines()[3:3 + n]]


def test_the_table_gives_leak_rates_in_the_unit_asked_for():
    ds = table_dataset([100, 200])
    q_si = ds["leak_rate"].values[0]
    np.testing.assert_allclose(q_si, 2.5e-12, rtol=1e-12)  # dp = 1 kPa
    default = format_table(ds)
    assert default.splitlines()[2].split()[-2:] == ["m^3/s", "m^3/s"]
    for unit, per_si in (("mL/min", 6e7), ("uL/h", 3.6e12), ("mm^3/s", 1e9)):
        text = format_table(ds, rate_unit=unit)
        lines = text.splitlines()
        assert lines[1].split()[-2:] == ["Q_x", "Q_y"] and lines[2].split()[-2:] == [unit] * 2
        got = np.array([[float(v) for v in row[-2:]] for row in rows_of(text, 2)])
        np.testing.assert_allclose(got, q_si * per_si, rtol=TABLE_RTOL)
        # only the leak rates change
        assert [r[:-2] for r in rows_of(text, 2)] == [r[:-2] for r in rows_of(default, 2)]
    assert ds["leak_rate"].attrs["units"] == "m^3/s"
    with pytest.raises(InputError, match="rate_unit: 'bar' is not a volume rate"):
        format_table(ds, rate_unit="bar")


def test_a_long_unit_widens_the_columns_it_heads():
    text = format_table(table_dataset([100]), rate_unit="cm^3/minute")
    head, unit, row = text.splitlines()[1:4]
    assert unit.endswith(" cm^3/minute cm^3/minute")
    assert len(head) == len(unit) == len(row)


def test_the_table_marks_rows_of_few_contact_cells_apart_from_empty_ones():
    text = format_table(table_dataset([0, 1, 15, 16, 300]))
    assert [r[1] for r in rows_of(text, 5)] == [
        "0*", f"{1 / 576:.4g}~", f"{15 / 576:.4g}~", f"{16 / 576:.4g}", f"{300 / 576:.4g}"]
    notes = [line for line in text.splitlines() if line.startswith("note: ")]
    assert sum(n.startswith("note: * ") for n in notes) == 1
    [few] = [n for n in notes if n.startswith("note: ~ ")]
    assert "fewer than 16 of its 24 x 24 cells" in few and "under-resolved" in few
    # no such row, no note
    assert "note: ~" not in format_table(table_dataset([16, 300]))


N = 32  # 'window' drops 4 cells of each side (1/8): a 24 x 24 window


def heights() -> np.ndarray:
    """A low, slightly rough field with a tall asperity in the dropped border and a lower
    one of 2 x 2 cells in the window: at 1e-4 E* only the first touches, at 1e-3 E* the
    second too (4 window cells), at 1e-2 E* the field (measured: 0, 4 and 116 cells)."""
    h = 1e-3 * np.random.default_rng(0).standard_normal((N, N))
    h[1:3, 1:3] += 0.05
    h[15:17, 15:17] += 0.045
    return h


def test_leak_curve_warns_of_a_window_with_few_contact_cells(caplog):
    info = ScanInfo(source="test", reader="test", channel="h", length_scale=1e-6,
                    rms_gradient=1.0, detrend="none", fill="none", filled=0)
    scan = Surface(heights=heights(), lx=1.0, ly=1.0, scan=info)
    with caplog.at_level(logging.WARNING, logger="roughflow.leak"):
        c = leak_curve(scan, [1e-4, 1e-3, 1e-2], sealing=False)
    assert c.window_shape == (24, 24)
    # a_c is the window's mask averaged: a whole number of cells (to round-off, 1e-13)
    cells = c.area_fraction * 576
    np.testing.assert_allclose(cells, np.rint(cells), atol=1e-9)
    assert contact_cells(c.area_fraction, c.window_shape).tolist() == [0, 4, 116]
    assert few_cell_pressures(c.pressure, c.area_fraction, c.window_shape).tolist() == [1e-3]
    said = [r.getMessage() for r in caplog.records if r.name == "roughflow.leak"]
    assert len(said) == 2  # the empty window's warning, and this one
    assert "holds no contact cell at the nominal pressures 0.0001 E*" in said[0]
    assert said[1].startswith("the analysed window holds fewer than 16 contact cells at the "
                              "nominal pressures 0.001 E* (4 of its 24 x 24 cells)")
    assert "about 10 % of itself" in said[1]


@pytest.fixture(scope="module")
def scan_file(tmp_path_factory):
    """The scan through `roughflow import`: heights in nm over 1000 nm, so that L = 1 um
    and the dimensionless heights are those of :func:`heights`."""
    folder = tmp_path_factory.mktemp("few_cells")
    np.save(folder / "scan.npy", 1000 * heights())
    out = folder / "scan.nc"
    assert main(["import", str(folder / "scan.npy"), "--size", "1000nm", "--unit", "nm",
                 "--detrend", "none", "-o", str(out)]) == 0
    return out


#: E* = 1 GPa: 0.1, 1 and 10 MPa are 1e-4, 1e-3 and 1e-2 E*.
LEAK = ["--modulus", "1GPa", "--pressures", "0.1MPa,1MPa,10MPa", "--fluid-pressure", "1kPa",
        "--viscosity", "1mPa.s", "--seal-width", "2mm", "--seal-length", "60mm",
        "--no-sealing"]


def test_cli_prints_rates_in_the_unit_asked_for_and_writes_si(scan_file, tmp_path, capsys):
    capsys.readouterr()
    assert main(["leak", str(scan_file), *LEAK, "-o", str(tmp_path / "si.nc")]) == 0
    assert main(["leak", str(scan_file), *LEAK, "--rate-unit", "uL/min",
                 "-o", str(tmp_path / "ul.nc")]) == 0
    text, err = capsys.readouterr()
    table = text[text.rindex("scan: boundary"):]  # the second run's
    assert table.splitlines()[2].split()[-2:] == ["uL/min", "uL/min"]
    with xr.open_dataset(tmp_path / "si.nc") as si, xr.open_dataset(tmp_path / "ul.nc") as ul:
        # the file stays SI whatever the table says
        assert ul["leak_rate"].attrs["units"] == si["leak_rate"].attrs["units"] == "m^3/s"
        np.testing.assert_array_equal(ul["leak_rate"].values, si["leak_rate"].values)
        q_si = ul["leak_rate"].values[0]
    rows = rows_of(table, 3)
    got = np.array([[float(v) for v in row[-2:]] for row in rows])
    np.testing.assert_allclose(got, q_si * 6e10, rtol=TABLE_RTOL)
    # the marks: no contact cell in the window, 4 cells, 116 cells (none)
    assert [r[1] for r in rows] == ["0*", f"{4 / 576:.4g}~", f"{116 / 576:.4g}"]
    assert "note: ~ the analysed window holds contact on fewer than 16 of its 24 x 24" in table
    assert "fewer than 16 contact cells at the nominal pressures 0.001 E*" in err  # the log


@pytest.mark.parametrize("unit, match", [
    ("kg/s", "--rate-unit: 'kg/s' is not a volume rate"),
    ("xyz/min", "--rate-unit: cannot parse 'xyz/min'"),
    ("L", "--rate-unit: 'L' is not a volume rate"),
])
def test_cli_refuses_another_rate_unit_before_any_solve(scan_file, tmp_path, capsys,
                                                       monkeypatch, unit, match):
    import roughflow.leak as leak

    monkeypatch.setattr(leak, "leak_curve", lambda *a, **k: pytest.fail("it solved"))
    out = tmp_path / "leak.nc"
    with pytest.raises(SystemExit) as exc:
        main(["leak", str(scan_file), *LEAK, "--rate-unit", unit, "-o", str(out)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and match in err and "mL/min" in err
    assert not out.exists()
