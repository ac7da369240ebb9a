"""The measured study's figure and caption file against the leak table's row flags and the
sealing searches (roughflow.figures.measured, roughflow.figures.data_summary): rows whose
analysed window holds no contact cell ("*") or contact on fewer than
LEAK_MIN_CONTACT_CELLS cells ("~") are drawn hollow, off the lines, and counted in the
caption file, which states each scan's sealing pressures or that its search did not
bracket one. Leak files are built with the library's dataset builder from small
synthetic leak curves: no solve runs."""

from __future__ import annotations

import re

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from roughflow.aggregate import aggregate  # noqa: E402
from roughflow.cli.leak import format_table  # noqa: E402
from roughflow.datasets import leak_dataset  # noqa: E402
from roughflow.defaults import LEAK_MIN_CONTACT_CELLS  # noqa: E402
from roughflow.figures import caption_document, data_summary, make_figure, measured  # noqa: E402
from roughflow.io import write_dataset  # noqa: E402
from roughflow.leak import LeakCurve  # noqa: E402
from roughflow.search import Threshold  # noqa: E402
from roughflow.surface import ScanInfo, Surface  # noqa: E402
from roughflow.units import Scales  # noqa: E402

MODULUS = 200e9
#: On a 12 x 12 window (144 cells): none, 1 cell ("~"), 29 and 72 cells (resolved).
AREAS = (0.0, 0.01, 0.2, 0.5)
PRESSURES = (1e7, 1e8, 1e9, 2e9)


def _threshold(axis: int, p_lo: float, p_hi: float | None) -> Threshold:
    """A sealing search's result; ``p_hi`` None: not bracketed (nothing found sealed)."""
    if p_hi is None:
        return Threshold(axis=axis, a_c_star=np.nan, a_lo=0.39, a_hi=np.nan, p_lo=p_lo,
                         p_hi=np.nan, n_solves=3, model="elastic", tol=0.02, bracketed=False,
                         message=f"axis {axis}: not bracketed")
    return Threshold(axis=axis, a_c_star=0.4, a_lo=0.39, a_hi=0.41, p_lo=p_lo, p_hi=p_hi,
                     n_solves=3, model="elastic", tol=0.02)


def leak_file(name: str, pressures_pa=PRESSURES, areas=AREAS, *, window=(12, 12),
              unbracketed_y: bool = False, sealing: bool = True) -> xr.Dataset:
    """A one-scan leak dataset at ``pressures_pa`` (Pa) with contact areas ``areas`` on an
    analysed window of ``window`` cells, leaking along both axes at every row; sealed (x
    between 2 and 3, y between 2 and 4 times the top pressure) unless ``unbracketed_y``
    (y: nothing sealed within the range) or not ``sealing`` (no search)."""
    p = np.asarray(pressures_pa, dtype=float) / MODULUS
    n = p.size
    sigma = np.outer(np.geomspace(2e-3, 1e-4, n), [1.0, 0.8])
    top = p[-1]
    thresholds = ({0: _threshold(0, 2 * top, 3 * top),
                   1: _threshold(1, 2 * top, None if unbracketed_y else 4 * top)}
                  if sealing else {})
    curve = LeakCurve(
        pressure=p, area_fraction=np.asarray(areas, dtype=float),
        mean_gap=np.full(n, 0.05), percolating=np.ones((n, 2), bool), sigma=sigma,
        iterations=np.full(n, 7), residual=np.full(n, 1e-7),
        flow_imbalance=np.zeros((n, 2)), flow_sigma_error=np.zeros((n, 2)),
        thresholds=thresholds, boundary="window", rms_gradient=0.9, window_lx=0.75,
        window_ly=0.75, window_shape=window,
        settings={"contact_tol": 1e-6, "sealing_searched": int(sealing)})
    info = ScanInfo(source="scan.opd", reader="test", channel="h", length_scale=1e-5,
                    rms_gradient=0.9, detrend="plane", fill="none", filled=0,
                    crop="0:16,0:16")
    surface = Surface(heights=np.zeros((16, 16)), lx=1.0, ly=1.0, scan=info)
    return leak_dataset(curve, surface,
                        scales=Scales(length=1e-5, modulus=MODULUS, viscosity=1e-3),
                        fluid_pressure=1e6, seal_width=2e-3, seal_length=60e-3, name=name)


def study(tmp_path, files: dict[str, xr.Dataset]) -> xr.Dataset:
    """The measured study dataset (roughflow aggregate) of the leak files ``files``."""
    paths = []
    for stem, ds in files.items():
        paths.append(tmp_path / f"{stem}.nc")
        write_dataset(ds, paths[-1])
    aggregate(paths, tmp_path / "study.nc", study="measured")
    return xr.load_dataset(tmp_path / "study.nc")


def _lines(ax) -> dict:
    return {ln.get_label(): ln for ln in ax.get_lines()}


def _table_marks(ds: xr.Dataset) -> list[str]:
    """The mark after a_c of each row of ``roughflow leak``'s table."""
    rows = [m.group(1) for line in format_table(ds).splitlines()
            if (m := re.match(r"^\s*\d[\d.e+-]*\s+\d[\d.e+-]*([*~ ]) ", line))]
    assert len(rows) == ds.sizes["pressure"]
    return rows


