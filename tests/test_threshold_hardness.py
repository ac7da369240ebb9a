"""The threshold search with a hardness: ``SearchOptions(hardness=H)`` solves every contact of
the search elastic-perfectly-plastic (``contact.solve(..., hardness=H)``, by gfmd unless
``method="cg"``; tests/test_contact_hardness_gfmd.py compares the two), and
``roughflow threshold --hardness``, ``roughflow leak --hardness`` with its sealing search."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from cli_checks import LEAK_ARGS, refused

from roughflow.cli import main
from roughflow.contact import Adhesion, solve
from roughflow.errors import InputError
from roughflow.search import SearchOptions, scaled_options, threshold
from roughflow.search.critical import HARDNESS_RANGE_FRACTION
from roughflow.search.load import Point, compact, warm_start, warm_start_compliance
from roughflow.surface import Surface, SurfaceSpec, generate

TOL = 2e-3  # the search's default tol
#: The ladder of hardnesses, in units of the surface's elastic threshold pressure.
LADDER = (50, 5, 2.5, 1.5, 1.0, 0.5, 0.25, 0.125)
SEEDS = (0, 1, 2, 3)


def _surface(seed: int):
    """64^2, 2 points per lambda_s, rms gradient 1: a search takes 0.01-0.2 s here."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, l_over_lambda_r=2,
                                           seed=seed))


@pytest.fixture(scope="module")
def ladders():
    """Per seed: the surface, its elastic and bearing thresholds, the reference pressure
    (the mean of the two axes' elastic p_hi) and the capped thresholds at LADDER x it."""
    out = []
    for seed in SEEDS:
        s = _surface(seed)
        el = threshold(s)
        ref = 0.5 * (el[0].p_hi + el[1].p_hi)
        capped = {f: threshold(s, options=SearchOptions(hardness=f * ref)) for f in LADDER}
        out.append((s, el, threshold(s, model="bearing"), ref, capped))
    return out


def _p_c(t) -> float:
    return 0.5 * (t.p_lo + t.p_hi)


def test_without_a_hardness_the_search_is_the_elastic_one():
    # hardness=None is no cap: the same solves (gfmd, lean states) and the same numbers as
    # the default options, and the results say that no cap was applied. (That the search
    # without a hardness is unchanged by the cap's code was checked against the commit
    # before it on the default workflow's results, file for file.)
    s = _surface(1)
    default = threshold(s)
    explicit = threshold(s, options=SearchOptions(hardness=None))
    for ax in (0, 1):
        a, b = default[ax], explicit[ax]
        assert (a.a_c_star, a.p_lo, a.p_hi, a.n_solves) == (b.a_c_star, b.p_lo, b.p_hi,
                                                             b.n_solves)
        assert a.hardness is None and b.hardness is None
        assert np.isfinite(a.a_c_star_corrected)  # the elastic correction applies


def test_a_hardness_no_cell_reaches_gives_the_elastic_threshold(ladders):
    for s, el, _, ref, capped in ladders:
        cap = LADDER[0] * ref
        for ax in (0, 1):
            t = capped[LADDER[0]][ax]
            assert t.hardness == cap and t.model == "elastic" and t.bracketed
            assert np.isnan(t.a_c_star_corrected)  # calibrated on elastic contacts only
            # no cell reaches the cap at the search's highest pressure (the elastic contact's
            # largest pressure at p_hi is 6.7-10 x ref on these surfaces), so the capped
            # solves are the elastic ones (capped gfmd's iteration with no cell below the
            # wall is the elastic one): the same contact to the contact tolerance, the same
            # threshold within the search's tol (measured by cg: 4.1e-4 at most over 12
            # seeds)
            top = max(q.pressure for q in t.solves)
            assert solve(s, top, method="cg").contact_pressure.max() < cap
            assert abs(t.a_c_star - el[ax].a_c_star) <= TOL
            assert t.a_lo < el[ax].a_hi and el[ax].a_lo < t.a_hi  # the same event


def test_a_lower_hardness_seals_at_a_lower_pressure(ladders):
    # A plastic cell carries no more than H, so the load spreads: the capped contact has
    # more area at a given load, and the fluid stops spanning at a lower pressure. From 2.5 x
    # the elastic threshold pressure down, each step of the ladder lowers p_c by more than
    # the brackets' width: the brackets are disjoint (measured on 12 seeds x 2 axes, none
    # overlapping; at 5 x, where few cells are plastic, they overlap in half).
    for _, el, _, _, capped in ladders:
        for ax in (0, 1):
            steps = [el[ax]] + [capped[f][ax] for f in LADDER if f <= 2.5]
            for upper, lower in zip(steps[:-1], steps[1:], strict=True):
                assert lower.p_hi < upper.p_lo
            # and no capped search's p_c lies above the elastic one by more than a bracket
            for f in LADDER:
                t = capped[f][ax]
                assert _p_c(t) <= el[ax].p_hi + (t.p_hi - t.p_lo)


