"""The direct flow solver's LDL^T in a chosen order (roughflow.flow.ldl) and the reuse of one
state's elimination order for the next (flow.CellOrdering)."""

from __future__ import annotations

import numpy as np
import pytest
import qdldl
import scipy.sparse as sp

import roughflow.flow.core as flow_core
from roughflow.errors import ConvergenceError, InputError
from roughflow.flow import CellOrdering, ldl, linsolve, solve
from roughflow.flow.core import flowing_cells, reynolds_system
from roughflow.surface import SurfaceSpec, generate


@pytest.fixture(scope="module")
def heights():
    """128 x 128 random-phase surface, H = 0.8, L / lambda_r = 4."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=5)).heights


def bearing_gap(h, a_c):
    return np.maximum(np.quantile(h, 1.0 - a_c) - h, 0.0)


def system(gap, axis=0):
    sigma = gap**3 / 12.0
    return reynolds_system(sigma, flowing_cells(sigma, axis), axis, lx=1.0, ly=1.0)


def test_the_qdldl_wheel_exports_what_ldl_calls():
    """CI must notice a qdldl build that hides QDLDL's and AMD's C routines: the direct solver
    would then order every state afresh (``qdldl.Solver``)."""
    assert ldl.available()


def test_amd_factor_matches_qdldl_solver(heights):
    """Fresh factorisations run the same AMD and QDLDL code as ``qdldl.Solver``: the same
    fill, and solutions equal to round-off. They are not bit for bit equal (1.2e-13 apart
    on this gap, pressures in [0, 1]); 1e-10 allows for the condition number of these
    matrices (up to about 1e6 near a_c*) times the solves' round-off."""
    sy = system(bearing_gap(heights, 0.3))
    a = sy.matrix
    f = ldl.factor(a)
    ref = qdldl.Solver(sp.triu(a, format="csc"), upper=True)
    assert f.amd and f.nnz == ref.factors()[0].nnz
    x = f.solve(sy.rhs)
    np.testing.assert_allclose(x, ref.solve(sy.rhs), rtol=0, atol=1e-10)
    assert np.linalg.norm(a @ x - sy.rhs) <= 1e-12 * np.linalg.norm(sy.rhs)


def test_fill_and_flops_of_a_path_graph_are_exact():
    """On the path 0 - 1 - 2, the natural order has no fill (L: 2 entries, flops 1 + 1);
    eliminating the middle first joins its neighbours (L: 3 entries, flops 2^2 + 1^2)."""
    a = sp.csr_matrix(np.array([[2.0, -1, 0], [-1, 2, -1], [0, -1, 2]]))
    b = np.array([1.0, 0.0, 1.0])
    natural, middle = ldl.factor(a, np.arange(3)), ldl.factor(a, np.array([1, 0, 2]))
    assert (natural.nnz, natural.flops, natural.amd) == (2, 2.0, False)
    assert (middle.nnz, middle.flops, middle.amd) == (3, 5.0, False)
    for f in (natural, middle):
        # forward error of LDL^T: up to about n cond(a) eps = 3 x 5.8 x 2.2e-16 = 3.9e-15
        # (measured 2 ulps)
        np.testing.assert_allclose(f.solve(b), [1.0, 1.0, 1.0], rtol=1e-14)
    # an order that would need more flops than allowed is replaced by AMD's
    assert ldl.factor(a, np.array([1, 0, 2]), max_flops=4.0).amd
    assert not ldl.factor(a, np.array([1, 0, 2]), max_flops=5.0).amd


@pytest.mark.parametrize("bad", [np.array([0, 0, 1]), np.array([0, 1]), np.array([0, 1, 3])])
def test_an_order_that_is_not_a_permutation_is_refused(bad):
    a = sp.csr_matrix(np.eye(3))
    with pytest.raises(InputError, match="permutation"):
        ldl.factor(a, bad)


def spy_on_orders(monkeypatch) -> list[bool]:
    """Record, for each numeric factorisation, whether it took AMD's order."""
    taken = []
    real = ldl._numeric

    def spy(lib, symbolic, perm, *, amd):
        taken.append(amd)
        return real(lib, symbolic, perm, amd=amd)

    monkeypatch.setattr(ldl, "_numeric", spy)
    return taken


def test_a_ladder_reuses_its_order_with_the_same_sigma(heights, monkeypatch):
    """Along a bearing ladder (nested contact sets) each state's order, restricted to the next
    state's cells, factorises it with at most the flops it had (restriction to a subgraph
    adds no fill) and gives sigma equal to a fresh solve's: a direct solve ends at round-off,
    where sigma's bound is below 1e-12 on these gaps."""
    taken = spy_on_orders(monkeypatch)
    for axis in (0, 1):
        ordering = None
        for a_c in (0.2, 0.25, 0.3, 0.35):
            gap = bearing_gap(heights, a_c)
            fresh = solve(gap, axis, method="direct")
            warm = solve(gap, axis, method="direct", ordering=ordering)
            assert warm.sigma == pytest.approx(fresh.sigma, rel=1e-12)
            assert warm.sigma_error <= 1e-12
            assert isinstance(warm.ordering, CellOrdering)
            if ordering is not None:
                assert warm.ordering.flops <= ordering.flops
            # the order covers exactly the flowing cells
            ranks = np.sort(warm.ordering.rank[warm.ordering.rank >= 0])
            np.testing.assert_array_equal(ranks, np.arange(warm.n_active))
            ordering = warm.ordering
    # fresh solves ordered by AMD, the warm ones after the first did not
    assert taken == [True, True, True, False, True, False, True, False] * 2


