"""Reading measured scans (roughflow.scan, `roughflow import`): formats written by the test
with writers the reader supports, units, detrending, missing points and refusals."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.errors import InputError
from roughflow.io import read_surface
from roughflow.scan import (
    detrend,
    fill_missing,
    largest_defined_window,
    level_lines,
    parse_crop,
    read_scan,
)

ST = pytest.importorskip("SurfaceTopography")
DATA = Path(__file__).resolve().parent / "data"

UM = 1e-6


def heights(nx=16, ny=12, seed=0) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(nx, ny))


def check_scaled(surface, h_m: np.ndarray, lx_m: float, ly_m: float) -> None:
    """The surface is h_m (metres) on lx_m x ly_m in units of L = sqrt(lx_m ly_m)."""
    L = np.sqrt(lx_m * ly_m)
    assert surface.scan.length_scale == pytest.approx(L, rel=1e-12)
    assert surface.lx == pytest.approx(lx_m / L) and surface.ly == pytest.approx(ly_m / L)
    np.testing.assert_allclose(surface.heights * L, h_m, rtol=1e-6, atol=1e-12 * UM)


def test_netcdf_written_by_surfacetopography_gives_size_and_unit(tmp_path):
    h = heights()
    ST.Topography(h, (2.0, 1.5), unit="um").to_netcdf(str(tmp_path / "scan.nc"))
    s = read_scan(tmp_path / "scan.nc", detrend_mode="none")
    check_scaled(s, h * UM, 2 * UM, 1.5 * UM)
    assert s.scan.filled == 0 and not s.periodic and s.scan.detrend == "none"
    # the file gives its size: a --size of our own is refused, naming it
    with pytest.raises(InputError, match="already gives its size"):
        read_scan(tmp_path / "scan.nc", size="3um")


def test_a_refused_scan_leaves_its_reader_closed(tmp_path, monkeypatch):
    # a refusal after the file is open (its size given twice) closes the reader too: a
    # session that imports many scans held one open file per refused one
    import roughflow.scan.read as scan

    closed = []
    monkeypatch.setattr(scan, "_close", lambda reader: closed.append(type(reader).__name__))
    ST.Topography(heights(), (2.0, 1.5), unit="um").to_netcdf(str(tmp_path / "scan.nc"))
    with pytest.raises(InputError, match="already gives its size"):
        read_scan(tmp_path / "scan.nc", size="3um")
    assert len(closed) == 1
    read_scan(tmp_path / "scan.nc")
    assert len(closed) == 2  # and once, not twice, on success


def test_npy_needs_size_and_unit(tmp_path):
    h = heights()
    np.save(tmp_path / "scan.npy", h)
    with pytest.raises(InputError, match="unit"):
        read_scan(tmp_path / "scan.npy", size="2um,1.5um")
    with pytest.raises(InputError, match="physical size"):
        read_scan(tmp_path / "scan.npy", unit="nm")
    s = read_scan(tmp_path / "scan.npy", size="2um,1.5um", unit="nm", detrend_mode="none")
    check_scaled(s, h * 1e-9, 2 * UM, 1.5 * UM)
    # numbers alone are in --unit; heights in another unit via height_unit
    s = read_scan(tmp_path / "scan.npy", size="2000,1500", unit="nm", height_unit="um",
                  detrend_mode="none")
    check_scaled(s, h * UM, 2 * UM, 1.5 * UM)


def test_cli_import_passes_the_height_unit(tmp_path):
    """`roughflow import` once dropped --height-unit: the heights were read in --unit (nm),
    1000 times too small against heights in um. The command's surface is read_scan's, and
    both are the raw numbers in um."""
    h = heights()
    np.save(tmp_path / "scan.npy", h)
    out = tmp_path / "s.nc"
    assert main(["import", str(tmp_path / "scan.npy"), "--size", "2000,1500", "--unit", "nm",
                 "--height-unit", "um", "--detrend", "none", "-o", str(out)]) == 0
    got = read_surface(out)
    check_scaled(got, h * UM, 2 * UM, 1.5 * UM)
    want = read_scan(tmp_path / "scan.npy", size="2000,1500", unit="nm", height_unit="um",
                     detrend_mode="none")
    np.testing.assert_array_equal(got.heights, want.heights)
    assert got.scan.length_scale == want.scan.length_scale


def test_npy_missing_unit_and_size_are_named_together(tmp_path):
    # they were refused one per run; and a size in units with height_unit= was refused for
    # lacking unit=, which would have said nothing more
    h = heights()
    np.save(tmp_path / "scan.npy", h)
    with pytest.raises(InputError, match=r"its length unit, of the heights and sizes: pass "
                                         r"unit= \(CLI --unit\).*, nor its physical size"):
        read_scan(tmp_path / "scan.npy")
    by_height_unit = read_scan(tmp_path / "scan.npy", size="2mm,1.5mm", height_unit="um",
                               detrend_mode="none")
    by_unit = read_scan(tmp_path / "scan.npy", size="2mm,1.5mm", unit="um",
                        detrend_mode="none")
    np.testing.assert_array_equal(by_height_unit.heights, by_unit.heights)
    assert by_height_unit.scan.length_scale == by_unit.scan.length_scale
    with pytest.raises(InputError, match="has no unit"):  # bare numbers need unit=
        read_scan(tmp_path / "scan.npy", size="2,1.5", height_unit="um")


def test_a_size_with_units_and_no_unit_asks_for_the_heights_unit(tmp_path, capsys, caplog):
    """`import afm-64.npy --size 500nm` said the file "does not give its length unit: pass
    unit=", blaming the unit the user had just given; the heights' unit is missing."""
    np.save(tmp_path / "scan.npy", heights())
    said = ("does not give the unit of its heights (the size '2mm,1.5mm' gives only the "
            "lateral one): pass it as unit= or height_unit= (CLI --unit or --height-unit)")
    with pytest.raises(InputError, match=re.escape(said)):
        read_scan(tmp_path / "scan.npy", size="2mm,1.5mm")
    # bare numbers in the size still need unit=, which the message names
    with pytest.raises(InputError, match=r"its length unit, of the heights and sizes"):
        read_scan(tmp_path / "scan.npy", size="2,1.5")
    # the warning on an implausible gradient no longer reads the size in the heights' unit
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        read_scan(tmp_path / "scan.npy", size="2mm,1.5mm", unit="furlong")
    assert "read in furlong and the lateral sizes as given ('2mm,1.5mm')" in caplog.text
    out = tmp_path / "s.nc"
    with pytest.raises(SystemExit) as exc:
        main(["import", str(tmp_path / "scan.npy"), "--size", "2mm,1.5mm", "-o", str(out)])
    assert exc.value.code == 2 and said in capsys.readouterr().err


