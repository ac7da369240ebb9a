"""The capped gfmd solve: ``solve(..., hardness=H)`` by the hard-wall CG with the pressure
cap (``contact.gfmd`` "Hardness"), against the capped cg (``method="cg"``), Tamaas's
KatoSaturated, the elastic solve and the capped threshold search by cg."""

from __future__ import annotations

import math

import numpy as np
import pytest

from roughflow.contact import prepare, solve, workspace
from roughflow.contact.gfmd import gfmd
from roughflow.errors import InputError
from roughflow.search import scaled_options, threshold
from roughflow.search.load import Point, compact, warm_start, warm_start_compliance
from roughflow.surface import SurfaceSpec, generate


def _surface(seed: int = 5, **kw):
    """128^2 at 2 points per lambda_s (or as ``kw`` says), rms gradient 1."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=seed, **kw))


@pytest.fixture(scope="module")
def rough():
    return _surface()


@pytest.fixture(scope="module")
def anisotropic():
    """gamma 4: a 64 x 256 grid on an anisotropic spectrum."""
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, l_over_lambda_r=4, seed=3,
                                           gamma=4))


@pytest.mark.parametrize("load", [0.05, 0.2])
@pytest.mark.parametrize("ratio", [20, 5, 2, 1.2])
@pytest.mark.parametrize("which", ["rough", "anisotropic"])
def test_capped_gfmd_is_the_capped_cg(request, which, ratio, load):
    # The same discrete problem (the KKT conditions of cg.py's and gfmd's "Hardness"),
    # both to a gap error of 1e-10 rms(h): a gap error e on a cell moves its pressure by
    # about e over the cell compliance, 1e-8 H here; measured (these 16 cases) identical
    # contact and plastic sets, pressures within 2.8e-9 H, plastic depths and gaps within
    # 7e-11 rms(h), the mean pressure within 1.4e-11 of the load. Allowed: 1e-6 H and 1e-8
    # rms(h), two decades over the measured (and over the estimate).
    s = request.getfixturevalue(which)
    cap = ratio * load
    ref = solve(s, load, method="cg", hardness=cap, tol=1e-10)
    r = solve(s, load, hardness=cap, tol=1e-10)
    assert r.method == "gfmd" and r.hardness == cap and ref.plastic.any() == r.plastic.any()
    assert np.array_equal(r.contact, ref.contact)
    assert np.array_equal(r.plastic, ref.plastic)
    assert r.plastic_fraction == ref.plastic_fraction
    rms = s.heights.std()
    assert np.abs(r.contact_pressure - ref.contact_pressure).max() <= 1e-6 * cap
    assert np.abs(r.plastic_depth - ref.plastic_depth).max() <= 1e-8 * rms
    assert np.abs(r.gap - ref.gap).max() <= 1e-8 * rms
    # the box: plastic cells at H exactly, the others below it; gap 0 on contact; the load
    # to the residual (the imbalance is part of it, relative to the load)
    p = r.contact_pressure
    assert np.all(p[r.plastic] == cap) and p[~r.plastic].max() < cap and p.min() >= 0
    assert not r.gap[r.contact].any() and not r.plastic_depth[~r.plastic].any()
    assert p.mean() == pytest.approx(load, rel=1e-9)
    assert r.scalars()["hardness"] == cap
    assert r.scalars()["plastic_fraction"] == r.plastic_fraction


def test_numpy_twins_give_the_same_solve(rough):
    # the capped kernels' numpy twins (use_numba=False): the same iteration, sums in
    # another order (the compiled loops reassociate), so the same sets and iterations
    # within one, pressures to round-off of the tolerance
    load, cap = 0.05, 0.1
    a = gfmd(rough.heights, 1.0, 1.0, load, tol=1e-10, max_iter=5000, hardness=cap)
    b = gfmd(rough.heights, 1.0, 1.0, load, tol=1e-10, max_iter=5000, hardness=cap,
             use_numba=False)
    assert a.converged and b.converged and abs(a.iterations - b.iterations) <= 1
    assert np.array_equal(a.plastic, b.plastic) and np.array_equal(a.contact, b.contact)
    assert np.abs(a.pressure - b.pressure).max() <= 1e-8 * cap


def test_an_infinite_cap_is_the_elastic_iteration(rough):
    # hardness=inf runs the capped kernels with no cell on the plastic side: the elastic
    # iteration's arithmetic up to the order of the sums, so the same iterations and sets
    # (the elastic kernels themselves serve hardness=None, bit for bit: next test)
    for load in (0.05, 0.2):
        el = gfmd(rough.heights, 1.0, 1.0, load, tol=1e-8, max_iter=5000)
        inf = gfmd(rough.heights, 1.0, 1.0, load, tol=1e-8, max_iter=5000,
                   hardness=math.inf)
        assert inf.iterations == el.iterations
        assert np.array_equal(inf.contact, el.contact) and not inf.plastic.any()
        assert np.abs(inf.pressure - el.pressure).max() <= 1e-9 * el.pressure.max()


@pytest.mark.parametrize("seed", [0, 1])
def test_without_a_hardness_the_elastic_solve_is_unchanged(seed):
    # hardness=None takes the elastic kernels and code path: bit for bit the solve of a
    # call that never names a hardness (cold, and warm with a setup and a workspace)
    s = _surface(seed)
    for load in (0.05, 0.2):
        plain = solve(s, load, tol=1e-8)
        named = solve(s, load, tol=1e-8, hardness=None)
        assert named.hardness is None and named.plastic is None
        for a, b in ((plain, named),
                     (solve(s, 1.1 * load, tol=1e-8, init=plain),
                      solve(s, 1.1 * load, tol=1e-8, init=named, hardness=None,
                            setup=prepare(s), work=workspace(s)))):
            assert (a.iterations, a.residual, a.separation) == (b.iterations, b.residual,
                                                                b.separation)
            for name in ("gap", "contact_pressure", "contact"):
                assert np.array_equal(getattr(a, name), getattr(b, name)), name


def test_a_warm_start_carries_the_plastic_depth(rough):
    load, cap = 0.1, 0.2
    cold = solve(rough, load, hardness=cap)
    # from its own result: the start is the solution (u = heights + gap - depth)
    again = solve(rough, load, hardness=cap, init=cold)
    assert again.iterations == 0 and np.array_equal(again.plastic, cold.plastic)
    # from a nearby load: fewer iterations than cold, the same state to the tolerance
    for target in (0.95 * load, 1.05 * load):
        warm = solve(rough, target, hardness=cap, init=cold)
        fresh = solve(rough, target, hardness=cap)
        assert warm.iterations < fresh.iterations
        assert int((warm.plastic != fresh.plastic).sum()) <= 2
        assert warm.area_fraction == pytest.approx(fresh.area_fraction, abs=2 / cold.gap.size)
    # a compact state (q = gap - c p - depth, float32) gives the depth back
    c = warm_start_compliance(rough)
    state = compact(cold, c)
    assert state.hardness == cap
    start = warm_start([Point(load, cold.area_fraction, state)], load, compliance=c)
    assert start.plastic_depth is not None
    assert np.abs(start.plastic_depth - cold.plastic_depth).max() <= 1e-6 * rough.heights.std()
    assert solve(rough, load, hardness=cap, init=start).iterations <= 5


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_capped_search_by_gfmd_is_the_one_by_cg(seed):
    # the same capped contacts (above: the same sets at tol 1e-10; at the search's contact
    # tolerance a marginal cell), so a_c* within the searches' tol of each other
    s = _surface(seed, l_over_lambda_r=2)  # 64^2
    for cap in (0.5, 0.2):
        by_gfmd = threshold(s, options=scaled_options(s.gbar, hardness=cap))
        by_cg = threshold(s, options=scaled_options(s.gbar, hardness=cap, method="cg"))
        for ax in (0, 1):
            a, b = by_gfmd[ax], by_cg[ax]
            assert a.hardness == cap and a.bracketed and b.bracketed
            assert abs(a.a_c_star - b.a_c_star) <= 2e-3  # the search's tol
            assert a.a_lo < b.a_hi and b.a_lo < a.a_hi


def test_refusals(rough):
    with pytest.raises(InputError, match="backend='cupy'"):
        solve(rough, 0.05, hardness=0.2, backend="cupy")
    with pytest.raises(InputError, match="backend='cupy'"):
        solve(rough, 0.05, hardness=0.2, method="gfmd", backend="cupy")
    with pytest.raises(InputError, match="on the CPU"):
        threshold(rough, options=scaled_options(rough.gbar, hardness=0.2), backend="cupy")
    with pytest.raises(InputError, match="hard wall's CG only"):
        gfmd(rough.heights, 1.0, 1.0, 0.05, tol=1e-6, max_iter=10, hardness=0.2,
             minimizer="fire")
    with pytest.raises(InputError, match="not below"):
        solve(rough, 0.2, hardness=0.2, method="gfmd")
