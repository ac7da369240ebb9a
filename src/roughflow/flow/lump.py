"""Near-equipotential regions of a gap, each solved as one unknown.

A region whose faces conduct far more inside than any face that leaves it (a deep dead-end
pocket beside a channel, a scan's dropout, a pool joined to the rest through near-contact
cells) holds one pressure to within the ratio of the two: the pressure differences inside it
are set by the small flux through its boundary faces, over its own large transmissibilities.
Float64 cannot resolve them beside the region's own conductances: each row of the
Reynolds system there carries round-off of eps T_inside |p|, which can exceed the flux
through the region's boundary. A pocket of gap 3e4 beside a channel of gap 1 (u^3 2.7e13
times larger) left sigma uncertain by 24 % after a direct solve, and a pocket of gap 3e5
raised the unresolved-gap floor over the channel itself (sigma 0 for an open channel).

Lumping such a region into one unknown removes its internal faces from the system. The
lumped field is admissible in the full system (constant over the region), so its
dissipation is still an upper bound on the exact one (Dirichlet's principle), and Thomson's
bound on the full system (:func:`roughflow.flow.bound.dissipation_bounds`, whose spanning
tree routes a region's excess through its own strong faces) certifies it, the lumping's
error included. Regions are found by the levels of the faces' transmissibilities: a
connected set of cells joined by faces of at least t whose every face outward is below
t / ``ratio`` (the same set at both levels), with no reservoir among them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from roughflow.defaults import FLOW_LUMP_RATIOS

from .assembly import Faces

__all__ = ["Lumps", "find_lumps", "inner_potential", "lumped_system"]

#: the levels looked at, a decade apart from the largest face: the unresolved-gap floor's 16
#: decades and the largest ratio's
_MAX_LEVELS = 26


@dataclass(frozen=True)
class Lumps:
    """The unknowns of a lumped Reynolds system (flow along axis 0).

    node: (cells.size,) the unknown of each flowing cell (``cells``: flat indices in C
    order, as :func:`roughflow.flow.assembly.assemble` numbers them), ``n_nodes`` for a cell
    merged with the inlet reservoir (pressure 1) and ``n_nodes + 1`` with the outlet (0);
    n_nodes: the number of unknowns; region: (n0, n1) the region of each cell merged with
    others or with a reservoir (0 ... n - 1), -1 elsewhere; n_regions: how many regions."""

    node: np.ndarray
    n_nodes: int
    region: np.ndarray
    n_regions: int

    @property
    def lumped(self) -> np.ndarray:
        """The cells merged into a region of several, or with a reservoir."""
        return self.region >= 0

    def pressures(self, x: np.ndarray) -> np.ndarray:
        """The pressure of each cell of ``cells`` from the unknowns ``x``."""
        return np.concatenate([x, (1.0, 0.0)])[self.node]

    def largest_face_outside(self, faces: Faces) -> float:
        """The largest of ``faces`` (along and across the flow) that is not inside a region:
        the scale of the unresolved-gap floor once the regions are lumped (their inner faces
        no longer enter the system, so their round-off no longer hides smaller faces)."""
        r = self.region
        inside_along = (r[:-1] == r[1:]) & (r[:-1] >= 0)
        inside_across = (r == np.roll(r, -1, axis=1)) & (r >= 0)
        return float(max(np.where(inside_along, 0.0, faces.t_along).max(initial=0.0),
                         np.where(inside_across, 0.0, faces.t_across).max(initial=0.0)))


class _Edges:
    """The faces of the flowing cells as edges (a, b, T) on the grid's flat indices, the
    inlet reservoir node n0 n1 and the outlet n0 n1 + 1."""

    def __init__(self, faces: Faces, active: np.ndarray):
        n0, n1 = active.shape
        flat = np.arange(active.size).reshape(n0, n1)
        self.inlet, self.outlet = active.size, active.size + 1
        heads, tails, trans = [], [], []

        def add(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
            on = t > 0
            heads.append(np.broadcast_to(a, t.shape)[on])
            tails.append(np.broadcast_to(b, t.shape)[on])
            trans.append(t[on])

        add(faces.t_along, flat[:-1], flat[1:])
        if n1 > 1:
            add(faces.t_across, flat, np.roll(flat, -1, axis=1))
        add(faces.t_in, np.full(n1, self.inlet), flat[0])
        add(faces.t_out, flat[-1], np.full(n1, self.outlet))
        self.head = np.concatenate(heads)
        self.tail = np.concatenate(tails)
        self.trans = np.concatenate(trans)
        self.n_nodes = active.size + 2

    def components(self, level: float) -> np.ndarray:
        """Each node's component in the graph of the edges of T >= ``level``."""
        on = self.trans >= level
        graph = sp.coo_matrix((np.ones(int(on.sum()), dtype=np.int8),
                               (self.head[on], self.tail[on])),
                              shape=(self.n_nodes, self.n_nodes))
        return connected_components(graph, directed=False)[1]


