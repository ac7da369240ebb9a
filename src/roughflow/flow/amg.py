"""Classical Ruge-Stueben AMG for the Reynolds system: the hierarchy and its V-cycle.

The algorithm is pyamg's ``ruge_stuben_solver(A, CF=("RS", {"second_pass": True}),
max_coarse=500, coarse_solver="splu")``: classical strength of connection (theta 0.25),
RS C/F splitting with the second pass, classical interpolation with strong F-F connections
removed, Galerkin coarse matrices R A P with R = P^T, sparse LU on the coarsest level. Both
the set-up (:func:`rs_hierarchy`) and the cycle (:func:`rs_vcycle`) call pyamg's compiled
kernels (``pyamg.amg_core``) directly and do the bookkeeping between them in one pass each:
pyamg's own set-up spends about a third of its time on Python-level copies and conversions
(absolute values and row scaling of a strength matrix whose pattern alone is used, the
diagonal dropped through a COO round trip, A's values put on the interpolation pattern by
an element-wise product), its cycle a third on residual norms and argument checks. The
interpolation weights are our own kernel (:func:`_classical_weights`, pyamg's formula with
a marker instead of pyamg's nested scans). The C/F splittings are pyamg's on every level,
the weights pyamg's up to summation order, and the cycle is pyamg's arithmetic
(tests/test_flow.py); see docs/flow.md, "Linear solver".
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from roughflow._jit import njit
from roughflow.errors import InputError

if TYPE_CHECKING:
    from pyamg.multilevel import MultilevelSolver

#: classical strength of connection: j is a strong neighbour of i if |a_ij| >= theta
#: max_k!=i |a_ik| (pyamg's and the classical choice)
STRENGTH_THETA = 0.25
#: an entry a_km of a strong F neighbour k below ROUNDOFF |a_kk| is round-off of the Galerkin
#: product (seen: 1e-25 against a_kk = 3.4e-8, its sign changing with the heights' last bits),
#: not a connection: it neither carries a_ik to C_i nor keeps it from being left out
ROUNDOFF = 1e-12
#: the hierarchy stops when a level has at most this many unknowns (solved by sparse LU)
MAX_COARSE = 500
#: at most this many levels (pyamg's default; 2048^2 grids take 10-11)
MAX_LEVELS = 30

#: Smoothing of the RS V-cycle: one forward Gauss-Seidel sweep before the coarse-grid
#: correction and one backward sweep after it. The backward sweep is the adjoint of the
#: forward one, so the V-cycle stays a symmetric operator, as CG needs. pyamg's default, a
#: symmetric sweep (forward and backward) on both sides, does twice the smoothing for the
#: same 10-17 CG iterations; one sweep each took 0.73-0.93x the time of a whole flow solve
#: at 1024^2 (docs/flow.md, "Linear solver").
RS_SMOOTHERS = {"presmoother": ("gauss_seidel", {"sweep": "forward"}),
                "postsmoother": ("gauss_seidel", {"sweep": "backward"})}

#: pyamg's smoother of a level when RS_SMOOTHERS names none (ruge_stuben_solver's default)
_PYAMG_DEFAULT_SMOOTHER = ("gauss_seidel", {"sweep": "symmetric"})
_SWEEP_ORDER = {"forward": (False,), "backward": (True,), "symmetric": (False, True)}


@dataclass(frozen=True)
class Level:
    """One level: its matrix ``A`` and, above the coarsest, the interpolation ``P`` to it
    from the next coarser level and the restriction ``R`` = P^T (all CSR)."""

    A: sp.csr_matrix
    P: sp.csr_matrix | None = None
    R: sp.csr_matrix | None = None
    splitting: np.ndarray | None = None  # 1: C point, 0: F point


@dataclass(frozen=True)
class Hierarchy:
    """The levels, finest first, and the sparse LU of the coarsest matrix. ``levels`` and
    ``coarse_solver(A, b)`` are what pyamg's MultilevelSolver offers under the same names,
    so :func:`rs_vcycle` cycles either."""

    levels: tuple[Level, ...]
    coarse_lu: spla.SuperLU

    def coarse_solver(self, _a: sp.csr_matrix, b: np.ndarray) -> np.ndarray:
        return self.coarse_lu.solve(b)


@njit(cache=True)
def _strong_offdiagonal(sp_, sj):  # pragma: no cover (compiled)
    """The strength pattern without its diagonal, each row sorted by column (the order
    pyamg's splitting sees)."""
    n = sp_.size - 1
    tp = np.empty(n + 1, sp_.dtype)
    tj = np.empty(sp_[n], sj.dtype)
    tp[0] = 0
    k = 0
    for i in range(n):
        start = k
        for jj in range(sp_[i], sp_[i + 1]):
            j = sj[jj]
            if j != i:
                m = k  # insertion sort: a row holds 4-30 entries
                while m > start and tj[m - 1] > j:
                    tj[m] = tj[m - 1]
                    m -= 1
                tj[m] = j
                k += 1
        tp[i + 1] = k
    return tp, tj[:k]


@njit(cache=True)
def _kept_entries(cp, cj, keep, values):  # pragma: no cover (compiled)
    """The entries of (cp, cj) where ``keep`` is nonzero, with ``values`` on them."""
    n = cp.size - 1
    op = np.empty(n + 1, cp.dtype)
    oj = np.empty(cp[n], cj.dtype)
    ox = np.empty(cp[n], values.dtype)
    op[0] = 0
    k = 0
    for i in range(n):
        for jj in range(cp[i], cp[i + 1]):
            if keep[jj] != 0:
                oj[k] = cj[jj]
                ox[k] = values[jj]
                k += 1
        op[i + 1] = k
    return op, oj[:k], ox[:k]


@njit(cache=True)
def _classical_weights(ap, aj, ax, cp, cj, cx, splitting, pp):  # pragma: no cover (compiled)
    """Classical (Ruge-Stueben) interpolation on the pattern ``pp`` of the kept strong
    connections (cp, cj, cx): P's column indices (coarse numbering) and weights.

    An F point i interpolates from its strong C neighbours C_i with
    w_ij = -(a_ij + sum_{k in F_i} a_ik abar_kj / sum_{m in C_i} abar_km) / (a_ii + sum of
    its weak connections), F_i its strong F neighbours and abar_km the entries of row k of
    A whose sign is opposite to a_kk; a strong F neighbour with no such entry in C_i (only
    on coarse levels, whose Galerkin matrices have positive off-diagonal entries) is left
    out. These are the weights of pyamg's
    ``rs_classical_interpolation_pass2`` (``modified=True``) up to summation order, but
    each a_kj is found through a marker over the columns of C_i instead of a scan of row
    i for every entry of row k."""
    n = splitting.size
    pj = np.empty(pp[n], pp.dtype)
    px = np.zeros(pp[n], ax.dtype)
    coarse = np.empty(n, pp.dtype)  # the coarse index of each C point
    nc = 0
    for i in range(n):
        coarse[i] = nc
        nc += splitting[i]
    slot = np.full(n, -1, pp.dtype)  # -1: not a kept strong neighbour of the row at hand
    diag = np.zeros(n, ax.dtype)
    for i in range(n):
        for jj in range(ap[i], ap[i + 1]):
            if aj[jj] == i:
                diag[i] += ax[jj]
    for i in range(n):
        k0 = pp[i]
        if splitting[i] == 1:
            pj[k0] = coarse[i]
            px[k0] = 1.0
            continue
        t = k0
        for jj in range(cp[i], cp[i + 1]):
            j = cj[jj]
            if j == i:
                continue
            if splitting[j] == 1:
                slot[j] = t
                pj[t] = coarse[j]
                px[t] = cx[jj]
                t += 1
            else:
                slot[j] = -2  # a strong F neighbour
        diagonal = 0.0
        for jj in range(ap[i], ap[i + 1]):
            j = aj[jj]
            if j == i or slot[j] == -1:
                diagonal += ax[jj]
        for jj in range(cp[i], cp[i + 1]):
            k = cj[jj]
            if k == i or splitting[k] == 1:
                continue
            akk = diag[k]
            floor = ROUNDOFF * abs(akk)
            denominator = 0.0
            for mm in range(ap[k], ap[k + 1]):
                m = aj[mm]
                if slot[m] >= 0 and ax[mm] * akk < 0.0 and abs(ax[mm]) > floor:
                    denominator += ax[mm]
            if denominator == 0.0:  # as pyamg: left out, not lumped into the diagonal
                continue
            share = cx[jj] / denominator
            for mm in range(ap[k], ap[k + 1]):
                m = aj[mm]
                if slot[m] >= 0 and ax[mm] * akk < 0.0 and abs(ax[mm]) > floor:
                    px[slot[m]] += share * ax[mm]
        for tt in range(k0, t):
            px[tt] = -px[tt] / diagonal
        for jj in range(cp[i], cp[i + 1]):
            slot[cj[jj]] = -1
    return pj, px


def _coarsen(a: sp.csr_matrix):
    """(P, R, splitting) of one RS coarsening of ``a``, or None where it would keep every
    point or none."""
    from pyamg import amg_core

    n = a.shape[0]
    ap, aj, ax = a.indptr, a.indices, a.data
    # strong connections and the diagonal, in A's order, with A's values. The kernel keeps
    # no stored zero (its threshold is positive) and an SPD diagonal is positive, so the
    # zeros pyamg eliminates here are none (tested with stored zeros in A).
    sp_, sj, sx = np.empty_like(ap), np.empty_like(aj), np.empty_like(ax)
    amg_core.classical_strength_of_connection_abs(n, STRENGTH_THETA, ap, aj, ax, sp_, sj, sx)
    sj, sx = sj[: sp_[-1]], sx[: sp_[-1]]

    # C/F splitting on the strong off-diagonal pattern and its transpose
    tp, tj = _strong_offdiagonal(sp_, sj)
    st = sp.csr_matrix((np.ones(tj.size), tj, tp), shape=(n, n)).T.tocsr()
    splitting = np.empty(n, dtype=ap.dtype)
    amg_core.rs_cf_splitting(n, tp, tj, st.indptr, st.indices, np.zeros(n, ap.dtype), splitting)
    amg_core.rs_cf_splitting_pass2(n, tp, tj, splitting)
    n_coarse = int(splitting.sum())
    if n_coarse in (0, n):
        return None

    # classical interpolation over the strong connections less the F-F ones without a
    # common C point (pyamg's "modified" interpolation)
    keep = np.abs(sx)
    amg_core.remove_strong_FF_connections(n, sp_, sj, keep, splitting)
    cp, cj, cx = _kept_entries(sp_, sj, keep, sx)
    pp = np.empty_like(ap)
    amg_core.rs_classical_interpolation_pass1(n, cp, cj, splitting, pp)
    pj, px = _classical_weights(ap, aj, ax, cp, cj, cx, splitting, pp)
    p = sp.csr_matrix((px, pj, pp), shape=(n, n_coarse))
    return p, p.T.tocsr(), splitting


def rs_hierarchy(a: sp.csr_matrix) -> Hierarchy:
    """The RS hierarchy of the SPD matrix ``a`` (CSR, float64)."""
    levels = []
    while len(levels) + 1 < MAX_LEVELS and a.shape[0] > MAX_COARSE:
        step = _coarsen(a)
        if step is None:
            break
        p, r, splitting = step
        levels.append(Level(a, p, r, splitting))
        a = r @ a @ p
    levels.append(Level(a))
    return Hierarchy(tuple(levels), spla.splu(sp.csc_matrix(a)))


def pyamg_rs_hierarchy(a: sp.csr_matrix, smoothers: dict | None = None) -> MultilevelSolver:
    """pyamg's own build of the same hierarchy (a MultilevelSolver smoothed as
    ``smoothers``, :data:`RS_SMOOTHERS` when None): the reference of the tests and of
    ``benchmarks/bench_flow.py``."""
    import pyamg

    smoothers = RS_SMOOTHERS if smoothers is None else smoothers
    return pyamg.ruge_stuben_solver(a, strength=("classical", {"theta": STRENGTH_THETA}),
                                    CF=("RS", {"second_pass": True}), max_coarse=MAX_COARSE,
                                    max_levels=MAX_LEVELS, coarse_solver="splu", **smoothers)


def _sweeps(spec) -> tuple[bool, ...]:
    """The Gauss-Seidel sweeps (True: backward) of one pyamg smoother spec."""
    name, opts = spec if isinstance(spec, tuple) else (spec, {})
    sweep = opts.get("sweep", "forward")
    if name != "gauss_seidel" or set(opts) - {"sweep"} or sweep not in _SWEEP_ORDER:
        raise InputError(f"rs_vcycle smooths with plain Gauss-Seidel sweeps only, got {spec!r}")
    return _SWEEP_ORDER[sweep]


def rs_vcycle(ml: Hierarchy | MultilevelSolver,
              smoothers: dict | None = None) -> spla.LinearOperator:
    """One V-cycle of the hierarchy ``ml`` (a :class:`Hierarchy` or pyamg's
    MultilevelSolver) from a zero guess, smoothed as ``smoothers`` (pyamg's
    presmoother/postsmoother keywords; :data:`RS_SMOOTHERS` when None). On pyamg's
    hierarchy it is the arithmetic of ``ml.aspreconditioner(cycle="V")`` bit for bit
    (tested), without what pyamg's cycle adds to each call, a third of its time at 1024^2:
    the residual norm before and after the cycle (two extra products with the finest
    matrix, three norms) and the argument checks of every smoothing sweep."""
    from pyamg import amg_core

    smoothers = RS_SMOOTHERS if smoothers is None else smoothers
    pre = _sweeps(smoothers.get("presmoother", _PYAMG_DEFAULT_SMOOTHER))
    post = _sweeps(smoothers.get("postsmoother", _PYAMG_DEFAULT_SMOOTHER))
    levels = [(lv.A, lv.P, lv.R) for lv in ml.levels[:-1]]
    coarsest, coarse_solve = ml.levels[-1].A, ml.coarse_solver

    def smooth(a, x, b, sweeps) -> None:
        n = a.shape[0]
        for backward in sweeps:
            start, stop, step = (n - 1, -1, -1) if backward else (0, n, 1)
            amg_core.gauss_seidel(a.indptr, a.indices, a.data, x, b, start, stop, step)

    def apply(b: np.ndarray) -> np.ndarray:
        b = np.ascontiguousarray(b, dtype=np.float64).ravel()
        down = []
        for a, _, r in levels:
            x = np.zeros(a.shape[0])
            smooth(a, x, b, pre)
            down.append((x, b))
            b = r @ (b - a @ x)
        x = np.ravel(coarse_solve(coarsest, b))
        for (a, p, _), (xk, bk) in zip(reversed(levels), reversed(down), strict=True):
            xk += p @ x
            smooth(a, xk, bk, post)
            x = xk
        return x

    n = ml.levels[0].A.shape[0]
    return spla.LinearOperator((n, n), matvec=apply, rmatvec=apply, dtype=np.float64)