def test_truncated_npy_refused_before_reading(tmp_path):
    # a cut .npy was read past its end (a different map on each run, once exit 0 with a
    # complete-looking file); the CLI now exits 2 naming it and writes nothing
    np.save(tmp_path / "scan.npy", np.arange(64.0 * 64).reshape(64, 64))
    data = (tmp_path / "scan.npy").read_bytes()
    (tmp_path / "cut.npy").write_bytes(data[:300])
    with pytest.raises(InputError, match="truncated"):
        read_scan(tmp_path / "cut.npy", size="1um", unit="um")
    (tmp_path / "junk.npy").write_bytes(b"garbage")
    with pytest.raises(InputError, match="not a valid .npy"):
        read_scan(tmp_path / "junk.npy", size="1um", unit="um")
    out = tmp_path / "cut.nc"
    with pytest.raises(SystemExit) as exc:
        main(["import", str(tmp_path / "cut.npy"), "--size", "1um", "--unit", "um",
              "-o", str(out)])
    assert exc.value.code == 2
    assert not out.exists()


def test_plain_text_written_by_numpy(tmp_path):
    h = heights()
    # SurfaceTopography's plain-text reader takes a row as a line along x (rows are y):
    # write the transpose so that the file holds h[ix, iy]
    np.savetxt(tmp_path / "scan.txt", h.T)
    s = read_scan(tmp_path / "scan.txt", size="2mm,1.5mm", unit="mm", detrend_mode="none")
    check_scaled(s, h * 1e-3, 2e-3, 1.5e-3)


@pytest.mark.parametrize("token", ["-", "NA", "***", "1.0.0"])
def test_a_text_line_the_reader_would_drop_is_refused(tmp_path, token):
    """SurfaceTopography's text reader skipped a line holding a token it cannot read (a
    common export's mark of a missing point) and imported 127 of 128 lines, every later line
    moved by one: it is refused, naming the line and the token. A nan is a missing point."""
    h = heights()
    lines = [" ".join(f"{v:.6g}" for v in row) for row in h.T]  # a line along x per row
    row = lines[4].split()
    row[2] = token
    lines[4] = " ".join(row)
    (tmp_path / "gap.txt").write_text("\n".join(lines) + "\n")
    expected = (f"kept {h.shape[1] - 1} of the {h.shape[1]} lines.*"
                + re.escape(f"line 5 holds {token!r}"))
    with pytest.raises(InputError, match=expected):
        read_scan(tmp_path / "gap.txt", size="2mm,1.5mm", unit="mm", fill="harmonic")
    row[2] = "nan"
    lines[4] = " ".join(row)
    (tmp_path / "nan.txt").write_text("\n".join(lines) + "\n")
    s = read_scan(tmp_path / "nan.txt", size="2mm,1.5mm", unit="mm", fill="harmonic")
    assert s.shape == h.shape and s.scan.filled == 1


def test_a_header_line_of_as_many_words_is_not_a_dropped_line(tmp_path):
    """The dropped-line check counts lines of nx values; a header of nx words is not one."""
    h = 0.01 * heights(4, 6)  # 4 values a line: a header "w x y z" has as many words
    lines = [" ".join(f"{v:.6g}" for v in row) for row in h.T]
    (tmp_path / "head.txt").write_text("w x y z\n" + "\n".join(lines) + "\n")
    s = read_scan(tmp_path / "head.txt", size="4mm,6mm", unit="mm", detrend_mode="none")
    assert s.shape == (4, 6)


def test_heights_in_the_wrong_unit_draw_a_warning(tmp_path, caplog):
    """Heights in nm imported as um ran through with an rms gradient of 884 and a leak rate
    1e9 times too large; an rms gradient outside SCAN_GRADIENT_WARN names the units."""
    h = 0.01 * heights()  # rms gradient 0.15 on mm pixels
    np.save(tmp_path / "h.npy", h)
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        right = read_scan(tmp_path / "h.npy", size="2mm,1.5mm", unit="mm")
    assert caplog.text == ""
    for height_unit, factor in (("m", 1e3), ("nm", 1e-6)):
        caplog.clear()
        with caplog.at_level("WARNING", logger="roughflow.scan"):
            wrong = read_scan(tmp_path / "h.npy", size="2mm,1.5mm", unit="mm",
                              height_unit=height_unit)
        assert wrong.scan.rms_gradient == pytest.approx(factor * right.scan.rms_gradient)
        assert "rms gradient is" in caplog.text and f"read in {height_unit}" in caplog.text


