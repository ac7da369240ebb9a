"""Green's function molecular dynamics with mass weighting (docs/physics.md Sect. 3.2).

The elastic surface height u(r) (gap = u - h) relaxes under the force per unit area

    f = -IFFT(k(q) FFT(u)) - p + f_int(u - h),        k(q) = |q| E*/2,

with the Fourier-space masses of Zhou, Moseler & Mueser (PRB 99, 144103, 2019),
m(q) = sqrt(m_0^2 + k(q)^2): the preconditioned force IFFT(FFT(f) / m(q)) moves every
elastic mode with k(q) > m_0 at one rate. Cost: two FFT pairs per iteration (the force,
the preconditioning), plus one inverse FFT for each residual check; on the hard wall in
single precision (below, "Precision").

Hard wall (elastic model): projected preconditioned conjugate gradients. Points on the wall
whose force pushes into it are active: their force (the wall reaction cancels it) and their
search direction are zero, i.e. the preconditioner acts on the free points only. A fixed
point has f = 0 off the active set and f <= 0 on it, exactly the contact (KKT) conditions,
so this and ``cg.polonsky_keer`` solve the same discrete problem. Each iteration:

1. z = M^-1 r (r = f off the active set), Polak-Ribiere direction d = z + beta d;
2. trial point u_t = max(u + alpha d, h), the actual step s = u_t - u and its force -K s
   (the FFT pair);
3. the energy is quadratic along s (f is linear in u), so the minimum t = f.s / s.K s is
   known without another FFT; move to u + t s with force f - t K s. t > 1 extrapolates
   only when nothing clipped (up to the wall); when something clipped and t >= ``T_KEEP``
   the trial point itself is kept, so that the clipped points sit on the wall and join the
   active set (a point moved only part of the way never joins it and the iteration jams:
   measured). alpha follows t.

The loops carry the gap g = u - h (the wall is g >= 0, so they need not read h) and do not
store s: the update recomputes it from d and alpha with the same arithmetic, and s.K s comes
from the transform of s by Parseval; they are vectorized (``_kernels.CG_FASTMATH``), about
0.35 of a double FFT pair per iteration together (docs/contact.md "Kernel traffic").

Why not FIRE here (benchmarks/gfmd_growth.py, docs/contact.md "Step count at scale"): the
masses cannot make the constrained problem uniformly stiff. Contacts pin the long waves of
the free surface, so the largest eigenvalue of the preconditioned operator grows with the
number of contact patches (about n^0.8 at fixed points per lambda_s), and its stiff modes
reverse the power f.v every 2-4 steps; FIRE answers each reversal with a restart and a
smaller dt, which then decays far below the stable step (0.2 against 0.4-0.6) and, at
8192^2 and beyond, towards a stall. CG takes the exact step along each direction instead.
m_0 = max(z k_min, k_h), where k_h is the stiffness averaged over the height spectrum:
modes longer than the surface's own wavelengths are pinned by the contacts and need no
faster rate, and the heavier long-wave masses cut the pinned modes' eigenvalues.

Cold start (hard wall, no ``u0``): the flat elastic surface at the height whose bearing area is
the contact area the elastic law expects for the load (``law.elastic_area``, the load in units
of the surface's own rms slope), not the flat touching the highest point. The elastic contact
area at a load is close to the bearing area at the same mean separation (0.41 against 0.445 at
p = 0.22), so the start already cuts the heights where the solution's contacts lie and CG does
not have to walk the surface down from the top: 17 % fewer iterations over 36 cold solves at
512^2 (H 0.3 and 0.8, gamma 1 and 4, L/lambda_r 1 and 4, a_c 0.01 - 0.9, tol 1e-4), the same
contact area (docs/contact.md "Cold start"). The level comes from a sorted sample of the heights
kept in the setup (:data:`LEVEL_SAMPLE`). The widest spectra (k2 / k_h >= ``BAND_R_HI``, the
heavy-mass end of ``mass_floor``) keep the flat at the top: there the count moves by +-15 %
with the seed whichever the start, and the level did no better (4 solves at 4096^2 and
8192^2: 256 iterations against 255).

Precision (hard wall): the two transforms of an iteration and of a residual check run in
single precision (float32 FFTW, 0.6-0.7 of a double pair's time), everything else in double
(g, f, d, the step s, every sum). The preconditioned residual z and the curvature s.K s need
only relative accuracy, and the force is carried as f - t K s, whose round-off is relative to
the step: it drifts from the exact force by about 1e-7 of the distance moved (``SINGLE_DRIFT``,
in the residual's units). A drift bound is kept; the exact force (a double FFT pair) replaces
the carried one when the bound reaches a tenth of the residual estimate (about once per cold
solve). The residual a solve reports is the transform's plus the drift bound, a bound on the
exact force's; when only the bound stands between a check and the tolerance, the exact force
decides. Same iteration counts as double precision to tol 1e-10 (256^2 - 2048^2,
docs/contact.md "Single precision"); the residual's own round-off is 1e-8 - 2e-7 relative.

Hardness (``hardness=H``, the hard wall on the CPU; docs/contact.md "Hardness"): the same CG
on E(u) = 1/2 u.K u + p sum(u) + H sum max(0, -g), g = u - h: the wall becomes a kink of the
energy at g = 0, which a cell may cross into the plastic side g < 0 (depth -g, pressure H).
A cell is free (g > 0: r = f), stuck on the wall (g = 0, -H <= f < 0: r = 0, the active set)
or plastic (g < 0, or g = 0 with f < -H: r = f + H); the trial gap clips at the kink from the
cell's own side, so every cell stays on one quadratic piece along the step and t = r.s / s.K s
is still exact (``_kernels.cg_*_capped``; the elastic kernels stay as they are). The residual
and the single-precision transforms are the elastic solve's (the same contact and plastic
sets as ``cg.polonsky_keer(hardness=)`` at tol 1e-10, pressures within 3e-9 H, over 16
cases at 128^2 and 64 x 256, H = 1.2 - 20 x the load; the exact force is refreshed as
often as without a cap). A cold start where the load over H exceeds the elastic law's
area starts from the flat at bearing area p / H, its cells above it plastic; a warm start's
negative gaps are plastic depths (``contact.solve`` passes heights + gap - plastic depth).

Adhesive model (``adhesion=``, not convex): with the hard wall (the default,
``repulsion="hard"``), mass-weighted FIRE (Bitzek et al., PRL 97, 170201, 2006; :mod:`.fire`),
the cosine attraction acting on the free points of the active-set wall above; with the
harmonic repulsion, nonlinear CG with exact line minima (``adhesive_cg``, 2-6x fewer
iterations than FIRE there). ``minimizer="fire"`` runs FIRE on the harmonic repulsion too
(without a wall), as before ``adhesive_cg``. The contact mask is the adhesion's
(``Adhesion.contact_mask``), and a contact cell's gap is set to zero.

Residual: max |G f_eff| / rms(h), the largest displacement the unbalanced force would still
cause, in units of the rms height (G = compliance 2/(|q| E*)); same units as the CG
residual. G has no q = 0 part, so the load imbalance |mean f_eff| enters the maximum as
well, over the pressure the contacts hold (:func:`~._gfmd_common.load_scale`): min(p, k_min
rms(h)); with adhesion the load plus the mean attraction, at least one held cell's stiffness
times rms(h), where that is below k_min rms(h) (at zero load the few contacts alone hold the
mean separation). FIRE and the adhesive CG check it every ``check_every``
iterations; the hard-wall CG
checks it once the free estimate max |z| / rms(h) says it may be below the tolerance (the
start only if its estimate is within ``START_CHECK`` tolerances), and after a failed check
once the estimate has fallen by the factor still missing.
"""

