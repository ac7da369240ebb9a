"""Labelling and spanning on hand-made masks with known answers, against a brute-force
flood fill, and the 4/8 duality on random masks (docs/physics.md Sect. 4)."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from roughflow.errors import InputError
from roughflow.percolation import (
    contact_percolates,
    critical_open_count,
    critical_open_count_by_key,
    label,
    percolates,
    percolates_along,
    spanning_cells,
)


def _neighbours(i, j, nx, ny, periodic, connectivity):
    steps = [(1, 0), (-1, 0), (0, 1), (0, -1)]
    if connectivity == 8:
        steps += [(1, 1), (1, -1), (-1, 1), (-1, -1)]
    for di, dj in steps:
        a, b = i + di, j + dj
        if periodic[0]:
            a %= nx
        if periodic[1]:
            b %= ny
        if 0 <= a < nx and 0 <= b < ny:
            yield a, b


def _flood_components(mask, periodic, connectivity):
    """Reference labelling: breadth-first flood fill, returns a list of cell sets."""
    nx, ny = mask.shape
    seen = np.zeros_like(mask)
    comps = []
    for i in range(nx):
        for j in range(ny):
            if mask[i, j] and not seen[i, j]:
                comp, todo = set(), deque([(i, j)])
                seen[i, j] = True
                while todo:
                    c = todo.popleft()
                    comp.add(c)
                    for nb in _neighbours(*c, nx, ny, periodic, connectivity):
                        if mask[nb] and not seen[nb]:
                            seen[nb] = True
                            todo.append(nb)
                comps.append(comp)
    return comps


def _flood_spans(mask, axis, connectivity=4):
    periodic = (False, True) if axis == 0 else (True, False)
    n = mask.shape[axis]
    cells = set()
    for comp in _flood_components(mask, periodic, connectivity):
        ends = {c[axis] for c in comp}
        if 0 in ends and n - 1 in ends:
            cells |= comp
    return cells


def _mask(rows: list[str]) -> np.ndarray:
    """Mask from strings: row k is x index k, '.' open (True), '#' closed."""
    return np.array([[ch == "." for ch in r] for r in rows])


# ---- hand-made masks -----------------------------------------------------------------

def test_straight_channel_along_x():
    m = np.zeros((8, 6), dtype=bool)
    m[:, 2] = True  # a line of open cells running along x at y index 2
    assert percolates(m, 0)
    assert not percolates(m, 1)
    assert np.array_equal(spanning_cells(m, 0), m)
    assert not spanning_cells(m, 1).any()


def test_straight_channel_along_y():
    m = np.zeros((8, 6), dtype=bool)
    m[3, :] = True
    assert percolates(m, 1)
    assert not percolates(m, 0)


def test_channel_through_periodic_seam_only():
    # Along x the channel leaves through the y seam and comes back: it spans x only
    # because y is periodic. Along y (x periodic) the two half-channels are dead ends.
    m = _mask([
        "##.#",
        "##.#",
        "##..",
        ".##.",  # row x=3: (3, 3) and (3, 0) are neighbours only across the y seam
        ".###",
    ])
    assert percolates(m, 0)
    assert not percolates(m, 1)
    # Without the seam (plain label, no periodicity) the two parts are separate clusters.
    _, n_open = label(m, periodic=(False, False))
    _, n_per = label(m, periodic=(False, True))
    assert (n_open, n_per) == (2, 1)


def test_spiral_is_one_cluster_that_does_not_span():
    m = _mask([
        ".......",
        "######.",
        ".....#.",
        ".###.#.",
        ".#...#.",
        ".#####.",
        ".......",
    ])
    m = np.pad(m, 1, constant_values=False)  # closed frame: nothing touches the edges
    lab, n = label(m)
    assert n == 1
    assert not percolates(m, 0) and not percolates(m, 1)
    # Opening one frame cell at each end along x lets the spiral's outer arm span x.
    m2 = m.copy()
    m2[0, 1] = m2[-1, 1] = True
    assert percolates(m2, 0)
    assert spanning_cells(m2, 0).sum() == m2.sum()


def test_checkerboard_connectivity():
    m = (np.add.outer(np.arange(6), np.arange(6)) % 2 == 0)
    assert label(m, connectivity=4)[1] == 18  # every cell alone
    assert label(m, connectivity=8)[1] == 1  # diagonals join everything
    assert not percolates(m, 0) and not percolates(m, 1)
    assert percolates(m, 0, connectivity=8) and percolates(m, 1, connectivity=8)
    # the closed cells of a checkerboard wind around both directions (8-connected)
    assert contact_percolates(~m, 0) and contact_percolates(~m, 1)


def test_diagonal_contact_line_does_not_block():
    # A contact diagonal touches both ends along y but does not close on itself across the
    # y seam, so fluid still crosses along x: contact_percolates tests winding, not touching.
    c = np.eye(6, dtype=bool)
    assert percolates(~c, 0) and not contact_percolates(c, 1)


def test_label_matches_flood_fill_on_seams_and_corners():
    rng = np.random.default_rng(3)
    for _ in range(40):
        m = rng.random((9, 7)) < 0.45
        for periodic in [(True, True), (True, False), (False, True), (False, False)]:
            for conn in (4, 8):
                lab, n = label(m, periodic=periodic, connectivity=conn)
                comps = _flood_components(m, periodic, conn)
                assert n == len(comps)
                assert set(np.unique(lab[m])) == set(range(1, n + 1))
                assert not lab[~m].any()
                for comp in comps:
                    assert len({lab[c] for c in comp}) == 1


@settings(max_examples=200, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 9), st.integers(1, 9))), st.sampled_from([0, 1]))
def test_spanning_matches_flood_fill(m, axis):
    ref = _flood_spans(m, axis)
    got = spanning_cells(m, axis)
    assert {tuple(c) for c in np.argwhere(got)} == ref
    assert percolates(m, axis) == bool(ref)


def _critical_count_by_flood_fill(order, shape, axis):
    """Smallest k whose first k cells of ``order`` span along ``axis`` (flood fill)."""
    mask = np.zeros(shape, bool)
    for k, cell in enumerate(order, start=1):
        mask.flat[cell] = True
        if _flood_spans(mask, axis):
            return k
    return -1


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 12), st.integers(1, 10), st.integers(0, 2**32 - 1),
       st.sampled_from([0, 1]))
def test_critical_open_count_matches_flood_fill(nx, ny, seed, axis):
    # the sweep's periodic seam across the axis and its last join are what it is for: the
    # count is exact, one cell early or late is a different threshold
    rng = np.random.default_rng(seed)
    order = rng.permutation(nx * ny)
    ref = _critical_count_by_flood_fill(order, (nx, ny), axis)
    assert critical_open_count(order, (nx, ny), axis) == ref
    key = np.empty(nx * ny)
    key[order] = -np.arange(nx * ny, dtype=float)  # larger key opens first: the same order
    assert critical_open_count_by_key(key.reshape(nx, ny), axis, expect=rng.uniform()) == ref


@settings(max_examples=200, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 9), st.integers(1, 9))), st.booleans())
def test_percolates_along_both_axes_in_one_pass(m, periodic):
    # one seamless union-find pass, each axis's seam joined over the roots afterwards: the
    # same answers as the labelling of percolates() per axis (walls across the flow with
    # periodic=False included), checked against the flood fill; also with a reused work
    from roughflow.percolation import sweep_work

    got = percolates_along(m, periodic=periodic)
    assert got == {ax: percolates(m, ax, periodic=periodic) for ax in (0, 1)}
    if periodic:
        assert got == {ax: bool(_flood_spans(m, ax)) for ax in (0, 1)}
    assert percolates_along(m, (1,), periodic=periodic) == {1: got[1]}
    assert percolates_along(m, periodic=periodic, work=sweep_work(m.size)) == got


def test_percolates_along_on_correlated_masks_near_the_threshold():
    # Long runs of open cells, clusters that span only through a seam, and a work reused
    # from mask to mask (as a threshold search does, none of its arrays reset): smoothed
    # random fields cut near their percolation threshold, against the labelling
    from scipy.ndimage import gaussian_filter

    from roughflow.percolation import sweep_work

    rng = np.random.default_rng(12)
    work = sweep_work(64 * 48)
    seen = set()
    for _ in range(60):
        field = gaussian_filter(rng.standard_normal((64, 48)), 3.0, mode="wrap")
        m = field > np.quantile(field, rng.uniform(0.35, 0.65))
        for periodic in (True, False):
            got = percolates_along(m, periodic=periodic, work=work)
            assert got == {ax: percolates(m, ax, periodic=periodic) for ax in (0, 1)}
            seen.add((got[0], got[1]))
    assert len(seen) == 4  # every combination of the two axes occurred
    with pytest.raises(InputError, match="sweep work"):
        percolates_along(m[:10], work=work)


@settings(max_examples=300, deadline=None)
@given(arrays(np.bool_, st.tuples(st.integers(1, 12), st.integers(1, 12))), st.sampled_from([0, 1]))
def test_duality_fluid_spans_iff_contact_does_not(contact, axis):
    # Exact on the square grid: open 4-connected fluid crosses along `axis` exactly when no
    # 8-connected contact cluster closes around the other direction.
    assert percolates(~contact, axis) != contact_percolates(contact, 1 - axis)


def test_duality_on_dense_random_masks_near_threshold():
    rng = np.random.default_rng(1)
    for _ in range(30):
        c = rng.random((40, 30)) < 0.41  # site percolation of the 8-connected phase
        for axis in (0, 1):
            assert percolates(~c, axis) != contact_percolates(c, 1 - axis)


# ---- bad input -----------------------------------------------------------------------

@pytest.mark.parametrize("bad", [np.zeros((4, 4)), np.zeros((4, 4), dtype=int),
                                 np.zeros(4, dtype=bool), np.zeros((2, 2, 2), dtype=bool),
                                 np.zeros((0, 3), dtype=bool)])
def test_mask_must_be_2d_boolean(bad):
    with pytest.raises(InputError, match="mask"):
        percolates(bad, 0)
    with pytest.raises(InputError, match="mask"):
        label(bad)
    with pytest.raises(InputError, match="mask"):
        contact_percolates(bad, 0)


@pytest.mark.parametrize("axis", [2, -1, "X", "z", None, True, 1.0, np.float64(0)])
def test_axis_must_be_0_or_1(axis):
    m = np.ones((3, 3), dtype=bool)
    with pytest.raises(InputError, match="axis"):
        percolates(m, axis)
    with pytest.raises(InputError, match="axis"):
        spanning_cells(m, axis)


def test_axis_by_name_is_the_axis_by_number():
    m = np.zeros((6, 5), dtype=bool)
    m[:, 2] = True  # open along x only
    assert percolates(m, "x") == percolates(m, np.int64(0)) is True
    assert percolates(m, "y") == percolates(m, 1) is False


def test_connectivity_must_be_4_or_8():
    with pytest.raises(InputError, match="connectivity"):
        label(np.ones((3, 3), dtype=bool), connectivity=6)