def test_swapped_axes_draw_a_warning_about_the_pixels(tmp_path, caplog):
    # np.savetxt of an [x, y] array: the reader takes it as [y, x], and the size given for
    # (x, y) then makes rectangular pixels; nothing said so, and every wavelength was off
    h = heights()
    assert h.shape[0] != h.shape[1]
    size = f"{h.shape[0]}um,{h.shape[1]}um"  # square pixels of 1 um in the array's order
    np.savetxt(tmp_path / "xy.txt", h)
    np.savetxt(tmp_path / "yx.txt", h.T)
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        swapped = read_scan(tmp_path / "xy.txt", size=size, unit="um")
    assert swapped.shape == h.shape[::-1]
    assert "the pixels are" in caplog.text and "axes are swapped" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        right = read_scan(tmp_path / "yx.txt", size=size, unit="um")
    assert right.shape == h.shape and caplog.text == ""


def test_repository_scan_imports():
    s = read_scan(DATA / "afm-64.npy", size="500nm", unit="nm")
    assert s.shape == (64, 64) and s.scan.length_scale == pytest.approx(500e-9)
    # the AFM scan's rms gradient is about 0.77 at full resolution; the 8x8 block average
    # smooths the shortest wavelengths away. Independently: the plane fitted by least squares
    # over the grid indices, and forward differences inside the map (rms of each axis's
    # differences, a scan being non-periodic), in metres; equal up to round-off
    h = np.load(DATA / "afm-64.npy").astype(float) * 1e-9
    i, j = np.meshgrid(np.arange(64), np.arange(64), indexing="ij")
    a = np.stack([np.ones(h.size), i.ravel(), j.ravel()], axis=1)
    r = h - (a @ np.linalg.lstsq(a, h.ravel(), rcond=None)[0]).reshape(h.shape)
    d = 500e-9 / 64
    g = np.sqrt(np.mean((np.diff(r, axis=0) / d) ** 2) + np.mean((np.diff(r, axis=1) / d) ** 2))
    assert s.scan.rms_gradient == pytest.approx(g, rel=1e-9)
    assert 0.2 < g < 0.77
    assert abs(s.heights.mean()) < 1e-12  # the plane fit removed the mean


def test_missing_points_refused_unless_filled(tmp_path):
    h = heights()
    h[3:5, 4] = np.nan
    h[0, 0] = np.nan
    np.save(tmp_path / "scan.npy", h)
    with pytest.raises(InputError, match="3 missing points"):
        read_scan(tmp_path / "scan.npy", size="1um", unit="um")
    s = read_scan(tmp_path / "scan.npy", size="1um", unit="um", fill="min",
                  detrend_mode="none")
    assert s.scan.filled == 3 and s.scan.fill == "min"
    ok = np.isfinite(h)
    assert np.all(s.heights[~ok] == pytest.approx(s.heights[ok].min()))
    s = read_scan(tmp_path / "scan.npy", size="1um", unit="um", fill="harmonic")
    assert s.scan.filled == 3 and np.isfinite(s.heights).all()
    # masked points of a SurfaceTopography file count as missing too
    m = np.ma.masked_array(heights(), mask=np.zeros((16, 12), bool))
    m.mask[5, 5] = True
    ST.Topography(m, (1.0, 1.0), unit="um").to_netcdf(str(tmp_path / "m.nc"))
    with pytest.raises(InputError, match=r"has 1 missing point \(.*crop it away"):
        read_scan(tmp_path / "m.nc")
    # cropping the missing points away needs no fill
    s = read_scan(tmp_path / "m.nc", crop="6:,:")
    assert s.shape == (10, 12) and s.scan.filled == 0 and s.scan.crop == "6:16,0:12"


def _largest_by_brute_force(missing: np.ndarray) -> int:
    """Points of the largest window without a missing point, by trying every window
    (prefix sums count the missing points of each)."""
    nx, ny = missing.shape
    c = np.zeros((nx + 1, ny + 1), int)
    c[1:, 1:] = missing.cumsum(0).cumsum(1)
    best = 0
    for i0 in range(nx):
        for i1 in range(i0 + 1, nx + 1):
            for j0 in range(ny):
                for j1 in range(j0 + 1, ny + 1):
                    if c[i1, j1] - c[i0, j1] - c[i1, j0] + c[i0, j0] == 0:
                        best = max(best, (i1 - i0) * (j1 - j0))
    return best


@pytest.mark.parametrize("seed", range(12))
def test_largest_defined_window_is_the_largest(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(3, 11, size=2))
    missing = rng.random(shape) < rng.choice([0.05, 0.15, 0.3])
    sx, sy = largest_defined_window(missing)
    assert not missing[sx, sy].any()
    assert missing[sx, sy].size == _largest_by_brute_force(missing)


def test_largest_defined_window_of_edge_cases():
    assert largest_defined_window(np.zeros((5, 3), bool)) == (slice(0, 5), slice(0, 3))
    sx, sy = largest_defined_window(np.ones((4, 4), bool))
    assert np.zeros((4, 4))[sx, sy].size == 0
    # a border of missing points, as on a profiler scan of a sample smaller than the field
    missing = np.ones((20, 16), bool)
    missing[3:17, 2:13] = False
    missing[:, 0] = False  # a defined column beside the border does not widen the window
    assert largest_defined_window(missing) == (slice(3, 17), slice(2, 13))
    with pytest.raises(InputError, match="2D"):
        largest_defined_window(np.zeros(5, bool))


