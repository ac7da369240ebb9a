"""Sparse SPD solvers for the Reynolds system: AMG-preconditioned CG or a direct solve.

The relative residual is ||b - A x|| / ||b|| of the unscaled system. The system is not
diagonally scaled: D^-1/2 A D^-1/2 changes the classical strength of connection, and
RS-AMG then needs about 160 instead of about 8 CG iterations on bearing gaps at n = 512,
for no gain in the accuracy of sigma. Since sigma is computed from
the dissipation, its relative error is of order (residual)^2 times the condition
factor: at 1e-8 it is about 1e-11 on bearing gaps.

Methods (chosen by measurement, see ``benchmarks/bench_flow.py`` and docs/flow.md):

- ``"rs"``: CG preconditioned by one V-cycle of classical Ruge-Stueben AMG with
  second-pass coarsening and one Gauss-Seidel sweep before and after each coarse-grid
  correction (:mod:`roughflow.flow.amg`); the default where most cells carry flow.
- ``"sa"``: CG preconditioned by smoothed-aggregation AMG.
- ``"direct"``: sparse Cholesky-type LDL^T factorisation (QDLDL, approximate minimum
  degree ordering, or an order the caller passes: :mod:`roughflow.flow.ldl`; no pivoting
  is needed for this SPD M-matrix); the default for small systems and for thin flowing
  clusters, near a_c*, where its fill is small.
- ``"cg"``: CG without preconditioner (benchmark reference; slow: on contact gaps of
  128^2 - 256^2 it misses the default tol within its 20,000 iterations and raises).

``"auto"`` (:func:`choose`) takes the direct solver up to :data:`DIRECT_MAX_UNKNOWNS`
unknowns, and beyond where the flowing cells are at most
:data:`DIRECT_MAX_FLOWING_FRACTION` of the grid (or the caller's
``direct_max_flowing_fraction``) and the factorisation fits in memory; otherwise RS. An RS
solve that does not converge is retried by the direct solver where it fits
(:func:`solve_prepared`): near a_c*, on the paper config's largest grids, RS-CG can stall
on conductivities that span 16 decades (docs/flow.md "Direct solver").

The iterative methods run :func:`pcg`, which a caller can keep going past ``tol`` until its
own test accepts the iterate (:mod:`roughflow.flow.core` balances the reservoir fluxes so),
or end early once its own test certifies the iterate (a proven bound on sigma's error).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np
import qdldl
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from roughflow.defaults import FLOW_METHOD
from roughflow.defaults import FLOW_METHODS as METHODS
from roughflow.errors import ConvergenceError, InputError, require_finite
from roughflow.flow import amg, ldl
from roughflow.resources import FLOW_LDL_BYTES_PER_UNKNOWN, describe, headroom_bytes

log = logging.getLogger(__name__)

#: up to this many unknowns ``"auto"`` uses the direct solver: 0.4-1.6x RS's time there
#: (the most with every cell open; tens of milliseconds), and no iteration that could stall
#: (docs/flow.md "Direct solver")
DIRECT_MAX_UNKNOWNS = 70_000
#: beyond it, ``"auto"`` uses the direct solver where the unknowns (the cells that carry
#: flow) are at most this fraction of the grid's cells, if the factorisation fits in memory.
#: On elastic gaps it took 0.74-1.03x the time of RS stopped at ``FLOW_SIGMA_TOL`` there at
#: 2048^2 (0.86-1.23x at 512^2-1024^2, a few tenths of a second either way) and 0.09-1.33x
#: RS to ``tol`` at 2048 x 4096, where RS stalls near a_c*; 1.3-1.9x at fractions 0.8-0.85
#: and up to 10x with every cell open. On isotropic bearing gaps RS was the faster at every
#: fraction measured, on anisotropic ones (gamma 2, 2048 x 4096) mostly not: the ladders keep
#: this limit for every model (docs/flow.md "Direct solver", ``benchmarks/bench_direct.py``)
DIRECT_MAX_FLOWING_FRACTION = 0.75
MAX_ITER_AMG = 500
#: AMG-CG iterations after which ``"auto"`` retries with the direct solver (where its
#: factorisation fits; :func:`solve_prepared`). First solves that converged took at most
#: 98 (near a_c* on the paper config's 2048 x 4096 grid; 8-15 elsewhere), and the stalls
#: measured there ran the full 500 to residuals of 1e-5 - 1e-7 (docs/flow.md "Direct fallback").
AMG_ITER_BEFORE_FALLBACK = 200
MAX_ITER_CG = 20_000
#: a CG run whose recursive residual has fallen this far below the true one is at round-off:
#: its iterates no longer move (at the last percolating step of a 128^2 bearing gap the true
#: residual stays at 2e-14 from iteration 14 while the recursive one falls two decades every
#: two iterations, docs/flow.md "Flux balance near a_c*")
DRIFT_AT_ROUNDOFF = 1e-2


@dataclass(frozen=True)
class LinearSolution:
    """A solve of A x = b: the solution, its relative residual, the CG iterations taken
    (0 for a direct solve) and the method; ``certified``: an iterative solve that its
    caller's ``certify`` ended before the residual met ``tol`` (:func:`pcg`)."""

    x: np.ndarray
    residual: float
    iterations: int
    method: str
    certified: bool = False