from __future__ import annotations

import functools
import logging
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from roughflow import fft, gpu
from roughflow.defaults import CONTACT_CHECK_EVERY, DEFAULT_BACKEND, SOLVER_LOG_EVERY
from roughflow.errors import InputError, require_field
from roughflow.surface import spectral_rms_gradient

from . import _kernels as _k
from ._gfmd_common import (
    TOUCH_TOL,
    Z_MASS,
    load_scale,
    spectral_factors,
)
from ._linalg import height_scale
from ._result import SolverOutput
from .adhesion import Adhesion
from .adhesive_cg import adhesive_cg
from .fire import fire
from .law import elastic_area

if TYPE_CHECKING:
    from types import ModuleType

# Hard-wall CG (measured on the rows of docs/contact.md "Step count at scale"): the mass
# floor m_0 = max(Z_MASS k_min, H_MASS k_h) (H_MASS 0, i.e. z k_min alone: 10-30 % more
# iterations from 2048^2 on), where H_MASS follows the bandwidth through the spectrum's
# r = k2 / k_h (k2: stiffness of the rms slope over the rms height): H_MASS_NARROW up to
# r = BAND_R_LO, H_MASS_WIDE from BAND_R_HI, linear in between (docs/contact.md "The mass
# floor against the bandwidth": 3 instead of 1 takes 8192^2 at L/lambda_r 4 from 69 to
# 57 iterations and 4096^2 at L/lambda_r 1 from 72 to 61, while 2 or 3 cost 4-5
# iterations at r <= 2.2); the change of the trial step alpha per iteration and its range;
# the largest extrapolation T_MAX of the secant step; T_KEEP (0.5: 10-20 % more
# iterations, 0.95: about the same as 0.8).
H_MASS_NARROW = 1.0
H_MASS_WIDE = 3.0
BAND_R_LO = 2.3
BAND_R_HI = 2.9
ALPHA_SHRINK = 0.1
ALPHA_GROW = 2.0
ALPHA_MIN = 1e-3
ALPHA_MAX = 1e3
T_MAX = 4.0
T_KEEP = 0.8
#: The start of a hard-wall solve gets an exact residual check (an inverse FFT) only when
#: its free estimate max |M^-1 r| is below this many tolerances: over 35 starts of threshold
#: searches (512^2, 4 seeds) the estimate was 0.58-1.17 times the exact residual, so a
#: converged start is always checked (and returned unchanged).
START_CHECK = 10.0
#: Single precision (module docstring, "Precision"): the carried force drifts from the exact
#: one by at most SINGLE_DRIFT per unit of max |t s| / rms(h) moved (in the residual's units;
#: measured 1.6e-7 - 4e-7 from 256^2 to 2048^2, float32 round-off 6e-8). It is recomputed
#: exactly (a double FFT pair) when the drift bound exceeds DRIFT_REFRESH times the residual
#: estimate (0.1: the same iteration counts as double precision to tol 1e-10 within 1-2,
#: measured at 256^2 - 2048^2).
SINGLE_DRIFT = 1e-6
DRIFT_REFRESH = 0.1
#: Heights kept (a strided sample, sorted) to place the cold start's flat (module docstring,
#: "Cold start"): the level's bearing area is then off by at most 0.005 (1024^2 and 2048^2,
#: gamma 1 and 4, 6 seeds, a_c 0.05 - 0.8), far inside the +-0.3 rms(h) (about +-0.1 in
#: area) over which a start at the solution's mean separation needed the same iterations
#: (1024^2, 2 seeds, within 1-2). The stride is coprime with the row length: a stride that
#: divides it samples a few whole columns, whose correlated heights put the level off by up
#: to 0.044 (2048^2).
LEVEL_SAMPLE = 16384