def test_the_figure_flags_the_rows_the_leak_table_marks():
    one = leak_file("s")
    assert _table_marks(one) == ["*", "~", " ", " "]
    empty, few = measured.row_flags(one)
    assert empty.tolist() == [[True, False, False, False]]
    assert few.tolist() == [[False, True, False, False]]


def test_flagged_rows_are_hollow_markers_off_the_lines(tmp_path):
    # the figure drew an empty window's leak rate (held open from outside) as a point of
    # the seal's curve, joined to the resolved rows
    ds = study(tmp_path, {"S": leak_file("s")})
    fig = measured.draw(ds)
    ax_q, ax_a = fig.axes[:2]
    for ax, names in ((ax_q, ("s, flow along x", "s, flow along y")), (ax_a, ("s",))):
        lines = _lines(ax)
        for name in names:
            resolved, hollow = lines[name], lines[f"{name}: not resolved"]
            np.testing.assert_allclose(resolved.get_xdata(), PRESSURES[2:])
            assert resolved.get_markerfacecolor() != "none"
            np.testing.assert_allclose(hollow.get_xdata(), PRESSURES[:2])
            assert hollow.get_markerfacecolor() == "none"
            assert hollow.get_linestyle() == "None"  # no line through them
            assert hollow.get_color() == resolved.get_color()
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert measured.UNRESOLVED_LABEL in legend
    assert f"fewer than {LEAK_MIN_CONTACT_CELLS} contact cells" in measured.UNRESOLVED_LABEL


def test_a_study_without_flagged_rows_has_no_hollow_markers(tmp_path):
    ds = study(tmp_path, {"S": leak_file("s", areas=(0.2, 0.3, 0.5, 0.7))})
    fig = measured.draw(ds)
    assert not [ln for ax in fig.axes[:2] for ln in ax.get_lines()
                if ln.get_markerfacecolor() == "none"]
    assert measured.UNRESOLVED_LABEL not in [t.get_text() for t in fig.legends[0].get_texts()]
    assert "all 4 rows resolved" in data_summary(ds)


def test_each_scan_is_flagged_on_its_own_window_and_pressures(tmp_path):
    # a_c = 0.01 is 1 cell of a 12 x 12 window but 41 of a 64 x 64 one; the scans differ
    # in their windows (per-scan window_nx) and pressure grids (NaN at the other's: not a
    # row, though NaN rounds to a count below 16)
    small = leak_file("small", areas=(0.01, 0.02, 0.2, 0.5))
    large = leak_file("large", (3e7, 3e8, 3e9, 5e9), areas=(0.01, 0.02, 0.2, 0.5),
                      window=(64, 64))
    ds = study(tmp_path, {"A": small, "B": large})
    assert ds["window_nx"].dims == ("scan",)
    empty, few = measured.row_flags(ds)
    assert not empty.any()
    p = ds["pressure"].values
    assert p[few[ds.get_index("scan").get_loc("small")]].tolist() == [1e7, 1e8]
    assert not few[ds.get_index("scan").get_loc("large")].any()
    summary = data_summary(ds)
    assert ("2 of 8 rows not resolved, drawn hollow off the lines: 2 with contact on fewer "
            f"than {LEAK_MIN_CONTACT_CELLS} of its cells (small 2; '~')") in summary
    fig = measured.draw(ds)
    hollow = _lines(fig.axes[1])["small: not resolved"]
    np.testing.assert_allclose(hollow.get_xdata(), [1e7, 1e8])
    assert "large: not resolved" not in _lines(fig.axes[1])


def test_the_caption_file_states_the_sealing_pressures_and_the_flagged_rows(tmp_path):
    # it said "no a_c* (no search bracketed it)", the synthetic studies' words, where
    # every scan's search had bracketed its sealing pressure
    ds = study(tmp_path, {"A": leak_file("a"), "B": leak_file("b", unbracketed_y=True)})
    assert ds["bracketed"].sel(scan="a").values.tolist() == [1, 1]
    summary = data_summary(ds)
    assert "no search bracketed" not in summary and "a_c*" not in summary
    # x sealed from 3 x the top pressure (2 GPa), y from 4 x; b's y not bracketed
    assert ("sealing pressure (lowest found sealed): a x 6e+09 Pa and y 8e+09 Pa, "
            "b x 6e+09 Pa and y not bracketed") in summary
    assert ("4 of 8 rows not resolved, drawn hollow off the lines: 2 with no contact cell "
            "in the analysed window (a 1, b 1; the leak table's '*') and 2 with contact on "
            f"fewer than {LEAK_MIN_CONTACT_CELLS} of its cells (a 1, b 1; '~')") in summary
    document = caption_document("measured", ds, "the dataset", "figure.png")
    assert f"Its data: {summary}." in document


def test_a_leak_run_without_sealing_search_says_not_searched(tmp_path):
    ds = study(tmp_path, {"A": leak_file("a", sealing=False)})
    summary = data_summary(ds)
    assert "sealing pressure (lowest found sealed): a not searched" in summary
    assert "not bracketed" not in summary


def test_make_figure_writes_the_summary_next_to_the_figure(tmp_path):
    study(tmp_path, {"A": leak_file("a")})
    png = tmp_path / "figure.png"
    make_figure("measured", tmp_path / "study.nc", png)
    text = png.with_suffix(".md").read_text()
    assert "a x 6e+09 Pa and y 8e+09 Pa" in text and "2 of 4 rows not resolved" in text
    assert "Hollow markers" in measured.CAPTION