def test_crop_defined_keeps_the_largest_window_without_missing_points(tmp_path, caplog):
    h = 0.01 * heights(24, 20)  # rms gradient 0.4: no warning about the units
    h[:, :3] = np.nan  # a border, as around a sample smaller than the field of view
    h[21:, :] = np.nan
    h[10, 12] = np.nan  # and one hole inside
    np.save(tmp_path / "scan.npy", h)
    opts = {"size": "1.2um,1um", "unit": "um"}  # square pixels of 0.05 um
    with pytest.raises(InputError, match=r"largest window without missing points is "
                                         r"0:21,3:12 .*crop='defined'"):
        read_scan(tmp_path / "scan.npy", **opts)
    s = read_scan(tmp_path / "scan.npy", crop="defined", detrend_mode="none", **opts)
    assert s.scan.crop == "0:21,3:12" and s.scan.filled == 0 and s.shape == (21, 9)
    check_scaled(s, h[:21, 3:12] * UM, 21 * 0.05 * UM, 9 * 0.05 * UM)
    # the same window given by hand gives the same surface
    by_hand = read_scan(tmp_path / "scan.npy", crop="0:21,3:12", detrend_mode="none", **opts)
    np.testing.assert_array_equal(s.heights, by_hand.heights)
    # a large fill is reported with where the defined window lies; a small one is not
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        read_scan(tmp_path / "scan.npy", fill="harmonic", **opts)
    assert "% of the points are missing and filled" in caplog.text
    assert "0:21,3:12" in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        read_scan(tmp_path / "scan.npy", fill="harmonic", crop="0:21,3:20", **opts)
    assert caplog.text == ""  # 1 of 357 points filled
    # inside a crop given by hand the hint names file indices and no crop='defined'
    with pytest.raises(InputError, match=r"is 0:10,3:20 \(10 x 17 points, 85 % of the "
                                         r"points\)$"):
        read_scan(tmp_path / "scan.npy", crop=":10,:", **opts)


def test_crop_defined_refuses_a_window_too_small(tmp_path):
    h = heights(12, 12)
    h[::3, :] = np.nan  # defined strips 2 points wide
    np.save(tmp_path / "scan.npy", h)
    with pytest.raises(InputError, match="crop='defined'.*at least 4 x 4"):
        read_scan(tmp_path / "scan.npy", size="1um", unit="um", crop="defined")


def test_crop_beyond_the_grid_is_refused_not_clamped():
    assert parse_crop("0:12,2:", (12, 10)) == (slice(0, 12), slice(2, None))
    with pytest.raises(InputError, match="index 13 along x.*12 points"):
        parse_crop("0:13,:", (12, 10))
    with pytest.raises(InputError, match="index 40 along y.*10 points"):
        parse_crop(":,30:40", (12, 10))


def test_harmonic_fill_is_exact_for_a_plane_inside():
    plane = np.add.outer(0.3 * np.arange(20.0), -0.7 * np.arange(15.0))
    miss = np.zeros(plane.shape, bool)
    miss[3:8, 4:9] = True
    miss[12, 1:3] = True
    filled = fill_missing(np.where(miss, 0.0, plane), miss, "harmonic")
    np.testing.assert_allclose(filled, plane, atol=1e-12)


def test_harmonic_fill_has_zero_normal_slope_at_the_scan_s_edges():
    """Outside the scan nothing is known: the fill's edges are Neumann (zero normal slope),
    so a constant field is filled with that constant wherever the missing points touch the
    edge or a corner. An edge taken as a fixed value (say 0 outside) pulls them towards it.
    The solve is a sparse direct one: round-off only, hence 1e-12."""
    field = np.full((20, 15), 2.5)
    miss = np.zeros(field.shape, bool)
    miss[:3, :2] = True  # a corner
    miss[8:13, -1] = True  # along the last column
    miss[-1, 5:9] = True  # along the last row
    filled = fill_missing(np.where(miss, 0.0, field), miss, "harmonic")
    np.testing.assert_allclose(filled, field, rtol=0, atol=1e-12)


def test_detrend_removes_plane_and_curvature_exactly():
    x = np.linspace(-1, 1, 20)[:, None]
    y = np.linspace(-1, 1, 15)[None, :]
    # a residual of the curvature fit is orthogonal to every fitted function: adding a plane
    # or a quadratic and detrending again gives it back
    rough = detrend(heights(20, 15, seed=3), 1, 1, "curvature")
    tilt = 2.0 + 3.0 * x - 1.5 * y
    np.testing.assert_allclose(detrend(rough + tilt, 1, 1, "plane"), rough, atol=1e-12)
    quad = tilt + 0.8 * x * x - 0.4 * x * y + 1.1 * y * y
    np.testing.assert_allclose(detrend(rough + quad, 1, 1, "curvature"), rough, atol=1e-12)
    np.testing.assert_array_equal(detrend(rough + quad, 1, 1, "none"), rough + quad)


def line_artefacts(shape, axis, seed=5) -> np.ndarray:
    """Random offsets and tilts of the lines along ``axis`` (scan-line drift of an AFM)."""
    rng = np.random.default_rng(seed)
    n_along, n_lines = shape[axis], shape[1 - axis]
    t = np.linspace(-1, 1, n_along)[:, None]
    a = 3.0 * rng.normal(size=n_lines) + 2.0 * rng.normal(size=n_lines) * t
    return a if axis == 0 else a.T


@pytest.mark.parametrize("axis, mode", [(0, "lines-x"), (1, "lines-y")])
def test_line_levelling_removes_line_offsets_and_tilts_exactly(axis, mode):
    # A levelled surface has zero mean and tilt on every line, so adding any offset and
    # tilt per line and levelling again gives it back (to round-off); a plane cannot remove
    # them (the grooves they make stay), and levelling across the lines would not either
    rough = level_lines(heights(20, 15, seed=3), axis)
    t = np.linspace(-1, 1, rough.shape[axis])
    t = t[:, None] if axis == 0 else t[None, :]
    np.testing.assert_allclose(rough.mean(axis=axis), 0.0, atol=1e-12)
    np.testing.assert_allclose((rough * t).mean(axis=axis), 0.0, atol=1e-12)
    scanned = rough + line_artefacts(rough.shape, axis)
    np.testing.assert_allclose(level_lines(scanned, axis), rough, atol=1e-12)
    np.testing.assert_array_equal(detrend(scanned, 1, 1, mode), level_lines(scanned, axis))
    assert np.abs(detrend(scanned, 1, 1, "plane") - rough).max() > 1.0
    assert np.abs(level_lines(scanned, 1 - axis) - rough).max() > 1.0