log = logging.getLogger(__name__)


@functools.lru_cache(maxsize=2)
def _spectral_single(shape: tuple[int, int], lx: float, ly: float):
    """float32 copies of -k(q)/N and G(q)/N for the single-precision transforms."""
    _, neg_k, comp, _ = spectral_factors(shape, lx, ly)
    out = neg_k.astype(np.float32), comp.astype(np.float32)
    for a in out:  # cached and shared: a caller's in-place change would reach every solve
        a.setflags(write=False)
    return out


def _band(hpow: np.ndarray, k: np.ndarray) -> tuple[float, float] | None:
    """(k_h, k2 / k_h) of the height power ``hpow`` (rfft2 grid, column weights included)
    and stiffness ``k``: k_h the power-weighted mean stiffness, k2 the rms one; None without
    roughness (no power, or all of it at q = 0)."""
    total = float(hpow.sum())
    if total <= 0:
        return None
    k_h = float((hpow * k).sum()) / total
    if k_h <= 0:
        return None
    return k_h, math.sqrt(float((hpow * k * k).sum()) / total) / k_h


def mass_floor(hpow: np.ndarray, k: np.ndarray, kmin: float) -> float:
    """H_MASS k_h of the hard-wall masses for the height power ``hpow`` (rfft2 grid, column
    weights included) and stiffness ``k``: k_h = power-weighted mean stiffness, H_MASS from
    the bandwidth ratio k2 / k_h (module constants)."""
    return _floor_of_band(_band(hpow, k), kmin)


def _floor_of_band(band: tuple[float, float] | None, kmin: float) -> float:
    """:func:`mass_floor` from the (k_h, k2 / k_h) of :func:`_band`."""
    if band is None:  # no roughness to set a scale
        return kmin
    k_h, ratio = band
    x = min(max((ratio - BAND_R_LO) / (BAND_R_HI - BAND_R_LO), 0.0), 1.0)
    return (H_MASS_NARROW + x * (H_MASS_WIDE - H_MASS_NARROW)) * k_h


@dataclass(frozen=True, eq=False)
class HardWallSetup:
    """What a hard-wall solve derives from the heights alone: built once by
    :func:`hard_wall_setup` for many solves of one surface (threshold searches, load ladders
    call ``contact.solve(..., setup=contact.prepare(surface))``), it saves a forward FFT and
    the preconditioner per solve (about 20 ms at 1024^2, half an iteration).

    heights, lx, ly: what it was built from (a solve checks that it gets the same array);
    h0: mean height; h: the centred heights, flat; pre: 1 / (N m(q)) on the rfft2 grid (the
    masses of the module docstring); hscale: rms height; gbar: rms slope (from the spectrum);
    levels: about :data:`LEVEL_SAMPLE` centred heights sorted, the highest last (the cold
    start's level); band_ratio: k2 / k_h of :func:`mass_floor` (nan without roughness). The
    solves only read the arrays.
    """

    heights: np.ndarray
    lx: float
    ly: float
    h0: float
    h: np.ndarray
    pre: np.ndarray
    hscale: float
    gbar: float
    levels: np.ndarray
    band_ratio: float


