"""A measured scan keeps its own rms gradient gbar, so its pressures are in E*, not E* gbar:
the threshold search's default pressures scale with it, Persson theory reads the scan's
spectrum without the wrap-around step, and the theory files keep the scan's units
(roughflow.surface.Surface.gbar, roughflow.search.scaled_options, `roughflow threshold`,
`roughflow theory`)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.defaults import THRESHOLD_PRESSURE_RANGE
from roughflow.search import SearchOptions, first_pressure, scaled_options
from roughflow.surface import ScanInfo, Surface, SurfaceSpec, generate, rms_gradient
from roughflow.theory.persson import discrete_spectrum
from roughflow.units import registry

DATA = Path(__file__).resolve().parent / "data"


def _window_as_scan(seed: int) -> tuple[Surface, Surface]:
    """A quarter of a generated 256^2 surface (rms gradient 1) as a non-periodic scan, and
    the same heights taken as a periodic cell."""
    spec = SurfaceSpec.from_sweep(gamma=1, hurst=0.8, l_over_lambda_r=4, eps_f=0.0625,
                                  points_per_lambda_s=4, seed=seed)
    full = generate(spec)
    n = full.shape[0] // 2
    h = full.heights[:n, :n].copy()
    lx, ly = full.lx / 2, full.ly / 2
    info = ScanInfo(source="window", reader="test", channel="h", length_scale=1e-6,
                    rms_gradient=rms_gradient(h, lx, ly, periodic=False), detrend="none",
                    fill="none", filled=0)
    return Surface(heights=h, lx=lx, ly=ly, scan=info), Surface(heights=h, lx=lx, ly=ly)


def test_gbar_of_generated_scanned_and_bare_surfaces():
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, seed=1)
    assert generate(spec).gbar == 1.0  # E* gbar = E*: the sweep's pressures, unchanged
    scan, bare = _window_as_scan(0)
    assert scan.gbar == scan.scan.rms_gradient  # the recorded, finite-difference value
    assert bare.gbar == pytest.approx(rms_gradient(bare.heights, bare.lx, bare.ly))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_persson_spectrum_of_a_scan_has_no_wrap_around_step(seed):
    # a window of a surface of rms gradient 1: its spectrum as a periodic cell adds the
    # step at the wrap-around (measured 1.15-1.33 over seeds 0-5); the mirror-tiled cell's
    # gives 0.973-1.029, the window's own sampling scatter: 0.05 bounds that, and not the
    # step
    scan, periodic = _window_as_scan(seed)
    assert discrete_spectrum(scan).rms_slope == pytest.approx(1.0, abs=0.05)
    assert discrete_spectrum(periodic).rms_slope > 1.1


def test_scaled_search_options():
    gbar = 1e-4
    opts = scaled_options(gbar, "elastic", contact_tol=1e-4)
    assert opts.pressure_range == tuple(gbar * p for p in THRESHOLD_PRESSURE_RANGE)
    assert opts.first_pressure == pytest.approx(gbar * first_pressure("elastic"), rel=1e-15)
    assert opts.contact_tol == 1e-4
    # a range given in E* is kept, the scaled first pressure held inside it
    opts = scaled_options(gbar, "elastic", pressure_range=(1e-3, 1e-2))
    assert opts.pressure_range == (1e-3, 1e-2) and opts.first_pressure == 1e-3
    assert scaled_options(gbar, "elastic", first_pressure=5e-5).first_pressure == 5e-5
    # a generated surface (gbar 1): the search's own defaults, to the last bit
    assert scaled_options(1.0).pressure_range == THRESHOLD_PRESSURE_RANGE
    assert scaled_options(1.0).first_pressure == first_pressure()
    # a steep surface's range stops where contact.solve refuses pressures (100 E*)
    assert scaled_options(50.0).pressure_range == (50.0 * THRESHOLD_PRESSURE_RANGE[0], 100.0)
    # an end given as None keeps its scaled default (the command line's --p-min alone), and
    # the upper one its cap: the CLI scaled a half-given range itself, without the cap
    assert scaled_options(gbar, pressure_range=(None, 1e-2)).pressure_range == (
        gbar * THRESHOLD_PRESSURE_RANGE[0], 1e-2)
    assert scaled_options(50.0, pressure_range=(1.0, None)).pressure_range == (1.0, 100.0)
    assert scaled_options(gbar, pressure_range=(None, None)) == scaled_options(gbar)
    # the bearing model's loads are areas
    assert scaled_options(gbar, "bearing", pressure_range=(None, None)) == scaled_options(
        gbar, "bearing")
    bearing = scaled_options(gbar, "bearing")
    assert bearing.pressure_range == THRESHOLD_PRESSURE_RANGE and bearing.first_pressure is None


def _import(tmp_path: Path, heights: np.ndarray, name: str) -> Path:
    np.save(tmp_path / f"{name}.npy", heights)
    out = tmp_path / f"{name}.nc"
    assert main(["-q", "import", str(tmp_path / f"{name}.npy"), "--size", "500nm", "--unit",
                 "nm", "-o", str(out)]) == 0
    return out


def test_threshold_of_a_smooth_scan_equals_that_of_the_rough_one(tmp_path):
    # heights scaled by 1e-4 scale every contact pressure by 1e-4 and leave the contact
    # areas (linear elasticity): the default range (1e-4 ... 4 E* gbar) must follow gbar.
    # Before, the smooth scan's fluid never spanned at the lowest pressure 1e-4 E*: exit 2.
    h = np.load(DATA / "afm-64.npy")
    rough = _import(tmp_path, h, "rough")
    smooth = _import(tmp_path, h * 1e-4, "smooth")
    with xr.open_dataset(rough) as a, xr.open_dataset(smooth) as b:
        assert b.attrs["scan_rms_gradient"] == pytest.approx(1e-4 * a.attrs["scan_rms_gradient"],
                                                             rel=1e-9)
    found = {}
    for path in (rough, smooth):
        out = tmp_path / f"t-{path.stem}.nc"
        assert main(["-q", "threshold", str(path), "-o", str(out)]) == 0
        with xr.open_dataset(out) as ds:
            found[path.stem] = ds["a_c_star"].values, ds["p_lo"].values
    # the same search, each pressure times 1e-4: a_c* to round-off of the solves
    np.testing.assert_allclose(found["smooth"][0], found["rough"][0], atol=1e-9)
    np.testing.assert_allclose(found["smooth"][1], 1e-4 * found["rough"][1], rtol=1e-6)


def test_theory_files_keep_the_scan_and_its_units(tmp_path):
    scan = _import(tmp_path, np.load(DATA / "afm-64.npy"), "afm")
    persson = tmp_path / "persson.nc"
    assert main(["-q", "theory", str(scan), "--pressures", "0.1", "-o", str(persson)]) == 0
    contact = tmp_path / "contact.nc"
    assert main(["-q", "contact", str(scan), "--pressure", "0.1", "-o", str(contact)]) == 0
    gap = tmp_path / "gap-theory.nc"
    assert main(["-q", "theory", str(contact), "-o", str(gap)]) == 0
    with xr.open_dataset(scan) as s:
        length = s.attrs["ref_length_m"]
    for path in (persson, gap):
        with xr.open_dataset(path) as ds:
            assert ds.attrs["ref_length_m"] == length and "scan_source" in ds.attrs
            # before, the reference length was lost: ref_length did not convert to metres
            q = registry(ds.attrs).Quantity(float(ds["mean_gap"][0]), "ref_length")
            assert q.to("m").magnitude == pytest.approx(float(ds["mean_gap"][0]) * length)


@pytest.mark.parametrize("argv", [["-v", "-q"], ["-q", "-vv"]])
def test_quiet_and_verbose_together_are_refused(argv, capsys, tmp_path):
    out = tmp_path / "unused.nc"
    with pytest.raises(SystemExit) as exc:
        main([argv[0], "surface", "--l-over-lambda-r", "1", argv[1], "-o", str(out)])
    assert exc.value.code == 2
    assert "-q (errors only) contradicts -v" in capsys.readouterr().err
    assert not out.exists()  # refused before any work


@pytest.mark.parametrize("rms_slope", [20.0, 1e-5])
def test_the_library_search_follows_the_surfaces_rms_gradient(rms_slope):
    # search.threshold(surface) searched 1e-4 ... 4 E* whatever the surface: an rms slope of
    # 20 or 1e-5 was refused as unbracketed, though a_c* does not depend on it (an API audit)
    from roughflow.search import ThresholdNotBracketed, threshold

    spec = SurfaceSpec.from_sweep(points_per_lambda_s=2, l_over_lambda_r=2, seed=1)
    ref = threshold(generate(spec))
    steep = generate(replace(spec, rms_slope=rms_slope))
    got = threshold(steep)
    for ax in (0, 1):
        # the same contact problem scaled by rms_slope (heights and loads alike): the same
        # solves (measured: same count, a_c* equal, p_lo to 7e-16), so round-off is the margin
        assert got[ax].n_solves == ref[ax].n_solves
        assert got[ax].a_c_star == pytest.approx(ref[ax].a_c_star, abs=1e-12)
        assert got[ax].p_lo == pytest.approx(rms_slope * ref[ax].p_lo, rel=1e-12)
    # options given in E* are taken as they are, and the refusal says how to scale them
    with pytest.raises(ThresholdNotBracketed, match=r"rms gradient is .*scaled_options"):
        threshold(steep, options=SearchOptions())