@dataclass(frozen=True)
class CGRun:
    """What :func:`pcg` returns: the last iterate, the iterations taken, and whether
    ``certify`` accepted that iterate (the run ended there)."""

    x: np.ndarray
    iterations: int
    certified: bool = False


@dataclass(frozen=True)
class OrderHint:
    """An elimination order for a direct solve (a permutation of the unknowns), and the
    floating point operations above which the solve orders afresh instead (those of the
    factorisation the order came from: on a subset of its unknowns an order cannot need
    more, so exceeding them means unknowns it never saw got in its way)."""

    order: np.ndarray
    max_flops: float


@dataclass(frozen=True)
class Prepared:
    """What a solve of one matrix builds before it iterates, kept for further solves of the
    same matrix (the flux-balance refinement of :mod:`roughflow.flow.core` solves it up to
    five times): the LDL^T factorisation of ``"direct"`` (:class:`ldl.LDLFactor`; a
    ``qdldl.Solver`` where :func:`ldl.available` is False) or the AMG preconditioner of
    ``"rs"`` and ``"sa"`` (None for ``"cg"``). Built by :func:`prepare`."""

    method: str
    factor: ldl.LDLFactor | qdldl.Solver | None = None
    preconditioner: spla.LinearOperator | None = None


def check_method(method: str | None) -> str:
    m = FLOW_METHOD if method is None else method
    if m not in METHODS:
        raise InputError(f"method must be one of {METHODS} or None, got {method!r}")
    return m


#: how pyamg's smoothed aggregation smooths its tentative prolongator: Jacobi with each row
#: weighted by its Gershgorin bound ("local") instead of by one spectral-radius estimate of
#: D^-1 A ("diagonal", pyamg's default), which starts from ``np.random.rand``: a draw from
#: numpy's global stream, which another thread may be using (unseeded, sigma differed at
#: 1e-16 from solve to solve). Deterministic without touching that stream; on bearing gaps
#: (256^2 and 512^2, a_c 0.1-0.45) it took 12 fewer to 4 more CG iterations (of 25-93) in
#: as much time, and sigma moved by at most 2e-12 (docs/flow.md)
SA_SMOOTH = ("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"})


def _amg_preconditioner(a: sp.csr_matrix, method: str) -> spla.LinearOperator:
    if method == "rs":
        return amg.rs_vcycle(amg.rs_hierarchy(a))
    import pyamg

    ml = pyamg.smoothed_aggregation_solver(a, max_coarse=amg.MAX_COARSE,
                                           coarse_solver="splu", smooth=SA_SMOOTH)
    return ml.aspreconditioner(cycle="V")


class DirectFit(NamedTuple):
    """Whether a direct factorisation fits in memory, the bytes it needs and those available
    (None: unknown, taken as fitting)."""

    fits: bool
    need: int
    have: int | None


def direct_fits(n: int) -> DirectFit:
    """Whether the direct factorisation of ``n`` unknowns fits beside what this process
    holds (``FLOW_LDL_BYTES_PER_UNKNOWN`` each, :mod:`roughflow.resources`)."""
    need = FLOW_LDL_BYTES_PER_UNKNOWN * n
    have = headroom_bytes()
    return DirectFit(have is None or need <= have, need, have)


def check_direct_max_flowing_fraction(value: float | None) -> float | None:
    """``value`` as a float in [0, 1] (None stays None: :data:`DIRECT_MAX_FLOWING_FRACTION`);
    :class:`InputError` otherwise."""
    if value is None:
        return None
    v = require_finite("direct_max_flowing_fraction", value)
    if not 0.0 <= v <= 1.0:
        raise InputError(f"direct_max_flowing_fraction must lie in [0, 1] (a share of the "
                         f"grid's cells), got {value!r}")
    return v