def test_line_levelling_fits_the_defined_points_only():
    # Missing points hold anything (here 1e6, and nan on one line) and must not enter the
    # fit: on the defined points the result is that of the same surface without them. A
    # line with a single defined point loses its height there; a line with none is left as
    # it is (the fill replaces it afterwards)
    clean = heights(20, 15, seed=4)
    defined = np.ones(clean.shape, bool)
    defined[3:9, 2] = False
    defined[:, 5] = False
    defined[:, 6] = False
    defined[11, 6] = True
    scanned = np.where(defined, clean + line_artefacts(clean.shape, 0), 1e6)
    scanned[3:9, 2] = np.nan
    got = level_lines(scanned, 0, defined)
    assert np.isfinite(got[defined]).all()
    ref = level_lines(np.where(defined, clean, 1e6), 0, defined)
    np.testing.assert_allclose(got[defined], ref[defined], atol=1e-9)
    full = np.delete(np.arange(15), [2, 5, 6])
    np.testing.assert_allclose(got[:, full], level_lines(clean, 0)[:, full], atol=1e-9)
    assert got[11, 6] == 0.0
    np.testing.assert_array_equal(got[:, 5], scanned[:, 5])
    # line 2: the mean and tilt of its 14 defined points only
    ok = defined[:, 2]
    t = np.linspace(-1, 1, 20)
    fit = np.polyval(np.polyfit(t[ok], clean[ok, 2], 1), t)
    np.testing.assert_allclose(got[ok, 2], (clean[:, 2] - fit)[ok], atol=1e-9)


def test_line_levelling_refuses_bad_input_naming_it():
    h = heights()
    for axis in (2, -1, True, 1.0, "X"):
        with pytest.raises(InputError, match="axis"):
            level_lines(h, axis)
    with pytest.raises(InputError, match=r"defined has shape \(3, 4\)"):
        level_lines(h, 0, np.ones((3, 4), bool))
    with pytest.raises(InputError, match="2D"):
        level_lines(h[0], 0)


def test_scan_lines_levelled_on_import(tmp_path):
    # `roughflow import --detrend lines-x` levels the lines along x and records it; with
    # the default plane fit the steps between neighbouring lines (offsets of rms 6 against
    # unit roughness) stay and more than double the rms gradient
    rough = level_lines(heights(32, 24, seed=6), 0)
    np.save(tmp_path / "scan.npy", rough + 2.0 * line_artefacts(rough.shape, 0))
    kw = {"size": "2um,1.5um", "unit": "um"}
    s = read_scan(tmp_path / "scan.npy", detrend_mode="lines-x", **kw)
    assert s.scan.detrend == "lines-x"
    check_scaled(s, rough * UM, 2 * UM, 1.5 * UM)
    plane = read_scan(tmp_path / "scan.npy", **kw)
    assert plane.scan.rms_gradient > 2 * s.scan.rms_gradient
    main(["import", str(tmp_path / "scan.npy"), "--size", "2um,1.5um", "--unit", "um",
          "--detrend", "lines-x", "-o", str(tmp_path / "s.nc"), "-q"])
    np.testing.assert_allclose(read_surface(tmp_path / "s.nc").heights, s.heights, atol=1e-15)


@pytest.mark.parametrize("kwargs, match", [
    ({"size": "0um", "unit": "um"}, "positive"),
    ({"size": "-2um", "unit": "um"}, "positive"),
    ({"size": "2furlongz", "unit": "um"}, "furlongz"),
    ({"size": "2um", "unit": "kg"}, "not a length"),
    ({"size": "2um", "unit": "um", "crop": "0:2,:"}, "at least 4 x 4"),
    ({"size": "2um", "unit": "um", "crop": "zero"}, "i0:i1,j0:j1"),
    ({"size": "2um", "unit": "um", "crop": "defined:"}, "'defined'"),
    ({"size": "2um", "unit": "um", "detrend_mode": "cubic"}, "cubic"),
    ({"size": "2um", "unit": "um", "fill": "zero"}, "zero"),
    ({"size": "2um", "unit": "um", "channel": "phase"}, "phase"),
])
def test_bad_options_are_refused_naming_them(tmp_path, kwargs, match):
    np.save(tmp_path / "scan.npy", heights())
    with pytest.raises(InputError, match=match):
        read_scan(tmp_path / "scan.npy", **kwargs)


def test_a_file_that_is_not_a_topography_is_refused(tmp_path):
    bad = tmp_path / "notes.txt"
    bad.write_text("this is not a height map\nat all\n")
    with pytest.raises(InputError, match="notes.txt"):
        read_scan(bad, size="1um", unit="um")
    with pytest.raises(InputError, match="does not exist"):
        read_scan(tmp_path / "missing.di")


def test_cli_import_round_trip(tmp_path, capsys):
    out = tmp_path / "s.nc"
    assert main(["import", str(DATA / "afm-64.npy"), "--size", "500nm", "--unit", "nm",
                 "-o", str(out)]) == 0
    assert "64 x 64 points" in capsys.readouterr().out
    s = read_surface(out)
    assert s.scan.length_scale == pytest.approx(500e-9) and s.scan.reader.startswith("NumPy")
    direct = read_scan(DATA / "afm-64.npy", size="500nm", unit="nm")
    np.testing.assert_array_equal(s.heights, direct.heights)
    assert s.scan == direct.scan


