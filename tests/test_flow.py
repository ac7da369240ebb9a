"""Validation of the Reynolds flow solver against exact results."""

from __future__ import annotations

import numpy as np
import pytest

import roughflow.flow.core as flow_core
from roughflow.errors import ConvergenceError, InputError
from roughflow.flow import FlowResult, conductance, solve
from roughflow.flow.linsolve import solve_spd
from roughflow.percolation import critical_open_count
from roughflow.surface import SurfaceSpec, generate


def sigma_of(u):
    """Local conductivity u^3 / (12 eta), eta = 1 (paper Eq. 3)."""
    return np.asarray(u, float) ** 3 / 12.0


@pytest.fixture(scope="module")
def heights():
    """128 x 128 random-phase surface, H = 0.8, L / lambda_r = 4 (quick size)."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=3)).heights


def bearing_gap(h, a_c):
    return np.maximum(np.quantile(h, 1.0 - a_c) - h, 0.0)


# --- uniform gap -------------------------------------------------------------------------

@pytest.mark.parametrize("method", ["direct", "rs", "sa"])
@pytest.mark.parametrize(("shape", "lx", "ly"), [((16, 16), 1.0, 1.0), ((12, 20), 2.0, 0.5)])
def test_uniform_gap_gives_u0_cubed_over_12(method, shape, lx, ly):
    u0 = 0.37
    g = np.full(shape, u0)
    for axis in (0, 1):
        r = solve(g, axis, lx=lx, ly=ly, method=method, eta=2.0)
        # the discretisation is exact for a uniform gap (linear pressure): only
        # round-off and the 1e-8 solver tolerance, entering the dissipation squared, remain
        assert r.sigma == pytest.approx(u0**3 / 24.0, rel=1e-12)
        assert r.percolating and r.residual <= 1e-8
        # flux density = sigma dp / L_flow everywhere, and no flux across
        along, across = (r.flux_x, r.flux_y) if axis == 0 else (r.flux_y, r.flux_x)
        np.testing.assert_allclose(along, u0**3 / 24.0 / (lx, ly)[axis], rtol=1e-7)
        np.testing.assert_allclose(across, 0.0, atol=1e-9 * u0**3)


@pytest.mark.parametrize("method", ["auto", "direct", "rs", "sa", "cg"])
def test_sigma_is_scale_free(heights, method):
    """The solve runs in units of a power of two of the largest u^3 / (12 eta), so sigma
    scales as u^3 / eta over float64's range. Uniform gaps of 1e-80 and 1e80 (u^3 1e-240
    and 1e240) and eta 1e-300 failed before ("float64 cannot resolve this gap's flow" from
    u 1e-60, a nan residual with overflow warnings from 1e60): they give u^3 / (12 eta) to
    1e-12 (round-off and the solver tolerance, as above). A gap scaled by 2^k is the same
    system in those units, so its sigma is 2^3k times the unscaled one bit for bit (k = 200:
    u^3 2^600 = 4e180 times)."""
    for u, eta in ((1e-80, 1.0), (1e80, 1.0), (1.0, 1e-300)):
        r = solve(np.full((16, 16), u), 0, eta=eta, method=method)
        assert r.sigma == pytest.approx(u**3 / (12.0 * eta), rel=1e-12)
        assert r.sigma_flux == pytest.approx(r.sigma, rel=1e-6)
        assert np.mean(r.flux_x) == pytest.approx(r.sigma, rel=1e-6)
    gap = bearing_gap(heights[:32, :32], 0.2)
    base = solve(gap, 1, method=method)
    for k in (-200, 200):
        scaled = solve(np.ldexp(gap, k), 1, method=method)
        assert scaled.sigma == np.ldexp(base.sigma, 3 * k)
        assert scaled.iterations == base.iterations
        np.testing.assert_array_equal(scaled.flux_y, np.ldexp(base.flux_y, 3 * k))


# --- layered media -----------------------------------------------------------------------

def test_stripes_arithmetic_along_harmonic_across():
    rng = np.random.default_rng(0)
    u_layers = rng.uniform(0.2, 1.5, 24)  # conductivities spanning a factor ~400
    g = np.broadcast_to(u_layers[None, :], (10, 24)).copy()  # layers vary along y
    s = sigma_of(u_layers)
    # flow along x (along the stripes): parallel resistors -> arithmetic mean;
    # flow along y (across): series resistors -> harmonic mean. Both exact in the
    # discretisation (half-cell resistances add up), so only round-off: 1e-10.
    assert conductance(g, 0, ly=1.7) == pytest.approx(s.mean(), rel=1e-10)
    assert conductance(g, 1, ly=1.7) == pytest.approx(1.0 / np.mean(1.0 / s), rel=1e-10)
    both = conductance(g, ly=1.7)  # named: sigma_x along the stripes, sigma_y across them
    assert both.sigma_x == pytest.approx(s.mean(), rel=1e-10)
    assert both.sigma_y == pytest.approx(1.0 / np.mean(1.0 / s), rel=1e-10)


# --- Keller-Dykhne -----------------------------------------------------------------------

@pytest.mark.parametrize("shape", [(33, 17), (1, 5), (7, 1), (2, 2)])
@pytest.mark.parametrize("periodic", [True, False])
def test_face_transmissibilities_are_harmonic_means_bit_for_bit(shape, periodic):
    # the compiled pass (one sweep instead of numpy's ten) against the harmonic means it
    # stands for, on closed cells (sigma 0: both sides of a face closed too), a one-row and
    # a one-column grid and a transposed (non-contiguous) input: the same arithmetic, so equal
    from roughflow.flow.assembly import face_transmissibilities, harmonic_mean

    rng = np.random.default_rng(3)
    sigma = rng.random(shape) ** 3 * (rng.random(shape) > 0.4)
    for s in (sigma, sigma.T):
        faces = face_transmissibilities(s, 0.5, 0.25, periodic=periodic)
        along = harmonic_mean(s[:-1], s[1:]) * 0.5
        across = (harmonic_mean(s, np.roll(s, -1, axis=1)) * 2.0 if s.shape[1] > 1
                  else np.zeros_like(s))  # a cell's face with itself carries nothing
        if not periodic:
            across[:, -1] = 0.0
        np.testing.assert_array_equal(faces.t_along, along)
        np.testing.assert_array_equal(faces.t_across, across)
        assert faces.t_along.shape == (s.shape[0] - 1, s.shape[1])


def test_keller_dykhne_random_checkerboard():
    """Symmetric 50/50 two-phase medium: sigma_eff -> sqrt(s1 s2) (Keller 1964, Dykhne 1970).

    Random checkerboard of 16 x 16 blocks, 8 x 8 cells each (128^2 grid), contrast
    s2/s1 = 10. Each realisation is paired with its phase-swapped twin and both axes
    are used, (sx sy sx' sy')^(1/4), which removes most of the sample-to-sample
    scatter (measured std 0.8% over seeds). Remaining bias: staircase interfaces and
    corners at 8 cells per block (~1%: 16-cell blocks move the mean by +1.3%) and
    reservoir boundaries (O(1/16)); tolerance 3%. An arithmetic-mean face rule
    would give ~+10% and fail.
    """
    s1, s2 = 1.0, 10.0
    u1, u2 = (12 * s1) ** (1 / 3), (12 * s2) ** (1 / 3)
    est = []
    for seed in range(6):
        phase = np.random.default_rng(seed).random((16, 16)) < 0.5
        phase = np.kron(phase, np.ones((8, 8), bool))
        sx, sy = conductance(np.where(phase, u1, u2))
        tx, ty = conductance(np.where(phase, u2, u1))
        est.append(0.25 * np.log(sx * sy * tx * ty))
    assert np.exp(np.mean(est)) == pytest.approx(np.sqrt(s1 * s2), rel=0.03)


# --- symmetries and conservation ---------------------------------------------------------

def test_scaling_transposition_and_conservation(heights):
    g = bearing_gap(heights, 0.3)[:, :96]  # non-square grid
    lx, ly = 1.0, 0.75
    sx, sy = conductance(g, lx=lx, ly=ly, method="direct")
    assert sx > 0 and sy > 0
    # gap * c -> sigma * c^3 (round-off of the direct solve only)
    c = 1.7
    sx_c, sy_c = conductance(c * g, lx=lx, ly=ly, method="direct")
    assert sx_c == pytest.approx(c**3 * sx, rel=1e-10)
    assert sy_c == pytest.approx(c**3 * sy, rel=1e-10)
    # the transposed field (and cell) swaps the two conductances exactly
    tx, ty = conductance(g.T, lx=ly, ly=lx, method="direct")
    assert tx == pytest.approx(sy, rel=1e-10)
    assert ty == pytest.approx(sx, rel=1e-10)


def test_flux_in_equals_flux_out(heights):
    g = bearing_gap(heights, 0.3)
    r = solve(g, 0, method="rs", tol=1e-8)
    # with relative residual 1e-8 the inlet/outlet fluxes agree to ~1e-7 (measured
    # 1e-7 to 1e-6 on such gaps): 1e-5 bounds it
    assert r.flux_imbalance < 1e-5
    # the dissipation estimate and the boundary flux agree to the same level
    assert r.sigma_flux == pytest.approx(r.sigma, rel=1e-5)
    # every cross-section carries the same flow Q = sigma * L_across * dp / L_flow:
    # the sum of cell-centred j_x over a column is the mean of two face sections
    q_sections = r.flux_x.sum(axis=1) / g.shape[1]
    np.testing.assert_allclose(q_sections, r.sigma, rtol=1e-5)
    assert r.iterations > 0 and r.residual <= 1e-8


def test_rs_converges_at_last_percolating_step(heights):
    """Bearing gap at the last step before percolation is lost: the bottleneck cell has
    a gap of about 1e-4 of the rms, so sigma spans > 12 decades. RS-CG must still reach
    1e-8 and agree with the direct solve (dissipation: error ~ residual^2 -> 1e-8)."""
    order = np.argsort(heights, axis=None, kind="stable")
    k = critical_open_count(order, heights.shape, 0)
    hs = heights.ravel()[order]
    d = 0.5 * (hs[k - 1] + hs[k])  # first k cells open, cell k-1 barely
    g = np.maximum(d - heights, 0.0)
    r = solve(g, 0, method="rs", tol=1e-8)
    ref = solve(g, 0, method="direct")
    assert r.percolating and r.sigma > 0
    assert r.sigma == pytest.approx(ref.sigma, rel=1e-8)
    # one step earlier the gap does not percolate
    d0 = 0.5 * (hs[k - 2] + hs[k - 1])
    assert solve(np.maximum(d0 - heights, 0.0), 0).sigma == 0.0


def _reynolds_system(gap) -> flow_core.ReynoldsSystem:
    """The system ``solve(gap, 0)`` assembles on a unit square."""
    s = sigma_of(gap)
    return flow_core.reynolds_system(s, flow_core.flowing_cells(s, 0), 0, lx=1.0, ly=1.0)


def _reynolds_matrix(heights, a_c):
    return _reynolds_system(bearing_gap(heights, a_c)).matrix


def test_rs_preconditioner_is_symmetric_positive_definite(heights):
    """CG needs an SPD preconditioner. The V-cycle smooths with one forward Gauss-Seidel
    sweep before and one backward sweep after the coarse-grid correction (its adjoint), so
    x.My = y.Mx up to round-off. Measured relative to |x| |My|: 5e-18 (pyamg's symmetric
    sweeps: 5e-19); a forward sweep on both sides: 1.5e-12. The bound 1e-14 (about 50
    ulps) leaves the V-cycle's own round-off room and still catches a one-sided cycle."""
    from roughflow.flow.linsolve import prepare

    matrix = _reynolds_matrix(heights, 0.3)
    m = prepare(matrix, "rs").preconditioner
    rng = np.random.default_rng(0)
    x, y = rng.standard_normal((2, matrix.shape[0]))
    mx, my = m.matvec(x), m.matvec(y)
    assert abs(x @ my - y @ mx) <= 1e-14 * np.linalg.norm(x) * np.linalg.norm(my)
    assert x @ mx > 0 and y @ my > 0


