"""The nonlinear CG of the harmonic adhesive model (contact.adhesive_cg)."""

from __future__ import annotations

import numpy as np
import pytest

from roughflow.contact import _kernels as K
from roughflow.contact import gfmd as G
from roughflow.contact import solve
from roughflow.contact.adhesion import Adhesion, adhesion_for
from roughflow.defaults import ADHESION_RANGE_OVER_LAMBDA_S, ADHESION_SURFACE_ENERGY_RATIO
from roughflow.errors import ConvergenceError, InputError
from roughflow.surface import SurfaceSpec, generate


def _papers_case(n: int):
    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=4, eps_f=16.0 / n,
                                        points_per_lambda_s=4, seed=0))
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=ADHESION_SURFACE_ENERGY_RATIO,
                      range=ADHESION_RANGE_OVER_LAMBDA_S["harmonic"] * s.spec.lambda_s,
                      repulsion="harmonic")
    return s, ad


@pytest.mark.parametrize("numba", [True, False])
def test_line_kernels_are_the_potentials_derivatives(numba):
    # The line search's sums are those of Adhesion.pressure and Adhesion.curvature at
    # g + t d, across all three branches (repulsion, cosine neck, beyond the range); the
    # move updates g, sigma and the carried force exactly. Round-off only: rel 1e-12.
    # (The numpy twins evaluate an Adhesion rebuilt from the kernels' amp and rho: here they
    # check that rebuild and the move's arithmetic.)
    ad = Adhesion(surface_energy=2e-3, range=0.05, repulsion="harmonic")
    rng = np.random.default_rng(1)
    g = rng.uniform(-0.05, 0.1, 4000)
    d = rng.normal(size=g.size)
    pressures = K.adhesive_pressures if numba else K.adhesive_pressures_np
    line = K.adhesive_line if numba else K.adhesive_line_np
    move = K.adhesive_move if numba else K.adhesive_move_np
    amp, w = ad.max_tension, np.pi / ad.range
    for t in (0.0, 0.013):
        s1, s2 = line(g, d, t, amp, w, ad.range)
        x = g + t * d
        assert s1 == pytest.approx(float((ad.pressure(x) * d).sum()), rel=1e-12)
        assert s2 == pytest.approx(float((ad.curvature(x) * d * d).sum()), rel=1e-12)
    sigma = np.empty_like(g)
    assert pressures(g, sigma, amp, w, ad.range) == np.count_nonzero(g < 0)
    np.testing.assert_allclose(sigma, ad.pressure(g), rtol=1e-13, atol=1e-16)
    kd = rng.normal(size=g.size)
    f = rng.normal(size=g.size)
    g2, f2, sigma2 = g.copy(), f.copy(), sigma.copy()
    z = rng.normal(size=g.size)
    n_contact, fz = move(g2, d, 0.02, kd, f2, sigma2, z, amp, w, ad.range)
    new = g + 0.02 * d
    assert n_contact == np.count_nonzero(new < 0)
    np.testing.assert_allclose(g2, new, rtol=1e-15)
    np.testing.assert_allclose(sigma2, ad.pressure(new), rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(f2, f + ad.pressure(new) - sigma - 0.02 * kd, rtol=1e-12,
                               atol=1e-15)
    assert fz == pytest.approx(float(f2 @ z), rel=1e-12)
    # the direction update: d = z + beta d, K d = K z + beta K d, and the line coefficients
    direction = K.adhesive_direction if numba else K.adhesive_direction_np
    kz = rng.normal(size=g.size)
    d2, kd2 = d.copy(), kd.copy()
    fd, sd, dkd = direction(z, kz, 0.7, d2, kd2, f2, sigma2)
    np.testing.assert_allclose(d2, z + 0.7 * d, rtol=1e-15)
    np.testing.assert_allclose(kd2, kz + 0.7 * kd, rtol=1e-15)
    assert (fd, sd, dkd) == pytest.approx((float(f2 @ d2), float(sigma2 @ d2),
                                           float(d2 @ kd2)), rel=1e-12)
    # a restart (beta = 0) must not read the old d: the solver's first one finds
    # uninitialised memory there, and 0 * nan is nan (a ladder solve hung on it)
    d3, kd3 = np.full_like(d, np.nan), np.full_like(d, np.inf)
    fd, sd, dkd = direction(z, kz, 0.0, d3, kd3, f2, sigma2)
    np.testing.assert_array_equal(d3, z)
    np.testing.assert_array_equal(kd3, kz)
    assert np.isfinite([fd, sd, dkd]).all()


@pytest.mark.parametrize("load", [0.0, 0.02, 0.11])
def test_cg_finds_fires_minimum_in_fewer_iterations(load):
    # Same energy, same start (contact.solve's hard-wall start): both minimizers must land in
    # the same minimum. At tol 1e-8 the gaps agree to 1e-6 rms(h) (measured 5e-11 - 2e-10,
    # the residual is a displacement in rms(h)) and the contact sets are identical; zero
    # load is the case FIRE found hardest (85 steps against 30 here at tol 1e-4).
    # Iterations: measured 20-30 CG against 70-80 FIRE steps at tol 1e-8 on this 256^2
    # surface; pinned at "at most half" so that a CG that lost its exact line search (a
    # steepest-descent-like count, above FIRE's) fails. The masses' lift matters only on
    # larger grids: next test.
    s, ad = _papers_case(256)
    orig = G.gfmd
    try:
        G.gfmd = lambda *a, **kw: orig(*a, minimizer="fire", **kw) if kw.get(
            "adhesion") is not None else orig(*a, **kw)
        fire = solve(s, load, model="adhesive", adhesion=ad, tol=1e-8, max_iter=5000)
    finally:
        G.gfmd = orig
    cg = solve(s, load, model="adhesive", adhesion=ad, tol=1e-8)
    hrms = float(np.std(s.heights))
    assert np.abs(cg.gap - fire.gap).max() < 1e-6 * hrms
    assert np.array_equal(cg.contact, fire.contact)
    assert cg.contact_pressure.mean() == pytest.approx(load, abs=1e-6)
    assert cg.iterations <= fire.iterations / 2


@pytest.mark.slow
def test_lifted_masses_keep_large_grids_cheap(monkeypatch):
    # The mechanism against the growth with n (docs/contact.md "Adhesion", *Step count at
    # scale*): kappa grows ~3x per doubling of n, and lifting the masses by a_c kappa is what
    # keeps CG's count down. 1024^2, p = 0.11 (a_c 0.46), tol 1e-4 from the hard wall's
    # contact: measured 30 iterations lifted, 85 without the lift (and 75 FIRE steps).
    # Bounds: <= 40 lifted (a third of headroom for round-off in the iteration path), and
    # the unlifted run at least 2x that (measured 2.8x; 1.5x at 512^2 and 1.3x at 256^2,
    # which is why the test needs 1024^2).
    from roughflow.contact import adhesive_cg as A

    s, ad = _papers_case(1024)
    start = solve(s, 0.11, tol=1e-4)
    lifted = solve(s, 0.11, model="adhesive", adhesion=ad, tol=1e-4, init=start)
    monkeypatch.setattr(A, "REPULSION_MASS", 0.0)
    bare = solve(s, 0.11, model="adhesive", adhesion=ad, tol=1e-4, init=start)
    assert lifted.iterations <= 40
    assert bare.iterations >= 2 * lifted.iterations
    assert lifted.area_fraction == pytest.approx(bare.area_fraction, abs=1e-4)


@pytest.mark.parametrize("seed", [1, 2])
def test_light_mean_separation_mass_speeds_up_zero_load(monkeypatch, seed):
    # At zero load the mean separation is held only by the little contact there is (a_c
    # about 1e-3 here): its stiffness a_c kappa is far below FIRE's q = 0 mass Z_MASS k_min,
    # and with that mass the mode converged slowest. Measured on these 256^2 surfaces, tol
    # 1e-4 from the hard wall's start: 25 / 20 iterations with Q0_MASS against 50 / 40 with
    # Z_MASS (35 against 55-65 at 512^2, 40 against 100 at 1024^2), the same contact sets.
    # Bound: at most 0.7x (the counts move in steps of check_every = 5).
    from roughflow.contact import adhesive_cg as A
    from roughflow.contact._gfmd_common import Z_MASS
    from roughflow.contact.solve import _ADHESIVE_START_LOAD

    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=4, eps_f=16.0 / 256,
                                        points_per_lambda_s=4, seed=seed))
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=ADHESION_SURFACE_ENERGY_RATIO,
                      range=ADHESION_RANGE_OVER_LAMBDA_S["harmonic"] * s.spec.lambda_s,
                      repulsion="harmonic")
    start = solve(s, _ADHESIVE_START_LOAD, tol=1e-4)  # contact.solve's own start
    light = solve(s, 0.0, model="adhesive", adhesion=ad, tol=1e-4, init=start)
    monkeypatch.setattr(A, "Q0_MASS", Z_MASS)
    heavy = solve(s, 0.0, model="adhesive", adhesion=ad, tol=1e-4, init=start)
    assert light.iterations <= 0.7 * heavy.iterations, (light.iterations, heavy.iterations)
    assert np.array_equal(light.contact, heavy.contact)


