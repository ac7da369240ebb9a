"""LDL^T factorisation of the Reynolds matrix in an elimination order of the caller's choice.

The direct flow solver factorises A = P^T L D L^T P with QDLDL, after an approximate minimum
degree (AMD) ordering P. On the gaps of a ladder that ordering is 60-90 % of the
factorisation's time, and consecutive states of one ladder differ by a few percent of their
cells, so a state's order restricted to the next state's cells factorises that one in
0.3-0.8 of the time, for somewhat more fill (docs/flow.md "Reusing the ordering along a
ladder"). ``qdldl.Solver`` always orders afresh, so this module
calls the C routines it wraps, QDLDL's ``QDLDL_etree``, ``QDLDL_factor`` and ``QDLDL_solve``
and SuiteSparse's ``amd_l_order``, whose public C interfaces the qdldl wheel's extension
module exports (both built with 64-bit integers). Where they cannot be loaded (another build)
:func:`available` is False and the caller uses ``qdldl.Solver``.
"""

from __future__ import annotations

import ctypes
import functools
from dataclasses import dataclass

import numpy as np
import qdldl
import scipy.sparse as sp

from roughflow.errors import ConvergenceError, InputError

_INT = ctypes.c_int64
_P_INT = ctypes.POINTER(ctypes.c_int64)
_P_FLOAT = ctypes.POINTER(ctypes.c_double)
_P_BOOL = ctypes.POINTER(ctypes.c_ubyte)
#: SuiteSparse AMD: the length of its Info array, and its status for "out of memory"
_AMD_INFO, _AMD_OUT_OF_MEMORY = 20, -1


def _ptr(a: np.ndarray, kind=_P_INT):
    return a.ctypes.data_as(kind)


@functools.cache
def _library() -> ctypes.CDLL | None:
    """The qdldl extension module as a C library, if it exports the routines this module
    calls with 64-bit integers (checked on a 3 x 3 system); else None."""
    try:
        lib = ctypes.CDLL(qdldl.__file__)
        for name in ("QDLDL_etree", "QDLDL_factor", "amd_l_order"):
            getattr(lib, name).restype = _INT
        lib.QDLDL_solve.restype = None
    except (OSError, AttributeError):
        return None
    probe = sp.csc_matrix(np.array([[4.0, -1, 0], [-1, 4, -1], [0, -1, 4]]))
    perm = np.array([2, 0, 1])
    try:
        f = _numeric(lib, _symbolic(lib, probe, perm), perm, amd=False)
        order = _amd_order(lib, probe)
    except (ConvergenceError, InputError):
        return None
    if not np.array_equal(np.sort(order), np.arange(3)):
        return None
    x = f.solve(np.array([3.0, 2.0, 3.0]))
    return lib if np.allclose(x, 1.0, rtol=0, atol=1e-14) else None


def available() -> bool:
    """Whether this module can factorise (else ``qdldl.Solver`` orders afresh every time)."""
    return _library() is not None


@dataclass(frozen=True)
class LDLFactor:
    """A = P^T L D L^T P of a symmetric matrix: ``perm`` (P: row i of the permuted matrix is
    row perm[i] of A), the strictly lower CSC factor L (``lp``, ``li``, ``lx``), 1/D
    (``dinv``), the factorisation's floating point operations, sum over the columns of L of
    their count squared (``flops``), and whether :func:`factor` took AMD's order
    (``amd``) or the caller's."""

    perm: np.ndarray
    lp: np.ndarray
    li: np.ndarray
    lx: np.ndarray
    dinv: np.ndarray
    flops: float
    amd: bool
    _lib: ctypes.CDLL

    @property
    def nnz(self) -> int:
        """Nonzeros of L."""
        return int(self.li.size)

    def solve(self, b: np.ndarray) -> np.ndarray:
        """A^-1 b."""
        x = np.ascontiguousarray(np.asarray(b, dtype=np.float64)[self.perm])
        self._lib.QDLDL_solve(_INT(x.size), _ptr(self.lp), _ptr(self.li),
                              _ptr(self.lx, _P_FLOAT), _ptr(self.dinv, _P_FLOAT),
                              _ptr(x, _P_FLOAT))
        out = np.empty_like(x)
        out[self.perm] = x
        return out


def amd_order(a: sp.spmatrix) -> np.ndarray:
    """The approximate minimum degree order of the symmetric ``a`` (SuiteSparse AMD with its
    default controls): a permutation of its rows."""
    return _amd_order(_require(), a)


