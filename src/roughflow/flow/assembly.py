"""Finite-volume assembly of the Reynolds equation div(sigma grad p) = 0 (paper Eq. 4
with div j = 0).

Cell-centred finite volumes on the contact grid, written for flow along axis 0
(callers transpose for flow along y). Local conductivity sigma = u^3 / (12 eta)
(paper Eq. 3). The conductance of a face between two cells is the harmonic mean
of the two cells' sigma, so a contact cell (sigma = 0) closes its faces; the
transmissibility of a face is that conductance times face length / centre
distance. Reservoirs: p = 1 at the inlet (before cell row 0) and p = 0 at the
outlet (after the last row), imposed at the outer cell faces, i.e. half a cell
from the first/last cell centres; the boundary transmissibility is the cell's own
sigma times h_across / (h_flow / 2). With this choice a uniform gap u0 gives
sigma_eff = u0^3 / (12 eta) exactly, on any grid. The direction across the flow
is periodic, or closed by walls (no flux through the seam) for a non-periodic scan.

Only the cells passed in ``active`` (those connected to both reservoirs) become
unknowns; every face touching another cell has zero transmissibility anyway.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp

from roughflow._jit import njit


@dataclass(frozen=True)
class Faces:
    """Transmissibilities of the faces of an (n0, n1) grid, flow along axis 0.

    ``t_along[i, j]`` couples cells (i, j) and (i + 1, j) for i < n0 - 1;
    ``t_across[i, j]`` couples (i, j) and (i, (j + 1) % n1); ``t_in[j]`` and
    ``t_out[j]`` couple the first/last cell of column j to the reservoirs.
    Units: sigma (u^3 / eta) times a dimensionless length ratio.
    """

    t_along: np.ndarray
    t_across: np.ndarray
    t_in: np.ndarray
    t_out: np.ndarray


def harmonic_mean(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """2ab / (a + b), exactly 0 where either a or b is 0 (a, b >= 0).

    Written as 2 a (b / (a + b)) so that nothing overflows or underflows early.
    """
    total = a + b
    ratio = np.divide(b, total, out=np.zeros(np.broadcast_shapes(a.shape, b.shape)),
                      where=total > 0)
    return 2.0 * a * ratio


def face_transmissibilities(sigma: np.ndarray, h_flow: float, h_across: float, *,
                            periodic: bool = True) -> Faces:
    """Transmissibilities for local conductivities ``sigma`` (n0, n1), flow along axis 0.

    ``sigma`` must already be zero outside the cells that carry flow. ``periodic=False``
    closes the seam across the flow (faces between column n1 - 1 and column 0).
    """
    r_along = h_across / h_flow
    r_across = h_flow / h_across
    t_along, t_across = _face_means(np.ascontiguousarray(sigma, dtype=np.float64), r_along,
                                    r_across, bool(periodic))
    t_in = sigma[0] * (2.0 * r_along)
    t_out = sigma[-1] * (2.0 * r_along)
    return Faces(t_along, t_across, t_in, t_out)


@njit(cache=True)
def _face_means(sigma, r_along, r_across, periodic):  # pragma: no cover (compiled)
    """Every face's :func:`harmonic_mean` (the same arithmetic, bit for bit) times its
    length ratio, in one pass: numpy's form took ten passes and temporaries, 3 % of a
    ladder. A cell's face with itself (one column) and, where not ``periodic``, the seam
    carry nothing."""
    n0, n1 = sigma.shape
    t_along = np.empty((max(n0 - 1, 0), n1))
    t_across = np.zeros((n0, n1))
    seam = n1 if periodic else n1 - 1
    for i in range(n0):
        for j in range(n1):
            a = sigma[i, j]
            if i < n0 - 1:
                b = sigma[i + 1, j]
                total = a + b
                t_along[i, j] = 2.0 * a * (b / total if total > 0 else 0.0) * r_along
            if n1 > 1 and j < seam:
                b = sigma[i, j + 1 if j + 1 < n1 else 0]
                total = a + b
                t_across[i, j] = 2.0 * a * (b / total if total > 0 else 0.0) * r_across
    return t_along, t_across


@njit(cache=True)
def _fill_csr(index, t_along, t_across, t_in, t_out, cells):  # pragma: no cover (compiled)
    n0, n1 = index.shape
    nd = cells.size
    indptr = np.zeros(nd + 1, dtype=np.int64)
    indices = np.empty(5 * nd, dtype=np.int64)
    data = np.empty(5 * nd, dtype=np.float64)
    rhs = np.zeros(nd)
    k = 0
    for row in range(nd):
        i = cells[row] // n1
        j = cells[row] - i * n1
        diag = 0.0
        # columns are not in increasing order across the periodic seam: sorted afterwards
        if i > 0 and t_along[i - 1, j] > 0:
            t = t_along[i - 1, j]
            indices[k] = index[i - 1, j]
            data[k] = -t
            diag += t
            k += 1
        if n1 > 1:
            jm = j - 1 if j > 0 else n1 - 1
            t = t_across[i, jm]
            if t > 0:
                indices[k] = index[i, jm]
                data[k] = -t
                diag += t
                k += 1
            t = t_across[i, j]
            if t > 0:
                jp = j + 1 if j < n1 - 1 else 0
                indices[k] = index[i, jp]
                data[k] = -t
                diag += t
                k += 1
        if i < n0 - 1 and t_along[i, j] > 0:
            t = t_along[i, j]
            indices[k] = index[i + 1, j]
            data[k] = -t
            diag += t
            k += 1
        if i == 0:
            diag += t_in[j]
            rhs[row] = t_in[j]  # inlet pressure 1
        if i == n0 - 1:
            diag += t_out[j]
        indices[k] = row
        data[k] = diag
        k += 1
        indptr[row + 1] = k
    return indptr, indices[:k], data[:k], rhs


class LinearSystem(NamedTuple):
    """The assembled equations of the unknown pressures (:func:`assemble`)."""

    matrix: sp.csr_matrix
    rhs: np.ndarray
    cells: np.ndarray  #: flat cell index of each unknown


def assemble(faces: Faces, active: np.ndarray) -> LinearSystem:
    """Matrix, right-hand side and flat cell indices of the unknowns.

    Unknowns are the cells where ``active`` is True, in C order; inlet pressure
    1, outlet pressure 0. The matrix is symmetric positive definite when every
    active cell is connected to a reservoir (faces to inactive cells must have
    zero transmissibility).
    """
    cells = np.flatnonzero(active.ravel())
    index = np.full(active.size, -1, dtype=np.int64)
    index[cells] = np.arange(cells.size)
    index = index.reshape(active.shape)
    indptr, indices, data, rhs = _fill_csr(
        index, faces.t_along, faces.t_across, faces.t_in, faces.t_out, cells
    )
    nd = cells.size
    matrix = sp.csr_matrix((data, indices, indptr), shape=(nd, nd))
    matrix.sum_duplicates()  # sorts the rows; n1 == 2 has two faces between the same cells
    return LinearSystem(matrix, rhs, cells)