def test_numpy_twin_takes_the_same_path():
    s, ad = _papers_case(128)
    a = G.gfmd(s.heights, s.lx, s.ly, 0.05, tol=1e-8, max_iter=500, adhesion=ad)
    b = G.gfmd(s.heights, s.lx, s.ly, 0.05, tol=1e-8, max_iter=500, adhesion=ad,
               use_numba=False)
    assert a.converged and b.converged
    # the kernels sum in another order (last bits): a step or a check may shift, not more
    assert abs(a.iterations - b.iterations) <= 5
    np.testing.assert_allclose(a.gap, b.gap, atol=1e-9 * float(np.std(s.heights)))


def test_non_convergence_raises_with_its_residual():
    s, ad = _papers_case(128)
    with pytest.raises(ConvergenceError) as err:
        solve(s, 0.05, model="adhesive", adhesion=ad, tol=1e-10, max_iter=3)
    assert err.value.residual > 1e-10 and err.value.iterations == 3


def test_a_nan_stops_the_solver_at_once():
    # A nan in the state never recovers; the solver must hand it back at the next residual
    # check (then contact.solve raises with it) instead of iterating to max_iter.
    from roughflow.contact.adhesive_cg import adhesive_cg

    s, ad = _papers_case(128)
    u0 = np.zeros_like(s.heights)
    u0[3, 5] = np.nan
    out = adhesive_cg(s.heights, s.lx, s.ly, 0.05, adhesion=ad, tol=1e-4, max_iter=1000,
                      u0=u0)
    assert not out.converged and np.isnan(out.residual)
    assert out.iterations <= 5  # the first residual check (check_every = 5), not max_iter