def factor(a: sp.spmatrix, order: np.ndarray | None = None, *,
           max_flops: float | None = None) -> LDLFactor:
    """LDL^T of the symmetric positive definite ``a`` in the elimination ``order`` (a
    permutation of its rows; None: AMD's, :func:`amd_order`). With ``max_flops``, an
    ``order`` whose factorisation would take more floating point operations is replaced by
    AMD's (its symbolic pass, which counts them, costs 2-5 % of a factorisation). Raises
    :class:`ConvergenceError` on a zero pivot (``a`` singular to working precision)."""
    lib = _require()
    if order is not None:
        perm = np.asarray(order, dtype=np.int64)
        n = a.shape[0]
        if perm.shape != (n,) or (n and (perm.min() < 0 or perm.max() >= n or not np.all(
                np.bincount(perm, minlength=n) == 1))):
            raise InputError(f"order must be a permutation of the {n} unknowns")
        symbolic = _symbolic(lib, a, perm)
        if max_flops is None or symbolic.flops <= max_flops:
            return _numeric(lib, symbolic, perm, amd=False)
    perm = _amd_order(lib, a)
    return _numeric(lib, _symbolic(lib, a, perm), perm, amd=True)


def permuted_upper(a: sp.spmatrix, perm: np.ndarray) -> sp.csc_matrix:
    """The upper triangle of P A P^T (row i is row ``perm[i]`` of ``a``), CSC, sorted."""
    coo = sp.coo_matrix(a)
    inverse = np.empty_like(perm)
    inverse[perm] = np.arange(perm.size)
    r, c = inverse[coo.row], inverse[coo.col]
    keep = r <= c
    upper = sp.csc_matrix((coo.data[keep], (r[keep], c[keep])), shape=a.shape)
    upper.sum_duplicates()
    return upper


@dataclass(frozen=True)
class _Symbolic:
    """QDLDL's symbolic pass over a permuted upper triangle: its CSC arrays, the elimination
    tree, the nonzeros of each column of L and the flops they imply."""

    ap: np.ndarray
    ai: np.ndarray
    ax: np.ndarray
    etree: np.ndarray
    lnz: np.ndarray
    flops: float


def _symbolic(lib: ctypes.CDLL, a: sp.spmatrix, perm: np.ndarray) -> _Symbolic:
    upper = permuted_upper(a, perm)
    n = upper.shape[0]
    ap = upper.indptr.astype(np.int64)
    ai = upper.indices.astype(np.int64)
    lnz = np.empty(n, np.int64)
    etree = np.empty(n, np.int64)
    total = lib.QDLDL_etree(_INT(n), _ptr(ap), _ptr(ai), _ptr(np.empty(n, np.int64)),
                            _ptr(lnz), _ptr(etree))
    if total < 0:  # not upper triangular, or the count overflowed
        raise InputError(f"QDLDL_etree rejected the permuted matrix (status {total})")
    return _Symbolic(ap, ai, np.ascontiguousarray(upper.data, dtype=np.float64), etree, lnz,
                     float(np.dot(lnz.astype(np.float64), lnz)))


def _numeric(lib: ctypes.CDLL, s: _Symbolic, perm: np.ndarray, *, amd: bool) -> LDLFactor:
    n = s.lnz.size
    total = int(s.lnz.sum())
    lp = np.empty(n + 1, np.int64)
    li = np.empty(total, np.int64)
    lx = np.empty(total)
    dinv = np.empty(n)
    status = lib.QDLDL_factor(
        _INT(n), _ptr(s.ap), _ptr(s.ai), _ptr(s.ax, _P_FLOAT), _ptr(lp), _ptr(li),
        _ptr(lx, _P_FLOAT), _ptr(np.empty(n), _P_FLOAT), _ptr(dinv, _P_FLOAT), _ptr(s.lnz),
        _ptr(s.etree), _ptr(np.empty(n, np.uint8), _P_BOOL), _ptr(np.empty(3 * n, np.int64)),
        _ptr(np.empty(n), _P_FLOAT))
    if status < 0:
        # the flow's matrices are positive definite by construction: a zero pivot is one
        # lost to rounding, where the conductances span more than float64 resolves
        raise ConvergenceError("LDL^T factorisation met a zero pivot: the matrix is singular "
                               "to working precision (the local conductances span more than "
                               "float64 resolves; docs/flow.md \"Unresolved gaps\")",
                               residual=float("inf"), iterations=0)
    return LDLFactor(perm, lp, li, lx, dinv, s.flops, amd, lib)


def _amd_order(lib: ctypes.CDLL, a: sp.spmatrix) -> np.ndarray:
    upper = sp.triu(a, format="csc")
    upper.sort_indices()
    n = upper.shape[0]
    ap = upper.indptr.astype(np.int64)
    ai = upper.indices.astype(np.int64)
    perm = np.empty(n, np.int64)
    info = np.zeros(_AMD_INFO)
    status = lib.amd_l_order(_INT(n), _ptr(ap), _ptr(ai), _ptr(perm), None,
                             _ptr(info, _P_FLOAT))
    if status == _AMD_OUT_OF_MEMORY:
        raise MemoryError(f"AMD ordering of {n} unknowns ran out of memory")
    if status < 0:
        raise InputError(f"AMD rejected the matrix (status {status})")
    return perm


def _require() -> ctypes.CDLL:
    lib = _library()
    if lib is None:
        raise RuntimeError("the qdldl extension module does not export QDLDL's and AMD's C "
                           "routines with 64-bit integers; use qdldl.Solver")
    return lib