def find_lumps(faces: Faces, active: np.ndarray, cells: np.ndarray, *,
               ratio: float = FLOW_LUMP_RATIOS[0]) -> Lumps | None:
    """The regions of the flowing cells ``active`` (unknowns ``cells``) to lump, or None
    where there is none: the largest sets of at least two nodes (cells, and at most one
    reservoir) that are connected by faces of T >= t, where every face leaving the set (to
    another cell or a reservoir) is below t / ``ratio``, for a level t at a power of ten
    below the largest face. A region with a reservoir takes the reservoir's pressure."""
    edges = _Edges(faces, active)
    if edges.trans.size == 0:
        return None
    top = float(edges.trans.max())
    low = float(edges.trans.min())
    decades = int(round(math.log10(ratio)))
    # (a region deeper than the floor's 16 decades plus the ratio's has no use)
    count = min(int(math.ceil(math.log10(top / low))) + 2, _MAX_LEVELS)
    if count <= decades:
        return None
    inlet, outlet = edges.inlet, edges.outlet
    region = np.full(edges.n_nodes, -1, dtype=np.int64)
    offset = 0
    # the largest region first (a region at a lower level contains those above it), keeping
    # only the levels the comparison still needs
    window = {k: edges.components(top * 10.0**-k)
              for k in range(count - 1, count - 2 - decades, -1)}
    for k in range(count - 1 - decades, -1, -1):
        here, below = window[k], window.pop(k + decades)
        size_here = np.bincount(here)
        size_below = np.bincount(below)
        stable = (size_here[here] >= 2) & (size_here[here] == size_below[below])
        if here[inlet] == here[outlet]:  # a region at both pressures: not one pressure
            stable &= here != here[inlet]
        new = stable & (region < 0)
        region[new] = offset + here[new]
        offset += size_here.size
        if k > 0:
            window[k - 1] = edges.components(top * 10.0 ** -(k - 1))
    fixed = {int(r): end for r, end in ((region[inlet], 0), (region[outlet], 1)) if r >= 0}
    region = region[:active.size]
    if not (region >= 0).any():
        return None
    # an unknown per free region and per cell outside the regions; the reservoirs' last
    key = np.where(region >= 0, region, offset + np.arange(active.size))[cells]
    at_reservoir = np.zeros(cells.size, dtype=np.int64) - 1
    for r, end in fixed.items():
        at_reservoir[key == r] = end
    free = at_reservoir < 0
    labels, node_free = np.unique(key[free], return_inverse=True)
    n_free = int(labels.size)
    if n_free == 0:  # every cell at a reservoir's pressure: nothing to solve, keep it whole
        return None
    node = np.empty(cells.size, dtype=np.int64)
    node[free] = node_free.ravel()
    node[~free] = n_free + at_reservoir[~free]
    ids, numbered = np.unique(region[region >= 0], return_inverse=True)
    grid = np.full(active.size, -1, dtype=np.int64)
    grid[region >= 0] = numbered.ravel()
    return Lumps(node, n_free, grid.reshape(active.shape), int(ids.size))


