"""Non-periodic scans: the embeddings of roughflow.boundary and walls across the flow."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from roughflow import contact, flow
from roughflow.boundary import PAD_DEPTH, cell_points, embed
from roughflow.errors import InputError
from roughflow.percolation import percolates, spanning_cells
from roughflow.surface import Surface, SurfaceSpec, generate


def mirror_across(a: np.ndarray, axis: int) -> np.ndarray:
    """``a`` followed by its mirror image across ``axis`` (flow along the other axis)."""
    across = 1 - axis
    return np.concatenate([a, np.flip(a, axis=across)], axis=across)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.3, 0.7), st.integers(0, 1))
def test_walls_across_equal_the_mirrored_periodic_cell(seed, p_open, axis):
    """Folding the mirrored cell onto the original maps 4-neighbours to 4-neighbours or to
    the same cell, so a spanning path exists with walls exactly when one exists in the
    periodic, mirrored cell (the exact statement that lets "mirror" use walls)."""
    mask = np.random.default_rng(seed).random((9, 7)) < p_open
    assert percolates(mask, axis, periodic=False) == percolates(mirror_across(mask, axis), axis)
    cells = spanning_cells(mask, axis, periodic=False)
    mirrored = spanning_cells(mirror_across(mask, axis), axis)
    np.testing.assert_array_equal(mirror_across(cells, axis), mirrored)


def test_walls_block_a_path_that_needs_the_seam():
    # open along x only through the seam between the last and the first column
    m = np.zeros((6, 5), bool)
    m[:3, 0] = True
    m[2:, 4] = True
    assert percolates(m, 0) and not percolates(m, 0, periodic=False)


@pytest.mark.parametrize("axis", [0, 1])
def test_flow_with_walls_equals_the_mirrored_periodic_flow(axis):
    """By symmetry no fluid crosses the mirror lines of the mirrored periodic cell, so its
    conductance (per unit width) is that of the cell with walls across the flow."""
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4, seed=1)
    s = generate(spec)
    # the bearing-model gap at 20 % contact (with seed 1 the walls cut sigma by ~28 %)
    gap = np.maximum(np.quantile(s.heights, 0.8) - s.heights, 0.0)
    assert flow.solve(gap, axis, periodic=False).percolating
    walls = flow.solve(gap, axis, lx=s.lx, ly=s.ly, periodic=False).sigma
    lx, ly = (s.lx, 2 * s.ly) if axis == 0 else (2 * s.lx, s.ly)
    mirrored = flow.solve(mirror_across(gap, axis), axis, lx=lx, ly=ly).sigma
    periodic = flow.solve(gap, axis, lx=s.lx, ly=s.ly).sigma
    assert walls == pytest.approx(mirrored, rel=1e-7)  # solver tolerance 1e-8
    assert walls != pytest.approx(periodic, rel=1e-3)  # the walls matter on this gap


def scan(n=32, seed=0) -> Surface:
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25, points_per_lambda_s=4,
                                  seed=seed)
    h = generate(spec).heights[:n, : n - 4]  # a non-periodic piece
    return Surface(heights=h, lx=1.0, ly=(n - 4) / n)


def test_mirror_cell_is_symmetric_and_its_quadrant_carries_the_solution():
    s = scan()
    emb = embed(s, "mirror")
    nx, ny = s.shape
    h = emb.surface.heights
    assert h.shape == (2 * nx, 2 * ny) and emb.load_factor == 1.0 and not emb.periodic
    np.testing.assert_array_equal(h[:nx, :ny], s.heights)
    np.testing.assert_array_equal(h[nx:, :ny], s.heights[::-1, :])
    np.testing.assert_array_equal(h[:nx, ny:], s.heights[:, ::-1])
    np.testing.assert_array_equal(h[nx:, ny:], s.heights[::-1, ::-1])
    res = contact.solve(emb.surface, 0.2)
    seen = emb.observe(res)
    # the solution is mirror-symmetric: the quadrant has the cell's contact area, to one
    # cell in 2 x 2 (round-off may break a tie at the contact edge)
    assert abs(seen.area_fraction - res.area_fraction) <= 2 / res.contact.size * 4
    assert seen.pressure == pytest.approx(0.2) and seen.gap.shape == s.shape


def test_pad_keeps_the_load_on_the_scan():
    s = scan()
    emb = embed(s, "pad")
    assert emb.load_factor == 0.25 and emb.surface.heights.shape == (64, 56)
    low = s.heights.min() - PAD_DEPTH * np.ptp(s.heights)
    assert np.all(emb.surface.heights[32:, :] == low)
    res = contact.solve(emb.surface, emb.cell_pressure(0.2))
    seen = emb.observe(res)
    # no contact in the padding, so the scan carries the whole load: nominal pressure 0.2
    assert seen.contact.sum() == res.contact.sum() > 0
    # the solve's residual bounds the load imbalance by tol (1e-6) times the load; measured
    # 3e-9 (7e-7 the worst over seeds 0-5)
    assert seen.contact_pressure.mean() == pytest.approx(0.2, rel=1e-6)
    assert seen.pressure == pytest.approx(0.2)


def test_pad_refuses_a_state_whose_padding_touches():
    """At high load the sag of the whole cell brought the padding into contact: on a 128^2
    scan at 0.6 E* gbar it carried 15-20 % of the load, and a_c, gap and sigma of the scan
    came out wrong without a word (documented as never in contact)."""
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=8, eps_f=0.125, points_per_lambda_s=2,
                                  seed=0)
    s = Surface(heights=generate(spec).heights[:, :120], lx=1.0, ly=120 / 128)
    emb = embed(s, "pad")
    low = emb.observe(contact.solve(emb.surface, emb.cell_pressure(0.1)))
    assert low.area_fraction > 0.2
    high = contact.solve(emb.surface, emb.cell_pressure(0.8))
    outside = high.contact.copy()
    outside[emb.window] = False
    assert outside.any()  # the case: the padding is in contact
    with pytest.raises(InputError, match="padding of boundary 'pad' touches"):
        emb.observe(high)


def test_window_and_periodic():
    s = scan()
    emb = embed(s, "window", margin=0.125)
    assert emb.window == (slice(4, 28), slice(4, 24)) and emb.shape == (24, 20)
    assert emb.lx == pytest.approx(24 / 32) and emb.surface is s
    per = embed(s, "periodic")
    assert per.periodic and per.shape == s.shape
    res = contact.solve(s, 0.1)
    assert per.observe(res) is res


def test_window_margins_follow_each_axis_s_own_length():
    """The margin is a share of each side: on a 32 x 48 scan 0.125 drops 4 cells at either
    end along x and 6 along y (a y margin taken from nx kept 4 + 4 rows too many)."""
    s = Surface(heights=np.random.default_rng(3).normal(size=(32, 48)), lx=1.0, ly=1.5)
    emb = embed(s, "window", margin=0.125)
    assert emb.window == (slice(4, 28), slice(6, 42)) and emb.shape == (24, 36)
    # the window's size in L: 24 of 32 cells of 1.0, 36 of 48 cells of 1.5
    assert emb.lx == pytest.approx(0.75, rel=1e-12) and emb.ly == pytest.approx(1.125, rel=1e-12)


def test_bad_embeddings_are_refused():
    with pytest.raises(InputError, match="'tile'"):
        embed(scan(), "tile")
    with pytest.raises(InputError, match="margin"):
        embed(scan(), "window", margin=0.5)
    with pytest.raises(InputError, match="Surface"):
        embed(np.zeros((8, 8)), "mirror")


def test_cell_points_is_the_size_of_the_embedded_cell():
    # the workflow sizes a leak job's memory request with it before the scan is embedded
    from roughflow.defaults import BOUNDARY_METHODS

    surface = Surface(heights=np.random.default_rng(0).normal(size=(24, 40)), lx=1.0, ly=1.5)
    for method in BOUNDARY_METHODS:
        assert cell_points((24, 40), method) == embed(surface, method).surface.heights.size
    with pytest.raises(InputError, match="boundary method"):
        cell_points((24, 40), "tile")
