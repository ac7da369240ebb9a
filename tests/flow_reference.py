"""An exact reference for the flow solver's finite-volume system on small fields: the same
discretisation (flow.assembly: harmonic-mean faces, reservoir faces at half a cell) solved
in 80-digit decimal arithmetic, with every open cell of the cluster that joins the
reservoirs (no unresolved-gap floor, no lumping). Sparse elimination in natural order: for
the channel-like fields of the tests the fill stays small (a 48 x 48 field with a channel
and a pocket: milliseconds)."""

from __future__ import annotations

import decimal
from decimal import Decimal

import numpy as np

from roughflow.percolation import spanning_cells
from roughflow.reynolds import cubic_law

decimal.getcontext().prec = 80


def reference_sigma(gap: np.ndarray, axis: int = 0, *, lx: float = 1.0,
                    ly: float | None = None, periodic: bool = True) -> float:
    """sigma along ``axis`` of ``gap`` (units as :func:`roughflow.flow.solve`, eta = 1)."""
    ly = lx if ly is None else ly
    s = cubic_law(np.asarray(gap, dtype=np.float64), 1.0)
    active = spanning_cells(s > 0, axis, periodic=periodic)
    h_flow, h_across = (lx / s.shape[0], ly / s.shape[1])
    l_flow, l_across = lx, ly
    if axis == 1:
        s, active = s.T, active.T
        h_flow, h_across, l_flow, l_across = h_across, h_flow, ly, lx
    if not active.any():
        return 0.0
    n0, n1 = s.shape
    r_along = Decimal(h_across) / Decimal(h_flow)
    r_across = Decimal(h_flow) / Decimal(h_across)
    cells = [(i, j) for i in range(n0) for j in range(n1) if active[i, j]]
    index = {c: k for k, c in enumerate(cells)}
    value = {c: Decimal(float(s[c])) for c in cells}
    inlet, outlet = -1, -2
    edges = []  # (a, b, T): a, b unknowns or a reservoir
    for (i, j) in cells:
        k = index[(i, j)]
        if i + 1 < n0 and (i + 1, j) in index:
            edges.append((k, index[(i + 1, j)], _harmonic(value[(i, j)], value[(i + 1, j)])
                          * r_along))
        jp = (j + 1) % n1
        if n1 > 1 and (periodic or jp != 0) and (i, jp) in index:
            edges.append((k, index[(i, jp)], _harmonic(value[(i, j)], value[(i, jp)])
                          * r_across))
        if i == 0:
            edges.append((inlet, k, 2 * value[(i, j)] * r_along))
        if i == n0 - 1:
            edges.append((k, outlet, 2 * value[(i, j)] * r_along))
    m = len(cells)
    rows: list[dict[int, Decimal]] = [{} for _ in range(m)]
    rhs = [Decimal(0)] * m
    for a, b, t in edges:
        for p, q in ((a, b), (b, a)):
            if p < 0:
                continue
            rows[p][p] = rows[p].get(p, Decimal(0)) + t
            if q >= 0:
                rows[p][q] = rows[p].get(q, Decimal(0)) - t
            elif q == inlet:
                rhs[p] += t
    for k in range(m):  # elimination below the diagonal
        pivot_row = rows[k]
        for i in [c for c in pivot_row if c > k]:
            factor = rows[i].pop(k) / pivot_row[k]
            for j, v in pivot_row.items():
                if j > k:
                    rows[i][j] = rows[i].get(j, Decimal(0)) - factor * v
            rhs[i] -= factor * rhs[k]
    x = [Decimal(0)] * m
    for k in range(m - 1, -1, -1):
        acc = rhs[k] - sum((v * x[j] for j, v in rows[k].items() if j > k), Decimal(0))
        x[k] = acc / rows[k][k]
    pressure = {inlet: Decimal(1), outlet: Decimal(0)}
    dissipation = sum((t * ((pressure.get(a) if a < 0 else x[a])
                            - (pressure.get(b) if b < 0 else x[b])) ** 2 for a, b, t in edges),
                      Decimal(0))
    return float(dissipation * Decimal(l_flow) / Decimal(l_across))


def _harmonic(a: Decimal, b: Decimal) -> Decimal:
    return 2 * a * b / (a + b)