def hard_wall_setup(heights: np.ndarray, lx: float, ly: float,
                    threads: int | None = None, backend: str = DEFAULT_BACKEND) -> HardWallSetup:
    """The :class:`HardWallSetup` of ``heights`` (cell ``lx`` x ``ly``); ``backend="cupy"``:
    the heights' transform and the preconditioner built on the GPU, ``h`` and ``pre`` CuPy
    arrays (the per-shape spectral factors still come from the host)."""
    shape = heights.shape
    size = heights.size
    k, _, _, kmin = spectral_factors(shape, lx, ly)
    h0 = float(heights.mean())
    if gpu.check_backend(backend) == "cupy":
        xp = gpu.cupy()
        plan = gpu.plan(shape)
        k = _device_factors(shape, lx, ly)[3]
        h = xp.asarray(heights).ravel() - h0
    else:
        xp = np
        plan = fft.plan(shape, threads)
        h = np.ascontiguousarray(heights - h0, dtype=np.float64).ravel()
    hscale = height_scale(h, xp)
    plan.real_in.reshape(-1)[:] = h
    ht = plan.execute_forward()
    wts = xp.asarray(fft.rfft_weights(shape[1]))
    hpow = wts * (ht.real**2 + ht.imag**2)
    band = _band(hpow, k)
    pre = xp.hypot(max(Z_MASS * kmin, _floor_of_band(band, kmin)), k)
    xp.reciprocal(pre, out=pre)
    pre *= 1.0 / size
    gbar = spectral_rms_gradient(ht, shape, lx, ly)
    if not math.isfinite(gbar):
        raise InputError(f"surface slopes out of range: rms slope {gbar:.3g} (heights in "
                         "units of L)")
    # the same sample on either backend: h = heights - h0 is exact arithmetic on the host too
    flat = heights.ravel()
    levels = np.sort(np.append(flat[::_level_stride(size, shape[1])] - h0, flat.max() - h0))
    # writable: the numba kernels would compile a second, read-only signature
    return HardWallSetup(heights=heights, lx=float(lx), ly=float(ly), h0=h0, h=h, pre=pre,
                         hscale=hscale, gbar=gbar, levels=levels,
                         band_ratio=math.nan if band is None else band[1])