def choose(method: str | None, n: int, flowing_fraction: float | None = None,
           direct_max_flowing_fraction: float | None = None) -> str:
    """The method ``"auto"`` stands for with ``n`` unknowns that are ``flowing_fraction`` of
    the grid's cells (None: unknown; then by size only), else ``method`` itself.
    ``direct_max_flowing_fraction``: the largest flowing fraction at which ``"auto"`` takes
    the direct solver beyond :data:`DIRECT_MAX_UNKNOWNS` (None:
    :data:`DIRECT_MAX_FLOWING_FRACTION`)."""
    method = check_method(method)
    if method != "auto":
        return method
    if n <= DIRECT_MAX_UNKNOWNS:
        return "direct"
    limit = (DIRECT_MAX_FLOWING_FRACTION if direct_max_flowing_fraction is None
             else direct_max_flowing_fraction)
    if flowing_fraction is not None and flowing_fraction <= limit:
        return "direct" if direct_fits(n).fits else "rs"
    return "rs"


def prepare(a: sp.spmatrix, method: str = FLOW_METHOD,
            flowing_fraction: float | None = None, hint: OrderHint | None = None) -> Prepared:
    """Factorise (``"direct"``) or build the AMG preconditioner of ``a`` for
    :func:`solve_spd` (``"auto"``: :func:`choose`). ``hint``: the direct solver's
    elimination order (else approximate minimum degree's; ignored by the other methods)."""
    method = choose(method, a.shape[0], flowing_fraction)
    if method == "direct":
        if not ldl.available():
            # QDLDL reads the upper triangle of a CSC matrix (A is symmetric)
            return Prepared(method, factor=qdldl.Solver(sp.triu(a, format="csc"), upper=True))
        order, max_flops = (None, None) if hint is None else (hint.order, hint.max_flops)
        return Prepared(method, factor=ldl.factor(a, order, max_flops=max_flops))
    if method == "cg":
        return Prepared(method)
    return Prepared(method, preconditioner=_amg_preconditioner(sp.csr_matrix(a), method))


#: the round-off of the float64 residual b - A x, relative to (|A| |x| + |b|)_i: a row has at
#: most 5 entries, so forming it rounds by at most gamma_6 = 6u / (1 - 6u) of that (u = eps / 2,
#: the standard bound for a sum of products), and the diagonal, a sum of at most 4 face
#: conductances, differs from theirs by at most gamma_3 (the off-diagonal entries and b are the
#: faces' values exactly): 4.5 eps in all, taken as 8 eps for the factorisation's own error in
#: A^-1 (|A| |x| + |b|)
RESIDUAL_ROUNDOFF = 8.0 * np.finfo(np.float64).eps


def residual_scale(matrix: sp.csr_matrix, rhs: np.ndarray, x: np.ndarray) -> np.ndarray:
    """(|A| |x| + |b|)_i: what the round-off of the float64 residual b - A x is relative to."""
    size = np.abs(x)
    # |A| = 2 diag(A) - A: the Reynolds matrix has no positive off-diagonal entry
    return 2.0 * matrix.diagonal() * size - matrix @ size + np.abs(rhs)


def attainable_residual(matrix: sp.csr_matrix, rhs: np.ndarray, x: np.ndarray) -> float:
    """The smallest ||b - A x|| that float64 can certify for ``x``: the round-off of the
    residual itself (:data:`RESIDUAL_ROUNDOFF` of :func:`residual_scale`). A relative
    residual tol ||b|| below it cannot be met where the inlet's transmissibilities (b) are
    small against those inside (a gap of 1e-3 at the inlet against 1 inside: 6.7e-7 at best
    against tol 1e-8, while sigma was exact to 4e-16); such a solve is as accurate as its
    data, and is accepted. The pressures of the exact solution lie between the reservoirs'
    0 and 1 (maximum principle), so |x| counts at most 1 here: a diverged iterate (an RS run
    reached 7e301) must not raise its own floor."""
    size = np.minimum(np.abs(x), 1.0)
    return RESIDUAL_ROUNDOFF * float(np.linalg.norm(residual_scale(matrix, rhs, size)))


