"""The measured study dataset (roughflow aggregate of leak files) and its figure: scans
with different pressure grids keep their per-scan variables over ``scan`` only, and what
describes each scan (boundary treatment, scan provenance) survives as variables over
``scan`` when it differs between scans (roughflow.aggregate, roughflow.datasets.leak,
roughflow.figures.measured). Leak files are built with the library's dataset builder from
small synthetic leak curves: no solve runs."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402

from roughflow.aggregate import aggregate  # noqa: E402
from roughflow.cli import main  # noqa: E402
from roughflow.datasets import leak_dataset  # noqa: E402
from roughflow.figures import measured  # noqa: E402
from roughflow.io import write_dataset  # noqa: E402
from roughflow.leak import LeakCurve  # noqa: E402
from roughflow.search import Threshold  # noqa: E402
from roughflow.surface import ScanInfo, Surface  # noqa: E402
from roughflow.units import Scales  # noqa: E402

MODULUS = 200e9


def _threshold(axis: int, p_lo: float, p_hi: float) -> Threshold:
    return Threshold(axis=axis, a_c_star=0.4, a_lo=0.39, a_hi=0.41, p_lo=p_lo, p_hi=p_hi,
                     n_solves=3, model="elastic", tol=0.02)


def leak_file(name: str, pressures_pa, *, boundary: str = "window",
              length: float = 1e-5, source: str = "scan.opd",
              modulus: float = MODULUS) -> xr.Dataset:
    """A one-scan leak dataset of a 16 x 16 'scan' at ``pressures_pa`` (Pa), built by
    :func:`roughflow.datasets.leak_dataset` from a synthetic curve."""
    p = np.asarray(pressures_pa, dtype=float) / modulus
    n = p.size
    # >= 29 of the window's 144 cells in contact: no row is one the figure draws as not
    # resolved (tests/test_figure_measured_flags.py)
    area = np.linspace(0.2, 0.3, n)
    sigma = np.outer(np.linspace(2e-3, 1e-3, n), [1.0, 0.8])
    curve = LeakCurve(
        pressure=p, area_fraction=area, mean_gap=np.full(n, 0.05),
        percolating=np.ones((n, 2), bool), sigma=sigma, iterations=np.full(n, 7),
        residual=np.full(n, 1e-7), flow_imbalance=np.zeros((n, 2)),
        flow_sigma_error=np.zeros((n, 2)),
        thresholds={0: _threshold(0, 2 * p[-1], 3 * p[-1]),
                    1: _threshold(1, 2 * p[-1], 4 * p[-1])},
        boundary=boundary, rms_gradient=0.9, window_lx=0.75, window_ly=0.75,
        window_shape=(12, 12), settings={"contact_tol": 1e-6})
    info = ScanInfo(source=source, reader="test", channel="h", length_scale=length,
                    rms_gradient=0.9, detrend="plane", fill="none", filled=0,
                    crop="0:16,0:16")
    surface = Surface(heights=np.zeros((16, 16)), lx=1.0, ly=1.0, scan=info)
    return leak_dataset(curve, surface,
                        scales=Scales(length=length, modulus=modulus, viscosity=1e-3),
                        fluid_pressure=1e6, seal_width=2e-3, seal_length=60e-3, name=name)


def _write(tmp_path, datasets: dict[str, xr.Dataset]) -> list:
    paths = []
    for stem, ds in datasets.items():
        paths.append(tmp_path / f"{stem}.nc")
        write_dataset(ds, paths[-1])
    return paths


def _study(tmp_path, datasets: dict[str, xr.Dataset]) -> xr.Dataset:
    out = tmp_path / "study.nc"
    aggregate(_write(tmp_path, datasets), out, study="measured")
    return xr.load_dataset(out)


PER_SCAN = {"a_c_star": ("scan", "axis"), "sealing_pressure": ("scan", "axis"),
            "sealing_pressure_lo": ("scan", "axis"), "bracketed": ("scan", "axis"),
            "length_scale": ("scan",), "modulus": ("scan",), "rms_gradient": ("scan",)}


def _all_have_units(ds: xr.Dataset) -> None:
    for name in ds.data_vars:
        assert ds[name].attrs.get("units") and ds[name].attrs.get("long_name"), name


def test_sealing_pressures_are_the_bracket_s_ends_in_pascals():
    """The fluid stops spanning between p_lo (leaking) and p_hi (sealed): sealing_pressure
    is p_hi E*, the lowest pressure found sealed, and sealing_pressure_lo is p_lo E*. The
    helper's bracket is (2, 3) x and (2, 4) x its top pressure (1 GPa / E* here); one
    product and one quotient: round-off."""
    ds = leak_file("a", [1e8, 1e9])
    np.testing.assert_allclose(ds["sealing_pressure"].sel(scan="a"), [3e9, 4e9], rtol=1e-12)
    np.testing.assert_allclose(ds["sealing_pressure_lo"].sel(scan="a"), [2e9, 2e9],
                               rtol=1e-12)


def test_different_pressure_grids_keep_per_scan_dims(tmp_path):
    a = leak_file("a", [1e9, 2e9])
    c = leak_file("c", [1e7, 1e8])
    ds = _study(tmp_path, {"A": a, "C": c})
    assert ds.sizes == {"scan": 2, "pressure": 4, "axis": 2}
    np.testing.assert_allclose(ds["pressure"], [1e7, 1e8, 1e9, 2e9])
    for name, dims in PER_SCAN.items():
        assert ds[name].dims == dims, name
        assert np.isfinite(ds[name].values).all(), name
    np.testing.assert_allclose(ds["sealing_pressure"].sel(scan="a"),
                               a["sealing_pressure"].isel(scan=0), rtol=1e-12)
    np.testing.assert_allclose(ds["sealing_pressure"].sel(scan="c"),
                               c["sealing_pressure"].isel(scan=0), rtol=1e-12)
    # per-pressure variables: each scan's own pressures, NaN at the other scan's
    q = ds["leak_rate"].sel(scan="a", axis="x").values
    assert np.isnan(q[:2]).all() and np.isfinite(q[2:]).all()
    assert ds["percolating"].sel(scan="c", axis="y").values.tolist()[:2] == [1, 1]
    _all_have_units(ds)


def test_figure_draws_scans_with_different_pressure_grids(tmp_path):
    ds = _study(tmp_path, {"A": leak_file("a", [1e9, 2e9]), "C": leak_file("c", [1e7, 1e8])})
    fig = measured.draw(ds)
    try:
        ax_q, ax_a = fig.axes[:2]
        # each scan drawn at its own pressures only
        drawn = {ln.get_label(): ln.get_xdata() for ln in ax_a.get_lines()}
        np.testing.assert_allclose(drawn["a"], [1e9, 2e9])
        np.testing.assert_allclose(drawn["c"], [1e7, 1e8])
        assert ax_q.get_title() == "boundary: window"
    finally:
        plt.close(fig)
    png = tmp_path / "f.png"
    assert main(["figure", "measured", str(tmp_path / "study.nc"), "-o", str(png)]) == 0
    assert png.stat().st_size > 0


def test_boundary_and_scan_provenance_are_kept_per_scan(tmp_path):
    w = leak_file("w", [1e8, 1e9], boundary="window", length=1e-5, source="one.opd")
    m = leak_file("m", [1e8, 1e9], boundary="mirror", length=2e-5, source="two.opd")
    ds = _study(tmp_path, {"W": w, "M": m})
    assert "boundary" not in ds.attrs and "ref_length_m" not in ds.attrs
    for name, want in {"boundary": {"w": "window", "m": "mirror"},
                       "scan_source": {"w": "one.opd", "m": "two.opd"},
                       "scan_length_scale": {"w": 1e-5, "m": 2e-5},
                       "length_scale": {"w": 1e-5, "m": 2e-5}}.items():
        assert ds[name].dims == ("scan",), name
        assert {s: ds[name].sel(scan=s).item() for s in want} == pytest.approx(want), name
    assert ds["boundary_description"].sel(scan="m").item().startswith("non-periodic scan "
                                                                      "mirror-tiled")
    # values all scans share are variables too (and the attribute stays)
    assert ds["scan_detrend"].dims == ("scan",) and ds.attrs["scan_detrend"] == "plane"
    assert ds["scan_filled"].values.tolist() == [0, 0]
    _all_have_units(ds)
    fig = measured.draw(ds)
    try:
        ax_q, ax_a = fig.axes[:2]
        assert "per scan" not in ax_q.get_title() and "differs" in ax_q.get_title()
        labels = {ln.get_label() for ln in ax_a.get_lines()}
        assert labels == {"w (window)", "m (mirror)"}
    finally:
        plt.close(fig)
    assert "'boundary' attribute" not in measured.CAPTION
    assert "'boundary' variable" in measured.CAPTION


def test_an_attribute_some_scans_lack_is_not_the_study_s(tmp_path):
    """A leak file of a generated surface has no scan provenance; aggregated with a scan's,
    the study kept the scan's source, crop and reader as global attributes, false for the
    other: xarray's drop_conflicts keeps what only some datasets carry. They are variables
    over scan only."""
    scan = leak_file("s", [1e8, 1e9], source="one.opd")
    generated = leak_file("g", [1e8, 1e9])
    generated.attrs = {k: v for k, v in generated.attrs.items() if not k.startswith("scan_")}
    assert "scan_source" in scan.attrs
    ds = _study(tmp_path, {"S": scan, "G": generated})
    assert not [k for k in ds.attrs if k.startswith("scan_")]
    assert ds["scan_source"].sel(scan="s").item() == "one.opd"


def test_a_single_scan_study_has_the_same_per_scan_variables(tmp_path):
    ds = _study(tmp_path, {"A": leak_file("a", [1e8, 1e9], boundary="mirror")})
    assert ds["boundary"].dims == ("scan",) and ds["boundary"].values.tolist() == ["mirror"]
    assert ds["viscosity"].attrs["units"] == "Pa*s"
    np.testing.assert_allclose(ds["viscosity"], [1e-3])
    _all_have_units(ds)


def test_units_of_a_study_whose_scans_differ_in_length_convert_per_scan(tmp_path):
    from roughflow.errors import InputError
    from roughflow.units import registry

    study = _study(tmp_path, {"a": leak_file("a", [1e6, 2e6], length=1e-5),
                              "b": leak_file("b", [1e6, 2e6], length=4e-5)})
    assert "ref_length_m" not in study.attrs  # the scans disagree, so no attribute holds it
    with pytest.raises(InputError, match="differ in length_scale.*sel\\(scan=name\\)"):
        registry(study)
    for name, length in (("a", 1e-5), ("b", 4e-5)):
        one = study.sel(scan=name)
        ureg = registry(one)
        gap = ureg.Quantity(one["mean_gap"].values, one["mean_gap"].attrs["units"])
        # the synthetic curve's mean gap is 0.05 L at every pressure
        np.testing.assert_allclose(gap.to("m").magnitude, 0.05 * length, rtol=1e-12)
        sigma = ureg.Quantity(one["sigma"].values, one["sigma"].attrs["units"])
        np.testing.assert_allclose(sigma.to("m^3/(Pa*s)").magnitude,
                                   one["conductance"].values, rtol=1e-12)


def test_scans_are_sorted_by_name_whatever_the_order_of_the_files(tmp_path):
    """The study's scan axis is in name order, so that it does not depend on the order the
    workflow listed the files in; each scan keeps its own values (b's length is 2e-5 m,
    a's 1e-5 m: stored as given, compared exactly)."""
    b = leak_file("b", [1e8, 1e9], length=2e-5)
    a = leak_file("a", [1e8, 1e9], length=1e-5)
    ds = _study(tmp_path, {"B": b, "A": a})  # files listed b first
    assert ds["scan"].values.tolist() == ["a", "b"]
    assert ds["length_scale"].values.tolist() == [1e-5, 2e-5]


def test_the_legend_names_each_scans_modulus_where_they_differ(tmp_path):
    # a study of faces of different materials (scan entries may set their own modulus):
    # the figure said nothing of which face was the stiffer one
    ds = _study(tmp_path, {"A": leak_file("steel", [1e7, 1e8]),
                           "B": leak_file("sic", [1e7, 1e8], modulus=400e9)})
    fig = measured.draw(ds)
    try:
        labels = [t.get_text() for t in fig.legends[0].get_texts()]
        assert "sic (E* = 400 GPa)" in labels and "steel (E* = 200 GPa)" in labels
    finally:
        plt.close(fig)
    other = tmp_path / "same"
    other.mkdir()
    same = _study(other, {"A": leak_file("steel", [1e7, 1e8]),
                          "B": leak_file("sic", [1e7, 1e8])})
    fig = measured.draw(same)
    try:
        assert not any("E* =" in t.get_text() for t in fig.legends[0].get_texts())
    finally:
        plt.close(fig)