@pytest.mark.parametrize("smoothers", [None, {}], ids=["ours", "pyamg-default"])
def test_rs_vcycle_is_pyamgs_cycle_bit_for_bit(heights, smoothers):
    """Our V-cycle only drops pyamg's per-call residual norms and argument checks: on the
    same hierarchy it must return pyamg's preconditioned vector exactly (same kernels in the
    same order), for our one-sweep smoothing and for pyamg's symmetric default ({})."""
    from roughflow.flow import amg

    matrix = _reynolds_matrix(heights, 0.2)
    ml = amg.pyamg_rs_hierarchy(matrix, smoothers)
    assert len(ml.levels) >= 3  # the cycle recurses through more than one coarse level
    b = np.random.default_rng(1).standard_normal(matrix.shape[0])
    ours = amg.rs_vcycle(ml, smoothers).matvec(b)
    assert np.array_equal(ours, ml.aspreconditioner(cycle="V").matvec(b))


@pytest.mark.parametrize("explicit_zeros", [False, True])
def test_rs_hierarchy_is_pyamgs(heights, explicit_zeros):
    """Our set-up calls pyamg's kernels with its own bookkeeping between them, and its own
    kernel for the interpolation weights, so each of its coarsening steps must be pyamg's
    step on the same matrix: the same C/F splitting (it depends on the order of each row's
    strong connections, which is why ours sorts them), the same interpolation pattern and,
    up to summation order, the same weights and coarse matrix. The coarse levels' Galerkin
    matrices have positive off-diagonal entries, where a strong F neighbour can have no
    entry of the opposite sign in the row's C points: pyamg leaves it out rather than
    lumping it into the diagonal (6 weights of level 1 with explicit zeros, off by up to
    0.8 when lumped). With explicit zeros in A (which pyamg drops from the strength pattern)
    as well.
    Each step is compared on our own matrix of that level: the coarse matrices of the two
    set-ups differ by round-off (summation order), and a strength test |a_ij| >= theta
    max |a_ik| that ties on a coarse level can split it differently from there on (seen
    with FFTW_PATIENT plans, whose heights differ from MEASURE's at round-off).
    Classical weights divide by a_ii plus the weak connections, which nearly cancel on rows
    whose conductances span decades: reordered sums differ there by up to 7e-11 relative
    (measured at 512^2); rtol 1e-9 leaves room and still catches any change of the formula
    or of the pattern (those move weights by O(1)). atol 1e-13: a weight that cancels to
    zero is round-off (-6.0e-18 against -4.5e-18 seen), and weights are at most 1."""
    matrix = _reynolds_matrix(heights, 0.3)
    if explicit_zeros:  # zero some off-diagonal entries but keep them stored
        _zero_every_seventh_offdiagonal(matrix)
    _assert_steps_are_pyamgs(matrix)