def test_the_reused_order_is_the_old_one_restricted(heights):
    """``CellOrdering.hint`` keeps the old order among the cells both states share, puts
    cells it never saw last, and carries the old factorisation's flops as the limit."""
    axis = 1
    first = solve(bearing_gap(heights, 0.3), axis, method="direct").ordering
    sy = system(bearing_gap(heights, 0.2), axis)  # more cells flow: some are new to the order
    hint = first.hint(sy.cells)
    assert hint.max_flops == first.flops
    ranks = first.rank[sy.cells[hint.order]]
    seen = ranks >= 0
    assert 0 < seen.sum() < seen.size
    assert seen[: seen.sum()].all()  # the cells it never saw come last
    assert np.all(np.diff(ranks[seen]) > 0)
    # the solve takes it where its flops stay within the limit, else orders afresh; either
    # way sigma is the fresh solve's
    gap = bearing_gap(heights, 0.2)
    assert solve(gap, axis, method="direct", ordering=first).sigma == pytest.approx(
        solve(gap, axis, method="direct").sigma, rel=1e-12)


def test_the_flops_limit_orders_afresh(heights, monkeypatch):
    """A hint whose order would cost more than its limit is not taken."""
    gap = bearing_gap(heights, 0.3)
    old = solve(gap, 0, method="direct").ordering
    taken = spy_on_orders(monkeypatch)
    solve(gap, 0, method="direct", ordering=old)
    solve(gap, 0, method="direct", ordering=CellOrdering(0, old.shape, old.rank, old.flops / 2))
    assert taken == [False, True]


@pytest.mark.parametrize("which", ["axis", "shape", "type"])
def test_a_foreign_ordering_is_refused_before_any_work(heights, which, monkeypatch):
    gap = bearing_gap(heights, 0.3)
    ordering = solve(gap, 0, method="direct").ordering
    bad = {"axis": (gap, 1, ordering), "shape": (gap[:, :64], 0, ordering),
           "type": (gap, 0, ordering.rank)}[which]

    def no_solve(*args, **kwargs):
        raise AssertionError("a solve started")

    monkeypatch.setattr(flow_core, "_balanced_solution", no_solve)
    with pytest.raises(InputError, match="ordering"):
        solve(bad[0], bad[1], ordering=bad[2], ly=1.0)


def test_without_the_c_routines_qdldl_solver_orders_afresh(heights, monkeypatch):
    """A qdldl build without the exported routines still solves, through ``qdldl.Solver``,
    and returns no ordering (an ordering passed in is then ignored)."""
    gap = bearing_gap(heights, 0.3)
    ref = solve(gap, 0, method="direct")
    monkeypatch.setattr(ldl, "available", lambda: False)
    r = solve(gap, 0, method="direct", ordering=ref.ordering)
    assert isinstance(linsolve.prepare(system(gap).matrix, "direct").factor, qdldl.Solver)
    assert r.ordering is None and r.sigma == pytest.approx(ref.sigma, rel=1e-12)


def record_flow_solves(monkeypatch) -> list:
    """Record (axis, the ordering passed, the ordering returned) of each ``flow.solve`` that
    ``flow.flow_both_axes`` (the ladder's and the leak curve's) makes."""
    from roughflow.flow import axes as flow

    calls = []
    real = flow.solve

    def recording(gap, axis, **kw):
        result = real(gap, axis, **kw)
        calls.append((axis, kw.get("ordering"), result.ordering))
        return result

    monkeypatch.setattr(flow, "solve", recording)
    return calls


def assert_chained(calls, steps: int):
    for axis in (0, 1):
        mine = [(given, got) for ax, given, got in calls if ax == axis]
        assert len(mine) == steps and mine[0][0] is None
        assert all(isinstance(got, CellOrdering) for _, got in mine)
        assert all(mine[k][0] is mine[k - 1][1] for k in range(1, steps))


def test_the_ladder_scene_and_leak_curve_chain_each_axis_order(monkeypatch):
    """``run_ladder`` and ``leak_curve`` pass each axis's last ordering to their next solve
    along that axis."""
    from roughflow.leak import leak_curve
    from roughflow.scenes import LadderJob, SurfaceParams, run_ladder

    calls = record_flow_solves(monkeypatch)
    tiny = SurfaceParams(l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)
    run_ladder(LadderJob(surface=tiny, model="bearing", seeds=(0,),
                         area_fractions=(0.1, 0.2, 0.3), a_c_star=0.5, a_c_star_alt=0.4))
    assert_chained(calls, 3)
    calls.clear()
    surface = generate(SurfaceSpec.from_sweep(l_over_lambda_r=2, eps_f=0.25,
                                              points_per_lambda_s=4))
    leak_curve(surface, [0.02, 0.05, 0.1], sealing=False)
    assert_chained(calls, 3)


def test_a_pivot_lost_to_rounding_is_named_as_such():
    # a 4 x 1 strip, every third row at u^3 1e-16 of the others: the matrix is positive
    # definite, but a pivot rounds to zero; the message said "not positive definite" (the
    # flow solve itself now lumps the two open rows and solves it: test_flow_lump.py)
    col = np.where(np.arange(4) % 3 != 0, 1.0, 1e-16 ** (1 / 3))
    system = reynolds_system(col[:, None] ** 3 / 12.0, np.ones((4, 1), bool), 0, lx=1.0,
                             ly=0.25)
    with pytest.raises(ConvergenceError, match="zero pivot: the matrix is singular to "
                                               "working precision"):
        linsolve.solve_spd(system.matrix, system.rhs, tol=1e-10, method="direct")
