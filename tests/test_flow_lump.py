"""Near-equipotential regions (deep dead-end pockets) solved as one unknown each
(:mod:`roughflow.flow.lump`): where float64 cannot resolve a pocket's inner pressures
beside its channel, the flow solve lumps it and certifies the result."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla
from flow_reference import reference_sigma

from roughflow import flow
from roughflow.flow.assembly import assemble, face_transmissibilities
from roughflow.flow.core import _dissipation
from roughflow.flow.lump import find_lumps, lumped_system


def channel_with_pocket(pocket: float, n: int = 64) -> np.ndarray:
    """One straight channel of gap 1 along x (column 10) and a 2 x 2 dead-end pocket of gap
    ``pocket`` beside it (rows 30-31, columns 11-12); closed elsewhere."""
    g = np.zeros((n, n))
    g[:, 10] = 1.0
    g[30:32, 11:13] = pocket
    return g


def test_a_deep_pocket_is_lumped_and_its_channel_flows():
    """Before lumping, a pocket 3e4 or 1e5 times deeper than its channel (u^3 2.7e13 and 1e15
    times larger) left sigma uncertain by 24 % and 0.4 % after a direct solve (raised), and
    one of 3e5 or 1e6 raised the unresolved-gap floor over the channel (sigma 0, "not
    percolating", for an open channel). The pocket holds one pressure once it conducts 1e3
    times more than the channel, so sigma is that of any deep pocket: the unlumped solve at
    gap 1e3 (bound 5e-13) is the reference. Tolerance 1e-11: the bounds of both solves
    (measured 1e-14 and 5e-13), with room for round-off."""
    reference = flow.solve(channel_with_pocket(1e3), 0)
    assert reference.lumped_cells == 0 and reference.sigma_error < 1e-12
    for pocket in (3e4, 1e5, 3e5, 1e6):
        r = flow.solve(channel_with_pocket(pocket), 0)
        assert r.percolating and r.lumped_cells == 4
        assert r.sigma_error < 1e-12
        assert r.sigma == pytest.approx(reference.sigma, rel=1e-11)
        assert np.ptp(r.pressure[30:32, 11:13]) == 0.0  # one unknown


def test_regions_are_found_only_where_the_inside_outconducts_the_boundary():
    """A 2 x 2 pocket 1e4 times the gap around it (u^3 1e12) in an open field is one region,
    one unknown; a uniform field has none; the pocket moved to the inlet rows is merged with
    the inlet (its pressure is the reservoir's to 1e-12)."""
    def lumps_of(gap):
        s = gap ** 3 / 12.0
        active = s > 0
        faces = face_transmissibilities(s, 1.0, 1.0)
        return find_lumps(faces, active, np.flatnonzero(active.ravel()))

    field = np.ones((16, 16))
    assert lumps_of(field) is None
    field[6:8, 6:8] = 1e4
    lumps = lumps_of(field)
    assert lumps is not None and lumps.n_regions == 1
    assert np.array_equal(lumps.lumped, field > 1)
    assert lumps.n_nodes == field.size - 3
    edge = np.ones((16, 16))
    edge[0:2, 6:8] = 1e4
    at_inlet = lumps_of(edge)  # merged with the inlet: pressure 1, no unknown
    assert at_inlet.n_regions == 1 and at_inlet.n_nodes == edge.size - 4
    assert (at_inlet.node[edge.ravel() > 1] == at_inlet.n_nodes).all()


def test_the_lumped_system_is_the_full_one_with_each_region_at_one_pressure():
    """A region 100 times deeper than the gap around it (u^3 1e6), lumped at ratio 1e4:
    the lumped system is symmetric, carries none of the region's inner transmissibilities
    (every entry within the 8/6 of the region's 8 faces out), and its solution is the full
    system's to the region's pressure spread (measured 1.4e-7; tolerance 1e-5). Its
    dissipation lies above the full one (Dirichlet's principle) by the region's inner
    dissipation, about 1 / ratio of the flow through it: 1.4e-7 relative here (tolerance
    1e-6); at the default ratio 1e8, 1e-8 at most, and Thomson's bound certifies it."""
    g = np.ones((8, 8))
    g[3:5, 3:5] = 100.0
    s = g ** 3 / 12.0
    active = np.ones(g.shape, bool)
    faces = face_transmissibilities(s, 1.0, 1.0)
    cells = np.flatnonzero(active.ravel())
    lumps = find_lumps(faces, active, cells, ratio=1e4)
    assert lumps is not None and lumps.n_nodes == 61
    matrix, rhs = lumped_system(faces, active, cells, lumps)
    assert abs(matrix - matrix.T).max() == 0.0
    # the region's diagonal: 8 faces out, each below twice the outer cell's u^3 / 12
    assert abs(matrix).max() <= 8.0 / 6.0
    full = assemble(faces, active)
    p_full = spla.spsolve(full.matrix.tocsc(), full.rhs)
    p_lumped = spla.spsolve(matrix.tocsc(), rhs)[lumps.node]
    assert np.abs(p_lumped - p_full).max() < 1e-5
    q_full = _dissipation(faces, p_full.reshape(g.shape))
    q_lumped = _dissipation(faces, p_lumped.reshape(g.shape))
    assert q_full <= q_lumped <= q_full * (1 + 1e-6)  # Dirichlet: the lumped one is above


def test_open_stripes_between_closed_ones_are_solved_exactly():
    """Stripes across the flow whose u^3 alternates between 1 and 1e-15: each open stripe is
    one region (its faces conduct 5e14 times more than those out of it), and sigma_y is the
    series mean of u^3 / 12 to 1e-13 (measured 2.7e-15). Before lumping no method could
    certify it, and plain CG returned 8 times the exact sigma with a warning."""
    s3 = np.where(np.arange(32) % 2 == 0, 1.0, 1e-15)
    exact = 1.0 / np.mean(12.0 / s3)
    r = flow.solve(np.tile(s3 ** (1 / 3), (32, 1)), "y")
    assert r.lumped_cells == 16 * 32  # the first open stripe merged with the inlet
    assert r.sigma == pytest.approx(exact, rel=1e-13)


def _channel(n: int = 48) -> np.ndarray:
    g = np.zeros((n, n))
    g[:, 10] = 1.0
    return g


def _fields() -> dict[str, tuple[np.ndarray, dict]]:
    """The fields of a stress audit (2026-12-07) on which the first lumping still gave sigma
    0 or raised; a channel of gap 1 along x on 48^2 unless said."""
    out = {}
    g = _channel()
    g[0:2, 11:13] = 3e5  # a pocket in the inlet rows: merged with the inlet
    out["pocket at the inlet"] = (g, {})
    g = _channel()
    g[-2:, 11:13] = 1e6
    out["pocket at the outlet"] = (g, {})
    g = _channel()
    g[0:10, 10] = 3e5  # a deep segment of the only channel, at the inlet
    out["deep segment in series"] = (g, {})
    g = _channel()
    g[20:22, 12:14] = 1e6  # the floor first cut the pocket off, then found no region
    g[20:22, 11] = 1e-6
    out["pocket behind a neck"] = (g, {})
    g = _channel()
    g[20:22, 11:13], g[20:22, 13:15], g[20:22, 15:17] = 100.0, 1e4, 1e6
    out["graded pocket"] = (g, {})  # no step of 1e8 in u^3: a lower ratio lumps it
    g = _channel()
    g[18:28, 11:21] = 300.0
    g[22:24, 15:17] = 1e5
    out["pit in a pool"] = (g, {})
    g = np.zeros((40, 24))
    g[:, 5] = 1.0
    g[18:21, 6:8] = 3e4  # cells 1e3 long: the regions were found twice, differently
    out["long cells"] = (g, {"lx": 1e3, "ly": 1.0})
    g = _channel()
    g[20:22, 11:13] = 1e6
    g = g.T.copy()  # the same pocket, flow along y
    out["along y"] = (g, {"axis": 1})
    return out


@pytest.mark.parametrize("name", list(_fields()))
def test_deep_regions_give_the_exact_sigma_within_its_bound(name):
    """Each field against the same finite-volume system solved in 80-digit arithmetic with
    every open cell (tests/flow_reference.py): sigma within its own error bound, which is
    at most 1e-7 (measured 1e-14 - 7e-9; the graded pocket and the pit in a pool lumped at
    ratio 1e6 and 1e4). Before: sigma 0 (not percolating) for the first five, an error for
    the last three."""
    g, kw = _fields()[name]
    axis = kw.pop("axis", 0)
    exact = reference_sigma(g, axis, **kw)
    r = flow.solve(g, axis, **kw)
    assert exact > 0 and r.percolating
    # behind its neck the pocket is cut off by the floor the regions scaled: nothing to lump
    assert (r.lumped_cells > 0) == (name != "pocket behind a neck")
    assert r.sigma_error < 1e-7
    assert abs(r.sigma - exact) <= r.sigma_error * r.sigma  # relative to sigma, an upper bound


def test_the_flux_inside_a_lumped_region_is_the_flow_through_it():
    """A deep segment (gap 1e6) in series in the only channel carries the channel's whole
    flux. Its pressure is one number, so its faces' pressure differences are 0; the flux
    there comes from the region's inner potential (flow.lump.inner_potential) and equals the
    channel's elsewhere, to 1e-9 (measured 1e-15); it read 0 before."""
    g = _channel()
    g[20:30, 10] = 1e6
    r = flow.solve(g, 0)
    assert r.lumped_cells == 10
    channel = r.flux_x[:, 10]
    assert channel == pytest.approx(np.full(48, channel[0]), rel=1e-9)
    assert np.count_nonzero(r.flux_x[:, 11:]) == 0