def _zero_every_seventh_offdiagonal(matrix) -> None:
    rows = np.repeat(np.arange(matrix.shape[0]), np.diff(matrix.indptr))
    off = np.flatnonzero(rows != matrix.indices)
    matrix.data[off[::7]] = 0.0


def _assert_steps_are_pyamgs(matrix) -> None:
    """Each coarsening step of our hierarchy is pyamg's step on our matrix of that level
    (tolerances: test_rs_hierarchy_is_pyamgs)."""
    from roughflow.flow import amg

    ours = amg.rs_hierarchy(matrix)
    assert len(ours.levels) >= 3
    for k, (mine, coarse) in enumerate(zip(ours.levels[:-1], ours.levels[1:], strict=True)):
        theirs, their_coarse = amg.pyamg_rs_hierarchy(mine.A).levels[:2]
        assert np.array_equal(mine.splitting.astype(bool), theirs.splitting), k
        p, q = mine.P.tocsr(), theirs.P.tocsr()
        p.sort_indices()
        q.sort_indices()
        assert np.array_equal(p.indptr, q.indptr) and np.array_equal(p.indices, q.indices), k
        np.testing.assert_allclose(p.data, q.data, rtol=1e-9, atol=1e-13, err_msg=str(k))
        a, b = coarse.A.tocsr(), their_coarse.A.tocsr()
        a.sort_indices()
        b.sort_indices()
        # entries are conductances summed over faces: compare against the row's scale
        scale = abs(a).max()
        assert a.shape == b.shape and abs(a - b).max() <= 1e-9 * scale, k


def test_rs_weights_ignore_galerkin_roundoff(heights):
    """A coarse Galerkin matrix holds entries that are round-off of the product (1e-25
    against a diagonal of 3e-8), whose sign follows the heights' last bits. Where such an
    entry was a strong F neighbour's only link to the row's C points, it carried that whole
    connection into one weight (0.158 instead of pyamg's 0.115) in 11 of 60 perturbations of
    the heights by 2e-16 relative, and the comparison with pyamg failed at random (a CI run
    on 2026-12-05). amg.ROUNDOFF now ignores it: the heights perturbed 16 times (this test failed
    without it), every step still pyamg's."""
    rng = np.random.default_rng(0)
    for _ in range(16):
        matrix = _reynolds_matrix(heights * (1 + 2e-16 * rng.standard_normal(heights.shape)),
                                  0.3)
        _zero_every_seventh_offdiagonal(matrix)
        _assert_steps_are_pyamgs(matrix)


def test_rs_vcycle_refuses_smoothers_it_does_not_implement():
    from roughflow.flow.amg import rs_vcycle

    with pytest.raises(InputError, match="jacobi"):
        rs_vcycle(None, {"presmoother": ("jacobi", {})})


# --- skipping what carries no flow -------------------------------------------------------

def test_non_percolating_gives_zero_without_solve(monkeypatch):
    def boom(*args, **kwargs):
        raise AssertionError("the linear solver must not be called")

    monkeypatch.setattr(flow_core, "solve_prepared", boom)
    g = np.full((20, 16), 0.5)
    g[9, :] = 0.0  # a contact line across x blocks flow along x
    r = solve(g, 0, ly=1.0)
    assert isinstance(r, FlowResult)
    assert r.sigma == 0.0 and not r.percolating and r.iterations == 0
    assert np.all(np.isnan(r.pressure)) and not r.flux_x.any() and not r.flux_y.any()
    assert conductance(np.zeros((8, 8)), 1) == 0.0  # all contact
    with pytest.raises(AssertionError):  # along y the same gap percolates and is solved
        solve(g, 1, ly=1.0)