def test_a_c_star_stays_elastic_while_few_cells_are_plastic(ladders):
    # a_c* is a property of the contact's geometry: it stays the elastic one while the cap
    # only flattens the highest asperities. Measured (12 seeds x 2 axes, 64^2): a_c*(H) -
    # a_c*(elastic) within 4.1e-4 at H = 10 and 50 x the elastic threshold pressure, within
    # 0.020 at 5 x (sd 0.005: one channel of a 64^2 cell closes or opens with a few cells);
    # from 2.5 x down the geometry moves towards the bearing cut (next test): mean +0.021 at
    # 2.5 x, +0.055 at 1 x, up to 0.18 on one axis. Allowed at 5 x: 0.025, the measured
    # spread plus the two searches' tol.
    for _, el, _, _, capped in ladders:
        for ax in (0, 1):
            assert abs(capped[5][ax].a_c_star - el[ax].a_c_star) <= 0.025


def test_a_small_hardness_tends_to_the_bearing_threshold(ladders):
    # The rigid-plastic limit: as H falls, the capped contact tends to the bearing cut at
    # area p / H (tests/test_contact_hardness.py), so its threshold tends to the bearing
    # model's. Per axis the approach is not monotonic on a 64^2 cell (a channel can close
    # early on the way), so the mean over 4 seeds x 2 axes is checked. Measured (the mean
    # |a_c*(H) - a_c*(bearing)| on three sets of 4 seeds, H / elastic threshold pressure =
    # inf, 1, 0.5, 0.25, 0.125): 0.074 0.034 0.022 0.012 0.0065; 0.077 0.0295 0.0195 0.011
    # 0.0073; 0.095 0.048 0.032 0.021 0.012: each step cuts it by 1.5 - 2.6. Asserted: by
    # 1.3 at each step, and at 0.125 x below 0.02.
    def mismatch(pick) -> float:
        return float(np.mean([abs(pick(el, capped)[ax].a_c_star - bearing[ax].a_c_star)
                              for _, el, bearing, _, capped in ladders for ax in (0, 1)]))

    steps = [mismatch(lambda el, capped: el)] + [
        mismatch(lambda el, capped, f=f: capped[f]) for f in (1.0, 0.5, 0.25, 0.125)]
    for upper, lower in zip(steps[:-1], steps[1:], strict=True):
        assert lower * 1.3 < upper, steps
    assert steps[-1] < 0.02, steps


def test_the_compact_state_of_a_capped_solve_keeps_its_plastic_cells():
    # The lean search keeps q = gap - c p - plastic depth in float32 (CompactState). Its
    # warm start from one state at the same load must give the solve back: every plastic
    # cell above the cap (cg clips it there and holds it plastic: the plastic depths here
    # are at least 7.7e-5 c H, 1300 x float32's rounding), gap 0 on contact, the rest to
    # float32's rounding (6e-8 relative; measured 5.4e-8 H, 1.3e-7 rms(h) in the gap).
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=5))  # 128^2
    c = warm_start_compliance(s)
    for cap, load in ((1.0, 0.19), (0.1, 0.04)):
        r = solve(s, load, hardness=cap, tol=1e-8, method="cg")
        assert r.plastic.any()
        start = warm_start([Point(load, r.area_fraction, compact(r, c))], load, compliance=c)
        assert np.array_equal(np.clip(start.contact_pressure, 0, cap) >= cap, r.plastic)
        assert np.array_equal(start.contact, r.contact) and not start.gap[r.contact].any()
        elastic = r.contact & ~r.plastic
        assert np.abs(start.contact_pressure - r.contact_pressure)[elastic].max() <= 1e-7 * cap
        assert np.abs(start.gap - r.gap).max() <= 1e-6 * s.heights.std()
        # and the solve from it has next to nothing left to do
        assert solve(s, load, hardness=cap, tol=1e-8, init=start,
                     method="cg").iterations <= 10