def test_cli_import_crop_defined_prints_the_window(tmp_path, capsys):
    h = heights(12, 10)
    h[:2, :] = np.nan
    np.save(tmp_path / "b.npy", h)
    assert main(["import", str(tmp_path / "b.npy"), "--size", "1um", "--unit", "um",
                 "--crop", "defined", "-o", str(tmp_path / "s.nc")]) == 0
    out = capsys.readouterr().out
    assert "10 x 10 points" in out and "crop 2:12,0:10" in out
    assert read_surface(tmp_path / "s.nc").scan.crop == "2:12,0:10"


def test_cli_warns_where_a_scan_is_solved_as_a_periodic_cell(tmp_path, capsys):
    """contact, threshold and flow solve a periodic cell; only leak treats a scan's edges,
    so the three say so for a non-periodic scan, and only for one."""
    np.save(tmp_path / "h.npy", heights(16, 16))
    for name, extra in (("scan", []), ("periodic", ["--periodic"])):
        assert main(["import", str(tmp_path / "h.npy"), "--size", "1um", "--unit", "um",
                     *extra, "-o", str(tmp_path / f"{name}.nc")]) == 0
    assert main(["surface", "--nx", "16", "--ny", "16", "--lambda-r", "1", "--lambda-s", "0.25",
                 "-o", str(tmp_path / "gen.nc")]) == 0
    capsys.readouterr()
    for name, warned in (("scan", True), ("periodic", False), ("gen", False)):
        surface, contact = str(tmp_path / f"{name}.nc"), str(tmp_path / f"c_{name}.nc")
        runs = {"contact": ["contact", surface, "--pressure", "0.05", "-o", contact],
                "flow": ["flow", contact, "-o", str(tmp_path / f"f_{name}.nc")],
                "threshold": ["threshold", surface, "--model", "bearing",
                              "-o", str(tmp_path / f"t_{name}.nc")]}
        for command, argv in runs.items():
            assert main(argv) == 0
            err = capsys.readouterr().err
            assert ("non-periodic scan" in err) == warned, (name, command, err)
            assert (f"`roughflow {command}` solves it as a periodic cell" in err) == warned
    # the scan's length unit reaches the flow file under its own name (it was renamed
    # contact_ref_length_m, and units.registry of the flow file could not convert lengths)
    from roughflow.units import registry

    with xr.open_dataset(tmp_path / "f_scan.nc") as fl:
        assert registry(fl.attrs).Quantity(1.0, "ref_length").to("um").magnitude == \
            pytest.approx(1.0)
        assert "contact_ref_length_m" not in fl.attrs
    # the bearing contact is local: nothing wraps
    assert main(["contact", str(tmp_path / "scan.nc"), "--model", "bearing",
                 "--area-fraction", "0.3", "-o", str(tmp_path / "b.nc")]) == 0
    assert "non-periodic" not in capsys.readouterr().err


def test_cli_import_refusal_exits_2(tmp_path, capsys):
    np.save(tmp_path / "n.npy", np.where(np.eye(8, 6) > 0, np.nan, 1.0))
    with pytest.raises(SystemExit) as exc:
        main(["import", str(tmp_path / "n.npy"), "--size", "1um", "--unit", "um",
              "-o", str(tmp_path / "s.nc")])
    assert exc.value.code == 2
    assert "6 missing points" in capsys.readouterr().err
    assert not (tmp_path / "s.nc").exists()


def _fake_reader(monkeypatch, tmp_path, channels):
    """read_scan on a stand-in for a SurfaceTopography reader with these channels."""
    from types import SimpleNamespace

    import roughflow.scan.read as scan

    reader = SimpleNamespace(channels=channels, default_channel=channels[0],
                             name=lambda: "fake")
    monkeypatch.setattr(scan, "_open", lambda path: reader)
    (tmp_path / "scan.fake").write_bytes(b"x")
    return tmp_path / "scan.fake"


def _fake_channel(index, name, unit):
    from types import SimpleNamespace

    return SimpleNamespace(index=index, name=name, unit=unit, dim=2, is_uniform=True,
                           physical_sizes=(np.float64(500.0), np.float64(500.0)),
                           nb_grid_pts=(8, 8))


def test_a_channel_that_is_not_a_height_map_is_named(monkeypatch, tmp_path):
    # an AFM phase channel (units ('nm', None)) failed with 'cannot parse "1 ('nm', None)"'
    chans = [_fake_channel(0, "Height", "nm"), _fake_channel(2, "Phase", ("nm", None))]
    path = _fake_reader(monkeypatch, tmp_path, chans)
    with pytest.raises(InputError, match="channel 'Phase' is not a height map.*0: Height"):
        read_scan(path, channel="Phase")
    # the file's size is quoted as plain numbers, not numpy's repr
    with pytest.raises(InputError, match=r"already gives its size 500 x 500 nm: drop "
                                         r"size='1um' \(CLI --size\)"):
        read_scan(path, size="1um")
    # the option to drop is named for the command line too, and only the one given
    with pytest.raises(InputError, match=r"already gives its unit \(nm\): drop "
                                         r"height_unit='um' \(CLI --height-unit\)$"):
        read_scan(path, height_unit="um")


def test_channel_label_says_which_of_two_same_named_channels():
    from types import SimpleNamespace

    from roughflow.scan.read import _channel_label

    trace, retrace, phase = (_fake_channel(0, "Height", "nm"), _fake_channel(1, "Height", "nm"),
                             _fake_channel(2, "Phase", ("nm", None)))
    reader = SimpleNamespace(channels=[trace, retrace, phase])
    assert _channel_label(reader, retrace) == "Height (channel 1)"
    assert _channel_label(reader, phase) == "Phase"