def pcg(a: sp.csr_matrix, b: np.ndarray, *, tol: float,
        preconditioner: spla.LinearOperator | None, max_iter: int,
        x0: np.ndarray | None = None,
        accept: Callable[[np.ndarray], bool] | None = None,
        certify: Callable[[np.ndarray, float], bool] | None = None) -> CGRun:
    """Preconditioned conjugate gradients for SPD ``a``.

    It stops at the first iterate whose true residual meets ||b - A x|| <= tol ||b|| and that
    ``accept(x)`` accepts (None: any), at round-off (the recursive residual
    :data:`DRIFT_AT_ROUNDOFF` times below the true one, or the true one within
    :func:`attainable_residual`), at a non-finite step, or after ``max_iter`` iterations;
    the caller judges the iterate. A true residual above ``tol`` replaces the recursive one
    and the run goes on, keeping its search direction: restarting CG instead throws away the
    Krylov space, and near a_c* that is what finds the flux through the last constriction
    (one run converged after about 125 iterations where restarted rounds of 50 were still
    10 % off in sigma after 409, docs/flow.md "Flux check").
    ``certify(x, drop)``, called after every iteration with the new iterate and the step's
    decrease of the energy x^T A x - 2 b^T x (alpha r^T z: in exact arithmetic, the error
    of the previous iterate in the A-norm, squared, less that of the new one), ends the run
    where it returns True, whatever the residual.
    """
    x = np.zeros(b.size) if x0 is None else np.array(x0, dtype=np.float64)
    r = b - a @ x if x0 is not None else b.copy()

    def precondition(v):
        return v.copy() if preconditioner is None else preconditioner.matvec(v)

    z = precondition(r)
    p = z.copy()
    rz = float(r @ z)
    target = tol * np.linalg.norm(b)
    iterations = 0
    while True:
        recursive = np.linalg.norm(r)
        # checked at every iterate once the recursive residual is small: a check (a product
        # with A and ``accept``'s flux balance) costs about a quarter of an RS iteration
        if recursive <= target:
            true = b - a @ x
            residual = np.linalg.norm(true)
            if residual <= target and (accept is None or accept(x)):
                break
            if recursive < DRIFT_AT_ROUNDOFF * residual:
                break
            if residual > target:
                # float64 cannot do better than its round-off of the residual: replacing the
                # recursive residual by that noise and going on (64^2, inlet rows of gap
                # 3e-3 under RS-CG) lost conjugacy and diverged to 1e110, then NaN
                if residual <= attainable_residual(a, b, x):
                    break
                r, z = true, precondition(true)
                rz = float(r @ z)
        if iterations >= max_iter or rz == 0.0:
            break
        ap = a @ p
        pap = float(p @ ap)
        if not (math.isfinite(pap) and pap > 0.0):  # keep the last iterate for the caller
            break
        alpha = rz / pap
        if not math.isfinite(alpha):
            break
        x += alpha * p
        r -= alpha * ap
        iterations += 1
        if certify is not None and certify(x, alpha * rz):
            return CGRun(x, iterations, certified=True)
        z = precondition(r)
        rz_next = float(r @ z)
        p *= rz_next / rz
        p += z
        rz = rz_next
    return CGRun(x, iterations)