def test_the_lean_and_the_whole_state_searches_agree():
    # observe= keeps the states whole (the leak's sealing search does): the same warm starts
    # and predictions from the same q, so the same searches (measured: the same solves and
    # iterations on 3 seeds x 6 hardnesses at 128^2)
    s = _surface(2)
    for cap in (0.5, 0.1):
        lean = threshold(s, options=SearchOptions(hardness=cap))
        whole = threshold(s, options=SearchOptions(hardness=cap, observe=lambda r: r))
        for ax in (0, 1):
            assert lean[ax].n_solves == whole[ax].n_solves
            assert abs(lean[ax].a_c_star - whole[ax].a_c_star) <= 1 / s.heights.size


def test_the_range_ends_below_the_hardness_and_says_so_where_it_bounds_it():
    s = _surface(0)
    # 0.3 E* gbar: the elastic threshold pressure of this surface, 0.16 and 0.23 along x and
    # y, lies below it, the capped one (0.11 and 0.14) too
    cap = 0.3
    res = threshold(s, options=SearchOptions(hardness=cap))
    for t in res.values():
        assert t.bracketed and max(q.pressure for q in t.solves) <= HARDNESS_RANGE_FRACTION * cap
    # a range that ends below the capped threshold is unbracketed, as without a cap ...
    low = threshold(s, 0, options=SearchOptions(hardness=cap, pressure_range=(1e-3, 0.05),
                                                on_unbracketed="nan"))
    assert not low.bracketed and "hardness" not in low.message
    # ... and where the hardness ends the range, the message names it: a groove along x,
    # 10 rms heights deep, one row of 64 (a_c* = 63/64 at least, while 0.95 H holds a
    # contact of at least 0.95)
    h = np.array(s.heights)
    h[:, 10] -= 10 * h.std()
    groove = Surface.from_array(h)
    t = threshold(groove, 0, options=SearchOptions(hardness=0.1, on_unbracketed="nan"))
    assert not t.bracketed and t.hardness == 0.1
    assert ("still spans along x at the highest allowed pressure 0.095, 0.95 x the hardness "
            "0.1, which bounds the range") in t.message


def test_scaled_options_start_below_the_hardness():
    # the elastic law's first pressure for a_c* = 0.415 is 0.218 E* gbar; a capped contact
    # has at least p / H of area, so its search starts at most at 0.415 H
    assert scaled_options(1.0).first_pressure == pytest.approx(0.2179, abs=1e-4)
    assert scaled_options(1.0, hardness=0.1).first_pressure == pytest.approx(0.0415)
    assert scaled_options(1.0, hardness=10.0).first_pressure == scaled_options(1.0).first_pressure


@pytest.mark.parametrize(
    ("fields", "says"),
    [
        ({"hardness": 0.0}, "hardness must be positive, got 0.0"),
        ({"hardness": -0.2}, "hardness must be positive, got -0.2"),
        ({"hardness": float("nan")}, "hardness must be finite, got nan"),
        ({"hardness": float("inf")}, "hardness must be finite, got inf"),
        ({"hardness": True}, "hardness must be a pressure"),
        ({"hardness": "hard"}, "hardness must be a number, got 'hard'"),
        ({"hardness": 2e9}, "hardness 2e\\+09 E\\* is above 100 E\\*"),
        ({"hardness": 0.2, "pressure_range": (0.2, 1.0)},
         "pressure_range's lowest pressure 0.2 E\\* is not below hardness=0.2 E\\*"),
        ({"hardness": 0.2, "first_pressure": 0.3},
         "first_pressure 0.3 E\\* is not below hardness=0.2 E\\*"),
    ],
)
def test_bad_hardness_options_are_refused_on_construction(fields, says):
    with pytest.raises(InputError, match=says):
        SearchOptions(**fields)


def test_scaled_options_refuse_a_bad_hardness_too():
    for bad, says in ((float("nan"), "hardness must be finite"), (-1.0, "must be positive")):
        with pytest.raises(InputError, match=says):
            scaled_options(1.0, hardness=bad)


def test_the_cap_is_for_the_elastic_model_only():
    s = _surface(0)
    opts = SearchOptions(hardness=0.2)
    with pytest.raises(InputError, match="hardness=0.2 is for model='elastic', got "
                                         "model='bearing': it cuts the heights"):
        threshold(s, model="bearing", options=opts)
    with pytest.raises(InputError, match="hardness=0.2 is for model='elastic', got "
                                         "model='adhesive'"):
        threshold(s, model="adhesive", adhesion=Adhesion(1e-4, 0.01), options=opts)
    with pytest.raises(InputError, match="hardness=0.2 is solved on the CPU"):
        threshold(s, options=opts, backend="cupy")


