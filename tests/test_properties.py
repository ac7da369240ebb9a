"""Property-based tests across stages (hypothesis): symmetries and scalings that hold exactly.

- translation (np.roll) and mirror invariance of the contact area a_c (periodic half-space:
  the Green's function depends only on |q|, so the solution moves with the surface);
- translation across the flow axis and mirrors along and across it leave sigma unchanged
  (the Reynolds problem is periodic across the flow axis and symmetric under reversal of
  the flow direction);
- transposition swaps sigma_x and sigma_y, and fluid percolation along x and y;
- sigma(c u) = c^3 sigma(u) (Reynolds conductivity u^3 / (12 eta), Eq. 3-4);
- a_c grows with the load (monotone contact-area growth of frictionless contact).

Grids are small (16 to 48 cells a side) and ``max_examples`` is bounded so that the file
runs in a few seconds.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from roughflow import contact, flow
from roughflow.percolation import contact_percolates, percolates
from roughflow.surface import Surface, SurfaceSpec, generate

# derandomize: the same examples on every run (a failure that shows on some runs only would
# be a flaky CI), and no .hypothesis database written into the working directory
SETTINGS = settings(max_examples=12, deadline=None, derandomize=True, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
#: contact tolerance: gap error 1e-10 rms heights, so the contact set is decided far from
#: round-off except at cells whose pressure is within ~1e-10 of zero
CTOL = 1e-10

seeds = st.integers(min_value=0, max_value=2**31 - 1)
sizes = st.sampled_from([16, 24, 32])
gammas = st.sampled_from([0.5, 1.0, 2.0])
loads = st.floats(min_value=0.02, max_value=0.5)


def _surface(seed: int, n: int, gamma: float = 1.0) -> Surface:
    spec = SurfaceSpec(nx=n, ny=n, lx=1.0, ly=1.0, hurst=0.8, gamma=gamma, lambda_r=0.5,
                       lambda_s=4.0 / n, seed=seed)
    return generate(spec)


def _gap_field(seed: int, n: int, closed: float) -> np.ndarray:
    """Random gap: log-normal heights with a fraction ``closed`` of contact (zero) cells."""
    rng = np.random.default_rng(seed)
    g = np.exp(rng.normal(0.0, 1.0, size=(n, n + 3)))
    g[rng.random(g.shape) < closed] = 0.0
    return g


def _n_diff(a: np.ndarray, b: np.ndarray) -> int:
    return int(np.count_nonzero(a != b))


# ---------------------------------------------------------------------------------------
# contact
# ---------------------------------------------------------------------------------------

@SETTINGS
@given(seed=seeds, n=sizes, gamma=gammas, p=loads,
       shift=st.tuples(st.integers(0, 47), st.integers(0, 47)))
def test_contact_translation_invariance(seed, n, gamma, p, shift):
    s = _surface(seed, n, gamma)
    r0 = contact.solve(s, p, tol=CTOL)
    moved = Surface.from_array(np.roll(s.heights, shift, axis=(0, 1)))
    r1 = contact.solve(moved, p, tol=CTOL)
    # The contact set moves with the surface: allow at most one cell to flip, for a cell
    # whose contact pressure is at round-off level (the FFT sums in a different order).
    assert _n_diff(np.roll(r0.contact, shift, axis=(0, 1)), r1.contact) <= 1
    assert r1.area_fraction == pytest.approx(r0.area_fraction, abs=1.0 / n**2)
    # mean gap: an integral quantity, converged to ~CTOL rms heights
    assert r1.mean_gap == pytest.approx(r0.mean_gap, rel=1e-6)


@SETTINGS
@given(seed=seeds, n=sizes, gamma=gammas, p=loads, axis=st.sampled_from([0, 1]))
def test_contact_mirror_invariance(seed, n, gamma, p, axis):
    s = _surface(seed, n, gamma)
    r0 = contact.solve(s, p, tol=CTOL)
    r1 = contact.solve(Surface.from_array(np.flip(s.heights, axis=axis).copy()), p, tol=CTOL)
    assert _n_diff(np.flip(r0.contact, axis=axis), r1.contact) <= 1  # round-off, as above
    assert r1.mean_gap == pytest.approx(r0.mean_gap, rel=1e-6)


@SETTINGS
@given(seed=seeds, n=sizes, gamma=gammas, p=loads)
def test_contact_transposition_swaps_axes(seed, n, gamma, p):
    s = _surface(seed, n, gamma)
    r0 = contact.solve(s, p, tol=CTOL)
    r1 = contact.solve(Surface.from_array(s.heights.T.copy()), p, tol=CTOL)
    assert _n_diff(r0.contact.T, r1.contact) <= 1
    # The gap of the transposed surface is the transposed gap (to the solver tolerance,
    # CTOL rms heights; rms height < 1 here), so the conductances swap.
    np.testing.assert_allclose(r1.gap, r0.gap.T, atol=1e-8 * np.abs(r0.gap).max() + 1e-12)
    if _n_diff(r0.contact.T, r1.contact) == 0:
        sx, sy = flow.conductance(r0.gap)
        tx, ty = flow.conductance(r1.gap)
        # sigma is variational in the pressure: relative error ~ (solver residual)^2 plus
        # the gap difference (1e-8 relative): 1e-6 is a safe bound.
        assert tx == pytest.approx(sy, rel=1e-6, abs=1e-300)
        assert ty == pytest.approx(sx, rel=1e-6, abs=1e-300)


@SETTINGS
@example(seed=258350335, n=16, gamma=1.0, ps=[0.9921875, 1.0])
@example(seed=0, n=16, gamma=0.5, ps=[0.9999999999999999, 1.0])
@given(seed=seeds, n=sizes, gamma=gammas,
       ps=st.lists(st.floats(min_value=0.01, max_value=1.0), min_size=2, max_size=4,
                   unique=True))
def test_contact_area_monotone_in_load(seed, n, gamma, ps):
    s = _surface(seed, n, gamma)
    ps = sorted(ps)
    areas, gaps = [], []
    prev = None
    for p in ps:
        r = contact.solve(s, p, tol=CTOL)
        areas.append(r.area_fraction)
        gaps.append(r.mean_gap)
        if prev is not None:
            # contact never recedes under a larger load (one round-off cell allowed)
            assert np.count_nonzero(prev & ~r.contact) <= 1
        prev = r.contact
    assert all(a1 >= a0 - 1.0 / n**2 for a0, a1 in zip(areas, areas[1:], strict=False))
    # the mean gap falls strictly with the load (p = -d(elastic energy)/d(gap) > 0) until
    # full contact, where it stays 0 (a 16^2 surface is fully in contact from p = 0.99 on:
    # found by hypothesis, seed 258350335, loads 0.9921875 and 1). Loads closer than 1e-9
    # move it by less than the solver resolves (CTOL rms heights): at one ulp apart (seed 0,
    # gamma 0.5, loads 1 - 1.1e-16 and 1) it came out 1.8e-19 higher, 2e-15 relative; it
    # must then not rise by more than that resolution
    resolution = CTOL * float(np.std(s.heights))
    assert all(g1 < g0 or g0 == g1 == 0.0 or (p1 - p0 < 1e-9 and g1 <= g0 + resolution)
               for p0, p1, g0, g1 in zip(ps, ps[1:], gaps, gaps[1:], strict=False))


# ---------------------------------------------------------------------------------------
# flow and percolation on random gap fields (exact symmetries of the discrete problem)
# ---------------------------------------------------------------------------------------

closed_fractions = st.floats(min_value=0.0, max_value=0.55)


@SETTINGS
@given(seed=seeds, n=sizes, closed=closed_fractions, shift=st.integers(1, 40),
       axis=st.sampled_from([0, 1]))
def test_flow_translation_across_flow_axis(seed, n, closed, shift, axis):
    g = _gap_field(seed, n, closed)
    ly = g.shape[1] / g.shape[0]
    across = 1 - axis
    s0 = flow.solve(g, axis, ly=ly)
    s1 = flow.solve(np.roll(g, shift, axis=across), axis, ly=ly)
    assert s1.percolating == s0.percolating
    # periodic across the flow axis: the same linear system up to a relabelling; sigma from
    # the dissipation has relative error ~ residual^2 (1e-16) times the conditioning
    assert s1.sigma == pytest.approx(s0.sigma, rel=1e-7, abs=1e-300)


@SETTINGS
@given(seed=seeds, n=sizes, closed=closed_fractions, axis=st.sampled_from([0, 1]),
       mirror=st.sampled_from([0, 1]))
def test_flow_mirror_invariance(seed, n, closed, axis, mirror):
    g = _gap_field(seed, n, closed)
    ly = g.shape[1] / g.shape[0]
    s0 = flow.solve(g, axis, ly=ly)
    s1 = flow.solve(np.flip(g, axis=mirror).copy(), axis, ly=ly)
    # mirror along the flow axis reverses the flow (same conductance); across it, it is a
    # relabelling of the periodic direction: sigma is unchanged to solver accuracy (the
    # direct solve of these small grids, as below: measured at most 4.4e-16)
    assert s1.percolating == s0.percolating
    assert s1.sigma == pytest.approx(s0.sigma, rel=1e-12, abs=1e-300)


@SETTINGS
@given(seed=seeds, n=sizes, closed=closed_fractions)
def test_transposition_swaps_flow_and_percolation(seed, n, closed):
    g = _gap_field(seed, n, closed)
    lx, ly = 1.0, g.shape[1] / g.shape[0]
    gt = g.T.copy()
    sx, sy = flow.conductance(g, lx=lx, ly=ly)
    tx, ty = flow.conductance(gt, lx=ly, ly=lx)
    # grids this small take the direct solve, which certifies sigma to 1e-14 (sigma_error,
    # 465 random fields); measured equal over 300 fields; 1e-12 for another build's round-off
    assert tx == pytest.approx(sy, rel=1e-12, abs=1e-300)
    assert ty == pytest.approx(sx, rel=1e-12, abs=1e-300)
    open_mask = g > 0
    assert percolates(open_mask.T, 0) == percolates(open_mask, 1)
    assert percolates(open_mask.T, 1) == percolates(open_mask, 0)
    # duality (docs/physics.md Sect. 4): fluid spans x exactly when no 8-connected contact cluster
    # spans y
    for ax in (0, 1):
        assert percolates(open_mask, ax) != contact_percolates(~open_mask, 1 - ax)


@SETTINGS
@given(seed=seeds, n=sizes, closed=closed_fractions,
       c=st.floats(min_value=1e-3, max_value=1e3), axis=st.sampled_from([0, 1]))
def test_sigma_scales_as_c_cubed(seed, n, closed, c, axis):
    g = _gap_field(seed, n, closed)
    ly = g.shape[1] / g.shape[0]
    s0 = flow.solve(g, axis, ly=ly).sigma
    s1 = flow.solve(c * g, axis, ly=ly).sigma
    # sigma is homogeneous of degree 3 in the gap (Eq. 3-4); the pressure field is
    # unchanged, so only round-off of the solve enters
    assert s1 == pytest.approx(c**3 * s0, rel=1e-7, abs=1e-300)


def test_uniform_gap_reference():
    """Anchor for the properties above: a uniform gap u0 gives sigma = u0^3 / 12 exactly."""
    u0 = 0.37
    sx, sy = flow.conductance(np.full((12, 20), u0), lx=1.0, ly=20 / 12)
    assert sx == pytest.approx(u0**3 / 12, rel=1e-10)
    assert sy == pytest.approx(u0**3 / 12, rel=1e-10)
