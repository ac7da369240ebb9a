"""Rows of a leak curve whose analysed window holds no contact (roughflow.leak,
`roughflow leak`): at low load all of the contact of a measured scan lay in the border that
the default `window` treatment drops (the FRT example at 1 MPa: 3 cells, none in the window),
and the rows said a_c 0.0000 and a leak rate, like any other row, without a word."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.leak import empty_window_pressures, leak_curve
from roughflow.surface import ScanInfo, Surface

N = 32  # 'window' drops 4 cells of each side (1/8)


def heights() -> np.ndarray:
    """A low, slightly rough field with one tall asperity in the dropped border: at low load
    it alone touches; at 1e-2 E* the field does too (measured: 0 and 204 of the 24 x 24
    window's cells at 1e-4 and 1e-2 E*)."""
    h = 1e-3 * np.random.default_rng(0).standard_normal((N, N))
    h[1:3, 1:3] += 0.05
    return h


def border_asperity_scan() -> Surface:
    info = ScanInfo(source="test", reader="test", channel="h", length_scale=1e-6,
                    rms_gradient=1.0, detrend="none", fill="none", filled=0)
    return Surface(heights=heights(), lx=1.0, ly=1.0, scan=info)


def test_a_window_without_contact_is_found_and_warned(caplog):
    with caplog.at_level(logging.WARNING, logger="roughflow.leak"):
        c = leak_curve(border_asperity_scan(), [1e-4, 1e-2], sealing=False)
    assert c.boundary == "window" and c.window_shape == (24, 24)
    assert c.area_fraction[0] == 0.0 and c.area_fraction[1] > 0
    # the row still has a gap and a leak rate: those of a window held open from outside
    assert c.percolating[0].all() and (c.sigma[0] > 0).all()
    assert empty_window_pressures(c.pressure, c.area_fraction).tolist() == [1e-4]
    said = [r.getMessage() for r in caplog.records if r.name == "roughflow.leak"]
    assert len(said) == 1
    assert "holds no contact cell at the nominal pressures 0.0001 E*" in said[0]
    assert "boundary 'mirror'" in said[0]


def test_the_whole_scan_analysed_always_holds_the_contact(caplog):
    """mirror analyses the whole scan: the same load has its contact cells there."""
    with caplog.at_level(logging.WARNING, logger="roughflow.leak"):
        c = leak_curve(border_asperity_scan(), [1e-4], boundary="mirror", sealing=False)
    assert c.area_fraction[0] > 0
    assert "no contact cell" not in caplog.text


def test_a_tiny_contact_area_is_not_an_empty_window():
    # one contact cell carries load in the window: only exactly 0 marks a row
    assert empty_window_pressures([0.1, 0.2], [0.0, 1e-6]).tolist() == [0.1]


@pytest.fixture(scope="module")
def scan_file(tmp_path_factory):
    """The scan through `roughflow import`: heights in nm over 1000 nm, so that L = 1 um
    and the dimensionless heights are those of :func:`heights`."""
    folder = tmp_path_factory.mktemp("empty_window")
    np.save(folder / "scan.npy", 1000 * heights())
    out = folder / "scan.nc"
    assert main(["import", str(folder / "scan.npy"), "--size", "1000nm", "--unit", "nm",
                 "--detrend", "none", "-o", str(out)]) == 0
    return out


def test_cli_marks_the_row_and_says_why(scan_file, tmp_path, capsys):
    out = tmp_path / "leak.nc"
    capsys.readouterr()
    # E* = 1 GPa: 0.1 MPa and 10 MPa are 1e-4 and 1e-2 E*
    assert main(["leak", str(scan_file), "--modulus", "1GPa", "--pressures", "0.1MPa,10MPa",
                 "--fluid-pressure", "1kPa", "--viscosity", "1mPa.s", "--seal-width", "2mm",
                 "--seal-length", "60mm", "--no-sealing", "-o", str(out)]) == 0
    text, err = capsys.readouterr()
    rows = text.splitlines()[3:5]
    assert rows[0].split()[1] == "0*" and "*" not in rows[1]
    assert "note: * the analysed window holds no contact cell" in text
    assert "--boundary mirror" in text
    assert "holds no contact cell at the nominal pressures 0.0001 E*" in err  # the log too
    with xr.open_dataset(out) as ds:
        assert ds["area_fraction"].values[0, 0] == 0.0 < ds["area_fraction"].values[0, 1]