def lumped_system(faces: Faces, active: np.ndarray, cells: np.ndarray,
                  lumps: Lumps) -> tuple[sp.csr_matrix, np.ndarray]:
    """The Reynolds system A p = b on the unknowns of ``lumps`` (inlet pressure 1, outlet
    0, and so the regions merged with them), assembled from the faces between different
    unknowns only: a region's internal faces carry no flow in a field constant over it, and
    summing them into the matrix would leave their round-off (eps T_inside) in its rows."""
    edges = _Edges(faces, active)
    n = lumps.n_nodes
    index = np.full(edges.n_nodes, -1, dtype=np.int64)
    index[cells] = lumps.node
    index[edges.inlet], index[edges.outlet] = n, n + 1
    a, b, t = index[edges.head], index[edges.tail], edges.trans
    fixed_pressure = np.array([1.0, 0.0])
    both = (a < n) & (b < n) & (a != b)
    a_fixed = (a >= n) & (b < n)  # b an unknown beside a reservoir's pressure
    b_fixed = (b >= n) & (a < n)
    ends = np.concatenate([b[a_fixed], a[b_fixed]])
    t_end = np.concatenate([t[a_fixed], t[b_fixed]])
    p_end = fixed_pressure[np.concatenate([a[a_fixed], b[b_fixed]]) - n]
    aa, bb, tt = a[both], b[both], t[both]
    rows = np.concatenate([aa, bb, aa, bb, ends])
    cols = np.concatenate([bb, aa, aa, bb, ends])
    data = np.concatenate([-tt, -tt, tt, tt, t_end])
    matrix = sp.coo_matrix((data, (rows, cols)), shape=(n, n)).tocsr()
    matrix.sum_duplicates()
    rhs = np.bincount(ends, weights=t_end * p_end, minlength=n)
    return matrix, rhs


def inner_potential(faces: Faces, active: np.ndarray, pressure: np.ndarray,
                    lumps: Lumps) -> np.ndarray:
    """The pressure differences inside each region that carry the flow through it: (n0, n1),
    0 outside the regions. A region's pressure is one number, so its inner faces show no
    flow; the flow through it enters and leaves by its boundary faces (the lumped solution's
    fluxes there), and inside it follows the potential phi of L phi = q, L the Laplacian of
    the region's own faces and q each cell's inflow from outside (phi = 0 at the reservoir
    a region is merged with, else at its first cell). phi is of order q / T_inside, below
    float64's resolution of the pressure beside it, so it is kept apart: the inner faces'
    fluxes are T (phi_a - phi_b)."""
    edges = _Edges(faces, active)
    cells = np.flatnonzero(active.ravel())
    n = lumps.n_nodes
    region = np.full(edges.n_nodes, -1, dtype=np.int64)
    region[:active.size] = lumps.region.ravel()
    for end, node in ((edges.inlet, n), (edges.outlet, n + 1)):
        merged = lumps.region.ravel()[cells[lumps.node == node]]
        if merged.size:
            region[end] = merged[0]
    p = np.zeros(edges.n_nodes)
    p[:active.size] = np.where(active, pressure, 0.0).ravel()
    p[edges.inlet], p[edges.outlet] = 1.0, 0.0
    a, b, t = edges.head, edges.tail, edges.trans
    ra, rb = region[a], region[b]
    inner = (ra == rb) & (ra >= 0)
    q = np.zeros(edges.n_nodes)
    into_a = (ra >= 0) & ~inner
    into_b = (rb >= 0) & ~inner
    np.add.at(q, a[into_a], t[into_a] * (p[b[into_a]] - p[a[into_a]]))
    np.add.at(q, b[into_b], t[into_b] * (p[a[into_b]] - p[b[into_b]]))
    members = np.flatnonzero(region >= 0)
    # pinned: each region's reservoir, else its first member
    reservoir_regions = {int(region[e]) for e in (edges.inlet, edges.outlet) if region[e] >= 0}
    first = np.unique(region[members], return_index=True)[1]
    pinned = {int(v) for v in members[first] if int(region[v]) not in reservoir_regions}
    pinned |= {e for e in (edges.inlet, edges.outlet) if region[e] >= 0}
    free = members[~np.isin(members, np.array(sorted(pinned), dtype=np.int64))]
    phi = np.zeros(edges.n_nodes)
    if free.size:
        index = np.full(edges.n_nodes, -1, dtype=np.int64)
        index[free] = np.arange(free.size)
        ia, ib, ti = index[a[inner]], index[b[inner]], t[inner]
        both = (ia >= 0) & (ib >= 0)
        rows = np.concatenate([ia[both], ib[both], ia[ia >= 0], ib[ib >= 0]])
        cols = np.concatenate([ib[both], ia[both], ia[ia >= 0], ib[ib >= 0]])
        data = np.concatenate([-ti[both], -ti[both], ti[ia >= 0], ti[ib >= 0]])
        laplacian = sp.coo_matrix((data, (rows, cols)), shape=(free.size, free.size)).tocsc()
        phi[free] = spla.spsolve(laplacian, q[free])
    return phi[:active.size].reshape(active.shape)
