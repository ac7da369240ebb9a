"""Near-equipotential regions (deep dead-end pockets) solved as one unknown each
(:mod:`roughflow.flow.lump`): where float64 cannot resolve a pocket's inner pressures
beside its channel, the flow solve lumps it and certifies the result."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse.linalg as spla

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
    """A 2 x 2 pocket 1e4 times the gap around it (u^3 1e12) in an open field is one region;
    a uniform field, and a region reaching a reservoir (the pocket moved to the inlet row),
    have none (a reservoir fixes its own pressure)."""
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
    assert lumps_of(edge) is None


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
    assert r.lumped_cells == 15 * 32  # the first open stripe meets the inlet: not lumped
    assert r.sigma == pytest.approx(exact, rel=1e-13)