# --- files researchers export from their own tools (a helper's audit of formats) ---


def test_a_text_header_gives_the_size_unit_which_is_kept(tmp_path):
    """A header "Width: 20 um" without a unit for the values: SurfaceTopography keeps the
    number and drops its unit, and --unit nm read the scan as 20 nm wide (1000x off)."""
    h = heights()
    np.savetxt(tmp_path / "p.txt", h.T, header="Width: 16 um\nHeight: 12 um")
    s = read_scan(tmp_path / "p.txt", height_unit="nm", detrend_mode="none")
    check_scaled(s, h * 1e-9, 16 * UM, 12 * UM)
    with pytest.raises(InputError, match=r"gives its size in um \(16 x 12\); unit='nm'"):
        read_scan(tmp_path / "p.txt", unit="nm")
    with pytest.raises(InputError, match="not the unit of its heights"):
        read_scan(tmp_path / "p.txt")
    # a unit= equal to the header's reads both in it
    s = read_scan(tmp_path / "p.txt", unit="um", detrend_mode="none")
    check_scaled(s, h * UM, 16 * UM, 12 * UM)


def _netcdf3(path: Path, h: np.ndarray, dims: tuple[str, str]) -> None:
    import netCDF4

    nx, ny = h.shape
    with netCDF4.Dataset(str(path), "w", format="NETCDF3_64BIT_OFFSET") as nc:
        for name, n, length in (("x", nx, 6.0), ("y", ny, 4.5)):
            nc.createDimension(name, n)
            v = nc.createVariable(name, "f8", (name,))
            v.length, v.unit = length, "um"
        v = nc.createVariable("heights", "f8", dims)
        v[:] = h if dims == ("x", "y") else h.T
        v.unit = "um"


@pytest.mark.parametrize("shape", [(16, 12), (12, 12)])
def test_netcdf_heights_over_y_x_are_transposed(tmp_path, shape):
    """heights(y, x), the order of xarray and CF files, was read as (x, y): a square scan
    transposed without a word (sigma_x and sigma_y swapped)."""
    h = heights(*shape)
    _netcdf3(tmp_path / "xy.nc", h, ("x", "y"))
    _netcdf3(tmp_path / "yx.nc", h, ("y", "x"))
    a = read_scan(tmp_path / "xy.nc", detrend_mode="none")
    b = read_scan(tmp_path / "yx.nc", detrend_mode="none", crop="1:,:")
    assert a.shape == shape and b.shape == (shape[0] - 1, shape[1])
    check_scaled(a, h * UM, 6 * UM, 4.5 * UM)
    check_scaled(b, h[1:] * UM, 6 * UM * (shape[0] - 1) / shape[0],
                 4.5 * UM)
    # a netCDF-4 file (xarray's default) over (y, x), read as HDF5, with the size given
    xr.Dataset({"heights": (("y", "x"), h.T)}).to_netcdf(tmp_path / "nc4.nc")
    c = read_scan(tmp_path / "nc4.nc", size="6um,4.5um", unit="um", detrend_mode="none")
    check_scaled(c, h * UM, 6 * UM, 4.5 * UM)
    # without the size, the error says why its attributes were not read
    with pytest.raises(InputError, match="netCDF-4 file, read as plain HDF5"):
        read_scan(tmp_path / "nc4.nc")


@pytest.mark.parametrize("suffix", [".npz", ".mat", ".h5"])
def test_a_file_of_several_arrays_needs_the_height_array_named(tmp_path, suffix):
    """The readers of .npz, HDF5 and MATLAB files took the first array: "phase" before
    "height", MATLAB's X coordinate plane of X, Y, Z; all ran through (exit 0)."""
    import scipy.io

    h = heights()
    other = heights(seed=1)
    x = np.broadcast_to(np.arange(16.0)[:, None], h.shape).copy()

    def write(path, arrays):
        if suffix == ".npz":
            np.savez(path, **arrays)
        elif suffix == ".mat":
            scipy.io.savemat(path, arrays)
        else:
            import h5py

            with h5py.File(path, "w") as f:
                for k, v in arrays.items():
                    f[k] = v

    write(tmp_path / f"named{suffix}", {"phase": other, "X": x, "Z": h})
    s = read_scan(tmp_path / f"named{suffix}", size="16um,12um", unit="nm",
                  detrend_mode="none")
    assert s.scan.channel == "Z"
    check_scaled(s, h * 1e-9, 16 * UM, 12 * UM)
    write(tmp_path / f"unnamed{suffix}", {"a": other, "b": h})
    with pytest.raises(InputError, match=r"several arrays \(0: a, 1: b\).*channel="):
        read_scan(tmp_path / f"unnamed{suffix}", size="16um,12um", unit="nm")
    s = read_scan(tmp_path / f"unnamed{suffix}", size="16um,12um", unit="nm", channel="b",
                  detrend_mode="none")
    check_scaled(s, h * 1e-9, 16 * UM, 12 * UM)


def test_a_flat_scan_is_refused_despite_round_off(tmp_path):
    """A constant map came out 1.5e-24 m rough after the plane fit and ran a whole leak
    study ("sealing pressure 6.7e-08 Pa"); so does a tilted plane."""
    np.save(tmp_path / "c.npy", np.full((16, 12), 3.0))
    x, y = np.meshgrid(np.arange(16.0), np.arange(12.0), indexing="ij")
    np.save(tmp_path / "plane.npy", 1e3 + 0.3 * x - 0.7 * y)
    for name in ("c.npy", "plane.npy"):
        with pytest.raises(InputError, match="flat after detrending"):
            read_scan(tmp_path / name, size="1um", unit="nm")
    # heights a millionth of their level still count (1e-9 of it is the bound)
    np.save(tmp_path / "tiny.npy", 1.0 + 1e-6 * heights())
    assert read_scan(tmp_path / "tiny.npy", size="1um", unit="nm").shape == (16, 12)