def _level_stride(size: int, ny: int) -> int:
    """The stride of the cold start's height sample (:data:`LEVEL_SAMPLE`): about
    size / LEVEL_SAMPLE and coprime with the row length ``ny``, so that successive rows are
    sampled in different columns."""
    step = max(1, size // LEVEL_SAMPLE)
    while step > 1 and math.gcd(step, ny) != 1:
        step += 1
    return step


def cold_start_level(setup: HardWallSetup, load: float) -> float:
    """The centred height of the cold start's flat at ``load`` (module docstring, "Cold
    start"): the level whose bearing area is ``law.elastic_area(load / gbar)``; the highest
    point for the widest spectra (``band_ratio >= BAND_R_HI``), a flat surface or a
    vanishing load."""
    levels = setup.levels
    if setup.gbar <= 0 or setup.band_ratio >= BAND_R_HI:
        return float(levels[-1])
    return _level_at_area(setup, elastic_area(load / setup.gbar))


def _level_at_area(setup: HardWallSetup, area: float) -> float:
    """The centred height whose bearing area is ``area``, from the setup's sorted sample."""
    levels = setup.levels
    return float(levels[min(max(round((1.0 - area) * (levels.size - 1)), 0), levels.size - 1)])


@dataclass(frozen=True, eq=False)
class HardWallWork:
    """The arrays a hard-wall solve writes, kept for the next solve on the same grid.

    A search that keeps only a little of each state (``search.threshold`` keeps q = gap - c
    pressure in float32) passes one to every solve, so that no solve allocates: on machines
    whose fresh memory is expensive (transparent huge pages with synchronous compaction, as
    on ours) a fresh 8 MB array costs about 20 ms on first touch and a 32 MB one about
    110 ms (medians), and a threshold pair spent up to 16 % of its time in the kernel for
    them (docs/percolation.md, "Cost of a threshold pair"). The result of a solve with it
    is a view of these arrays: it is overwritten by the next solve with the same work.

    g, f, d, active: gap, force, search direction and active set of the iteration (flat);
    below: the plastic side of a capped solve (flat); rt_old: the transform of the previous
    residual; sigma, gap, contact: the result's wall reaction, gap and contact mask (grid
    shaped), plastic, depth: a capped solve's plastic mask and depth (grid shaped); u0: the
    warm start's elastic surface.
    """

    g: np.ndarray
    f: np.ndarray
    d: np.ndarray
    active: np.ndarray
    rt_old: np.ndarray
    sigma: np.ndarray
    gap: np.ndarray
    contact: np.ndarray
    u0: np.ndarray
    below: np.ndarray
    plastic: np.ndarray
    depth: np.ndarray

    @property
    def shape(self) -> tuple[int, int]:
        return self.gap.shape


def hard_wall_work(shape: tuple[int, int], xp: ModuleType = np) -> HardWallWork:
    """An empty :class:`HardWallWork` for grids of ``shape`` (``xp``: the array module,
    ``cupy`` for the GPU backend)."""
    nx, ny = (int(v) for v in shape)
    size = nx * ny
    return HardWallWork(g=xp.empty(size), f=xp.empty(size), d=xp.empty(size),
                        active=xp.empty(size, dtype=bool),
                        rt_old=xp.empty((nx, ny // 2 + 1), dtype=np.complex64),
                        sigma=xp.empty((nx, ny)), gap=xp.empty((nx, ny)),
                        contact=xp.empty((nx, ny), dtype=bool), u0=xp.empty((nx, ny)),
                        below=xp.empty(size, dtype=bool),
                        plastic=xp.empty((nx, ny), dtype=bool), depth=xp.empty((nx, ny)))


@functools.lru_cache(maxsize=1)  # large grids: four spectral arrays in GPU memory
def _device_factors(shape: tuple[int, int], lx: float, ly: float):
    """-k(q)/N in double and single precision, G(q)/N in single and k(q), on the GPU."""
    cp = gpu.cupy()
    k, neg_k, _, _ = spectral_factors(shape, lx, ly)
    neg_k32, comp32 = _spectral_single(shape, lx, ly)
    return cp.asarray(neg_k), cp.asarray(neg_k32), cp.asarray(comp32), cp.asarray(k)


@functools.lru_cache(maxsize=1)  # the last setup's arrays stay on the GPU for its next solve
def _on_device(setup: HardWallSetup):
    """``setup``'s h and pre as CuPy arrays (copied once for a setup built on the CPU)."""
    cp = gpu.cupy()
    return cp.asarray(setup.h), cp.asarray(setup.pre)


def gfmd(
    heights: np.ndarray,
    lx: float,
    ly: float,
    load: float,
    *,
    tol: float,
    max_iter: int,
    u0: np.ndarray | None = None,
    adhesion: Adhesion | None = None,
    threads: int | None = None,
    check_every: int = CONTACT_CHECK_EVERY,
    use_numba: bool = True,
    minimizer: str = "auto",
    setup: HardWallSetup | None = None,
    work: HardWallWork | None = None,
    backend: str = DEFAULT_BACKEND,
    hardness: float | None = None,
) -> SolverOutput:
    """Minimise elastic + interaction + load energy; returns a :class:`SolverOutput`.

    Hard wall (``adhesion=None``): projected conjugate gradients in the mass metric
    (``iterations`` counts CG iterations, two single-precision FFT pairs each). Adhesion with
    the hard wall (the default): mass-weighted FIRE (``iterations`` counts MD steps); harmonic
    adhesion: nonlinear CG (``adhesive_cg``; iterations of three transforms). Both check the
    residual every ``check_every`` iterations.
    ``u0``: initial elastic surface height (warm start), default a flat surface: on the hard
    wall at the level of the module docstring's "Cold start", under FIRE touching the
    highest point (or one range above it with adhesion). ``use_numba=False`` runs the
    same iteration with numpy (for testing and benchmarking the kernels).
    ``minimizer="fire"`` runs FIRE on the hard wall and the harmonic adhesion too (the
    method before CG; benchmarks).
    ``setup``: the hard wall's :class:`HardWallSetup` of these heights, built beforehand
    (default: built by this call; ignored by FIRE).
    ``work``: the hard wall's :class:`HardWallWork` for this grid: no arrays are allocated,
    and the output is a view of its arrays (overwritten by the next solve with it). ``u0``
    may be ``work.u0``. Ignored by FIRE.
    ``backend``: ``"cpu"`` or ``"cupy"`` (:mod:`roughflow.gpu`; the hard wall only): the same
    iteration with CuPy arrays, cuFFT and the CUDA forms of the fused kernels
    (``_cuda_kernels``; ``use_numba=False``: the kernels' array-module twins); ``work`` then
    holds CuPy arrays, and the output is copied to numpy.
    ``hardness``: the hard wall's pressure cap H (module docstring, "Hardness"; CPU only),
    None for none; ``u0`` below the heights is then a plastic depth, kept.
    """
    if hardness is not None and (adhesion is not None or minimizer != "auto"):
        raise InputError("hardness= serves the hard wall's CG only")
    if minimizer not in ("auto", "fire"):
        raise InputError(f"minimizer must be 'auto' or 'fire', got {minimizer!r}")
    if backend != "cpu" and (adhesion is not None or minimizer != "auto"):
        raise InputError(f"backend={backend!r} serves the hard wall's CG only")
    if u0 is not None:
        require_field("u0", u0)  # a nan start would leave every minimizer on nan
        if np.shape(u0) != np.shape(heights):  # flattened below: the size alone passed
            raise InputError(f"u0 of shape {np.shape(u0)} passed for heights of shape "
                             f"{np.shape(heights)}")
    if adhesion is None and minimizer == "auto":
        return _hard_wall(heights, lx, ly, load, tol=tol, max_iter=max_iter, u0=u0,
                          threads=threads, use_numba=use_numba, setup=setup, work=work,
                          backend=backend, hardness=hardness)
    if adhesion is not None and adhesion.repulsion == "harmonic" and minimizer == "auto":
        return adhesive_cg(heights, lx, ly, load, adhesion=adhesion, tol=tol,
                           max_iter=max_iter, u0=u0, threads=threads,
                           check_every=check_every, use_numba=use_numba)
    return fire(heights, lx, ly, load, tol=tol, max_iter=max_iter, u0=u0, adhesion=adhesion,
                threads=threads, check_every=check_every, use_numba=use_numba)


def _hard_wall_kernels(use_numba: bool, on_gpu: bool) -> tuple:
    """The hard-wall CG's kernels (update, precondition, direction, feasible, stiffness, finish,
    max_abs, max_free): the CUDA forms on the GPU, else numba's, or with ``use_numba=False``
    their array-module twins."""
    if use_numba and on_gpu:
        from . import _cuda_kernels

        return _cuda_kernels.HARD_WALL
    if use_numba:
        return (_k.cg_update, _k.cg_precondition, _k.cg_direction, _k.cg_feasible,
                _k.cg_stiffness, _k.cg_finish, _k.max_abs, _k.max_abs_free)
    return (_k.cg_update_np, _k.cg_precondition_np, _k.cg_direction_np, _k.cg_feasible_np,
            _k.cg_stiffness_np, _k.cg_finish_np, _k.max_abs_np, _k.max_abs_free_np)


def _capped_kernels(use_numba: bool) -> tuple:
    """The capped forms of update, direction, feasible and finish (``_kernels``)."""
    if use_numba:
        return (_k.cg_update_capped, _k.cg_direction_capped, _k.cg_feasible_capped,
                _k.cg_finish_capped)
    return (_k.cg_update_capped_np, _k.cg_direction_capped_np, _k.cg_feasible_capped_np,
            _k.cg_finish_capped_np)


def capped_cold_level(setup: HardWallSetup, load: float, hardness: float) -> float | None:
    """The cold start of a capped solve (module docstring, "Hardness"): where the
    rigid-plastic area load / H exceeds the elastic law's, the level whose bearing area is
    load / H (left unclipped: the cells above it start plastic); else None (the elastic
    start)."""
    if setup.gbar <= 0 or load / hardness <= elastic_area(load / setup.gbar):
        return None
    return min(cold_start_level(setup, load), _level_at_area(setup, min(load / hardness, 1.0)))


def _hard_wall(
    heights: np.ndarray,
    lx: float,
    ly: float,
    load: float,
    *,
    tol: float,
    max_iter: int,
    u0: np.ndarray | None,
    threads: int | None,
    use_numba: bool,
    setup: HardWallSetup | None = None,
    work: HardWallWork | None = None,
    backend: str = DEFAULT_BACKEND,
    hardness: float | None = None,
) -> SolverOutput:
    """Projected preconditioned CG with a secant step (module docstring, "Hard wall"), its
    transforms in single precision ("Precision"); on the GPU with ``backend="cupy"``; with
    a pressure cap ``hardness`` (CPU only; "Hardness")."""
    on_gpu = gpu.check_backend(backend) == "cupy"
    if hardness is not None and on_gpu:
        raise InputError("hardness= is solved on the CPU: the hard wall's CUDA kernels have "
                         "no cap")
    update, precondition, direction, feasible, stiffness, finish, max_abs, max_free = (
        _hard_wall_kernels(use_numba, on_gpu))
    shape = heights.shape
    size = heights.size
    if on_gpu:
        xp = gpu.cupy()
        exact = gpu.plan(shape)  # double: the force of the start and of each refresh
        plan = gpu.plan(shape, single=True)  # float32: everything else
    else:
        xp = np
        exact = fft.plan(shape, threads)
        plan = fft.plan(shape, threads, single=True)
    # the kernels read and write the plans' buffers directly; 1/size (the normalisation of
    # the inverse transform) is folded into the spectral factors
    rin = plan.real_in.reshape(-1)  # r, then the trial step s
    rout = plan.real_out.reshape(-1)  # z, then -K s
    spec_in = plan.spectral_in
    _, neg_k, _, kmin = spectral_factors(shape, lx, ly)
    neg_k32, comp32 = _spectral_single(shape, lx, ly)
    if on_gpu:
        neg_k, neg_k32, comp32, _ = _device_factors(shape, lx, ly)
    if setup is None:
        setup = hard_wall_setup(heights, lx, ly, threads, backend)
    elif tuple(setup.heights.shape) != tuple(shape) or (setup.lx, setup.ly) != (lx, ly):
        # the shape, not only the size: a transposed grid's setup passed and gave a wrong
        # answer reported as converged (its spectrum is another array)
        raise InputError(f"setup of a {setup.lx} x {setup.ly} cell with "
                         f"{tuple(setup.heights.shape)} points passed for {tuple(shape)} "
                         f"points on {lx} x {ly}")
    h0, h, pre, hscale = setup.h0, setup.h, setup.pre, setup.hscale
    if on_gpu and gpu.array_module(h) is np:
        h, pre = _on_device(setup)
    elif not on_gpu and gpu.array_module(h) is not np:
        raise InputError("setup built on the GPU (backend='cupy') passed to a CPU solve")
    scale = load_scale(kmin, hscale, load)
    eps = TOUCH_TOL * hscale

    if work is None:
        work = hard_wall_work(shape, xp)
    elif work.shape != shape:
        raise InputError(f"work for a {work.shape} grid passed for {shape} points")
    g, f, d, active, rt_old = work.g, work.f, work.d, work.active, work.rt_old
    d.fill(0.0)
    active.fill(False)
    rt_old.fill(0.0)  # the transform of the previous r
    capped = hardness is not None
    if capped:
        # the capped kernels in the elastic ones' signatures: one iteration below for both,
        # while the elastic solve keeps its own kernels untouched
        cap = float(hardness)
        below = work.below
        below.fill(False)
        update_c, direction_c, feasible_c, finish_c = _capped_kernels(use_numba)

        def update(g, f, d, fks, t, alpha, eps, r, active):
            return update_c(g, f, d, fks, t, alpha, eps, r, active, below, cap)

        def direction(z, d, g, f, beta, alpha, s_in, active):
            return direction_c(z, d, g, f, beta, alpha, s_in, active, below, cap)

        def feasible(g, d, alpha):
            return feasible_c(g, d, alpha, active, below)

    # the iteration moves the gap g = u - h (u: the elastic surface, centred heights): the
    # wall is g >= 0 and the loops need not read h; with a cap g < 0 is a plastic depth
    # (a warm start's is kept, and so is the plastic cold start's)
    if u0 is not None:
        xp.subtract(xp.asarray(u0, dtype=np.float64).ravel(), h0, out=g)
        g -= h
        if not capped:
            xp.maximum(g, 0.0, out=g)
    else:
        level = capped_cold_level(setup, load, cap) if capped else None
        if level is None:
            xp.subtract(cold_start_level(setup, load), h, out=g)
            xp.maximum(g, 0.0, out=g)
        else:
            xp.subtract(level, h, out=g)

    def refresh() -> float:
        """The exact force of u = g + h (a double FFT pair), the active set and r; returns
        sum(r)."""
        xp.add(g, h, out=exact.real_in.reshape(-1))
        xp.multiply(exact.execute_forward(), neg_k, out=exact.spectral_in)
        xp.subtract(exact.execute_inverse().reshape(-1), load, out=f)
        return update(g, f, d, rout, 0.0, 0.0, eps, rin, active)

    def residual() -> float:
        """max |G r| / rms(h) from the transform ``ft`` of r (one inverse FFT)."""
        xp.multiply(ft, comp32, out=spec_in)
        plan.execute_inverse()
        return max(max_abs(rout) / hscale, imbalance)

    r_sum = refresh()
    drift = 0.0  # bound on max |G (f - exact force)| / rms(h) since the last refresh
    alpha = 1.0  # trial step along d; M approximates K, so 1 is the unconstrained optimum
    rz_old = 0.0
    estimate = math.inf  # max |z| / rms(h) of the previous iteration: a free residual estimate
    check_at = tol  # exact residual once the estimate falls below this
    res = math.inf
    it = 0
    # progress at DEBUG every SOLVER_LOG_EVERY iterations, with the free estimate (the exact
    # residual is computed only near convergence; the level is read once)
    debug = log.isEnabledFor(logging.DEBUG)
    while True:
        if it > 0 and drift > DRIFT_REFRESH * max(estimate, tol):
            r_sum = refresh()
            drift = 0.0
        ft = plan.execute_forward()  # FFT of r
        imbalance = abs(r_sum) / size / scale
        # a nan estimate goes to the exact check at once (which then stops on it)
        nan_seen = math.isnan(estimate) or math.isnan(imbalance)
        if (it > 0 and (max(estimate, imbalance) <= check_at or nan_seen)) or it >= max_iter:
            res = residual()
            if res <= tol < res + drift:
                # converged unless the carried force is off by the whole drift bound: decide
                # with the exact force
                r_sum = refresh()
                drift = 0.0
                ft = plan.execute_forward()
                imbalance = abs(r_sum) / size / scale
                res = residual()
            res += drift  # a bound on the exact force's residual
            if res <= tol or it >= max_iter or math.isnan(res):  # nan never recovers
                break
            # next check when the estimate has fallen by the factor still missing
            check_at = max(estimate, imbalance) * tol / res
        rz, roz = precondition(ft, pre, rt_old, spec_in, shape[1])
        z = plan.execute_inverse()
        if it == 0:
            # the start gets its exact check only when the free estimate says it may be
            # converged (a converged init returns unchanged). The next check waits for the
            # estimate to reach the tolerance: an unconditional check at the first iteration,
            # to calibrate the estimate, cost an inverse FFT per solve and saved no iteration
            # (1024^2 threshold pairs, 10 seeds: 582 -> 581 iterations, 191 -> 100 checks;
            # cold solves to 1e-4 - 1e-8 at 512^2 - 2048^2: the same iterations, one check
            # less; waiting for tol / 1.5 instead: 614 iterations)
            if max(max_free(z.reshape(-1), active) / hscale, imbalance) <= START_CHECK * tol:
                res = residual()
                if res <= tol:
                    break
                rz, roz = precondition(ft, pre, rt_old, spec_in, shape[1])
                z = plan.execute_inverse()
            check_at = tol
        # Polak-Ribiere, >= 0: restarts itself when the active set changes (and after t = 0)
        beta = max(0.0, (rz - roz) / rz_old) if rz_old > 0 else 0.0
        rz_old = rz
        it += 1
        nclip, fs, zmax, smax = direction(z.reshape(-1), d, g, f, beta, alpha, rin, active)
        estimate = zmax / hscale
        if debug and it % SOLVER_LOG_EVERY == 0:
            log.debug("hard-wall cg iteration %d: residual estimate %.3e (tol %.1e), "
                      "trial step %.3g, contact %.4f", it, max(estimate, imbalance), tol,
                      alpha, float(xp.count_nonzero(active)) / size)
        trial = alpha  # update() recomputes the trial step s from d and this alpha
        sks = stiffness(plan.execute_forward(), neg_k32, spec_in, shape[1])
        plan.execute_inverse()  # -K s
        # exact minimum along the actual (clipped) trial displacement s, where the energy
        # is quadratic in t; t > 1 extrapolates only when nothing clipped (the clipped
        # points would leave the feasible set). The next trial step learns from t.
        t_opt = fs / sks if sks > 0 else (math.inf if fs > 0 else 0.0)
        if nclip and T_KEEP <= t_opt <= 1.0:
            # keep the trial point: its clipped points sit exactly on the wall (a point
            # short of it never joins the active set, and the step jams); the energy
            # still decreases for t_opt >= 1/2 (quadratic along s)
            t = 1.0
        elif t_opt <= 1.0:
            t = max(t_opt, 0.0)
            alpha *= max(t, ALPHA_SHRINK)
        elif nclip:
            t = 1.0
            alpha *= min(t_opt, ALPHA_GROW)
        else:  # extrapolate, up to the wall
            t = min(t_opt, T_MAX, feasible(g, d, alpha))
            alpha *= t
        alpha = min(max(alpha, ALPHA_MIN), ALPHA_MAX)
        r_sum = update(g, f, d, rout, t, trial, eps, rin, active)
        drift += SINGLE_DRIFT * t * smax / hscale

    sigma, gap, contact = work.sigma, work.gap, work.contact
    if capped:
        plastic, depth = work.plastic, work.depth
        separation = finish_c(g, h, f, active, below, eps, cap, sigma.reshape(-1),
                              gap.reshape(-1), contact.reshape(-1), plastic.reshape(-1),
                              depth.reshape(-1)) / size
        return SolverOutput(pressure=sigma, gap=gap, contact=contact, separation=separation,
                            iterations=it, residual=res, converged=res <= tol,
                            plastic=plastic, plastic_depth=depth)
    separation = finish(g, h, f, active, eps, sigma.reshape(-1), gap.reshape(-1),
                        contact.reshape(-1)) / size
    return SolverOutput(pressure=gpu.to_host(sigma), gap=gpu.to_host(gap),
                        contact=gpu.to_host(contact), separation=separation, iterations=it,
                        residual=res, converged=res <= tol)