@pytest.mark.parametrize("method", ["direct", "rs"])
def test_gaps_below_float64_resolution_are_closed_unless_the_bulk_is_lumped(method, caplog):
    """A cell with u^3 at most FLOW_CLOSED_BELOW (1e-16) of the largest carries no flow where
    other paths do (left open, such cells from warm-started contact solves stalled RS-CG on
    a 1024^2 ladder state): along y a row of them carries nothing, so sigma_y is the open
    rows' share, 19/20 of u0^3 / 12 (exact: the rows have the same linear pressure, no flux
    crosses between them; 1e-12 is round-off). Across x the row is every path: the floor
    closed it (sigma 0, "not percolating", where the open cells do span). Now the open bulk
    on either side, 2e16 times the row's conductance, is merged with its reservoir
    (flow.lump), the floor is scaled by the faces outside it, and the row is solved: sigma_x
    is the series (harmonic) mean of the 20 rows, exact for this discretisation; 1e-12
    allows the round-off of the row's 16 cells (measured 1e-16)."""
    from roughflow.defaults import FLOW_CLOSED_BELOW

    u0 = 0.5
    tiny = u0 * (0.5 * FLOW_CLOSED_BELOW) ** (1 / 3)  # u^3 half the floor
    g = np.full((20, 16), u0)
    g[9, :] = tiny
    with caplog.at_level("WARNING", logger="roughflow.flow.core"):
        along_y = solve(g, 1, method=method, ly=1.0)
        across = solve(g, 0, method=method, ly=1.0)
    assert not caplog.records  # neither blocks: no word
    assert along_y.sigma == pytest.approx(sigma_of(u0) * 19 / 20, rel=1e-12)
    assert np.isnan(along_y.pressure[9]).all() and along_y.lumped_cells == 0
    assert across.percolating and across.lumped_cells == 19 * 16
    series = 20 / (19 / sigma_of(u0) + 1 / sigma_of(tiny))
    assert across.sigma == pytest.approx(series, rel=1e-12)
    assert across.sigma_error < 1e-12
    # a row 10x above the floor stays open and sets sigma_x without lumping; 1e-6 allows
    # the round-off of a system whose conductivities span 15 decades
    g[9, :] = u0 * (10 * FLOW_CLOSED_BELOW) ** (1 / 3)
    open_row = solve(g, 0, method=method, ly=1.0)
    assert open_row.percolating and open_row.lumped_cells == 0
    series = 20 / (19 / sigma_of(u0) + 1 / sigma_of(g[9, 0]))
    assert open_row.sigma == pytest.approx(series, rel=1e-6)


@pytest.mark.parametrize("inlet", [1e-3, 3e-3])
@pytest.mark.parametrize("method", [None, "rs", "sa", "direct", "cg"])
def test_narrow_inlets_meet_the_attainable_residual(method, inlet):
    """Rows of gap 1e-3 at the inlet and outlet against 1 inside: the right-hand side (the
    inlet's transmissibilities) is 1e-9 of the matrix's scale, so a relative residual of
    1e-8 lies below float64's round-off of the residual (6.7e-7 at best), and every method
    raised ConvergenceError on a well-conditioned gap. At 3e-3, RS-CG's true residual
    stalled at 4.9e-8 (under that floor, above tol); replacing the recursive residual by
    it lost conjugacy and the run diverged to NaN: CG now stops at the floor. The exact
    sigma is the series mean of the rows; 1e-12 allows the round-off of a 1e9 contrast in
    conductivity."""
    n = 64
    g = np.ones((n, n))
    g[0, :] = g[-1, :] = inlet
    exact = n / np.sum(1 / sigma_of(g[:, 0]))
    r = solve(g, 0, method=method)
    assert r.sigma == pytest.approx(exact, rel=1e-12)
    assert r.sigma_error < 1e-10  # and the bound says so


def test_one_deep_cell_does_not_close_the_rest():
    """A cell counts as closed below 1e-16 of the largest conductance that carries flow;
    with the largest cell as the scale, one pit 3e5 times deeper than the gap around it
    closed every other cell (sigma = 0, not percolating). The scale is now the largest
    face, the harmonic mean of two cells, which the pit's neighbours bound. sigma changes
    by the pit's own few faces only: pits 1e4 and 1e10 deep give the same sigma to 1e-12."""
    sig = []
    for pit in (1e4, 3e5, 1e10):
        g = np.ones((64, 64))
        g[20, 20] = pit
        r = solve(g, 0)
        assert r.percolating
        sig.append(r.sigma)
    assert sig[1] == pytest.approx(sig[0], rel=1e-12) and sig[2] == pytest.approx(sig[0],
                                                                                   rel=1e-12)
    assert sig[0] > sigma_of(1.0)  # a pit only adds conductance


def test_isolated_pools_do_not_change_sigma(heights):
    g = bearing_gap(heights, 0.2)
    rng = np.random.default_rng(1)
    pooled = g.copy()
    filled = g.copy()
    for i, j in rng.integers(4, 120, size=(12, 2)):
        # a contact ring with a fluid pool inside
        pooled[i - 2:i + 3, j - 2:j + 3] = 0.0
        filled[i - 2:i + 3, j - 2:j + 3] = 0.0
        pooled[i - 1:i + 2, j - 1:j + 2] = 5.0
    for axis in (0, 1):
        rp = solve(pooled, axis, method="direct")
        rf = solve(filled, axis, method="direct")
        # the pools are dropped before assembly, so the systems are identical
        assert rp.sigma == rf.sigma
        assert rp.n_active == rf.n_active


# --- solver failure and bad input --------------------------------------------------------

def test_convergence_failure_raises_with_residual(heights):
    import scipy.sparse as sp

    n = 200
    a = sp.diags([-np.ones(n - 1), 2.0 * np.ones(n), -np.ones(n - 1)], [-1, 0, 1]).tocsr()
    b = np.zeros(n)
    b[0] = 1.0
    with pytest.raises(ConvergenceError) as exc:
        solve_spd(a, b, tol=1e-10, method="cg", max_iter=3)
    assert exc.value.residual > 1e-10 and exc.value.iterations == 3


def test_pcg_stops_at_round_off(heights):
    """Asked for more than float64 allows (``accept`` never satisfied), CG stops once its
    recursive residual has left the true one ``DRIFT_AT_ROUNDOFF`` behind instead of running
    to ``max_iter``: at the last percolating step of the bearing gap the true residual stays
    at 2e-14 from iteration 14 on (docs/flow.md); 40 leaves room for that and is far from
    the 500 allowed. The iterate it returns is converged (residual below 1e-12)."""
    from roughflow.flow.linsolve import pcg, prepare

    order = np.argsort(heights, axis=None, kind="stable")
    k = critical_open_count(order, heights.shape, 0)
    hs = heights.ravel()[order]
    system = _reynolds_system(np.maximum(0.5 * (hs[k - 1] + hs[k]) - heights, 0.0))
    matrix, rhs = system.matrix, system.rhs
    m = prepare(matrix, "rs").preconditioner
    calls = []

    def never(x):
        calls.append(1)
        return False

    run = pcg(matrix, rhs, tol=1e-8, preconditioner=m, max_iter=500, accept=never)
    x, iterations = run.x, run.iterations
    assert 0 < len(calls) <= iterations < 40
    assert np.linalg.norm(rhs - matrix @ x) < 1e-12 * np.linalg.norm(rhs)


@pytest.fixture(scope="module")
def amg_sized_heights():
    """A 384^2 surface: its bearing gaps have 70 000 - 140 000 unknowns, above
    ``DIRECT_MAX_UNKNOWNS``."""
    h = generate(SurfaceSpec.from_sweep(points_per_lambda_s=6, seed=3)).heights
    assert h.shape == (384, 384)
    return h