def test_cg_needs_the_harmonic_repulsion():
    s, _ = _papers_case(128)
    with pytest.raises(InputError, match="harmonic"):
        from roughflow.contact.adhesive_cg import adhesive_cg

        adhesive_cg(s.heights, s.lx, s.ly, 0.1, tol=1e-4, max_iter=10,
                    adhesion=Adhesion(surface_energy=1e-4, range=1e-2, repulsion="hard"))


def test_a_body_pulled_beyond_pull_off_stops_with_finite_gaps():
    # Past the pull-off force nothing holds the body once every point has left the
    # attraction's range: each line search pulled it further off, the gaps reached 4e14
    # in 50 iterations and overflowed to nan, and the error then reported "the largest gap
    # is nan" and max_iter as the reason. The solver stops at the first residual check
    # that sees every point beyond the range, and the error says so with finite gaps.
    s, ad = _papers_case(64)
    load = -0.3 * ad.max_tension  # a mean tension of 0.3 of the peak: far past pull-off
    with np.errstate(all="raise"):  # no overflow or invalid value on the way
        with pytest.raises(ConvergenceError, match="stopped after 5 of max_iter=20000") as err:
            solve(s, load, model="adhesive", adhesion=ad, max_iter=20000)
    assert err.value.iterations == 5 and np.isfinite(err.value.residual)
    assert "the largest gap is" in str(err.value) and "nan" not in str(err.value)


def test_a_tensile_load_within_pull_off_still_converges():
    # the stop above must not catch a body that is held: a small tension converges to an
    # attached state, with the contact area below that of zero load
    s, ad = _papers_case(64)
    free = solve(s, 0.0, model="adhesive", adhesion=ad)
    pulled = solve(s, -0.01 * ad.max_tension, model="adhesive", adhesion=ad)
    assert pulled.converged and 0 < pulled.area_fraction < free.area_fraction
