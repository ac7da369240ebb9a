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
from scipy.sparse.csgraph import connected_components

from roughflow.defaults import FLOW_LUMP_RATIO

from .assembly import Faces

__all__ = ["Lumps", "find_lumps", "lumped_system"]

#: the levels looked at, a decade apart from the largest face: the unresolved-gap floor's 16
#: decades and the ratio's
_MAX_LEVELS = 26


@dataclass(frozen=True)
class Lumps:
    """The unknowns of a lumped Reynolds system (flow along axis 0).

    node: (cells.size,) the unknown of each flowing cell (``cells``: flat indices in C
    order, as :func:`roughflow.flow.assembly.assemble` numbers them); n_nodes: the number
    of unknowns; region: (n0, n1) the region of each cell merged with others (0 ... n - 1),
    -1 elsewhere; n_regions: how many such regions."""

    node: np.ndarray
    n_nodes: int
    region: np.ndarray
    n_regions: int

    @property
    def lumped(self) -> np.ndarray:
        """The cells merged into a region of several."""
        return self.region >= 0

    def largest_face_outside(self, faces: Faces) -> float:
        """The largest of ``faces`` (along and across the flow) that is not inside a region."""
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
        inlet, outlet = active.size, active.size + 1
        heads, tails, trans = [], [], []

        def add(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> None:
            on = t > 0
            heads.append(np.broadcast_to(a, t.shape)[on])
            tails.append(np.broadcast_to(b, t.shape)[on])
            trans.append(t[on])

        add(faces.t_along, flat[:-1], flat[1:])
        if n1 > 1:
            add(faces.t_across, flat, np.roll(flat, -1, axis=1))
        add(faces.t_in, np.full(n1, inlet), flat[0])
        add(faces.t_out, flat[-1], np.full(n1, outlet))
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
               ratio: float = FLOW_LUMP_RATIO) -> Lumps | None:
    """The regions of the flowing cells ``active`` (unknowns ``cells``) to lump, or None
    where there is none: the largest sets of at least two cells that are connected by faces
    of T >= t, where every face leaving the set (to another cell or a reservoir) is below
    t / ``ratio``, for a level t at a power of ten below the largest face."""
    edges = _Edges(faces, active)
    if edges.trans.size == 0:
        return None
    top = float(edges.trans.max())
    low = float(edges.trans.min())
    decades = int(round(math.log10(ratio)))
    # every edge is in at the last level: a spanning system is one component there
    # (a region deeper than the floor's 16 decades plus the ratio's has no use)
    count = min(int(math.ceil(math.log10(top / low))) + 2, _MAX_LEVELS)
    levels = top * 10.0 ** -np.arange(count)
    if levels.size <= decades:
        return None
    components = [edges.components(t) for t in levels]
    inlet, outlet = active.size, active.size + 1
    region = np.full(edges.n_nodes, -1, dtype=np.int64)
    offset = 0
    # the largest region first: a region at a lower level contains those above it
    for k in range(levels.size - 1 - decades, -1, -1):
        here, below = components[k], components[k + decades]
        size_here = np.bincount(here)
        size_below = np.bincount(below)
        stable = (size_here[here] >= 2) & (size_here[here] == size_below[below])
        stable &= (here != here[inlet]) & (here != here[outlet])
        new = stable & (region < 0)
        region[new] = offset + here[new]
        offset += size_here.size
    region = region[:active.size]
    if not (region >= 0).any():
        return None
    # an unknown per region, and one per cell outside the regions
    key = np.where(region >= 0, region, offset + np.arange(active.size))[cells]
    labels, node = np.unique(key, return_inverse=True)
    ids, numbered = np.unique(region[region >= 0], return_inverse=True)
    grid = np.full(active.size, -1, dtype=np.int64)
    grid[region >= 0] = numbered
    return Lumps(node.astype(np.int64).ravel(), int(labels.size), grid.reshape(active.shape),
                 int(ids.size))


def lumped_system(faces: Faces, active: np.ndarray, cells: np.ndarray,
                  lumps: Lumps) -> tuple[sp.csr_matrix, np.ndarray]:
    """The Reynolds system A p = b on the unknowns of ``lumps`` (inlet pressure 1, outlet
    0), assembled from the faces between different unknowns only: a region's internal
    faces carry no flow in a field constant over it, and summing them into the matrix
    would leave their round-off (eps T_inside) in its rows."""
    edges = _Edges(faces, active)
    index = np.full(edges.n_nodes, -1, dtype=np.int64)
    index[cells] = lumps.node
    inlet, outlet = active.size, active.size + 1
    head, tail, trans = edges.head, edges.tail, edges.trans
    inner = (head != inlet) & (tail != outlet)
    a, b, t = index[head[inner]], index[tail[inner]], trans[inner]
    between = a != b
    a, b, t = a[between], b[between], t[between]
    into = index[tail[head == inlet]]
    t_in = trans[head == inlet]
    out_of = index[head[tail == outlet]]
    t_out = trans[tail == outlet]
    n = lumps.n_nodes
    rows = np.concatenate([a, b, a, b, into, out_of])
    cols = np.concatenate([b, a, a, b, into, out_of])
    data = np.concatenate([-t, -t, t, t, t_in, t_out])
    matrix = sp.coo_matrix((data, (rows, cols)), shape=(n, n)).tocsr()
    matrix.sum_duplicates()
    rhs = np.bincount(into, weights=t_in, minlength=n)
    return matrix, rhs