@pytest.fixture(scope="module")
def amg_sized_gap(amg_sized_heights):
    """A bearing gap at a_c 0.1 of the 384^2 surface: about 125 000 unknowns, 85 % of the
    cells, so that ``auto`` picks RS-AMG."""
    return bearing_gap(amg_sized_heights, 0.1)


def test_auto_picks_the_direct_solver_for_thin_clusters(amg_sized_heights, monkeypatch):
    """Beyond ``DIRECT_MAX_UNKNOWNS`` unknowns, ``auto`` takes the LDL^T factorisation where
    at most ``DIRECT_MAX_FLOWING_FRACTION`` of the cells carry flow (there it took 0.3-1.1x
    RS's time, docs/flow.md "Direct solver") and it fits in memory, else RS."""
    import roughflow.flow.linsolve as linsolve

    thin = bearing_gap(amg_sized_heights, 0.35)  # near the bearing model's a_c* of 0.4
    open_ = bearing_gap(amg_sized_heights, 0.05)
    r_thin, r_open = solve(thin, 0), solve(open_, 0)
    cells = thin.size
    assert r_thin.n_active > linsolve.DIRECT_MAX_UNKNOWNS
    assert r_thin.n_active / cells <= linsolve.DIRECT_MAX_FLOWING_FRACTION
    assert r_open.n_active / cells > linsolve.DIRECT_MAX_FLOWING_FRACTION
    assert (r_thin.method, r_open.method) == ("direct", "rs")
    # both solve to the flow tolerance; sigma (from the dissipation) agrees to its square
    for gap, r in ((thin, r_thin), (open_, r_open)):
        other = solve(gap, 0, method="rs" if r.method == "direct" else "direct")
        assert r.sigma == pytest.approx(other.sigma, rel=1e-10)
    # a caller that knows its gaps moves the limit: 0 leaves every state beyond
    # DIRECT_MAX_UNKNOWNS to RS (faster on isotropic bearing gaps at any flowing fraction
    # measured), 1 factorises the open state too
    bearing = solve(thin, 0, direct_max_flowing_fraction=0.0)
    assert bearing.method == "rs" and bearing.sigma == pytest.approx(r_thin.sigma, rel=1e-10)
    assert solve(open_, 0, direct_max_flowing_fraction=1.0).method == "direct"
    # a factorisation that would not fit leaves the thin state to RS
    monkeypatch.setattr(linsolve, "headroom_bytes", lambda: 1)
    assert solve(thin, 0).method == "rs"


@pytest.mark.parametrize("bad", [-0.1, 1.5, float("nan"), "most", [0.5]])
def test_direct_max_flowing_fraction_is_checked_before_any_work(bad, monkeypatch):
    def no_solve(*args, **kwargs):
        raise AssertionError("a solve started")

    monkeypatch.setattr(flow_core, "_balanced_solution", no_solve)
    with pytest.raises(InputError, match="direct_max_flowing_fraction"):
        solve(np.ones((8, 8)), 0, direct_max_flowing_fraction=bad)


def test_auto_falls_back_to_direct_when_amg_does_not_converge(amg_sized_gap, monkeypatch):
    import roughflow.flow.linsolve as linsolve

    reference = solve(amg_sized_gap, 0, method="direct")
    assert reference.n_active > linsolve.DIRECT_MAX_UNKNOWNS
    assert solve(amg_sized_gap, 0).method == "rs"
    # an AMG solve that cannot converge (the near-threshold stalls of docs/flow.md "Direct
    # fallback" need a 2048 x 4096 grid; caps of 2 iterations stand in for them)
    monkeypatch.setattr(linsolve, "MAX_ITER_AMG", 2)
    monkeypatch.setattr(linsolve, "AMG_ITER_BEFORE_FALLBACK", 2)
    with pytest.raises(ConvergenceError):
        solve(amg_sized_gap, 0, method="rs")  # an explicit method is never replaced
    r = solve(amg_sized_gap, 0)
    assert r.method == "direct" and r.residual <= 1e-8
    assert r.iterations >= 2  # the AMG iterations spent count
    # the same factorisation and right-hand side as the reference: equal to round-off
    assert r.sigma == pytest.approx(reference.sigma, rel=1e-12)
    # where the factorisation would not fit, the AMG failure is raised, naming the fallback
    monkeypatch.setattr(linsolve, "headroom_bytes", lambda: 1)
    with pytest.raises(ConvergenceError, match="direct fallback would need"):
        solve(amg_sized_gap, 0)


def test_dissipation_error_is_the_energy_norm_of_the_pressure_error(heights):
    """sigma comes from the dissipation Q(p) = sum over faces of T (delta p)^2, the energy of
    the assembled system: Q(p* + e) = Q(p*) + e^T A e for every pressure error e in the
    unknowns. That is what makes sigma's error quadratic in e, and what the certificate of a
    direct solve whose fluxes do not balance computes (r^T A^-1 r with r = -A e). The two
    sides (about 1.6 Q here) agree to 3e-15 relative (measured): 1e-9 leaves room for any
    summation order and still catches a change of either formula (a face kind missing from
    one of them moves the difference by O(1))."""
    system = _reynolds_system(bearing_gap(heights, 0.3))
    matrix = system.matrix
    exact = solve_spd(matrix, system.rhs, tol=1e-14, method="direct").x

    def dissipation(x):
        return flow_core._flux_balance(system.faces, system.active, system.cells, x).dissipation

    q_star = dissipation(exact)
    e = 1e-3 * np.random.default_rng(4).standard_normal(exact.size)
    assert dissipation(exact + e) - q_star == pytest.approx(e @ (matrix @ e), rel=1e-9)
    assert q_star == pytest.approx(solve(bearing_gap(heights, 0.3), 0).sigma, rel=1e-12)


