"""Reynolds flow through a contact gap: effective conductances sigma_x, sigma_y.

Solves div(sigma grad p) = 0 with sigma = u^3 / (12 eta) (paper Eq. 3-4) on the
cell-centred grid of the gap field (see :mod:`roughflow.flow.assembly` for the
discretisation), with a pressure drop dp = 1 between reservoirs at the two ends
of ``axis`` and periodic boundaries across it. Units: the gap u in L (cell side)
units, eta = 1 by default, so sigma is in L^3 / eta units (paper: u^3 / (12 eta)).

The effective conductance is sigma_eff = Q L_flow / (L_across dp). It is computed
from the dissipation, sum over faces of T (delta p)^2 = Q dp, which is variational
(its error is quadratic in the pressure error) and so about 100x more accurate than
the reservoir flux at the same solver tolerance; the relative difference between
inlet and outlet flux is reported as ``flux_imbalance``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import scipy.sparse as sp

from roughflow._repr import summary_repr
from roughflow.defaults import (
    AXIS_NAMES,
    DROPPED_FLOW_RESOLVE,
    FLOW_CLOSED_BELOW,
    FLOW_LUMP_RATIOS,
    FLOW_SIGMA_RTOL,
    FLOW_TOL,
    FLOW_TOL_MAX,
)
from roughflow.errors import (
    ConvergenceError,
    InputError,
    check_axis,
    plain_array,
    require_cell,
    require_field,
    require_numbers,
    require_positive,
)
from roughflow.percolation import spanning_cells
from roughflow.resources import check_memory, describe
from roughflow.reynolds import cubic_law

from .assembly import Faces, assemble, face_transmissibilities
from .bound import DroppedFlow, WidestTree, dissipation_bounds, dropped_flow, widest_tree
from .ldl import LDLFactor
from .linsolve import (
    RESIDUAL_ROUNDOFF,
    LinearSolution,
    OrderHint,
    check_direct_max_flowing_fraction,
    check_method,
    direct_fits,
    solve_prepared,
    solve_spd,
)
from .linsolve import residual_scale as _residual_scale
from .lump import Lumps, find_lumps, inner_potential, lumped_system

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FlowResult:
    """Reynolds flow along one axis.

    sigma: effective conductance Q L_flow / (L_across dp), units of u^3 / eta (Eq. 4).
    pressure: (nx, ny) pressure, inlet reservoir 1, outlet 0; NaN in cells that
        carry no flow (contact and cells not connected to both reservoirs).
    flux_x, flux_y: (nx, ny) cell-centred flux density -sigma grad p (volume flow
        per unit width per unit dp), the mean of the two face values in each direction.
    residual: relative residual ||b - A p|| / ||b|| of the linear system (<= ``tol``, unless
        ``sigma_tol`` ended the solve first or ``tol`` lies below float64's round-off of
        the residual, :func:`~roughflow.flow.linsolve.attainable_residual`).
    flux_imbalance: |Q_in - Q_out| / Q, a diagnostic of the solve (0 without a solve); the
        solve aims at ``tol`` but stops at round-off, and sigma is checked by its error bound
        (``sigma_error``) whatever the imbalance (docs/flow.md "Flux check").
    imbalance_floor: the |Q_in - Q_out| / Q that float64 round-off alone leaves this
        solution (0 without a solve): an imbalance near it says nothing about sigma.
    sigma_error: sigma's relative error (sigma is an upper bound: Dirichlet's principle).
        An upper bound in both cases: a direct solve bounds it from its residual r with its
        factorisation, the round-off of r allowed for (:func:`_sigma_error`); an AMG
        solve, which has no A^-1, takes the bound from Thomson's principle
        (:mod:`roughflow.flow.bound`). Both allow for the round-off of Q's sums
        (:data:`BOUND_ROUNDOFF`), so no solve reports less than 1e-14. Where the first
        exceeds :data:`DIRECT_BOUND_ABOVE` (r mostly round-off), or ``sigma_tol`` where that
        is larger (:func:`direct_bound_above`), a direct solve reports the smaller of the
        two. 0 without a solve. It includes the bound on the flow through open cells the
        floor below left out (:func:`roughflow.flow.bound.dropped_flow`; where that could
        exceed ``DROPPED_FLOW_RESOLVE`` of sigma, they are solved for too).
    iterations: CG iterations, those spent balancing the fluxes and before a fallback to
        the direct solver included (0 for a direct solve or when no solve was needed).
    percolating: whether the open cells connect the two reservoirs, cells whose u^3 is at
        most ``FLOW_CLOSED_BELOW`` of the largest counted as closed (float64 cannot resolve
        them; docs/flow.md "Unresolved gaps": a warning says when they alone block the flow),
        the largest taken outside the regions lumped (``lumped_cells``) where there are any.
    axis: flow axis (0 = x, 1 = y); method: linear solver used ("none" if none);
    sigma_flux: the boundary-flux estimate of sigma (less accurate, for comparison);
    n_active: number of unknowns (cells connected to both reservoirs);
    lx, ly: the lengths of the periodic cell (the domain) along x and y, units of L.
    ordering: the elimination order of a direct solve's factorisation (None after an
        iterative solve), for the ``ordering`` of the next solve of a similar gap.
    lumped_cells: the cells solved as parts of near-equipotential regions, one unknown each
        (deep dead-end pockets, where a solve could not be certified without: 0 otherwise;
        :mod:`roughflow.flow.lump`, docs/flow.md "Unresolved gaps").
    """

    __repr__ = summary_repr

    sigma: float
    pressure: np.ndarray
    flux_x: np.ndarray
    flux_y: np.ndarray
    residual: float
    flux_imbalance: float
    iterations: int
    percolating: bool
    axis: int = 0
    method: str = "none"
    sigma_flux: float = 0.0
    n_active: int = 0
    imbalance_floor: float = 0.0
    sigma_error: float = 0.0
    lx: float = 1.0
    ly: float = 1.0
    ordering: CellOrdering | None = None
    lumped_cells: int = 0


@dataclass(frozen=True)
class CellOrdering:
    """The order in which a direct flow solve eliminated a gap's cells, for the next solve of a
    similar gap along the same axis (:func:`solve`'s ``ordering``): the next state of a load
    ladder, whose flowing cells are mostly a subset of these. Ordering afresh is 60-90 % of a
    direct solve's time; this order, restricted to the next state's cells, leaves more fill
    (1.05-1.4x along the paper's ladders) but factorises in 0.3-0.8 of the time
    (docs/flow.md "Reusing the ordering along a ladder").

    axis: the flow axis; shape: the gap's shape; rank: (nx * ny,) each cell's place in the
    order, in the frame where the flow runs along axis 0 (C order; -1: not a flowing cell;
    int32 below 2^31 cells, so that a 2048 x 4096 ladder holds 34 MB per axis for it);
    flops: the floating point operations of the factorisation it came from."""

    __repr__ = summary_repr

    axis: int
    shape: tuple[int, int]
    rank: np.ndarray
    flops: float

    def hint(self, cells: np.ndarray) -> OrderHint:
        """The order of the unknowns ``cells`` (flat indices in the flow frame): by their rank,
        cells this order never saw last (their fill is then checked against ``flops``)."""
        keys = self.rank[cells]
        seen = keys >= 0
        # a bucket per rank instead of a sort: O(cells), where argsort took 0.25 s at 2048^2
        by_rank = np.full(int(self.rank.max()) + 1, -1, dtype=np.int64)
        by_rank[keys[seen]] = np.flatnonzero(seen)
        order = np.concatenate([by_rank[by_rank >= 0], np.flatnonzero(~seen)])
        return OrderHint(order, self.flops)

    @classmethod
    def of(cls, factor: LDLFactor, axis: int, shape: tuple[int, int],
           cells: np.ndarray) -> CellOrdering:
        """The order of ``factor``, a factorisation of the unknowns ``cells``."""
        size = shape[0] * shape[1]
        rank = np.full(size, -1, dtype=np.int32 if size < 2**31 else np.int64)
        rank[cells[factor.perm]] = np.arange(cells.size)
        return cls(axis, shape, rank, factor.flops)


def check_ordering(ordering: CellOrdering | None, axis: int,
                   shape: tuple[int, int]) -> CellOrdering | None:
    """``ordering`` for :func:`solve`: None, or a :class:`CellOrdering` of the same axis and
    gap shape; :class:`InputError` otherwise."""
    if ordering is None:
        return None
    if not isinstance(ordering, CellOrdering):
        raise InputError(f"ordering must be a CellOrdering (a FlowResult's) or None, got "
                         f"{type(ordering).__name__}")
    if ordering.axis != axis or tuple(ordering.shape) != tuple(shape):
        raise InputError(f"ordering is of a {ordering.shape} gap along axis {ordering.axis}, "
                         f"not of this {shape} gap along axis {axis}")
    return ordering


@dataclass(frozen=True)
class ReynoldsSystem:
    """The assembled Reynolds system of one gap and axis, in the frame where the flow runs
    along axis 0 (the gap's arrays transposed for flow along y).

    faces: face transmissibilities; active: the cells that carry flow (on the transposed
    grid for axis 1); cells: their flat indices, the unknowns in order; matrix (CSR, SPD)
    and rhs of A p = b (inlet pressure 1, outlet 0); h_flow, h_across: cell sides along and
    across the flow; l_flow, l_across: the domain's lengths.
    """

    faces: Faces
    active: np.ndarray
    cells: np.ndarray
    matrix: sp.csr_matrix
    rhs: np.ndarray
    h_flow: float
    h_across: float
    l_flow: float
    l_across: float


def reynolds_system(sigma_local: np.ndarray, active: np.ndarray, axis: int, *, lx: float,
                    ly: float, periodic: bool = True) -> ReynoldsSystem:
    """Assemble A p = b for flow along ``axis`` (0 or 1) from the local conductivities
    ``sigma_local`` = u^3 / (12 eta) (Eq. 3) and the flowing cells ``active``
    (:func:`flowing_cells`), both on the gap's grid of cell lengths ``lx`` x ``ly``."""
    nx, ny = sigma_local.shape
    hx, hy = lx / nx, ly / ny
    if axis == 0:
        s, act, h_flow, h_across, l_flow, l_across = sigma_local, active, hx, hy, lx, ly
    else:
        s, act, h_flow, h_across, l_flow, l_across = sigma_local.T, active.T, hy, hx, ly, lx
    faces = face_transmissibilities(np.where(act, s, 0.0), h_flow, h_across, periodic=periodic)
    matrix, rhs, cells = assemble(faces, act)
    return ReynoldsSystem(faces, act, cells, matrix, rhs, h_flow, h_across, l_flow,
                          l_across)


#: the smallest largest local conductivity a flow solve takes: the floor
#: (``FLOW_CLOSED_BELOW`` of it) is then a normal float64 number, so are the cells above it
SMALLEST_TOP = float(np.finfo(np.float64).tiny) / FLOW_CLOSED_BELOW


def check_gap(gap: ArrayLike) -> np.ndarray:
    """Return ``gap`` as a float64 2D array, or raise :class:`InputError` (a boolean array
    too: a contact mask passed as the gap flowed as a uniform gap of 1, sigma = 1/12)."""
    raw = require_numbers("gap", plain_array("gap", gap),
                          ": pass the contact state's gap, closed (0) where in contact")
    g = require_field("gap", raw)
    if (g < 0).any():
        idx = tuple(int(i) for i in np.argwhere(g < 0)[0])
        raise InputError(f"gap must be >= 0, got {g[idx]!r} at {idx}")
    return g


def _cell_fluxes(faces: Faces, p: np.ndarray, h_flow: float, h_across: float,
                 lumps: Lumps | None = None):
    """Cell-centred flux densities (along, across) from face values, flow along axis 0; on
    the inner faces of ``lumps``' regions from their
    :func:`~roughflow.flow.lump.inner_potential`."""
    q = np.where(np.isnan(p), 0.0, p)
    # face fluxes: transmissibility * dp (densities: over the face length, below)
    f_along = faces.t_along * (q[:-1] - q[1:])
    f_in = faces.t_in * (1.0 - q[0])
    f_out = faces.t_out * q[-1]
    f_across = faces.t_across * (q - np.roll(q, -1, axis=1))
    if lumps is not None:
        active = ~np.isnan(p)
        phi = inner_potential(faces, active, q, lumps)
        r = lumps.region
        inner = (r[:-1] == r[1:]) & (r[:-1] >= 0)
        f_along = np.where(inner, faces.t_along * (phi[:-1] - phi[1:]), f_along)
        inner = (r == np.roll(r, -1, axis=1)) & (r >= 0)
        f_across = np.where(inner, faces.t_across * (phi - np.roll(phi, -1, axis=1)),
                            f_across)
        node = np.full(p.shape, -1, dtype=np.int64)
        node[active] = lumps.node
        f_in = np.where(node[0] == lumps.n_nodes, -faces.t_in * phi[0], f_in)
        f_out = np.where(node[-1] == lumps.n_nodes + 1, faces.t_out * phi[-1], f_out)
    faces_along = np.concatenate([f_in[None], f_along, f_out[None]], axis=0) / h_across
    j_along = 0.5 * (faces_along[:-1] + faces_along[1:])
    f_across = f_across / h_flow
    j_across = 0.5 * (f_across + np.roll(f_across, 1, axis=1))
    return j_along, j_across


def _dissipation(faces: Faces, q: np.ndarray) -> float:
    """Sum over faces of T (delta p)^2 = Q dp for dp = 1 (flow along axis 0)."""
    return float(
        np.sum(faces.t_along * (q[:-1] - q[1:]) ** 2)
        + np.sum(faces.t_across * (q - np.roll(q, -1, axis=1)) ** 2)
        + np.sum(faces.t_in * (1.0 - q[0]) ** 2)
        + np.sum(faces.t_out * q[-1] ** 2)
    )


@dataclass(frozen=True)
class _Balanced:
    """A solve of the Reynolds system with its flux check: the linear solution, the pressure
    on the grid (0 in inactive cells), the dissipation Q(p), |Q_in - Q_out| / Q(p), what
    round-off leaves of that (:func:`_imbalance_floor`), the dissipation's relative error
    (Q(p) - Q) / Q(p), bounded from above: from the residual for a direct solve
    (:func:`_sigma_error`), by Thomson's principle for an AMG one
    (:func:`_sigma_error_bound`), and a direct solve's factorisation (None otherwise, or where
    it is ``qdldl.Solver``'s, whose order cannot be read)."""

    solution: LinearSolution
    pressure: np.ndarray
    dissipation: float
    imbalance: float
    floor: float
    sigma_error: float
    factor: LDLFactor | None = None

    @property
    def certified(self) -> bool:
        """Whether the dissipation's error is known to be at most :data:`FLOW_SIGMA_RTOL`: the
        only way a solve is accepted. A balance of the fluxes is no such proof: direct solves
        of stripes in series whose u^3 differs by 1e-14 - 1e-16 ended balanced to 1e-4 - 1e-2
        with sigma 3 - 6e8 times the exact one (docs/flow.md "Flux check")."""
        return self.sigma_error <= FLOW_SIGMA_RTOL


class _FluxBalance(NamedTuple):
    """The pressure field of a solution and the fluxes it balances (:func:`_flux_balance`)."""

    pressure: np.ndarray  #: on the grid, 0 in inactive cells
    dissipation: float  #: Q(p)
    imbalance: float  #: |Q_in - Q_out| / Q(p)


def _flux_balance(faces: Faces, act: np.ndarray, cells: np.ndarray,
                  x: np.ndarray) -> _FluxBalance:
    """The :class:`_FluxBalance` of the unknowns ``x``."""
    q = np.zeros(act.shape)
    q.ravel()[cells] = x
    dissipation = _dissipation(faces, q)
    q_in = float(np.sum(faces.t_in * (1.0 - q[0])))
    q_out = float(np.sum(faces.t_out * q[-1]))
    return _FluxBalance(q, dissipation, abs(q_in - q_out) / dissipation)


def _imbalance_floor(scale: np.ndarray, dissipation: float) -> float:
    """The |Q_in - Q_out| / Q that round-off alone leaves a solution x whose residual scale
    (:func:`_residual_scale`) is ``scale``.

    Q_in - Q_out is the sum of the residual b - A x, and each entry of a residual computed in
    float64 carries round-off of about eps (|A| |x| + |b|)_i; their root sum of squares over
    Q. Solves driven to round-off ended at 0.1 - 1.5 of it (128^2 - 2048 x 4096), while the
    RS iterate that met its residual with sigma 2.5 times too large (2048 x 4096, a_c 0.414,
    y) was about 2000 times above it (docs/flow.md "Flux check"). Where it approaches 1 the
    imbalance says nothing: it can end small by chance."""
    return float(np.finfo(np.float64).eps * np.linalg.norm(scale) / dissipation)


def _sigma_error(matrix, rhs, x: np.ndarray, scale: np.ndarray, solve_a,
                 dissipation: float) -> float:
    """An upper bound on the relative error (Q(x) - Q) / Q(x) of the dissipation of ``x``
    from its residual, with ``scale`` its :func:`_residual_scale` and ``solve_a`` applying
    A^-1 (the factorisation).

    The dissipation is the energy x^T A x - 2 b^T x + c, minimal at the solution, so it
    exceeds Q by the energy norm of the error, e^T A e = r*^T A^-1 r* with r* = b - A x
    (exact arithmetic); sigma is Q times a length ratio, so this is sigma's relative error
    too. The float64 residual r differs from r* by at most :data:`RESIDUAL_ROUNDOFF` w
    entrywise, w = |A| |x| + |b|, so |r*| <= (c + 8 eps) w with c = max_i |r_i| / w_i; and
    A^-1 has no negative entry (A is an M-matrix), so r*^T A^-1 r* <= |r*|^T A^-1 |r*| <=
    (c + 8 eps)^2 w^T A^-1 w: one solve with the factorisation. A direct solve ends at
    round-off, where c was 2.4 - 4.7 eps (128^2 bearing gaps up to the last flowing step),
    so this is 1.5 - 2.5 times the same bound with r*^T A^-1 r* split into r^T A^-1 r and
    the round-off's part, which needs a second solve. r^T A^-1 r / Q alone, which direct
    solves reported before, is an estimate that can be low where r is round-off: on a
    1024^2 elastic state near a_c* (floor 1.5e-6) it gave 6.2e-14 where the error is at
    least 1.2e-13, the distance to RS's sigma (docs/flow.md "Conductance estimate").
    :data:`BOUND_ROUNDOFF` covers the round-off of the sum that forms Q(x)."""
    r = rhs - matrix @ x
    open_rows = scale > 0  # where the scale is 0, so are A x and b, and r
    c = float(np.max(np.abs(r[open_rows]) / scale[open_rows], initial=0.0))
    energy = (c + RESIDUAL_ROUNDOFF) ** 2 * abs(float(scale @ solve_a(scale)))
    return energy / dissipation + BOUND_ROUNDOFF


#: the allowance for the round-off of the sums that form Q(x) and the bound, relative: ten
#: times the largest |bound| measured on direct solves at round-off (1.1e-15 over 112 solves,
#: 128^2 - 1024^2, a_c 0.1 up to the last percolating step). The bound sums its terms with
#: compensation and takes the divergence from pressure differences, so no cancellation of
#: order T |x| enters it (docs/flow.md "Error bound"). Both errors a solve reports include it.
BOUND_ROUNDOFF = 1e-14


#: a direct solve whose error bound from its residual (:func:`_sigma_error`) exceeds this
#: also computes Thomson's bound and reports the smaller. Near a_c* A^-1 couples the large
#: w = |A| |x| + |b| of the well-connected cells to the whole cluster, so the residual's
#: bound is loose there: 1.7e-3 at the last flowing step of a 128^2 bearing gap (floor 82),
#: where Thomson's is 7.6e-9, and over 4e-3 on a 1024^2 elastic state (floor 6e-4). Up to
#: 1e-10 Thomson's could not sharpen a number a user reads; near a_c* it costs 5-6 % of a
#: direct solve (docs/flow.md "Conductance estimate")
DIRECT_BOUND_ABOVE = 1e-10


def direct_bound_above(sigma_tol: float | None) -> float:
    """The error from a direct solve's residual above which it also computes Thomson's
    bound: :data:`DIRECT_BOUND_ABOVE`, or the caller's ``sigma_tol`` where that is larger.
    A caller that asked for sigma to ``sigma_tol`` gets an error bound within it either
    way; sharpening it further costs 1.65-1.8 s a solve at 2048^2 (a spanning tree of 6.6
    million faces), and 7 of the 8 direct solves of a 1024^2 elastic ladder that took it
    were within 1e-6 without it (docs/flow.md "Conductance estimate")."""
    return DIRECT_BOUND_ABOVE if sigma_tol is None else max(DIRECT_BOUND_ABOVE, sigma_tol)


def _sigma_error_bound(faces: Faces, act, cells, x: np.ndarray,
                       tree: WidestTree | None = None) -> float:
    """An upper bound on (Q(x) - Q) / Q(x) that needs no A^-1 (Thomson's principle,
    :func:`roughflow.flow.bound.dissipation_bounds`), plus :data:`BOUND_ROUNDOFF`. It was
    1.04 - 8.4 times the exact error on RS iterates with errors from 0.96 down to 1e-8, and
    10 - 115 times on converged RS solves (errors 3e-16 - 2.5e-13; docs/flow.md "Error
    bound")."""
    return dissipation_bounds(faces, act, cells, x, tree).relative_error + BOUND_ROUNDOFF


class _SigmaCertificate:
    """:func:`linsolve.pcg`'s ``certify`` for a target relative error ``target`` of sigma:
    true once Thomson's bound (:func:`_sigma_error_bound`) on the iterate is at most
    ``target``; ``bound`` then holds it.

    The bound costs about a V-cycle and a half (a pass over the faces and a spanning tree),
    so it is taken only where CG's own estimate says it can pass: Q(x) - Q is the energy
    error (x - x*)^T A (x - x*), and a step's energy decrease ``drop`` is the previous
    iterate's error less the new one's, about the previous error where AMG-CG gains a
    decade an iteration. The first check waits for drop <= target Q; a check that fails
    (the bound is 1 - 400 times the exact error on RS iterates) lowers the next one's
    threshold by the factor it missed by."""

    def __init__(self, faces: Faces, act: np.ndarray, cells: np.ndarray, target: float,
                 full=None):
        self.faces, self.act, self.cells, self.target = faces, act, cells, target
        # the pressures of ``cells`` from an iterate's unknowns (a lumped system's fewer)
        self.full = (lambda x: x) if full is None else full
        self.threshold = target
        # Q of an earlier iterate, at least the present one's (CG lowers Q at every step): at
        # first Q(0), the inlet faces' sum, since the run starts from zero (solve_prepared)
        self.dissipation = float(np.sum(faces.t_in))
        self.bound: float | None = None
        self.checks = 0
        # the spanning tree depends on the faces alone: built at the first check, kept for
        # the next (the 14 RS solves of a 1024 x 2048 gamma 2 ladder took 26 bounds; the
        # tree is about 80 % of a bound's time, docs/flow.md "Error bound")
        self.tree: WidestTree | None = None

    def __call__(self, x: np.ndarray, drop: float) -> bool:
        if drop > self.threshold * self.dissipation:  # no pass over the faces needed
            return False
        x = self.full(x)
        self.dissipation = _flux_balance(self.faces, self.act, self.cells, x).dissipation
        if drop > self.threshold * self.dissipation:
            return False
        if self.tree is None:
            self.tree = widest_tree(self.faces, self.act, self.cells)
        bound = _sigma_error_bound(self.faces, self.act, self.cells, x, self.tree)
        self.checks += 1
        if bound <= self.target:
            self.bound = bound
            return True
        self.threshold = drop / self.dissipation * self.target / bound
        return False


def _solve_flux_balanced(matrix, rhs, cells, act, faces: Faces, *, tol: float, method: str,
                         sigma_tol: float | None = None,
                         direct_max_flowing_fraction: float | None = None,
                         hint: OrderHint | None = None, rounds: int = 4,
                         lumps: Lumps | None = None) -> _Balanced:
    """Solve to ||b - A x|| <= tol ||b|| (else :class:`ConvergenceError`) and on until the
    flux imbalance |Q_in - Q_out| / Q is at most ``tol``, or round-off stops the solver.

    Near a_c* the flux through the last constriction is many decades below ||b|| (which
    the well-connected reservoir cells dominate), so the first criterion alone can leave
    |Q_in - Q_out| / Q = 2e-4 with RS-AMG and a negative outlet flux with SA-AMG
    (tests/test_stress_pipeline.py), and RS on the paper config's largest grid met it with
    an imbalance of 1.0 and sigma 2.5 times too large. An iterative solve goes on in one CG
    run (:func:`linsolve.pcg`) until the fluxes balance; a direct one refines, each round
    tightening the relative residual by the missing factor, while the residual still falls
    (the reservoir fluxes are differences 1 - p of order Q / T, so their round-off is
    eps T / Q). sigma comes from the dissipation, whose error is quadratic in the pressure
    error. Each solve returns an upper bound on that error: a direct one from its residual
    (:func:`_sigma_error`; one more solve with the factorisation, 1-4 % of a direct solve),
    an AMG one from Thomson's principle (:func:`_sigma_error_bound`; 6-9 % of an RS solve).
    With ``sigma_tol``, an iterative solve also stops at the first iterate whose bound is at
    most ``sigma_tol`` (:class:`_SigmaCertificate`), whatever its residual and imbalance,
    and a direct one takes Thomson's bound only beyond it (:func:`direct_bound_above`).
    ``direct_max_flowing_fraction``: see :func:`linsolve.choose`; ``hint``: the direct
    solver's elimination order (:func:`linsolve.prepare`). ``lumps``: where the system is
    lumped (:mod:`roughflow.flow.lump`), its unknowns; the error is then Thomson's bound on
    the full system, which covers the lumping too.
    """
    def full(x: np.ndarray) -> np.ndarray:  # the pressures of ``cells``
        return x if lumps is None else lumps.pressures(x)

    # not also "within _imbalance_floor": near a_c* that stopped RS with sigma 3e-4 off where
    # going on to round-off gave 1e-8 (1024^2, a_c 0.44, y)
    def balanced(x: np.ndarray) -> bool:
        return _flux_balance(faces, act, cells, full(x)).imbalance <= tol

    # one factorisation for every refinement round: near a_c* it costs as much as a round
    certificate = (None if sigma_tol is None
                   else _SigmaCertificate(faces, act, cells, sigma_tol, full))
    sol, prepared = solve_prepared(matrix, rhs, tol=tol, method=method, accept=balanced,
                                   certify=certificate, flowing_fraction=cells.size / act.size,
                                   direct_max_flowing_fraction=direct_max_flowing_fraction,
                                   hint=hint)
    q, dissipation, imbalance = _flux_balance(faces, act, cells, full(sol.x))
    for _round in range(rounds if prepared.factor is not None else 0):
        if imbalance <= tol:
            break
        rel = max(sol.residual * 0.25 * tol / imbalance, 1e-16)
        better = solve_spd(matrix, rhs, tol=rel, x0=sol.x, strict=False, prepared=prepared)
        if not better.residual < 0.5 * sol.residual:  # stalled at round-off
            break
        sol = replace(better, iterations=sol.iterations)
        q, dissipation, imbalance = _flux_balance(faces, act, cells, full(sol.x))
    scale = _residual_scale(matrix, rhs, sol.x)
    floor = _imbalance_floor(scale, dissipation)
    if lumps is not None:  # the residual's bound is the lumped system's alone
        error = (certificate.bound if sol.certified
                 else _sigma_error_bound(faces, act, cells, full(sol.x),
                                         None if certificate is None else certificate.tree))
    elif prepared.factor is not None:
        error = _sigma_error(matrix, rhs, sol.x, scale, prepared.factor.solve, dissipation)
        if error > direct_bound_above(sigma_tol):
            # where r is mostly round-off its allowance dominates; the bound does not use r
            error = min(error, _sigma_error_bound(faces, act, cells, sol.x))
    elif sol.certified:
        error = certificate.bound  # of this very iterate: the run ended on it
    else:
        error = _sigma_error_bound(faces, act, cells, sol.x,
                                   None if certificate is None else certificate.tree)
    factor = (prepared.factor if isinstance(prepared.factor, LDLFactor) and lumps is None
              else None)
    return _Balanced(sol, q, dissipation, imbalance, floor, error, factor)


def _uncertified(balanced: _Balanced) -> str:
    return (f"Reynolds solve ({balanced.solution.method}) ended with |Q_in - Q_out| / Q = "
            f"{balanced.imbalance:.2g} (round-off leaves {balanced.floor:.2g} of it) and "
            f"sigma's error bound {balanced.sigma_error:.2g} > {FLOW_SIGMA_RTOL:g}")


def _balanced_solution(matrix, rhs, cells, act, faces: Faces, *, tol: float,
                       method: str, sigma_tol: float | None = None,
                       direct_max_flowing_fraction: float | None = None,
                       hint: OrderHint | None = None,
                       lumps: Lumps | None = None) -> _Balanced:
    """:func:`_solve_flux_balanced`, checked where sigma's error is not certified to
    :data:`FLOW_SIGMA_RTOL`.

    Near a_c* the flux is many decades below ||b||, so the residual norm cannot tell a solve
    that missed the flux through the last constriction: an RS solve on the paper config's
    largest grid (a_c 0.414, y) met its residual with |Q_in - Q_out| / Q = 1.0 and a sigma
    2.5 times the direct solve's. The flux imbalance cannot tell it either, since solves at
    round-off end there too (every solver at the last percolating step of a bearing gap:
    3e-2, with sigma equal to 8e-12; docs/flow.md "Flux check"). The error of sigma can: each
    solve has an upper bound on it (:func:`_solve_flux_balanced`).
    A solve so certified is returned. Otherwise, with ``method="auto"``, the direct solver
    solves again where its factorisation fits; a direct solve that is not certified, and an
    AMG solve that cannot be checked so (an explicit iterative method, or no memory for the
    factorisation), raise :class:`ConvergenceError`. Neither a balance of the fluxes nor an
    imbalance within round-off tells sigma: on stripes in series whose u^3 differs by 1e-14
    - 1e-16, CG, RS and SA returned sigma 2 - 1e8 times the exact one so, and direct solves
    balanced to 1e-2 up to 6e8 times (docs/flow.md "Flux check").
    """
    first = _solve_flux_balanced(matrix, rhs, cells, act, faces, tol=tol, method=method,
                                 sigma_tol=sigma_tol,
                                 direct_max_flowing_fraction=direct_max_flowing_fraction,
                                 hint=hint, lumps=lumps)
    if first.certified:
        return first
    if first.solution.method != "direct":
        why = f"method={method!r}; 'auto' or 'direct' would check it"
        if method == "auto":
            fits, need, have = direct_fits(matrix.shape[0])
            why = "" if fits else (f"its factorisation would need about {describe(need)} more "
                                   f"memory than the {describe(have)} available")
        if why:
            sol = first.solution
            raise ConvergenceError(
                f"{_uncertified(first)} after {sol.iterations} CG iterations: its sigma is not "
                f"certified and can be wrong (no direct solve to check it: {why}; "
                f"docs/flow.md \"Flux check\")",
                residual=sol.residual, iterations=sol.iterations)
        log.warning("%s; checking with the direct solver (%d unknowns)", _uncertified(first),
                    matrix.shape[0])
        again = _solve_flux_balanced(matrix, rhs, cells, act, faces, tol=tol, method="direct",
                                     hint=hint, lumps=lumps)
        first = replace(again, solution=replace(
            again.solution, iterations=again.solution.iterations + first.solution.iterations))
        if first.certified:
            return first
    sol = first.solution
    raise ConvergenceError(
        f"{_uncertified(first)}: its dissipation is uncertain by more than {FLOW_SIGMA_RTOL:g} "
        f"relative (float64 cannot resolve this gap's flow, docs/flow.md \"Unresolved gaps\")",
        residual=sol.residual, iterations=sol.iterations)


def _largest_face(sigma: np.ndarray, axis: int, periodic: bool) -> float:
    """The largest harmonic mean 2 s1 s2 / (s1 + s2) of ``sigma`` over the faces that
    :func:`~roughflow.flow.assembly.face_transmissibilities` makes for flow along ``axis``
    (unit cell lengths: the conductances without their geometry)."""
    faces = face_transmissibilities(sigma if axis == 0 else sigma.T, 1.0, 1.0,
                                    periodic=periodic)
    return float(max(faces.t_along.max(initial=0.0), faces.t_across.max(initial=0.0)))


def flowing_cells(sigma_local: np.ndarray, axis: int, *, periodic: bool = True) -> np.ndarray:
    """The cells that carry flow along ``axis`` (0 or 1): open (u^3 > 0), above
    ``FLOW_CLOSED_BELOW`` of the largest face conductance among the cells that connect the
    two reservoirs (:func:`_largest_face`), and still connecting them."""
    # a gap so small that u^3 underflows is closed
    active = spanning_cells(sigma_local > 0, axis, periodic=periodic)
    if active.any():
        # so is one below float64's resolution of the largest conductance that carries
        # flow (pools that carry none must not move the floor): that of a face, the
        # harmonic mean of its two cells, since a single deep cell (a pit, a scan's
        # dropout) conducts no more than its neighbours let it (one pit 3e5 times the gap
        # around it closed every other cell and gave sigma = 0 for an open channel)
        top = _largest_face(np.where(active, sigma_local, 0.0), axis, periodic)
        active = _above_floor(sigma_local, active, top, axis, periodic)
    return active


def _above_floor(sigma_local: np.ndarray, active: np.ndarray, top: float, axis: int,
                 periodic: bool, keep: np.ndarray | None = None) -> np.ndarray:
    """The cells of ``active`` whose u^3 exceeds ``FLOW_CLOSED_BELOW`` of ``top`` (or that
    ``keep`` holds), and that still connect the reservoirs."""
    unresolved = active & (sigma_local <= FLOW_CLOSED_BELOW * top)
    if keep is not None:
        unresolved &= ~keep
    if unresolved.any():
        active = spanning_cells(active & ~unresolved, axis, periodic=periodic)
    return active


def _closed_by_floor(axis: int) -> None:
    log.warning(
        "flow along %s: every open path runs through a gap below %.2g of the largest (u^3 "
        "below %g of it), which float64 cannot resolve beside it: sigma is reported 0 and "
        "the gap as not percolating (docs/flow.md, 'Unresolved gaps')", AXIS_NAMES[axis],
        FLOW_CLOSED_BELOW ** (1 / 3), FLOW_CLOSED_BELOW)


def check_sigma_tol(sigma_tol: float | None) -> float | None:
    """``sigma_tol`` of :func:`solve`, checked: None, or in (0, ``FLOW_SIGMA_RTOL``] (a looser
    sigma would not pass as certified, and the direct solver would check it again)."""
    if sigma_tol is None:
        return None
    x = require_positive("sigma_tol", sigma_tol)
    if x > FLOW_SIGMA_RTOL:
        raise InputError(f"sigma_tol must be at most {FLOW_SIGMA_RTOL:g}, got {sigma_tol!r}")
    return x


def solve(
    gap: ArrayLike,
    axis: int | str,
    *,
    lx: float = 1.0,
    ly: float | None = None,
    eta: float = 1.0,
    tol: float = FLOW_TOL,
    method: str | None = None,
    periodic: bool = True,
    sigma_tol: float | None = None,
    direct_max_flowing_fraction: float | None = None,
    ordering: CellOrdering | None = None,
) -> FlowResult:
    """Reynolds flow along ``axis`` (0/"x" or 1/"y") through the gap field ``gap[ix, iy]``.

    ``lx``, ``ly``: cell lengths (``ly`` may be left out on a square grid only:
    :func:`roughflow.errors.require_cell`); ``eta``: viscosity;
    ``tol``: relative residual of the linear solve, at most ``FLOW_TOL_MAX`` (refined
    further, down to round-off, until |Q_in - Q_out| / Q <= ``tol``); ``method``: None/"auto"
    (direct up to 70k unknowns or where at most 3/4 of the cells carry flow, else "rs"),
    "rs", "sa", "direct" or "cg" (see :mod:`roughflow.flow.linsolve`). Open cells are
    those whose u^3 exceeds ``FLOW_CLOSED_BELOW`` (1e-16, :mod:`roughflow.defaults`) of the
    largest among the cells that connect the reservoirs; a gap whose open cells do not
    connect the two reservoirs gives sigma = 0 without a solve.
    ``periodic``: the cell is periodic across the flow (default), or closed by walls there
    (False: a non-periodic scan).
    ``sigma_tol``: where given (at most ``FLOW_SIGMA_RTOL``), an iterative solve also ends at
    the first iterate whose sigma is proven accurate to ``sigma_tol`` relative (Thomson's
    bound), whatever its residual and flux balance: sigma needs far fewer iterations than
    the pressure field (its error is quadratic in the pressure's). The sweeps and ``leak``
    use ``FLOW_SIGMA_TOL``; None (default): solve to ``tol`` as above. A direct solve whose
    error from its residual is within ``sigma_tol`` reports that error instead of
    sharpening it with Thomson's bound (:func:`direct_bound_above`).
    ``direct_max_flowing_fraction``: the largest share of the cells carrying flow at which
    ``auto`` takes the direct solver beyond 70k unknowns (None: 0.75). On isotropic
    bearing-model gaps RS was faster at every share measured, so 0 suits them; on elastic
    gaps and anisotropic (gamma 2) bearing gaps of the paper's sizes the default is as fast
    or faster (docs/flow.md "Since sigma_tol").
    ``ordering``: the ``ordering`` of an earlier result along the same axis on a gap of the
    same shape, whose order a direct solve here takes for the cells both share instead of
    ordering afresh (the next state of a load ladder: 0.3-0.75 of the factorisation's time;
    it falls back to a fresh order where cells the old one never saw would make it costlier
    than the factorisation it came from). sigma is the same to round-off either way.
    The solve runs in units of a power of two of the largest u^3 / (12 eta): scale-free
    (uniform gaps of 1e-96 - 1e100 give u^3 / (12 eta) to 2e-15), and, the scaling being
    exact, the same bit for bit as an unscaled solve wherever that neither under- nor
    overflowed.
    Where a solve is not certified, or the floor closes every open path, regions whose inside
    conducts ``FLOW_LUMP_RATIOS`` times more than any face out of them (deep dead-end
    pockets, open stripes between closed ones) are solved as one unknown each (or at the
    pressure of a reservoir they reach), the floor scaled by the faces outside them, and
    certified the same way (:mod:`roughflow.flow.lump`; ``lumped_cells`` counts them).
    Raises ``InputError`` for bad input (a boolean gap, a contact mask passed by mistake,
    included; and a largest u^3 / (12 eta) that overflows float64 or lies below
    :data:`SMALLEST_TOP`) and ``ConvergenceError`` if the solver misses ``tol``, or where
    sigma's error is not certified to ``FLOW_SIGMA_RTOL`` (after a direct solve, for
    ``auto``, where its factorisation fits).
    """
    g = check_gap(gap)
    ax = check_axis(axis)
    if not isinstance(periodic, (bool, np.bool_)):  # a string such as "no" is truthy
        raise InputError(f"periodic must be True or False, got {periodic!r}")
    lx, ly = require_cell(lx, ly, g.shape)
    eta = require_positive("eta", eta)
    tol = require_positive("tol", tol)
    if tol > FLOW_TOL_MAX:
        raise InputError(f"tol must be at most {FLOW_TOL_MAX:g} (a looser solve does not balance "
                         f"the inlet and outlet fluxes), got {tol!r}")
    method = check_method(method)
    sigma_tol = check_sigma_tol(sigma_tol)
    direct_max_flowing_fraction = check_direct_max_flowing_fraction(direct_max_flowing_fraction)
    ordering = check_ordering(ordering, ax, g.shape)
    check_memory("flow", g.shape, what="a Reynolds flow solve")

    sigma_local = cubic_law(g, eta)
    top = float(sigma_local.max())
    # an infinite cell would close every other one below the floor (sigma 0, measured)
    if not np.isfinite(top):
        raise InputError(f"the local conductivity u^3 / (12 eta) overflows float64: largest "
                         f"gap {float(g.max())!r} (units of L), eta {eta!r}")
    if top < SMALLEST_TOP and g.max() > 0:  # not all contact, or u^3 underflows to 0
        raise InputError(
            f"the local conductivity u^3 / (12 eta) underflows float64: largest gap "
            f"{float(g.max())!r} (units of L) and eta {eta!r} give at most {top:.3g}, below "
            f"{SMALLEST_TOP:.3g}, where cells down to {FLOW_CLOSED_BELOW:g} of it are no "
            f"normal float64 numbers (give the gap in larger units)")
    # solve in units of a power of two of the largest conductivity: scale-free (squares of
    # u^3 ~ 1e-180 underflowed, of 1e180 overflowed: uniform gaps of 1e-60 and 1e60 failed),
    # and exact, so that every number of a solve is the same as unscaled where that did not
    # under- or overflow
    unit = int(np.frexp(top)[1])
    sigma_local = np.ldexp(sigma_local, -unit, out=sigma_local)
    active = flowing_cells(sigma_local, ax, periodic=periodic)
    s_frame = sigma_local if ax == 0 else sigma_local.T  # flow along axis 0

    def attempt(active: np.ndarray, lumps: Lumps | None = None
                ) -> tuple[FlowResult, DroppedFlow, float]:
        system = reynolds_system(sigma_local, active, ax, lx=lx, ly=ly, periodic=periodic)
        faces, act, cells, matrix, rhs = (system.faces, system.active, system.cells,
                                          system.matrix, system.rhs)
        h_flow, h_across = system.h_flow, system.h_across
        if lumps is not None:
            matrix, rhs = lumped_system(faces, act, cells, lumps)
            log.info("flow along %s: %d cells in %d near-equipotential regions, each solved as "
                     "one unknown or at its reservoir's pressure (docs/flow.md, 'Unresolved "
                     "gaps')", AXIS_NAMES[ax], int(lumps.lumped.sum()), lumps.n_regions)
        balanced = _balanced_solution(matrix, rhs, cells, act, faces, tol=tol, method=method,
                                      sigma_tol=sigma_tol,
                                      direct_max_flowing_fraction=direct_max_flowing_fraction,
                                      hint=(None if ordering is None or lumps is not None
                                            else ordering.hint(cells)),
                                      lumps=lumps)
        sol, q, dissipation = balanced.solution, balanced.pressure, balanced.dissipation
        p = np.full(act.shape, np.nan)
        p.ravel()[cells] = sol.x if lumps is None else lumps.pressures(sol.x)
        # the flow the floor left out, bounded from the solved pressures
        dropped = dropped_flow(s_frame, act, np.where(act, p, 0.0), h_flow, h_across,
                               periodic=periodic)
        share = dropped.total / dissipation if dissipation > 0 else 0.0
        q_in = float(np.sum(faces.t_in * (1.0 - q[0])))
        q_out = float(np.sum(faces.t_out * q[-1]))
        q_mean = 0.5 * (q_in + q_out)
        scale = system.l_flow / system.l_across
        j_along, j_across = (np.ldexp(j, unit)
                             for j in _cell_fluxes(faces, p, h_flow, h_across, lumps))
        if ax == 0:
            pressure, fx, fy = p, j_along, j_across
        else:
            pressure, fx, fy = p.T.copy(), j_across.T.copy(), j_along.T.copy()
        result = FlowResult(
            sigma=float(np.ldexp(dissipation * scale, unit)),
            pressure=pressure,
            flux_x=fx,
            flux_y=fy,
            residual=sol.residual,
            flux_imbalance=balanced.imbalance,
            iterations=sol.iterations,
            percolating=True,
            axis=ax,
            method=sol.method,
            sigma_flux=float(np.ldexp(q_mean * scale, unit)),
            n_active=int(cells.size),
            imbalance_floor=balanced.floor,
            sigma_error=balanced.sigma_error + share,
            lx=lx,
            ly=ly,
            ordering=(None if balanced.factor is None
                      else CellOrdering.of(balanced.factor, ax, g.shape, cells)),
            lumped_cells=0 if lumps is None else int(lumps.lumped.sum()),
        )
        return result, dropped, share

    def unit_faces(active: np.ndarray) -> tuple[np.ndarray, Faces]:
        # the cells in the flow's frame and their faces by the conductances alone (unit cell
        # lengths), as the floor takes them
        frame = active if ax == 0 else active.T
        return frame, face_transmissibilities(np.where(frame, s_frame, 0.0), 1.0, 1.0,
                                              periodic=periodic)

    def lumps_of(active: np.ndarray, ratio: float) -> Lumps | None:
        frame, faces = unit_faces(active)
        return find_lumps(faces, frame, np.flatnonzero(frame.ravel()), ratio=ratio)

    def solved(active: np.ndarray, ratio: float | None = None) -> FlowResult:
        """The certified solve on ``active`` (lumped at ``ratio``, where given), repeated with
        the open cells below the floor that may carry flow; else :class:`ConvergenceError`."""
        lumps = None if ratio is None else lumps_of(active, ratio)
        result, dropped, share = attempt(active, lumps)
        if share <= DROPPED_FLOW_RESOLVE:
            return result
        # cells below the floor that carry flow (a deep pocket elsewhere set the floor's
        # scale): solve again with the regions that matter, and certify or raise
        regions = _regions_that_matter(dropped, share)
        if ax == 1:
            regions = regions.T
        log.info("flow along %s: open cells below the unresolved-gap floor carry up to %.2g "
                 "of sigma; solving again with %d of them", AXIS_NAMES[ax], share,
                 int(regions.sum()))
        active = spanning_cells(active | regions, ax, periodic=periodic)
        lumps = None if ratio is None else lumps_of(active, ratio)
        result, dropped, share = attempt(active, lumps)
        if result.sigma_error > FLOW_SIGMA_RTOL:
            raise ConvergenceError(
                f"Reynolds solve along {AXIS_NAMES[ax]}: sigma's error bound "
                f"{result.sigma_error:.2g} > {FLOW_SIGMA_RTOL:g} with the open cells below "
                f"the unresolved-gap floor (they carry up to {share:.2g} of sigma) taken in; "
                "float64 cannot resolve this gap's flow (docs/flow.md, 'Unresolved gaps')",
                residual=result.sigma_error, iterations=result.iterations)
        return result

    def lumped(open_cells: np.ndarray) -> FlowResult | None:
        """The solve on the open cells that connect the reservoirs, ``open_cells``, with
        near-equipotential regions lumped (:mod:`roughflow.flow.lump`) at the first of
        ``FLOW_LUMP_RATIOS`` that certifies it, the floor's scale taken from the faces outside
        them; None where there are no regions, the last :class:`ConvergenceError` where none
        certifies."""
        frame, faces = unit_faces(open_cells)
        cells = np.flatnonzero(frame.ravel())
        failed = None
        for ratio in FLOW_LUMP_RATIOS:
            lumps = find_lumps(faces, frame, cells, ratio=ratio)
            if lumps is None:
                continue
            keep = lumps.lumped if ax == 0 else lumps.lumped.T
            cells_on = _above_floor(sigma_local, open_cells, lumps.largest_face_outside(faces),
                                    ax, periodic, keep=keep)
            if not cells_on.any():
                continue
            try:
                return solved(cells_on, ratio)
            except ConvergenceError as exc:
                failed = exc
        if failed is not None:
            raise failed
        return None

    if not active.any():
        # (the open cells are found again only off the common path, where it is needed)
        open_cells = spanning_cells(sigma_local > 0, ax, periodic=periodic)
        if open_cells.any():
            # the floor closed every open path: deep regions may have set its scale
            result = lumped(open_cells)
            if result is not None:
                return result
            _closed_by_floor(ax)
        nan = np.full(g.shape, np.nan)
        zeros = np.zeros(g.shape)
        return FlowResult(0.0, nan, zeros, zeros.copy(), 0.0, 0.0, 0, False, ax,
                          lx=lx, ly=ly)
    try:
        return solved(active)
    except ConvergenceError as exc:
        failed = exc.with_traceback(None)  # its frames would keep the factorisation alive
    # float64 could not resolve the flow: where near-equipotential regions (deep pockets)
    # are the cause, lumping them resolves it
    try:
        again = lumped(spanning_cells(sigma_local > 0, ax, periodic=periodic))
    except ConvergenceError:
        raise failed from None
    if again is None:
        raise failed
    log.info("flow along %s: %s; solved with near-equipotential regions lumped",
             AXIS_NAMES[ax], failed)
    return again


def _regions_that_matter(dropped: DroppedFlow, share: float) -> np.ndarray:
    """The cells of the left-out regions to take into the next solve (flow along axis 0):
    those of largest bound, until the regions left bound a tenth of
    :data:`DROPPED_FLOW_RESOLVE` of sigma."""
    order = np.argsort(dropped.bound)[::-1]
    left = dropped.total - np.cumsum(dropped.bound[order])
    take = order[:int(np.searchsorted(-left, -0.1 * DROPPED_FLOW_RESOLVE
                                      * dropped.total / share)) + 1]
    matters = np.zeros(dropped.bound.size, dtype=bool)
    matters[take] = True
    matters[0] = False
    return matters[dropped.labels]


class Conductances(NamedTuple):
    """sigma_x and sigma_y of one gap (units L^3/eta), as :func:`conductance` returns them for
    ``axis=None``; unpacks as ``sx, sy = ...``."""

    sigma_x: float
    sigma_y: float


def conductance(
    gap: ArrayLike,
    axis: int | str | None = None,
    *,
    lx: float = 1.0,
    ly: float | None = None,
    eta: float = 1.0,
    tol: float = FLOW_TOL,
    method: str | None = None,
    periodic: bool = True,
    sigma_tol: float | None = None,
) -> float | Conductances:
    """Effective conductance sigma along ``axis`` (0/"x" or 1/"y"), or
    :class:`Conductances` (sigma_x, sigma_y) when ``axis`` is None: the flow per unit width
    across the flow per unit pressure gradient, in units of L^3 / eta (local conductivity
    u^3 / (12 eta)). ``gap[ix, iy]``: the gap field in units of L; ``lx``, ``ly``: cell
    lengths; ``eta``: viscosity. The other arguments are :func:`solve`'s, which returns
    the pressure and flux fields and the solver's diagnostics too."""
    kw = dict(lx=lx, ly=ly, eta=eta, tol=tol, method=method, periodic=periodic,
              sigma_tol=sigma_tol)
    if axis is None:
        return Conductances(solve(gap, 0, **kw).sigma, solve(gap, 1, **kw).sigma)
    return solve(gap, axis, **kw).sigma