# ---- the command line -------------------------------------------------------------------

def test_cli_threshold_with_hardness(cli_surface_file, tmp_path, capsys):
    from roughflow.io import read_surface

    s = read_surface(cli_surface_file)
    ref = threshold(s, options=scaled_options(s.gbar, hardness=0.2))
    plain, units = tmp_path / "t.nc", tmp_path / "u.nc"
    assert main(["threshold", str(cli_surface_file), "--hardness", "0.2", "-o",
                 str(plain)]) in (0, None)
    printed = capsys.readouterr().out
    assert "hardness 0.2)" in printed and "perimeter-corrected" not in printed
    # E* = 200 GPa: 40 GPa is 0.2 E*
    assert main(["threshold", str(cli_surface_file), "--hardness", "40GPa", "--modulus",
                 "200GPa", "-o", str(units)]) in (0, None)
    assert "hardness 0.2 (4e+10 Pa))" in capsys.readouterr().out
    for path in (plain, units):
        with xr.open_dataset(path) as ds:
            assert ds.attrs["hardness"] == pytest.approx(0.2, rel=1e-15)
            for i, t in enumerate(ref.values()):
                assert float(ds["a_c_star"][i]) == t.a_c_star
            assert "A07" in ds.attrs["references"].split()  # the saturated-pressure model
    with xr.open_dataset(units) as ds:
        assert ds.attrs["hardness_Pa"] == pytest.approx(4e10, rel=1e-12)
    with xr.open_dataset(plain) as ds:
        assert "hardness_Pa" not in ds.attrs


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--hardness", "0.2", "--model", "bearing"],
         ("--hardness 0.2 applies to --model elastic only", "no pressure to cap")),
        (["--hardness", "0.2", "--model", "adhesive"],
         ("--hardness 0.2 applies to --model elastic only, not --model adhesive",)),
        (["--hardness", "0"], ("--hardness must be a positive, finite pressure, got 0",)),
        (["--hardness", "nan"], ("--hardness must be a positive, finite pressure, got nan",)),
        (["--hardness", "2GPa"], ("--hardness", "--modulus")),
        (["--hardness", "0.2", "--p-max", "0.5"], ("--p-max 0.5 is not below --hardness 0.2",)),
        (["--hardness", "0.2", "--p-guess", "0.2"],
         ("--p-guess 0.2 is not below --hardness 0.2",)),
        (["--hardness", "1GPa", "--modulus", "200GPa", "--p-min", "2GPa"],
         ("--p-min 2GPa is not below --hardness 1GPa",)),
    ],
)
def test_cli_threshold_hardness_refusals(cli_surface_file, tmp_path, capsys, argv, says):
    out = tmp_path / "x.nc"
    refused(["threshold", str(cli_surface_file), *argv, "-o", str(out)], capsys, *says)
    assert not out.exists()


def test_cli_leak_with_hardness_searches_the_capped_sealing(afm_scan_file, tmp_path, capsys):
    out, elastic = tmp_path / "leak.nc", tmp_path / "elastic.nc"
    assert main(["leak", str(afm_scan_file), *LEAK_ARGS, "--hardness", "2GPa", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "caps the contact pressure of the rows and of the sealing search" in text
    assert "sealing pressure along x: between" in text
    assert main(["leak", str(afm_scan_file), *LEAK_ARGS, "-o", str(elastic)]) == 0
    capsys.readouterr()
    with xr.open_dataset(out) as ds, xr.open_dataset(elastic) as el:
        assert ds.attrs["sealing_searched"] == 1
        assert ds.attrs["hardness_Pa"] == pytest.approx(2e9, rel=1e-12)
        for name in ("a_c_star", "sealing_pressure", "sealing_pressure_lo"):
            assert "capped at the hardness" in ds[name].attrs["long_name"], name
            assert "capped" not in el[name].attrs["long_name"], name
        assert ds["bracketed"].values.all()
        sealed, sealed_el = ds["sealing_pressure"].values[0], el["sealing_pressure"].values[0]
        # Measured: 1.23 and 1.06 GPa along x and y capped, 38.9 and 15.0 GPa elastic (an
        # elastic contact far beyond the hardness). The capped window's sealing pressure
        # lies below the cap (its cell's mean pressure ends at 0.95 H) and below the elastic
        assert (sealed < HARDNESS_RANGE_FRACTION * 2e9).all() and (sealed < sealed_el).all()
        lo = ds["sealing_pressure_lo"].values[0]
        assert (lo < sealed).all() and np.isfinite(ds["a_c_star"].values).all()