def test_uncertified_solves_are_checked_by_the_direct_solver(amg_sized_gap, monkeypatch,
                                                             caplog):
    """A solve whose sigma error is not certified to ``FLOW_SIGMA_RTOL`` is checked: ``auto``
    solves an AMG one again directly, and a direct solve that is not certified raises, its
    fluxes balanced or not; so does an AMG solve that cannot be checked (an explicit method,
    or no memory for the factorisation), its imbalance within round-off or its fluxes
    balanced (neither tells sigma: test_a_sigma_is_certified_or_raises). The stall
    that needs the check (RS on the paper's largest grid at a_c 0.414, y: imbalance 1.0,
    sigma 2.5 times too large) takes a 2048 x 4096 grid. Limits below this gap's solves stand
    in for it: RS's error bound is 1.5e-14 (its round-off allowance 1e-14 and 5e-15) and its
    imbalance 5e-10; the direct solve's error is 1e-14 (the same allowance, and 6e-17 from
    its residual) and its imbalance 8e-12: a limit between the two errors certifies only the
    direct solve."""
    import roughflow.flow.linsolve as linsolve

    reference = solve(amg_sized_gap, 0, method="direct")
    rs = solve(amg_sized_gap, 0, method="rs")
    assert reference.flux_imbalance < 1e-11 < rs.flux_imbalance < 1e-8
    assert 1.2 * reference.sigma_error < rs.sigma_error < flow_core.FLOW_SIGMA_RTOL
    monkeypatch.setattr(flow_core, "FLOW_SIGMA_RTOL",
                        float(np.sqrt(reference.sigma_error * rs.sigma_error)))
    with caplog.at_level("WARNING", logger="roughflow.flow.core"):
        r = solve(amg_sized_gap, 0)
        assert "error bound" in caplog.text and "checking with the direct solver" in caplog.text
        assert r.method == "direct" and r.iterations >= rs.iterations
        # the same factorisation and right-hand side as the reference: equal to round-off
        assert r.sigma == pytest.approx(reference.sigma, rel=1e-12)
    # an AMG solve that cannot be checked raises, though its fluxes balance to 5e-10, 100
    # times what round-off leaves of them (5e-12)
    with pytest.raises(ConvergenceError, match="not certified.*no direct solve to check it: "
                                               "method='rs'"):
        solve(amg_sized_gap, 0, method="rs")
    monkeypatch.setattr(linsolve, "headroom_bytes", lambda: 1)
    with pytest.raises(ConvergenceError, match="not certified.*more memory than"):
        solve(amg_sized_gap, 0)
    # a direct solve whose dissipation is certified is returned ...
    assert solve(amg_sized_gap, 0, method="direct").sigma == reference.sigma
    # ... and one whose dissipation is not raises, though its fluxes balance to 8e-12
    monkeypatch.setattr(flow_core, "FLOW_SIGMA_RTOL", 0.0)
    with pytest.raises(ConvergenceError, match="dissipation is uncertain"):
        solve(amg_sized_gap, 0, method="direct")


def _laminate(pattern: str, n: int, nx: int, contrast: float):
    """Stripes across flow along y: u^3 1 and ``contrast`` alternating ("alt"), every third
    row low ("alt3"), or spread between them ("spread"); and their exact sigma_y, the series
    (harmonic) mean of u^3 / 12."""
    if pattern == "spread":  # 10^(log10(contrast) frac(0.618 k)) in row k
        s3 = contrast ** ((np.arange(n) * 0.6180339887) % 1.0)
    else:
        low = np.arange(n) % 2 == 1 if pattern == "alt" else np.arange(n) % 3 == 1
        s3 = np.where(low, contrast, 1.0)
    return np.tile(s3 ** (1 / 3), (nx, 1)), 1.0 / np.mean(12.0 / s3)


@pytest.mark.parametrize("method", ["auto", "direct", "rs", "sa", "cg"])
@pytest.mark.parametrize("case", [("alt", 32, 32, 1e-15), ("alt", 64, 64, 1e-15),
                                  ("alt3", 8, 4, 10**-15.9), ("alt3", 128, 4, 10**-15.4),
                                  ("alt", 32, 32, 1e-9), ("spread", 32, 32, 1e-16)],
                         ids=["alt32-15", "alt64-15", "alt3-8x4", "alt3-128x4", "alt32-9",
                              "spread32-16"])
def test_a_sigma_is_certified_or_raises(method, case):
    """Stripes in series whose u^3 differs by more than float64 resolves: every sigma a
    solve returns is within its error bound of the exact one, and that bound within
    ``FLOW_SIGMA_RTOL``; otherwise it raises, naming the bound. The explicit iterative
    methods returned sigma 1.6 - 1e8 times the exact one here with a warning only (their
    imbalance within round-off, or balanced), and ``auto`` and the direct solver 1e3 and 6e8
    times the exact one on the every-third-row stripes, silently (their fluxes balanced to
    5e-3 and 2e-4; measured). At contrast 1e-9 every method returns sigma to 1.5e-6.
    Since open stripes between closed ones are lumped into one unknown each
    (:mod:`roughflow.flow.lump`, ratios down to 1e4), every method but plain CG returns
    them to 1e-7 or better, also u^3 spread over 16 decades ("spread", which raised for
    every method before the lower ratios): measured 1.3e-15 - 3.4e-8, bounds up to 1.1e-7."""
    gap, exact = _laminate(*case)
    r = solve(gap, "y", ly=1.0, method=method)  # none raises since the stripes are lumped
    assert abs(r.sigma / exact - 1) <= min(r.sigma_error, flow_core.FLOW_SIGMA_RTOL)
    # lumped, every method but plain CG bounds sigma to 1.1e-7 or better (measured)
    assert r.sigma_error < (1e-6 if case[3] < 1e-9 and method != "cg"
                            else flow_core.FLOW_SIGMA_RTOL)
    assert (r.lumped_cells > 0) == (case[3] < 1e-9)


@pytest.mark.parametrize("method", ["rs", "sa"])
def test_cg_goes_on_until_the_fluxes_balance(amg_sized_heights, method):
    """Near a_c* a CG solve stopped at the residual tolerance 1e-8 leaves |Q_in - Q_out| / Q
    above it (RS about 1e-7, SA 1e-6 on this gap); the flow solve goes on in the same run
    until the imbalance is at most ``tol`` too."""
    gap = bearing_gap(amg_sized_heights, 0.35)
    system = _reynolds_system(gap)
    plain = solve_spd(system.matrix, system.rhs, tol=1e-8, method=method)
    balance = flow_core._flux_balance(system.faces, system.active, system.cells, plain.x)
    assert balance.imbalance > 1e-8
    r = solve(gap, 0, method=method, tol=1e-8)
    assert r.flux_imbalance <= 1e-8 and r.iterations > plain.iterations


