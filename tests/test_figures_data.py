"""Study figures on the data researchers end up with, not the tidy default: gammas below 1,
one seed, one gamma, empty series (roughflow.figures). Synthetic datasets; no solve runs."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.colors import to_rgba  # noqa: E402

from roughflow.figures import (  # noqa: E402
    threshold_vs_gamma,
    threshold_vs_hurst,
    threshold_vs_size,
)
from roughflow.figures._style import EASY, HARD, seed_stats  # noqa: E402

EASY_A, HARD_A = 0.38, 0.45


def study(gammas, n_seeds=3, eps_t=(0.125,), model="elastic") -> xr.Dataset:
    """a_c* = 0.38 in the easy direction and 0.45 in the hard one at every point (x is easy
    for gamma > 1, y for gamma < 1), seeds 0.001 apart."""
    dims = ("model", "gamma", "hurst", "eps_t", "eps_f", "seed", "axis")
    a = np.empty((1, len(gammas), 1, len(eps_t), 1, n_seeds, 2))
    for gi, g in enumerate(gammas):
        easy_x = g >= 1
        a[0, gi, ..., 0] = EASY_A if easy_x else HARD_A
        a[0, gi, ..., 1] = HARD_A if easy_x else EASY_A
    a += 0.001 * np.arange(n_seeds)[:, None]
    return xr.Dataset({"a_c_star": (dims, a)}, coords={
        "model": [model], "gamma": list(gammas), "hurst": [0.8], "eps_t": list(eps_t),
        "eps_f": [0.0625], "seed": np.arange(n_seeds), "axis": ["x", "y"]})


def lines_by_color(ax):
    out = {}
    for line in ax.get_lines():
        if len(line.get_xdata()) > 0:
            out.setdefault(to_rgba(line.get_color()), []).extend(line.get_ydata())
    return out


def test_gamma_below_one_is_drawn_by_direction_not_by_axis():
    """For gamma < 1 the easy direction is y (the fits take it so): the figures coloured
    and named by axis, so one blue "x (easy)" curve joined the hard value at gamma 0.5 to
    the easy one at gamma 2."""
    fig = threshold_vs_gamma.draw(study([0.5, 2.0]))
    ax = fig.axes[0]
    by_color = lines_by_color(ax)
    np.testing.assert_allclose(by_color[to_rgba(EASY)], EASY_A, atol=0.01)
    np.testing.assert_allclose(by_color[to_rgba(HARD)], HARD_A, atol=0.01)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any("easy (x for gamma > 1, y below)" in t for t in labels)
    assert ax.get_title() == "(a) elastic contact, H = 0.8"  # eps_f: in the legend
    fig = threshold_vs_size.draw(study([0.5, 2.0], eps_t=(0.125, 0.25)))
    by_color = lines_by_color(fig.axes[0])
    np.testing.assert_allclose(by_color[to_rgba(EASY)], EASY_A, atol=0.01)
    np.testing.assert_allclose(by_color[to_rgba(HARD)], HARD_A, atol=0.01)


@pytest.mark.parametrize(("model", "reference"), [("elastic", 0.415), ("bearing", 0.5)])
def test_the_reference_line_is_the_models(model, reference):
    # the bearing panel drew the elastic 0.415 as "the paper's a_c*"; its own is exactly 1/2
    for fig in (threshold_vs_gamma.draw(study([1.0, 2.0], model=model)),
                threshold_vs_hurst.draw(study([1.0, 2.0], model=model))):
        ax = fig.axes[0]
        flat = [line for line in ax.get_lines() if line.get_linestyle() == ":"]
        assert len(flat) == 1 and set(flat[0].get_ydata()) == {reference}
        assert any(f"a_c* = {reference:g}" in t.get_text() and model in t.get_text()
                   for t in ax.get_legend().get_texts())


def test_one_seed_has_no_error_bar_not_a_zero_one():
    one = study([2.0], n_seeds=1)["a_c_star"].isel(model=0, hurst=0, eps_f=0, eps_t=0)
    mean, sem, n = seed_stats(one)
    assert np.isfinite(mean).all() and np.isnan(sem).all() and (n == 1).all()
    three = study([2.0])["a_c_star"].isel(model=0, hurst=0, eps_f=0, eps_t=0)
    assert np.isfinite(seed_stats(three)[1]).all()


def test_error_bar_is_the_standard_error_of_the_seed_mean():
    # std (ddof 1) / sqrt(n): seeds 0 and 2 -> sqrt(2) / sqrt(2) = 1; 0, 1, 2 -> 1 / sqrt(3)
    # (the population std gives 1/sqrt(2) and sqrt(2)/3, the std alone sqrt(2) and 1).
    # A few floating-point operations: equal to round-off.
    two = xr.DataArray([0.0, 2.0], dims="seed")
    mean, sem, n = seed_stats(two)
    assert float(mean) == 1.0 and int(n) == 2
    assert float(sem) == pytest.approx(1.0, rel=1e-14)
    three = xr.DataArray([0.0, 1.0, 2.0, np.nan], dims="seed")  # NaN: a seed not run
    mean, sem, n = seed_stats(three)
    assert float(mean) == 1.0 and int(n) == 3
    assert float(sem) == pytest.approx(1 / np.sqrt(3), rel=1e-14)


def test_one_gamma_keeps_its_axis_around_it():
    """With one gamma the log axis autoscaled to 0.96-1.04, so the 2-4 % nudges that keep
    the eps_f series apart looked like other gammas."""
    ax = threshold_vs_gamma.draw(study([1.0])).axes[0]
    lo, hi = ax.get_xlim()
    assert lo < 0.8 and hi > 1.25
    # isotropic surfaces alone have no easy and hard direction: "x (easy)" was said of them
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels and not any("easy" in t or "hard" in t for t in labels)
    assert any(t.endswith(" x") for t in labels) and any(t.endswith(" y") for t in labels)


def test_an_empty_panel_says_so():
    ds = study([1.0, 2.0])
    ds["a_c_star"][:] = np.nan
    fig = threshold_vs_size.draw(ds)
    assert "no finite a_c*" in " ".join(t.get_text() for t in fig.axes[0].texts)
    fig = threshold_vs_gamma.draw(ds)
    assert "no finite a_c*" in " ".join(t.get_text() for t in fig.axes[0].texts)


def test_a_free_nu_at_its_bound_is_said_in_the_figure():
    """A joint fit whose free nu stopped at its bound was drawn as any other."""
    from roughflow.fits import fit_dataset

    ds = study([2.0], n_seeds=3, eps_t=(0.125, 0.25, 0.5))
    fit = fit_dataset(ds, n_boot=0)
    fit["nu_at_bound"].loc[{"group": "anisotropic", "fit": "joint", "nu_mode": "free"}] = 1
    fit["a_star"].loc[{"group": "anisotropic", "fit": "joint", "nu_mode": "free"}] = 0.4
    fig = threshold_vs_size.draw(ds, fit)
    text = " ".join(t.get_text() for ax in fig.axes for t in ax.texts)
    assert "nu free" in text and "at its bound: not determined" in text


def test_the_fitted_values_do_not_hide_data():
    """The fits' text box sat inside the plot, over the lower left, and hid a point of the
    default run (gamma = 4, hard, a_c* 0.33); it is below the plot now, and says where the
    law misses the seed means."""
    from roughflow.fits import fit_dataset

    ds = study([2.0], n_seeds=3, eps_t=(0.125, 0.25, 0.5))
    fit = fit_dataset(ds, n_boot=0)
    fit["lack_of_fit"].loc[{"group": "anisotropic", "fit": "joint", "nu_mode": "fixed"}] = 1
    fit["chi2_dof"].loc[{"group": "anisotropic", "fit": "joint", "nu_mode": "fixed"}] = 12.0
    fig = threshold_vs_size.draw(ds, fit)
    plot, below = fig.axes
    assert not [t for t in plot.texts if "a_c* =" in t.get_text()]
    text = " ".join(t.get_text() for t in below.texts)
    assert "joint, nu fixed" in text and "misses the seed means: chi2/dof 12" in text
    # wrapped: one long line squeezed the plot to 0.54 of the figure's width (0.89 without)
    fig.draw_without_rendering()
    assert plot.get_position().width > 0.8


def test_the_hard_fit_line_has_the_hard_amplitude():
    """The red (hard) line of the joint fit is a_c* + A_hard eps^(1/nu), the blue one
    a_c* + A_easy eps^(1/nu): amplitudes of opposite sign, so the easy one drawn in red
    shows. The figure evaluates the same expression on its own eps grid: exact to
    round-off."""
    from roughflow.fits import fit_dataset

    ds = study([2.0], n_seeds=3, eps_t=(0.125, 0.25, 0.5))
    fit = fit_dataset(ds, n_boot=0)
    joint = {"group": "anisotropic", "fit": "joint", "nu_mode": "fixed"}
    fit["amp_easy"].loc[joint] = -0.1
    fit["amp_hard"].loc[joint] = 0.1
    row = fit.sel(joint)
    a_star, nu = float(row["a_star"]), float(row["nu"])
    ax = threshold_vs_size.draw(ds, fit).axes[0]
    solid = {to_rgba(c): line for line in ax.get_lines()
             if line.get_linestyle() == "-" and len(line.get_xdata()) > 10
             for c in [line.get_color()]}
    for color, amp in ((HARD, 0.1), (EASY, -0.1)):
        line = solid[to_rgba(color)]
        x = np.asarray(line.get_xdata())
        np.testing.assert_allclose(line.get_ydata(), a_star + amp * x ** (1 / nu),
                                   rtol=1e-14, atol=1e-15)


def test_sealed_steps_are_marked_not_dropped():
    """Where the fluid no longer percolates, sigma is exactly 0, which the log axes of the
    flow figures dropped without a word: the last step of the default run's elastic ladder
    (a_c 0.39) simply had no point. Each sealed (seed, step) is now a triangle on the bottom
    edge, and in the ratio panel a step sealed along y alone (chi infinite) one on the top
    edge. A real bearing ladder (no elastic solve) closes at 90 % contact."""
    from roughflow.aggregate import combine
    from roughflow.datasets.sweep import area_values
    from roughflow.figures import flow_anisotropic, flow_isotropic
    from roughflow.scenes import LadderJob, SurfaceParams, run_ladder

    surface = SurfaceParams(gamma=1.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)
    ds = combine([run_ladder(LadderJob(surface=surface, model="bearing", seeds=(0,),
                                       area_fractions=(0.1, 0.3, 0.9)))])
    sigma = ds["sigma"].sel(model="bearing")
    closed = (sigma == 0).all("axis").values.ravel()
    assert closed.sum() == 1 and (sigma > 0).all("axis").values.ravel().sum() == 2
    a = area_values(ds.sel(model="bearing")).values.ravel()

    def edge_marks(ax, marker):
        return [line for line in ax.get_lines() if line.get_marker() == marker]

    fig = flow_isotropic.draw(ds)
    (mark,) = edge_marks(fig.axes[0], "v")
    np.testing.assert_allclose(mark.get_xdata(), a[closed])
    assert mark.get_label() == "sealed (sigma = 0)"
    fig = flow_anisotropic.draw(ds)
    marks = edge_marks(fig.axes[0], "v")
    assert [m.get_label() for m in marks] == ["sealed along x (sigma_x = 0)",
                                              "sealed along y (sigma_y = 0)"]
    for m in marks:
        np.testing.assert_allclose(m.get_xdata(), a[closed])
    assert not edge_marks(fig.axes[-1], "^")  # sealed along both: chi undefined, no mark
    # sealed along y alone: chi = sigma_x / 0, a top-edge mark in the ratio panel
    ds["sigma"].loc[{"axis": "y"}] = ds["sigma"].sel(axis="y").where(area_values(ds) < 0.2, 0.0)
    fig = flow_anisotropic.draw(ds)
    (top,) = edge_marks(fig.axes[-1], "^")
    np.testing.assert_allclose(top.get_xdata(), a[(a > 0.2) & ~closed])


def test_unbracketed_searches_are_said_not_averaged_away():
    """A search that did not bracket a_c* stores NaN (``bracketed`` 0); the seed means and
    fits left it out and the figures drew the mean of the remaining seeds as any other
    point. The figures now say how many searches are missing, as does the aggregation."""
    from roughflow.figures import threshold_vs_hurst

    ds = study([1.0, 2.0], eps_t=(0.125, 0.25))
    ds["bracketed"] = xr.ones_like(ds["a_c_star"])
    for fig in (threshold_vs_gamma.draw(ds.isel(eps_t=[0])), threshold_vs_size.draw(ds)):
        assert fig._suptitle is None
    ds["a_c_star"][0, 1, 0, 1, 0, 2, 1] = np.nan
    ds["bracketed"][0, 1, 0, 1, 0, 2, 1] = 0
    ds["bracketed"][0, 0, 0, 1, 0, :, :] = np.nan  # not run: not counted
    for fig in (threshold_vs_gamma.draw(ds.isel(eps_t=[1])), threshold_vs_size.draw(ds),
                threshold_vs_hurst.draw(ds.isel(eps_t=[1]))):
        assert fig._suptitle.get_text().startswith("1 of ")
    assert "1 of 18 threshold searches" in threshold_vs_size.draw(ds)._suptitle.get_text()


def test_aggregation_warns_of_unbracketed_searches(tmp_path, caplog):
    import logging

    from roughflow.aggregate import aggregate
    from roughflow.scenes import SurfaceParams, ThresholdJob, run_threshold

    surface = SurfaceParams(gamma=1.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)
    job = run_threshold(ThresholdJob(surface=surface, model="bearing", seeds=(0, 1)))
    with caplog.at_level(logging.WARNING, logger="roughflow.aggregate"):
        aggregate([job], tmp_path / "study.nc")
    assert "did not bracket" not in caplog.text
    # as run_threshold stores a search that did not bracket (on_unbracketed="nan")
    one = {"seed": 1, "axis": "x"}
    for name in ("a_c_star", "a_lo", "a_hi", "a_c_star_corrected"):
        job[name].loc[one] = np.nan
    job["bracketed"].loc[one] = 0
    with caplog.at_level(logging.WARNING, logger="roughflow.aggregate"):
        aggregate([job], tmp_path / "study2.nc")
    assert "1 of 4 threshold searches" in caplog.text


@pytest.mark.parametrize(("points", "shown"), [
    ((4, 4), "a_c* perimeter-corrected"),
    ((2, 2), "a_c* raw (cell counts)"),
    ((2, 4), "a_c* perimeter-corrected on grids of >= 4 points per lambda_s, raw on the others"),
])
def test_the_caption_file_says_what_this_runs_data_hold(points, shown):
    # the captions describe the paper's study; a custom run's size and whether its a_c* are
    # corrected were nowhere next to the figure (a run at L/lambda_r = 8 and one at 4 could
    # not be told apart, and at 2 points per lambda_s the "corrected" values are not used)
    from roughflow.figures import caption_document, data_summary

    ds = study([1.0, 2.0])
    ds["a_c_star_corrected"] = ds["a_c_star"] - 0.03
    grid = ("model", "gamma", "hurst", "eps_t", "eps_f")
    ds["points_per_lambda_s"] = (grid, np.array(points, float).reshape(1, 2, 1, 1, 1))
    ds["l_over_lambda_r"] = (grid, np.array([8.0, 11.3137]).reshape(1, 2, 1, 1, 1))
    summary = data_summary(ds)
    assert summary.startswith("model elastic; gamma 1, 2; H 0.8; eps_f 0.0625; "
                              "L/lambda_r 8, 11.31; ")
    assert "; 3 seeds; " in summary and summary.endswith(shown)
    document = caption_document("threshold_vs_gamma", ds, "the dataset", "figure.png")
    assert f"Its data: {summary}." in document
    # no search bracketed a threshold: not "raw"
    ds["a_c_star"][:] = np.nan
    assert data_summary(ds).endswith("no a_c* (no search bracketed it)")


def test_the_flux_map_names_its_two_colours_outside_the_colour_bar():
    # contact (black) and cells without flow (white) were in no key: the colour map's low
    # end is near-black too, so contact and slow flow could not be told apart
    from matplotlib.figure import Figure

    from roughflow.figures.flux import plot_flux
    from roughflow.flow import solve

    gap = np.full((16, 16), 0.1)
    contact = np.zeros((16, 16), bool)
    contact[4:8, 4:8] = True
    gap[contact] = 0.0
    ax = Figure().subplots()
    plot_flux(solve(gap, axis=0), contact, ax=ax)
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "contact", "no flow (isolated pools)"]