def solve_spd(
    a: sp.csr_matrix, b: np.ndarray, *, tol: float, method: str = FLOW_METHOD,
    max_iter: int | None = None, x0: np.ndarray | None = None, strict: bool = True,
    prepared: Prepared | None = None, accept: Callable[[np.ndarray], bool] | None = None,
    certify: Callable[[np.ndarray, float], bool] | None = None,
) -> LinearSolution:
    """Solve A x = b for symmetric positive definite A to relative residual ``tol``.

    ``x0`` is a starting guess for the iterative methods (a refinement step of the
    direct one). ``prepared``: :func:`prepare` of the same ``a`` (its method replaces
    ``method``), built here when None. ``accept``: the iterative methods go on past
    ``tol`` until it accepts the iterate, and stop where ``certify`` certifies one, which is
    then returned whatever its residual (:func:`pcg`). Raises :class:`ConvergenceError`
    (with the residual reached) when the tolerance is not met, unless ``strict=False``
    (then the best iterate is returned with its residual: used for refinement beyond a
    tolerance already met).
    """
    n = a.shape[0]
    method = prepared.method if prepared is not None else choose(method, n)
    a_s, b_s = a.tocsr(), b
    bnorm = np.linalg.norm(b_s)
    if bnorm == 0.0:
        return LinearSolution(np.zeros(n), 0.0, 0, method)
    if prepared is None:
        prepared = prepare(a_s, method)

    iterations, certified = 0, False
    if method == "direct":
        f = prepared.factor
        y = f.solve(b_s) if x0 is None else x0 + f.solve(b_s - a_s @ x0)
        for _refine in range(3):  # iterative refinement until the residual stalls
            r = b_s - a_s @ y
            if np.linalg.norm(r) <= tol * bnorm:  # a tol below round-off: all 3 rounds
                break
            y += f.solve(r)
    else:
        if max_iter is None:
            max_iter = MAX_ITER_AMG if prepared.preconditioner is not None else MAX_ITER_CG
        run = pcg(a_s, b_s, tol=tol, preconditioner=prepared.preconditioner, x0=x0,
                  max_iter=max_iter, accept=accept, certify=certify)
        y, iterations, certified = run.x, run.iterations, run.certified
    residual = float(np.linalg.norm(b_s - a_s @ y) / bnorm)
    floor = attainable_residual(a_s, b_s, y) / bnorm if np.isfinite(residual) else 0.0
    if not np.isfinite(residual) or (strict and residual > max(tol, floor) and not certified):
        said = f" (nor float64's round-off of it, {floor:.2g})" if floor > tol else ""
        raise ConvergenceError(
            f"Reynolds solver ({method}) did not reach relative residual {tol:g}{said}",
            residual=residual, iterations=iterations,
        )
    return LinearSolution(y, residual, iterations, method, certified)


class PreparedSolution(NamedTuple):
    """A solution of :func:`solve_prepared` and what was prepared for it (for further solves
    of the same matrix)."""

    solution: LinearSolution
    prepared: Prepared


def solve_prepared(a: sp.csr_matrix, b: np.ndarray, *, tol: float, method: str = FLOW_METHOD,
                   flowing_fraction: float | None = None,
                   direct_max_flowing_fraction: float | None = None,
                   accept: Callable[[np.ndarray], bool] | None = None,
                   certify: Callable[[np.ndarray, float], bool] | None = None,
                   hint: OrderHint | None = None,
                   ) -> PreparedSolution:
    """:func:`prepare` and :func:`solve_spd` of ``a x = b``, returning the solution and what
    was prepared (for further solves of the same matrix). ``flowing_fraction``: the
    unknowns' share of the grid's cells, and ``direct_max_flowing_fraction``, for
    :func:`choose`; ``accept``, ``certify``: see :func:`pcg`; ``hint``: see :func:`prepare`.

    With ``method="auto"``, an AMG solve is retried by the direct solver when it has not
    converged after :data:`AMG_ITER_BEFORE_FALLBACK` iterations, if the factorisation fits
    beside what this process held before the AMG set-up (:func:`direct_fits`); the AMG
    iterations spent count in the result's. Where it does not fit, AMG gets its full
    :data:`MAX_ITER_AMG` and raises :class:`ConvergenceError` as an explicit method does
    (naming the memory the fallback would have needed).
    """
    method = check_method(method)
    chosen = choose(method, a.shape[0], flowing_fraction, direct_max_flowing_fraction)
    fallback = method == "auto" and chosen != "direct"
    # measured before the AMG hierarchy, which is freed before the factorisation; only
    # where it matters
    fits, need, have = direct_fits(a.shape[0]) if fallback else DirectFit(True, 0, None)
    prepared = prepare(a, chosen, hint=hint)
    try:
        sol = solve_spd(a, b, tol=tol, prepared=prepared, accept=accept, certify=certify,
                        max_iter=AMG_ITER_BEFORE_FALLBACK if fallback and fits else None)
        return PreparedSolution(sol, prepared)
    except ConvergenceError as exc:
        if not fallback:
            raise
        if not fits:
            raise ConvergenceError(
                f"Reynolds solver ({prepared.method}) did not reach relative residual {tol:g}, "
                f"and its direct fallback would need about {describe(need)} more memory than "
                f"the {describe(have)} available", residual=exc.residual,
                iterations=exc.iterations) from None
        failed = exc.with_traceback(None)  # its frames would keep the AMG hierarchy alive
    del prepared
    log.warning("%s; retrying with the direct solver (%d unknowns)", failed, a.shape[0])
    prepared = prepare(a, "direct", hint=hint)
    sol = solve_spd(a, b, tol=tol, prepared=prepared)
    return PreparedSolution(replace(sol, iterations=sol.iterations + failed.iterations),
                            prepared)