def test_imbalance_floor_separates_round_off_from_a_missed_flux(heights):
    """``FlowResult.imbalance_floor`` is what float64 leaves of |Q_in - Q_out| / Q. Solves
    asked for more (tol 1e-12) end below 10 times it: on these bearing gaps (a_c 0.1, 0.3
    and the last percolating step, sigma spanning 12 decades) the direct, RS and SA solves
    end at 0.1 - 1 of it, and at most 1.5 on every gap measured (docs/flow.md "Flux
    check"). A CG iterate that has not yet carried the flux through the bottleneck (3
    iterations) is above that by orders of magnitude."""
    from roughflow.flow.linsolve import pcg, prepare

    margin = 10

    order = np.argsort(heights, axis=None, kind="stable")
    k = critical_open_count(order, heights.shape, 0)
    hs = heights.ravel()[order]
    last = np.maximum(0.5 * (hs[k - 1] + hs[k]) - heights, 0.0)
    for gap in (bearing_gap(heights, 0.1), bearing_gap(heights, 0.3), last):
        for method in ("direct", "rs", "sa"):
            r = solve(gap, 0, method=method, tol=1e-12)
            assert 0 < r.flux_imbalance <= margin * r.imbalance_floor
        sy = _reynolds_system(gap)
        early = pcg(sy.matrix, sy.rhs, tol=1.0, max_iter=3, accept=lambda x: False,
                    preconditioner=prepare(sy.matrix, "rs").preconditioner).x
        _, dissipation, imbalance = flow_core._flux_balance(sy.faces, sy.active, sy.cells, early)
        floor = flow_core._imbalance_floor(
            flow_core._residual_scale(sy.matrix, sy.rhs, early), dissipation)
        assert imbalance > 100 * margin * floor


def test_sigma_error_bounds_the_dissipation_error_of_the_iterate(heights):
    """``_sigma_error`` bounds (Q(x) - Q) / Q(x) from above for any x: for the iterates of
    1 - 5 RS-CG iterations (errors 0.9 down to 8e-9, measured against the direct solve) it
    is at least the exact error (it takes |r| <= c w entrywise, w = |A| |x| + |b|, so it is
    loose where r is not round-off). The energy identity it rests on, Q(x) - Q = r^T A^-1 r
    exactly, holds to round-off (eps Q / (Q(x) - Q), at most 3e-8 relative here, against
    the 1e-6 allowed). ``solve`` reports it for direct solves (round-off and its
    allowances: below 1e-12 here); RS, which has no A^-1, its bound."""
    import scipy.sparse.linalg as spla

    from roughflow.flow.linsolve import pcg, prepare

    for a_c in (0.1, 0.3):
        gap = bearing_gap(heights, a_c)
        sy = _reynolds_system(gap)
        lu = spla.splu(sy.matrix.tocsc())
        exact = flow_core._flux_balance(sy.faces, sy.active, sy.cells, lu.solve(sy.rhs)).dissipation
        m = prepare(sy.matrix, "rs").preconditioner
        errors = []
        for its in (1, 2, 3, 5):
            x = pcg(sy.matrix, sy.rhs, tol=1e-30, max_iter=its, accept=lambda x: False,
                    preconditioner=m).x
            q = flow_core._flux_balance(sy.faces, sy.active, sy.cells, x).dissipation
            r = sy.rhs - sy.matrix @ x
            assert float(r @ lu.solve(r)) / q == pytest.approx((q - exact) / q, rel=1e-6)
            bound = flow_core._sigma_error(
                sy.matrix, sy.rhs, x, flow_core._residual_scale(sy.matrix, sy.rhs, x), lu.solve, q)
            assert bound >= (q - exact) / q
            errors.append((q - exact) / q)
        assert errors[0] > 0.1 and errors[-1] < 1e-6  # a real range of errors
        direct, rs = solve(gap, 0, method="direct"), solve(gap, 0, method="rs")
        assert flow_core.BOUND_ROUNDOFF <= direct.sigma_error < 1e-12
        # RS reports its bound (tests/test_flow_bound.py): 1e-14 - 1e-12 measured
        assert 0 < rs.sigma_error < 1e-9
    closed = solve(np.zeros((8, 8)), 0)
    assert closed.sigma == 0 and closed.sigma_error == 0


def test_amg_solve_at_round_off_is_certified_by_its_bound(caplog, monkeypatch):
    """The open row of test_gaps_below_float64_resolution_are_closed, u^3 1e-15 of the rest:
    the fluxes cannot balance in float64 (RS and the direct solver end at |Q_in - Q_out| / Q
    of about 1.5 and 1.1, with a round-off floor of 1.1), but RS's error bound, built from
    pressure differences and not from the residual, certifies its sigma to 2e-14: it is
    returned without a warning, equal to the series conductance 20 / (19 / s0 + 1 / s1) to
    1e-14. Where the bound cannot certify (a limit of 0 stands in), it raises, though its
    imbalance is within what round-off leaves (it was returned with a warning that sigma is
    unchecked)."""
    from roughflow.defaults import FLOW_CLOSED_BELOW

    u0 = 0.5
    g = np.full((20, 16), u0)
    g[9, :] = u0 * (10 * FLOW_CLOSED_BELOW) ** (1 / 3)
    series = 20 / (19 / sigma_of(u0) + 1 / sigma_of(g[9, 0]))
    with caplog.at_level("WARNING", logger="roughflow.flow.core"):
        r = solve(g, 0, method="rs", ly=1.0)
    assert r.flux_imbalance > 1e-2  # far from balanced: round-off
    assert r.sigma_error < 1e-12 and not caplog.text
    # the series value is itself rounded (about 1e-15)
    assert abs(r.sigma / series - 1) <= r.sigma_error + 1e-15
    assert r.flux_imbalance <= 10 * r.imbalance_floor
    monkeypatch.setattr(flow_core, "FLOW_SIGMA_RTOL", 0.0)
    with pytest.raises(ConvergenceError, match=r"round-off leaves .* not certified"):
        solve(g, 0, method="rs", ly=1.0)


@pytest.mark.parametrize(
    ("gap", "kwargs", "match"),
    [
        (np.full((4, 4), -0.1), {}, "gap must be >= 0"),
        (np.full((4, 4), np.nan), {}, "non-finite"),
        (np.full((4, 4), np.inf), {}, "non-finite"),
        (np.ones(5), {}, "2D"),
        (np.ones((2, 3, 4)), {}, "2D"),
        (np.ones((4, 4)), {"eta": 0.0}, "eta"),
        (np.ones((4, 4)), {"eta": -1.0}, "eta"),
        (np.ones((4, 4)), {"lx": 0.0}, "lx"),
        (np.ones((4, 4)), {"ly": np.nan}, "ly"),
        (np.ones((4, 4)), {"tol": 0.0}, "tol"),
        (np.ones((4, 4)), {"method": "magic"}, "magic"),
        (np.ones((4, 4)), {"axis": 2}, "axis"),
        (np.ones((4, 4), bool), {}, "boolean array"),  # a contact mask passed as the gap
        (np.full((4, 4), 1e-97), {}, "underflows"),  # u^3 / 12 below SMALLEST_TOP
        (np.full((4, 4), 1e-110), {}, "underflows"),  # u^3 underflows to 0
        (np.ones((4, 4)), {"eta": 1e-320}, "overflows"),
    ],
)
def test_bad_input(gap, kwargs, match):
    axis = kwargs.pop("axis", 0)
    with pytest.raises(InputError, match=match):
        solve(gap, axis, **kwargs)


