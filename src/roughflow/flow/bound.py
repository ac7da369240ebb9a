"""A rigorous bound on sigma's error from any pressure field (complementary energy).

The dissipation Q(p) of a pressure field with the reservoir values is at least Q, the
exact one (Dirichlet's principle): that gives sigma from above. Thomson's principle gives
it from below: a flux field j on the faces that is divergence-free in every cell, with net
flux F from the inlet reservoir, has energy E(j) = sum over faces j^2 / T >= F^2 / Q. The
fluxes T grad p of an approximate pressure leave a divergence in each cell (its residual
b - A p); routing it to the reservoirs along a spanning tree cancels it, and then

    (Q(p) - Q) / Q(p) <= (Q(p) - F^2 / E) / Q(p),

an upper bound on sigma's relative error that needs no A^-1, so AMG solves get one too
(docs/flow.md "Error bound"). The bound is second order in the error of p like the error
itself, and tight where the tree's paths are good conductors: the tree is the maximum
spanning tree in the transmissibilities (Kruskal on keys of T's leading bits), so a cell's
excess reaches a reservoir through the widest path there is. A breadth-first tree gave
bounds 16 - 3e5 times the error on RS iterates; this one 1.04 - 8.4 times. The divergence
comes from the face fluxes, i.e. from pressure differences, not from b - A p, whose
round-off near a_c* can exceed the flux itself; with compensated sums the bound's own
round-off stayed below 1.1e-15.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from roughflow._jit import njit
from roughflow.flow.assembly import Faces, face_transmissibilities
from roughflow.percolation import label
from roughflow.percolation.sweep import _find

#: the tree's sort key is a transmissibility's float64 bits without the last 44 of its 52
#: mantissa bits: 256 keys an octave (ties within 0.3 %), 14 000 over the 16 decades of a
#: flowing gap's u^3
_MANTISSA_DROPPED = 44


@njit(cache=True)
def _face_edges(t_along, t_across, t_in, t_out, index, m):  # pragma: no cover
    """The faces as edges (head, tail, T) of a graph on the unknowns 0 .. m-1, the inlet m
    and the outlet m + 1. Edge 0 joins the two reservoirs: no face, it carries nothing and
    enters no sum, but lets one tree reach both."""
    n0, n1 = index.shape
    n_edges = 1
    for i in range(n0):
        for j in range(n1):
            if i < n0 - 1 and t_along[i, j] > 0:
                n_edges += 1
            if t_across[i, j] > 0:
                n_edges += 1
    for j in range(n1):
        if t_in[j] > 0:
            n_edges += 1
        if t_out[j] > 0:
            n_edges += 1
    head = np.empty(n_edges, np.int32)
    tail = np.empty(n_edges, np.int32)
    trans = np.empty(n_edges, np.float64)
    head[0], tail[0], trans[0] = m, m + 1, np.inf
    k = 1
    for i in range(n0):
        for j in range(n1):
            if i < n0 - 1 and t_along[i, j] > 0:
                head[k], tail[k], trans[k] = index[i, j], index[i + 1, j], t_along[i, j]
                k += 1
            if t_across[i, j] > 0:
                jp = j + 1 if j < n1 - 1 else 0
                head[k], tail[k], trans[k] = index[i, j], index[i, jp], t_across[i, j]
                k += 1
    for j in range(n1):
        if t_in[j] > 0:
            head[k], tail[k], trans[k] = m, index[0, j], t_in[j]
            k += 1
        if t_out[j] > 0:
            head[k], tail[k], trans[k] = index[n0 - 1, j], m + 1, t_out[j]
            k += 1
    return head, tail, trans


@njit(cache=True)
def _keys(trans):  # pragma: no cover
    """Each edge's sort key, smaller for larger T (a positive float64's bits order it; the
    last :data:`_MANTISSA_DROPPED` are dropped), edge 0's 0 before all; and the number of
    key values (keys run from 0 to that less one)."""
    n_edges = trans.size
    bits = trans.view(np.int64) >> _MANTISSA_DROPPED
    lo, hi = bits[1], bits[1]
    for e in range(2, n_edges):
        lo = min(lo, bits[e])
        hi = max(hi, bits[e])
    key = np.empty(n_edges, np.int32)
    key[0] = 0
    for e in range(1, n_edges):
        key[e] = hi - bits[e] + 1  # 1 .. hi - lo + 1
    return key, hi - lo + 2


# inlined at numba level: as a call it made the tree 1.3x slower (measured)
@njit(cache=True, inline="always")
def _join(parent, size, a, b):  # pragma: no cover
    """Union by size of the sets of ``a`` and ``b`` (shallow trees, fewer random reads);
    False where they are one set already."""
    a, b = _find(parent, a), _find(parent, b)
    if a == b:
        return False
    if size[a] > size[b]:
        a, b = b, a
    parent[a] = b
    size[b] += size[a]
    return True


@njit(cache=True)
def _maximum_spanning_tree(head, tail, trans, n_nodes):  # pragma: no cover
    """The maximum spanning tree of the edges ranked by (key, index), the one Kruskal's
    algorithm builds from a stable sort of the keys: which edges form it, each node's
    degree in it, whether it spans.

    Kruskal over all edges in key order reads the union-find at random (three quarters of
    a tree's time at 1024 x 2048), so the tree is built in two steps. Boruvka's first round:
    under a strict order each node's best edge belongs to the tree (cut property), and
    joining those is one pass over the grid's neighbours. Then Kruskal in the same order
    over the edges between the clusters this leaves (about a third of the nodes), on the
    contracted graph, whose smaller union-find and sorted endpoint arrays stay in cache.
    The same edges as Kruskal over all of them (tested), 2-4x faster."""
    n_edges = head.size
    key, n_keys = _keys(trans)
    best = np.full(n_nodes, -1, np.int32)
    for e in range(n_edges):  # increasing index: only a smaller key is better
        k = key[e]
        b = best[head[e]]
        if b < 0 or k < key[b]:
            best[head[e]] = e
        b = best[tail[e]]
        if b < 0 or k < key[b]:
            best[tail[e]] = e
    parent = np.arange(n_nodes).astype(np.int32)
    size = np.ones(n_nodes, np.int32)
    in_tree = np.zeros(n_edges, np.bool_)
    kept = 0
    for v in range(n_nodes):
        e = best[v]
        if e < 0:
            continue
        # a face picked by both its cells, or a self-loop, joins nothing
        if _join(parent, size, head[e], tail[e]):
            in_tree[e] = True
            kept += 1
    # the clusters, numbered in order of their first node (raster order, so neighbours in
    # the grid stay near in the union-find), and the edges between them by (key, index)
    cluster = np.full(n_nodes, -1, np.int32)
    of = np.empty(n_nodes, np.int32)
    n_clusters = 0
    for v in range(n_nodes):
        r = _find(parent, v)
        if cluster[r] < 0:
            cluster[r] = n_clusters
            n_clusters += 1
        of[v] = cluster[r]
    start = np.zeros(n_keys + 1, np.int32)  # start[k]: first slot of key k
    for e in range(n_edges):
        if of[head[e]] != of[tail[e]]:
            start[key[e] + 1] += 1
    for k in range(1, start.size):
        start[k] += start[k - 1]
    n_between = start[-1]
    ends = np.empty((n_between, 2), np.int32)
    edge = np.empty(n_between, np.int32)
    for e in range(n_edges):
        a, b = of[head[e]], of[tail[e]]
        if a != b:
            s = start[key[e]]
            ends[s, 0], ends[s, 1], edge[s] = a, b, e
            start[key[e]] += 1
    parent = np.arange(n_clusters).astype(np.int32)
    size = np.ones(n_clusters, np.int32)
    for s in range(n_between):
        if kept == n_nodes - 1:
            break
        if _join(parent, size, ends[s, 0], ends[s, 1]):
            in_tree[edge[s]] = True
            kept += 1
    degree = np.zeros(n_nodes, np.int32)
    for e in range(n_edges):
        if in_tree[e]:
            degree[head[e]] += 1
            degree[tail[e]] += 1
    return in_tree, degree, kept == n_nodes - 1


@njit(cache=True)
def _rooted(head, tail, in_tree, degree, root):  # pragma: no cover
    """The tree's nodes in breadth-first order from ``root`` and each node's edge to its
    parent (-1 at the root)."""
    n_nodes = degree.size
    start = np.zeros(n_nodes + 1, np.int32)
    for v in range(n_nodes):
        start[v + 1] = start[v] + degree[v]
    fill = start[:-1].copy()
    adjacent = np.empty(start[-1], np.int32)
    for e in range(head.size):
        if in_tree[e]:
            adjacent[fill[head[e]]] = e
            fill[head[e]] += 1
            adjacent[fill[tail[e]]] = e
            fill[tail[e]] += 1
    order = np.empty(n_nodes, np.int32)
    up = np.full(n_nodes, -1, np.int32)
    seen = np.zeros(n_nodes, np.bool_)
    order[0] = root
    seen[root] = True
    n_seen = 1
    for s in range(n_nodes):
        v = order[s]
        for a in range(start[v], start[v + 1]):
            e = adjacent[a]
            w = tail[e] if head[e] == v else head[e]
            if not seen[w]:
                seen[w] = True
                up[w] = e
                order[n_seen] = w
                n_seen += 1
    return order, up


@njit(cache=True)
def _add(sums, errors, k, term):  # pragma: no cover
    """Add ``term`` to the compensated (Neumaier) sum ``k``: ``sums[k] + errors[k]``."""
    t = sums[k] + term
    if abs(sums[k]) >= abs(term):
        errors[k] += (sums[k] - t) + term
    else:
        errors[k] += (term - t) + sums[k]
    sums[k] = t


@njit(cache=True)
def _widest_tree(t_along, t_across, t_in, t_out, index, m):  # pragma: no cover
    """The faces as edges (head, tail, T) and their maximum spanning tree: its nodes in
    breadth-first order from the inlet and each node's edge to its parent (both empty where
    the tree does not reach every unknown), and whether it does."""
    head, tail, trans = _face_edges(t_along, t_across, t_in, t_out, index, m)
    in_tree, degree, spans = _maximum_spanning_tree(head, tail, trans, m + 2)
    if not spans:
        return head, tail, trans, np.empty(0, np.int32), np.empty(0, np.int32), False
    order, up = _rooted(head, tail, in_tree, degree, m)
    return head, tail, trans, order, up, True


@njit(cache=True)
def _divergence_free(head, tail, trans, order, up, spans, x):  # pragma: no cover
    """The fluxes of the pressures ``x`` of the unknowns, their divergence routed to the
    reservoirs along the tree (:func:`_widest_tree`); returns (Q(x), the energy E of the
    corrected fluxes, their inlet flux, their outlet flux, whether the tree reached every
    unknown)."""
    m = x.size
    inlet, outlet = m, m + 1
    n_edges = head.size
    pressure = np.empty(m + 2)
    pressure[:m] = x
    pressure[inlet], pressure[outlet] = 1.0, 0.0
    if not spans:
        upper = 0.0
        for e in range(1, n_edges):
            upper += trans[e] * (pressure[head[e]] - pressure[tail[e]]) ** 2
        return upper, 0.0, 0.0, 0.0, False
    # the fluxes T (p_head - p_tail) of x, from pressure differences: the divergence they
    # leave is then exact to about eps times the flux through the gap, whereas the residual
    # b - A x carries eps T |x|, up to 1e3 times the flux near a_c* (its round-off floor)
    # Q(x), E and the reservoir fluxes are compensated sums (Neumaier), in that order
    sums = np.zeros(4)
    errors = np.zeros(4)
    flux = np.zeros(n_edges)
    carried = np.zeros(m + 2)  # what each node takes in: the divergence to cancel
    for e in range(1, n_edges):
        f = trans[e] * (pressure[head[e]] - pressure[tail[e]])
        flux[e] = f
        carried[head[e]] -= f
        carried[tail[e]] += f
        _add(sums, errors, 0, f * f / trans[e])
    carried[inlet] = 0.0  # the reservoirs take in or give out anything
    carried[outlet] = 0.0
    # each unknown sends what it takes in and its subtree's to its parent: afterwards every
    # cell's outflow equals its inflow
    for s in range(m + 1, 0, -1):
        v = order[s]
        e = up[v]
        if e == 0:
            continue
        p = tail[e] if head[e] == v else head[e]
        c = carried[v]
        carried[p] += c
        flux[e] += c if head[e] == v else -c
    for e in range(1, n_edges):
        _add(sums, errors, 1, flux[e] * flux[e] / trans[e])
        if head[e] == inlet:
            _add(sums, errors, 2, flux[e])
        elif tail[e] == outlet:
            _add(sums, errors, 3, flux[e])
    return (sums[0] + errors[0], sums[1] + errors[1], sums[2] + errors[2], sums[3] + errors[3],
            True)


@dataclass(frozen=True)
class WidestTree:
    """The maximum spanning tree in the transmissibilities of one Reynolds system's faces,
    which depends on the faces alone: built once (:func:`widest_tree`, about 80 % of a
    bound's time) for every iterate bounded on that system. ``head``, ``tail``, ``trans``:
    the faces as edges (edge 0 joins the two reservoirs); ``order``, ``up``: the tree's
    nodes breadth-first from the inlet and each one's edge to its parent; ``spans``:
    whether it reaches every unknown (else ``order`` and ``up`` are empty)."""

    head: np.ndarray
    tail: np.ndarray
    trans: np.ndarray
    order: np.ndarray
    up: np.ndarray
    spans: bool


def widest_tree(faces: Faces, active: np.ndarray, cells: np.ndarray) -> WidestTree:
    """The :class:`WidestTree` of the system assembled from ``faces`` on the flowing cells
    ``active`` (unknowns ``cells``, flat indices in C order; flow along axis 0)."""
    # int32 indices (a quarter less time than int64 at 1024^2: Kruskal's random reads hit the
    # cache more often) hold 2^31 faces; ``check_memory`` refuses a flow solve on such a grid
    # long before (560 B a point)
    index = np.full(active.size, -1, dtype=np.int32)
    index[cells] = np.arange(cells.size)
    return WidestTree(*_widest_tree(faces.t_along, faces.t_across, faces.t_in, faces.t_out,
                                    index.reshape(active.shape), cells.size))


@dataclass(frozen=True)
class DissipationBounds:
    """Q(x) >= Q >= F^2 / E for the exact dissipation Q (units of T, i.e. of sigma), and
    ``relative_error``, (Q(x) - F^2 / E) / Q(x): a bound on the relative error of Q(x), so
    of sigma, up to round-off. ``lower`` is 0 where the faces leave an unknown cut off."""

    upper: float
    lower: float

    @property
    def relative_error(self) -> float:
        return max(1.0 - self.lower / self.upper, 0.0) if self.upper > 0 else math.inf


def dissipation_bounds(faces: Faces, active: np.ndarray, cells: np.ndarray,
                       x: np.ndarray, tree: WidestTree | None = None) -> DissipationBounds:
    """The bounds on the exact dissipation Q of the Reynolds system assembled from
    ``faces`` on the flowing cells ``active`` (unknowns ``cells``, flat indices in C order)
    that the pressures ``x`` of the unknowns give (flow along axis 0). ``tree``: the
    system's :func:`widest_tree`, built here when None."""
    t = widest_tree(faces, active, cells) if tree is None else tree
    upper, energy, f_in, f_out, connected = _divergence_free(
        t.head, t.tail, t.trans, t.order, t.up, t.spans,
        np.ascontiguousarray(x, dtype=np.float64))
    if not connected or energy <= 0.0:
        return DissipationBounds(upper, 0.0)
    # the corrected fluxes are divergence-free up to round-off, so the inlet and outlet
    # fluxes agree to that; the bound holds for either sign of F (a reversed flow has the
    # same energy)
    flux = 0.5 * (f_in + f_out)
    return DissipationBounds(upper, flux**2 / energy)


@dataclass(frozen=True)
class DroppedFlow:
    """The open cells a flow solve left out (below the unresolved-gap floor, or cut off by
    it), as regions: ``labels`` 1..n on them (0 elsewhere), ``bound[k]`` an upper bound on
    the dissipation region k would add to the solved one (``bound[0]`` = 0); same units and
    orientation (flow along axis 0) as the solve's."""

    labels: np.ndarray
    bound: np.ndarray

    @property
    def total(self) -> float:
        return float(self.bound.sum())


def dropped_flow(sigma: np.ndarray, active: np.ndarray, pressure: np.ndarray, h_flow: float,
                 h_across: float, *, periodic: bool = True) -> DroppedFlow:
    """Bound the flow through the open cells (``sigma`` > 0, flow along axis 0) outside
    ``active``, given the solved ``pressure`` on ``active`` (inlet 1, outlet 0).

    A region R of such cells meets the solved network (and the reservoirs) through its
    boundary faces, whose pressures span [p_min, p_max]. Adding R raises the dissipation by
    at most what the trial field p = (p_min + p_max) / 2 in R costs (Dirichlet's principle:
    the old solution extended by it is admissible), i.e. (p_max - p_min)^2 / 4 times the
    transmissibilities of R's boundary faces, however well R conducts inside.
    """
    dropped = (sigma > 0) & ~active
    labels, n = label(dropped, periodic=(False, bool(periodic)))
    bound = np.zeros(n + 1)
    if n == 0:
        return DroppedFlow(labels, bound)
    faces = face_transmissibilities(sigma, h_flow, h_across, periodic=periodic)
    low, high, trans = np.full(n + 1, np.inf), np.full(n + 1, -np.inf), np.zeros(n + 1)

    def meet(region: np.ndarray, p: np.ndarray, t: np.ndarray) -> None:
        # region: the label of a dropped cell whose face t reaches pressure p (0: no such)
        m = (region > 0) & (t > 0)
        k = region[m]
        np.minimum.at(low, k, p[m])
        np.maximum.at(high, k, p[m])
        np.add.at(trans, k, t[m])

    meet(np.where(active[1:], labels[:-1], 0), pressure[1:], faces.t_along)
    meet(np.where(active[:-1], labels[1:], 0), pressure[:-1], faces.t_along)
    if sigma.shape[1] > 1:
        meet(np.where(np.roll(active, -1, 1), labels, 0), np.roll(pressure, -1, 1),
             faces.t_across)
        meet(np.where(active, np.roll(labels, -1, 1), 0), pressure, faces.t_across)
    meet(labels[0], np.ones(sigma.shape[1]), faces.t_in)
    meet(labels[-1], np.zeros(sigma.shape[1]), faces.t_out)
    spread = np.where(trans > 0, high - low, 0.0)
    bound = trans * spread * spread / 4.0
    return DroppedFlow(labels, bound)