def test_a_coordinate_list_the_grid_reader_refused_is_not_read_as_a_matrix(tmp_path):
    """x y z (intensity) lines that are not a complete grid went to the matrix reader: a
    4 x 768 "scan" of the columns (exit 0), or a refusal about 4 x 4 points."""
    x, y = np.meshgrid(np.arange(32) * 0.1, np.arange(24) * 0.1, indexing="ij")
    z = heights(32, 24)
    np.savetxt(tmp_path / "xyzi.txt", np.c_[x.ravel(), y.ravel(), z.ravel(), z.ravel()])
    np.savetxt(tmp_path / "gap.txt", np.c_[x.ravel(), y.ravel(), z.ravel()][1:])
    for name, lines in (("xyzi.txt", "768 lines of 4 values"), ("gap.txt", "767 lines of 3")):
        with pytest.raises(InputError, match=f"looks like a list of points \\({lines}"):
            read_scan(tmp_path / name, size="1um", unit="nm")
    # a genuine matrix 4 values wide and 40 lines long is read (the first cut refused it)
    np.savetxt(tmp_path / "narrow.txt", heights(4, 40).T)
    assert read_scan(tmp_path / "narrow.txt", size="4um,40um", unit="nm").shape == (4, 40)


def test_a_placeholder_that_overflows_is_refused(tmp_path):
    h = heights()
    h[3, 3] = 1e300  # an instrument's "no data", in nm
    np.save(tmp_path / "big.npy", h)
    with pytest.raises(InputError, match="overflow the statistics: a placeholder"):
        read_scan(tmp_path / "big.npy", size="1um", unit="nm")


@pytest.mark.parametrize("write, match", [
    (lambda p: np.savetxt(p / "c.csv", heights(), delimiter=","),
     r"c.csv' cannot be read: XYZReader: .*whitespace-separated"),
    (lambda p: (p / "e.txt").write_bytes(b""), "e.txt' is empty"),
    (lambda p: np.save(p / "z.npy", np.zeros((2, 8, 8))), "NPYReader: .*3-dimensional"),
    (lambda p: np.save(p / "line.npy", np.zeros((1, 24)) + np.arange(24)),
     r"1 x 24 points; at least 4 x 4"),
])
def test_unreadable_files_get_the_reason_of_their_own_reader(tmp_path, write, match):
    """Every reader failure was one 50-line message of 17 readers' complaints, with raw
    bytes of the file; a file's own reader (by its ending) now says why."""
    write(tmp_path)
    path = next(tmp_path.iterdir())
    with pytest.raises(InputError, match=match) as exc:
        read_scan(path, size="1um", unit="nm")
    assert "tried" not in str(exc.value) and len(str(exc.value)) < 600
    assert str(exc.value).isprintable()


def test_pixels_the_file_states_draw_no_swapped_axes_warning(tmp_path, caplog):
    # a file that gives its own size (netCDF, x3p, ...) states rectangular pixels; the
    # warning about swapped axes is for sizes given to arrays and text matrices
    _netcdf3(tmp_path / "r.nc", heights(12, 12), ("x", "y"))
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        s = read_scan(tmp_path / "r.nc")
    assert s.lx / s.ly == pytest.approx(6 / 4.5) and "axes are swapped" not in caplog.text


def test_cli_import_refuses_to_overwrite_its_scan(tmp_path, capsys):
    _netcdf3(tmp_path / "scan.nc", heights(), ("x", "y"))
    before = (tmp_path / "scan.nc").read_bytes()
    with pytest.raises(SystemExit) as exc:
        main(["import", str(tmp_path / "scan.nc"), "-o", str(tmp_path / "." / "scan.nc")])
    assert exc.value.code == 2 and "is also an input" in capsys.readouterr().err
    assert (tmp_path / "scan.nc").read_bytes() == before


def test_a_placeholder_for_missing_points_can_be_named(tmp_path, capsys):
    """Instrument exports mark missing points with a number (-999999, 1e38 in float32);
    it ran through as a height (a warning about units at most). missing_value= names it."""
    h = heights()
    h[2, 3] = h[7, 1] = -999999.0
    np.save(tmp_path / "p.npy", h)
    f32 = heights().astype(np.float32)
    f32[5, 5] = np.float32(1e38)  # 9.99999968e37 as float32
    np.save(tmp_path / "f32.npy", f32)
    with pytest.raises(InputError, match="2 missing points"):
        read_scan(tmp_path / "p.npy", size="16um,12um", unit="nm", missing_value=-999999)
    s = read_scan(tmp_path / "p.npy", size="16um,12um", unit="nm", missing_value=-999999,
                  fill="harmonic")
    assert s.scan.filled == 2 and s.scan.missing_value == "-999999.0"
    assert np.abs(s.heights * s.scan.length_scale).max() < 1e-8  # no -1e-3 m left
    s = read_scan(tmp_path / "f32.npy", size="16um,12um", unit="nm", missing_value=1e38,
                  fill="min")
    assert s.scan.filled == 1
    with pytest.raises(InputError, match="missing_value must be finite"):
        read_scan(tmp_path / "p.npy", size="16um,12um", unit="nm", missing_value=float("nan"))
    # the command line, and the record in the surface file
    out = tmp_path / "p.nc"
    assert main(["import", str(tmp_path / "p.npy"), "--size", "16um,12um", "--unit", "nm",
                 "--missing-value=-999999", "--fill", "min", "-o", str(out)]) == 0
    assert "2 points filled" in capsys.readouterr().out
    back = read_surface(out)
    assert back.scan.missing_value == "-999999.0" and back.scan.filled == 2