@pytest.mark.parametrize("ny", [1, 2, 5])
def test_periodic_tiling_leaves_sigma_unchanged(ny):
    """The cell is periodic across the flow: repeating it 3 times across (with 3x the
    length) must give the same sigma; checks the seam, including the degenerate
    widths 1 (no across faces) and 2 (two distinct faces between the same cells)."""
    g = np.random.default_rng(ny).uniform(0.1, 1.0, (7, ny))
    s1 = conductance(g, 0, ly=0.4, method="direct")
    s3 = conductance(np.tile(g, (1, 3)), 0, ly=1.2, method="direct")
    assert s3 == pytest.approx(s1, rel=1e-12)  # same linear system up to round-off


def test_rectangular_cells_discretise_the_same_medium_as_square_ones():
    """Anisotropic sweeps solve on gamma : 1 rectangular cells, where the faces across the
    flow carry sigma dx/dy and those along it sigma dy/dx. A random checkerboard of square
    blocks (16 x 16, contrast 10) drawn on square cells (8 x 8 per block) and on 2 : 1 cells
    (8 x 4 and 4 x 8 per block) is one medium: measured ratios 0.981-0.989 (seeds 0-2), the
    staircase error of 4 cells per block along one axis, against 1.14 / 0.85 where the
    rectangular cells are taken as square (a wrong face ratio). So both conductances within
    3 %, and their ratio, which the staircase error moves alike on both axes (measured
    within 0.1 %), within 1 %."""
    s1, s2 = 1.0, 10.0
    u1, u2 = (12 * s1) ** (1 / 3), (12 * s2) ** (1 / 3)
    phase = np.random.default_rng(0).random((16, 16)) < 0.5
    square = conductance(np.where(np.kron(phase, np.ones((8, 8), bool)), u1, u2))
    for block in ((8, 4), (4, 8)):
        rect = conductance(np.where(np.kron(phase, np.ones(block, bool)), u1, u2), ly=1.0)
        assert rect[0] == pytest.approx(square[0], rel=0.03), block
        assert rect[1] == pytest.approx(square[1], rel=0.03), block
        assert rect[0] / rect[1] == pytest.approx(square[0] / square[1], rel=0.01), block


def test_sa_is_repeatable_and_never_touches_the_global_stream(heights, monkeypatch):
    """pyamg's smoothed aggregation by default weights its prolongation smoother by a
    spectral radius estimated from ``np.random.rand``, numpy's global stream: seeding it
    around the build (saved and restored) showed another thread using the stream the seeded
    values meanwhile. The SA solve now weights each row by its Gershgorin bound: it calls
    no function of the global stream, and two solves agree bit for bit whatever the caller
    seeded."""
    gap = bearing_gap(heights, 0.3)
    sigmas = []
    for seed in (1, 2):  # the legacy global stream is what pyamg would read (NPY002)
        np.random.seed(seed)  # noqa: NPY002
        sigmas.append(conductance(gap, method="sa"))
        after = np.random.rand()  # noqa: NPY002
        np.random.seed(seed)  # noqa: NPY002
        assert after == np.random.rand(), "the solve moved the caller's global stream"  # noqa: NPY002
    assert sigmas[0] == sigmas[1]
    calls = []

    def spy(name):
        real = getattr(np.random, name)

        def called(*args, **kwargs):
            calls.append(name)
            return real(*args, **kwargs)
        return called

    for name in ("rand", "random", "random_sample", "randn", "seed", "get_state",
                 "set_state", "default_rng"):
        monkeypatch.setattr(np.random, name, spy(name))
    assert conductance(gap, method="sa") == sigmas[0]
    assert calls == [], f"the SA solve called np.random.{calls[0]}"


def test_a_non_square_grid_needs_both_cell_lengths():
    """ly defaulted to lx (a square cell, as generate makes at gamma != 1), while
    Surface.from_array makes square pixels: an isotropic 150 x 250 array wrapped by it gave
    sigma_x 31 % high and sigma_y 31 % low, and a Peklenik number of 1.67, with the
    defaults. A non-square grid now needs ly; a square one keeps lx."""
    from roughflow.accuracy import contact_line_length
    from roughflow.theory import peklenik_number

    g = np.ones((150, 250))
    noise = np.random.default_rng(0).random(g.shape)
    for call in (lambda: solve(g, 0), lambda: conductance(g), lambda: peklenik_number(noise),
                 lambda: contact_line_length(g == 0)):
        with pytest.raises(InputError, match=r"150 x 250: give ly too .*1\.66667 for square "
                                             r"pixels, 1 for a square cell"):
            call()
    square_pixels = conductance(g, lx=1.0, ly=250 / 150)
    assert square_pixels.sigma_x == pytest.approx(square_pixels.sigma_y, rel=1e-12)  # uniform
    assert solve(np.ones((64, 64)), 0).sigma == pytest.approx(1 / 12, rel=1e-12)


def test_flow_both_axes_solves_only_where_the_fluid_spans():
    from roughflow.flow import flow_both_axes

    rng = np.random.default_rng(4)
    gap = np.maximum(rng.normal(0.5, 0.3, (40, 30)), 0.0)
    gap[:, 11] = 0.0  # a contact line along x: the fluid spans along x only
    open_mask = gap > 0
    fx, fy = flow_both_axes(gap, open_mask, lx=1.0, ly=0.75)
    assert fx.percolating and fx.sigma == solve(gap, 0, lx=1.0, ly=0.75).sigma
    assert fx.ordering is fx.result.ordering and fx.ordering is not None  # a direct solve
    assert not fy.percolating and fy.result is None and fy.sigma == 0.0
    # the next state of a ladder reuses the orderings; an axis without a solve keeps its own
    g2 = np.where(gap > 0, gap * 0.9, 0.0)
    nx_, ny_ = flow_both_axes(g2, g2 > 0, lx=1.0, ly=0.75, previous=(fx, fy))
    assert nx_.sigma == pytest.approx(solve(g2, 0, lx=1.0, ly=0.75).sigma, rel=1e-12)
    assert ny_.ordering is fy.ordering
