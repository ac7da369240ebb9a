"""Where the leak question leaves its model, the table, the log and `roughflow contact` say
so (roughflow.leak, `roughflow leak`, `roughflow contact`, from a user audit): nominal
pressures at or above E* (strains of order one: 300 GPa against 200 GPa, or a modulus typed
in MPa, ran without a word), fluid pressures at or above a row's contact pressure (the fluid
would push the faces apart: only the mild dp ~ p note said anything), a pressure below what
the grid resolves (refused in E*, not in the option's words), the mean gap of `roughflow
contact` in metres, and the wording of a few import and unit messages."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.cli.leak import format_table
from roughflow.contact.solve import check_resolved_load, resolved_load_floor
from roughflow.datasets import leak_dataset
from roughflow.defaults import CONTACT_MIN_CELLS, LARGE_STRAIN_PRESSURE
from roughflow.errors import InputError
from roughflow.leak import (
    LeakCurve,
    fluid_lifted_rows,
    fluid_pressure_note,
    large_strain,
    leak_curve,
    lowest_resolved_pressure,
)
from roughflow.scan import read_scan
from roughflow.search import Threshold
from roughflow.surface import Surface
from roughflow.units import Scales, parse_quantity, parse_range

MODULUS = 1e9  # E* = 1 GPa: the table's pressures are 1e9 times the curve's
#: The seal of every test here (and the command line's words for it).
SEAL = ["--fluid-pressure", "1kPa", "--viscosity", "1mPa.s", "--seal-width", "2mm",
        "--seal-length", "60mm"]


def test_the_bound_is_e_star_and_round_off_counts_as_at_it():
    assert LARGE_STRAIN_PRESSURE == 1.0
    p = np.array([0.1, 0.999, 1.0 - 1e-12, 1.0, 1.5, 100.0])
    assert large_strain(p).tolist() == [False, False, True, True, True, True]
    assert not large_strain(0.1)  # a rubber seal's 0.1 E*: no flag
    # the fluid pressure at or above the row's (1 MPa back from E* an ulp above 1 MPa)
    rows = np.array([1e6 * (1 + 2e-16), 2e6, 1e7])
    assert fluid_lifted_rows(rows, 1e6).tolist() == [True, False, False]
    assert fluid_lifted_rows(rows, 5e6).tolist() == [True, True, False]
    assert fluid_lifted_rows(rows, 1e5).tolist() == [False, False, False]
    # the mild note is there exactly where some row is lifted
    for fluid in (1e5, 1e6, 5e6):
        assert bool(fluid_pressure_note(fluid, rows, "Pa")) == fluid_lifted_rows(rows, fluid).any()


def table_dataset(pressures, areas, *, fluid=1e3, thresholds=None) -> xr.Dataset:
    """A leak dataset (no solve) with E* = 1 GPa, rows at ``pressures`` (E*) with contact
    areas ``areas`` on a 24 x 24 window, under the fluid pressure ``fluid`` (Pa)."""
    n = len(pressures)
    curve = LeakCurve(
        pressure=np.asarray(pressures, dtype=float), area_fraction=np.asarray(areas, float),
        mean_gap=np.full(n, 0.1), percolating=np.ones((n, 2), bool),
        sigma=np.full((n, 2), 1e-4), iterations=np.zeros(n, int), residual=np.zeros(n),
        flow_imbalance=np.zeros((n, 2)), flow_sigma_error=np.zeros((n, 2)),
        thresholds=thresholds or {}, boundary="window", rms_gradient=1.0, window_lx=0.75,
        window_ly=0.75, window_shape=(24, 24),
        settings={"sealing_searched": int(thresholds is not None)})
    surface = Surface.from_array(np.zeros((32, 32)), lx=1.0, ly=1.0)
    return leak_dataset(curve, surface, scales=Scales(length=10e-6, modulus=MODULUS,
                                                      viscosity=1e-3),
                        fluid_pressure=fluid, seal_width=2e-3, seal_length=60e-3, name="t")


def marks_of(text: str, n: int) -> list[str]:
    """The marks after a_c of the table's ``n`` rows (the second column's tail)."""
    return [row.split()[1].lstrip("0123456789.e+-") for row in text.splitlines()[3:3 + n]]


def notes_of(text: str) -> list[str]:
    return [line for line in text.splitlines() if line.startswith("note: ")]


def test_rows_at_or_above_e_star_are_marked_and_named():
    # 0.5 E* (a hard seal), 1 E* exactly, 1.5 E* (the audit's 300 GPa against 200 GPa)
    ds = table_dataset([0.1, 0.5, 1.0, 1.5], [0.1, 0.5, 1.0, 1.0])
    text = format_table(ds)
    assert marks_of(text, 4) == ["", "", "^", "^"]
    [note] = [n for n in notes_of(text) if n.startswith("note: ^ ")]
    assert "(1e+09, 1.5e+09 Pa) is at or above E* = 1e+09 Pa" in note
    assert "strains of order one" in note and "check --modulus" in note
    # below E* nothing is said, however high the pressure against a seal's usual
    quiet = format_table(table_dataset([0.1, 0.5, 0.99], [0.1, 0.5, 0.9]))
    assert marks_of(quiet, 3) == ["", "", ""] and "E* = 1e+09 Pa:" not in quiet


def test_rows_the_fluid_would_lift_are_marked_apart_from_the_mild_note():
    # dp = 5 MPa against rows of 1, 5 and 10 MPa (1e-3 ... 1e-2 E*)
    ds = table_dataset([1e-3, 5e-3, 1e-2], [0.1, 0.2, 0.3], fluid=5e6)
    text = format_table(ds)
    assert marks_of(text, 3) == ["!", "!", ""]
    notes = notes_of(text)
    [lift] = [n for n in notes if n.startswith("note: ! ")]
    assert lift.startswith("note: ! the fluid pressure 5e+06 Pa is at or above the contact "
                           "pressure of these rows (1e+06, 5e+06 Pa): on the high-pressure "
                           "side of the seal it would push the faces apart")
    assert "does not hold there" in lift
    # the milder note stays, for the rows above it
    assert sum("is not small against the lowest contact pressure 1e+06 Pa" in n
               for n in notes) == 1
    # a fluid pressure below every row: neither
    text = format_table(table_dataset([1e-3, 5e-3], [0.1, 0.2], fluid=1e5))
    assert "!" not in text and "not small against" not in text


def test_a_row_carries_every_mark_that_applies_and_the_columns_stay_aligned():
    # 1 MPa with 2 contact cells under dp = 2 MPa: under-resolved and lifted; 2 GPa: above E*
    ds = table_dataset([1e-3, 1e-2, 2.0], [2 / 576, 0.2, 1.0], fluid=2e6)
    text = format_table(ds)
    assert marks_of(text, 3) == ["~!", "", "^"]
    lines = text.splitlines()
    assert len({len(line) for line in lines[1:6]}) == 1  # header, units and rows
    # the gap column starts at the same place on every line
    starts = {line.index(" 1.000e-06") for line in lines[3:6]}
    assert len(starts) == 1 and lines[2].index("m ") == min(starts) + 9
    assert {n[:8] for n in notes_of(text)} >= {"note: ~ ", "note: ! ", "note: ^ "}


def _threshold(axis: int, p_lo: float, p_hi: float) -> Threshold:
    return Threshold(axis=axis, a_c_star=0.4, a_lo=0.39, a_hi=0.41, p_lo=p_lo, p_hi=p_hi,
                     n_solves=3, model="elastic", tol=0.02)


def test_a_sealing_pressure_at_or_above_e_star_gets_a_note():
    # the AFM example: sealed along x between 218 and 241 GPa against E* = 200 GPa
    ds = table_dataset([1e-3, 0.5], [0.1, 0.5],
                       thresholds={0: _threshold(0, 1.09, 1.205), 1: _threshold(1, 0.04, 0.05)})
    text = format_table(ds)
    [note] = [n for n in notes_of(text) if "sealing pressure along" in n]
    assert note.startswith("note: the sealing pressure along x (between 1.09e+09 Pa and "
                           "1.205e+09 Pa) is at or above E* = 1e+09 Pa: strains of order one")
    assert marks_of(text, 2) == ["", ""]  # no row is there


def test_leak_curve_logs_rows_at_or_above_e_star_in_pascals_too(caplog):
    rng = np.random.default_rng(1)
    s = Surface.from_array(0.05 * rng.standard_normal((32, 32)), lx=1.0, ly=1.0)
    with caplog.at_level(logging.WARNING, logger="roughflow.leak"):
        leak_curve(s, [0.01, 0.3], boundary="periodic", sealing=False)
    assert "at or above E*" not in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="roughflow.leak"):
        leak_curve(s, [0.01, 1.0, 3.0], boundary="periodic", sealing=False, modulus=2e11)
    said = [r.getMessage() for r in caplog.records if "at or above E*" in r.getMessage()]
    assert len(said) == 1
    assert said[0].startswith("the nominal pressures at or above E* (1, 3 E* = 2e+11, 6e+11 "
                              "Pa): strains of order one")


def test_the_floor_function_is_the_check_s_floor():
    shape, gbar = (128, 128), 0.0169
    floor = resolved_load_floor(gbar, shape)
    assert floor == pytest.approx(gbar * CONTACT_MIN_CELLS / (128 * 128) / 2.0, rel=1e-12)
    check_resolved_load(floor, gbar, shape)
    with pytest.raises(InputError, match="below what a 128 x 128 grid resolves"):
        check_resolved_load(0.999 * floor, gbar, shape)


def test_leak_curve_refuses_an_unresolved_pressure_before_any_solve(monkeypatch):
    import roughflow.leak as leak

    s = Surface.from_array(np.random.default_rng(3).standard_normal((32, 32)), lx=1.0, ly=1.0)
    floor = lowest_resolved_pressure(s)
    assert floor == pytest.approx(resolved_load_floor(s.gbar, s.shape))
    monkeypatch.setattr(leak, "solve", lambda *a, **k: pytest.fail("a solve ran"))
    with pytest.raises(InputError, match="below what a 32 x 32 grid resolves"):
        leak_curve(s, [0.5 * floor, 0.1])
    # a mirror-tiled cell has four times the cells: its floor is lower
    assert lowest_resolved_pressure(s, "mirror") < floor


@pytest.fixture(scope="module")
def steep_scan(tmp_path_factory) -> str:
    """tests/data/afm-64.npy with heights ten times as tall (rms gradient 3), imported."""
    from pathlib import Path

    folder = tmp_path_factory.mktemp("steep")
    h = np.load(Path(__file__).resolve().parent / "data" / "afm-64.npy")
    np.save(folder / "steep.npy", 10 * h)
    out = folder / "steep.nc"
    assert main(["-q", "import", str(folder / "steep.npy"), "--size", "500nm", "--unit", "nm",
                 "-o", str(out)]) == 0
    return str(out)


def test_cli_leak_marks_rows_above_e_star_and_logs_them(afm_scan_file, tmp_path, capsys):
    # the audit's typo: --modulus 200MPa for 200GPa puts the rows up to 50 E*
    capsys.readouterr()
    assert main(["leak", str(afm_scan_file), "--modulus", "200MPa", "--pressures",
                 "1MPa:10GPa:4", *SEAL, "--no-sealing", "-o", str(tmp_path / "l.nc")]) == 0
    out, err = capsys.readouterr()
    assert marks_of(out, 4)[2:] == ["^", "^"] and "^" not in "".join(marks_of(out, 4)[:2])
    assert "note: ^ the nominal pressure of these rows (4.642e+08, 1e+10 Pa) is at or above " \
           "E* = 2e+08 Pa" in out
    assert "the nominal pressures at or above E* (2.321, 50 E* = 4.642e+08, 1e+10 Pa)" in err


def test_cli_leak_notes_a_sealing_pressure_above_e_star(steep_scan, tmp_path, capsys):
    capsys.readouterr()
    assert main(["leak", steep_scan, "--modulus", "200GPa", "--pressures", "10GPa,100GPa",
                 *SEAL, "-o", str(tmp_path / "s.nc")]) == 0
    out, err = capsys.readouterr()
    with xr.open_dataset(tmp_path / "s.nc") as ds:
        hi = ds["sealing_pressure"].values[0]
    above = [a for a, v in zip("xy", hi, strict=True) if v >= 2e11]
    assert above, hi  # this scan seals above E* along at least one axis
    for a, v in zip("xy", hi, strict=True):
        note = f"note: the sealing pressure along {a} (between "
        assert (note in out) == (v >= 2e11)
        assert (f"the sealing pressure along {a} at or above E*" in err) == (v >= 2e11)
    assert marks_of(out, 2) == ["", ""]  # the rows, at 0.05 and 0.5 E*, are not


def test_cli_threshold_logs_a_sealing_pressure_above_e_star(steep_scan, tmp_path, capsys):
    # the same flag as leak's, from the window search of roughflow threshold
    capsys.readouterr()
    out = tmp_path / "t.nc"
    assert main(["threshold", steep_scan, "--boundary", "window", "--modulus", "200GPa",
                 "-o", str(out)]) == 0
    err = capsys.readouterr().err
    with xr.open_dataset(out) as ds:
        hi = {a: float(ds["p_hi"].sel(axis=a)) for a in ("x", "y")}
    assert any(v >= 1.0 for v in hi.values()), hi  # p_hi in E*
    for a, v in hi.items():
        assert (f"p_hi along {a} at or above E*" in err) == (v >= 1.0), err


def test_cli_leak_refuses_an_unresolved_pressure_in_the_options_words(afm_scan_file,
                                                                       tmp_path, capsys,
                                                                       monkeypatch):
    import roughflow.leak as leak

    monkeypatch.setattr(leak, "leak_curve", lambda *a, **k: pytest.fail("a solve ran"))
    with pytest.raises(SystemExit) as exc:
        main(["leak", str(afm_scan_file), "--modulus", "200GPa", "--pressures", "1Pa:1GPa:3",
              *SEAL, "--no-sealing", "-o", str(tmp_path / "l.nc")])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    s = read_scan_of(afm_scan_file)
    floor = lowest_resolved_pressure(s) * 2e11
    assert f"--pressures 1 Pa is below what the 64 x 64 grid resolves: {floor:.3g} Pa for " \
           f"its rms gradient {s.gbar:.3g} and --modulus 200GPa" in err
    assert f"give --pressures of {floor:.3g} Pa or more" in err


def read_scan_of(path) -> Surface:
    from roughflow.io import read_dataset, surface_from_dataset

    return surface_from_dataset(read_dataset(path, "surface", what="surface file"))


def test_cli_leak_gives_its_logged_pressures_in_pascals_too(afm_scan_file, tmp_path, capsys):
    capsys.readouterr()
    assert main(["leak", str(afm_scan_file), "--modulus", "200GPa", "--pressures", "1MPa,1GPa",
                 *SEAL, "--no-sealing", "-o", str(tmp_path / "l.nc")]) == 0
    err = capsys.readouterr().err
    assert "fewer than 16 contact cells at the nominal pressures 5e-06 E* = 1e+06 Pa" in err


def test_cli_contact_warns_at_or_above_e_star_and_gives_the_gap_in_metres(afm_scan_file,
                                                                          tmp_path, capsys):
    capsys.readouterr()
    assert main(["contact", str(afm_scan_file), "--pressure", "300GPa", "--modulus", "200GPa",
                 "-o", str(tmp_path / "c.nc")]) == 0
    out, err = capsys.readouterr()
    assert "--pressure 300GPa is at or above E* (1.5 E* = 3e+11 Pa): strains of order one" in err
    assert main(["contact", str(afm_scan_file), "--pressure", "1GPa", "--modulus", "200GPa",
                 "-o", str(tmp_path / "d.nc")]) == 0
    out, err = capsys.readouterr()
    assert "at or above E*" not in err
    with xr.open_dataset(tmp_path / "d.nc") as ds:
        gap, length = float(ds.attrs["mean_gap"]), float(ds.attrs["ref_length_m"])
    assert length == pytest.approx(500e-9)
    assert f"mean gap {gap:.6g} L = {gap * length:.6g} m (L = 5e-07 m)" in out
    # without a modulus, in E*
    assert main(["contact", str(afm_scan_file), "--pressure", "2", "-o",
                 str(tmp_path / "e.nc")]) == 0
    assert "--pressure 2 is at or above E* (2 E*)" in capsys.readouterr().err


def test_cli_contact_refuses_an_unresolved_pressure_in_pascals(afm_scan_file, tmp_path,
                                                              capsys):
    with pytest.raises(SystemExit) as exc:
        main(["contact", str(afm_scan_file), "--pressure", "1Pa", "--modulus", "200GPa",
              "-o", str(tmp_path / "c.nc")])
    assert exc.value.code == 2
    assert "--pressure 1 Pa is below what the 64 x 64 grid resolves" in capsys.readouterr().err


def test_the_unit_messages_name_a_modulus_example_and_both_units():
    with pytest.raises(InputError, match=r"--modulus: '200' has no unit; give a pressure such "
                                         r"as '200GPa'"):
        parse_quantity("200", "pressure", "--modulus")
    with pytest.raises(InputError, match="such as '1MPa'"):  # other pressures keep theirs
        parse_quantity("1", "pressure", "--fluid-pressure")
    with pytest.raises(InputError, match=r"low end 1e\+07 Pa >= high end 1e\+06 Pa\)"):
        parse_range("10MPa:1MPa:4", "pressure", "--pressures")


def test_one_size_for_a_grid_that_is_not_square_is_named_as_such(tmp_path, caplog):
    h = np.random.default_rng(0).standard_normal((64, 48))
    np.save(tmp_path / "r.npy", h)
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        s = read_scan(tmp_path / "r.npy", size="500nm", unit="nm")
    assert s.lx == s.ly  # one size is both sides
    assert "one size ('500nm') was given for the 64 x 48 grid and taken for both sides" \
        in caplog.text
    assert "lx:ly = 64:48" in caplog.text and "swapped" not in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING", logger="roughflow.scan"):
        read_scan(tmp_path / "r.npy", size="500nm,375nm", unit="nm")
    assert caplog.text == ""
