"""``solve``: dispatch to the contact models and methods, with input checks and warm starts."""

from __future__ import annotations

import dataclasses
import logging
import math
from typing import TYPE_CHECKING

import numpy as np

from roughflow.defaults import (
    CONTACT_MAX_ITER,
    CONTACT_METHODS,
    CONTACT_MIN_CELLS,
    CONTACT_PRESSURE_MAX,
    CONTACT_TOL,
    CONTACT_TOL_MAX,
    CONTACT_TOL_MIN,
    DEFAULT_BACKEND,
    DEFAULT_MODEL,
    MODELS,
)
from roughflow.errors import (
    ConvergenceError,
    InputError,
    require_field,
    require_finite,
    require_positive,
)
from roughflow.gpu import array_module, check_backend
from roughflow.gpu import check_memory as gpu_check_memory
from roughflow.resources import check_memory
from roughflow.surface import Surface

from ._result import ContactResult
from .adhesion import Adhesion, check_overlap, check_setup
from .bearing import solve_bearing
from .cg import check_hardness, require_below_hardness
from .law import elastic_load_for_cells

if TYPE_CHECKING:  # gfmd (numba) is imported on first use: the CLI starts faster
    from numpy.typing import ArrayLike

    from .gfmd import HardWallSetup, HardWallWork

log = logging.getLogger(__name__)

METHODS = CONTACT_METHODS
# The repulsive state an adhesive solve starts from: a small load (so that the attraction
# acts from the first step) and a loose tolerance (it is only a starting point).
_ADHESIVE_START_LOAD = 1e-2
_ADHESIVE_START_TOL = 1e-4


def solve(
    surface: Surface,
    pressure: float | None = None,
    *,
    model: str = DEFAULT_MODEL,
    method: str | None = None,
    area_fraction: float | None = None,
    tol: float = CONTACT_TOL,
    max_iter: int | None = None,
    init: ContactResult | None = None,
    adhesion: Adhesion | None = None,
    threads: int | None = None,
    setup: HardWallSetup | None = None,
    work: HardWallWork | None = None,
    backend: str = DEFAULT_BACKEND,
    hardness: float | None = None,
) -> ContactResult:
    """Contact of the rigid rough ``surface`` with a flat elastic half-space (E* = 1).

    Periodic, frictionless, load controlled: the mean contact pressure equals
    ``pressure`` (units E*, which is E* gbar for generated surfaces: their rms gradient gbar
    is 1; a surface of one's own, e.g. ``Surface.from_array``, keeps its gbar). Heights, gap
    and lengths are in units of L.

    model:
      ``"elastic"`` (hard-wall repulsion), ``"adhesive"`` (``adhesion=Adhesion(...)``,
      docs/physics.md Sect. 3.3; ``pressure`` may be 0 or negative; refused with an
      :class:`InputError` where the model does not hold: an adhesive zone under 1.5 grid
      spacings, a contact gap beyond the height range, a harmonic wall too soft for the load,
      the last also after the solve, see ``adhesion.check_setup``) or ``"bearing"`` (overlap model,
      ``area_fraction=a``: contact at the top fraction a of heights, gap = max(d - h, 0),
      no elasticity and no pressure: ``pressure`` is refused, the result's is NaN;
      ``method`` and ``tol``, unused, are still checked).
      A pressure beyond ``CONTACT_PRESSURE_MAX`` E* either way is refused
      (:func:`check_pressure_scale`).
    method:
      ``"cg"``: constrained conjugate gradients on the pressure (Polonsky-Keer), 2 FFT
      pairs per iteration. ``"gfmd"``: Green's function molecular dynamics with mass
      weighting (the paper's method), see ``roughflow.contact.gfmd``: for the hard wall
      projected conjugate gradients in the mass metric, for adhesion on the hard wall (the
      default adhesive model) FIRE dynamics, for the harmonic adhesive model nonlinear
      conjugate gradients.
      Default: ``"gfmd"``. In ``benchmarks/bench_scaling.py`` it needs 25-45 iterations to
      the default tolerance from 512^2 to 4096^2 (docs/contact.md), while the Polonsky-Keer
      iteration count grows with the grid (about 120 at 256^2, 470 at 1024^2, a_c = 0.4);
      both cost two FFT pairs per iteration (GFMD's in single precision on the hard
      wall, about 0.65 of a double pair), so GFMD is several times faster from 256^2 up.
      GFMD is also the only method for the (non-convex) adhesive model.
    tol:
      residual to reach: the largest gap error (cg: max |gap - 0| on the contact set and
      max overlap off it; gfmd: the same measured after the solve) in units of the rms
      height, within [``CONTACT_TOL_MIN``, ``CONTACT_TOL_MAX``] (:func:`check_contact_tol`).
      The default 1e-6 converges a_c and the mean gap to about 1e-7 relative
      (docs/contact.md). The load holds to it as well: gfmd
      counts the imbalance |mean(contact_pressure) - pressure| in its residual, relative
      to ``pressure`` on the hard wall (measured up to 9.4e-3 at tol 1e-2), relative to
      k_min rms(h) with adhesion; the result's ``pressure`` is the applied load, not that
      mean.
    max_iter:
      iteration cap; if it is reached first a :class:`ConvergenceError` carrying the
      residual is raised.
    init:
      a previous result on the same surface (any load): warm start from its pressure
      field (cg) or displacement (gfmd).
    setup:
      :func:`prepare` of this surface, for many elastic gfmd solves of it (load searches):
      the heights' spectrum and the preconditioner are then built once, not per solve.
      The results are the same as without it.
    work:
      :func:`workspace` of this grid, for a sequence of elastic gfmd solves that keep only
      what they need of each result (threshold searches): the solver allocates nothing, and
      the result's arrays are the workspace's, **overwritten by the next solve with it**.
      The results are the same as without it.
    backend:
      ``"cpu"`` (default) or ``"cupy"``: the elastic gfmd solve on a CUDA GPU through CuPy
      (:mod:`roughflow.gpu`), the same algorithm and tolerance; the result's arrays are
      numpy. Not with ``work=`` (its arrays live on the CPU).
    hardness:
      the elastic model only: cap H of the local pressure (same units as ``pressure``,
      finite, above it), the elastic-perfectly-plastic (saturated pressure) model: 0 <= p
      <= H, cells at H are plastic, count as contact with gap 0, and the rigid surface
      penetrates the elastic body there by the result's ``plastic_depth``
      (docs/contact.md, "Hardness"). Solved by gfmd (the default: its hard-wall CG with
      the cap, ``contact/gfmd.py`` "Hardness"; on the CPU: ``backend="cupy"`` is refused;
      ``setup=`` and ``work=`` serve it as without a cap) or by ``method="cg"``
      (Polonsky-Keer stages on the plastic set, ``contact/cg.py``; a hardness above every
      pressure of the elastic cg solve gives, from a cold start, its result bit for bit;
      ``max_iter`` bounds the iterations of all stages together). A warm start from a
      capped result carries its plastic depth.
    """
    if model not in MODELS:
        raise InputError(f"model must be one of {MODELS}, got {model!r}")
    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    heights = require_field("surface heights", surface.heights)
    if hardness is not None:
        hardness = _check_hardness(hardness, model, backend)
    if check_backend(backend, model, method, work is not None) == "cupy":
        gpu_check_memory(heights.shape, "an elastic contact solve on the GPU")
    check_memory("bearing" if model == "bearing" else "contact", heights.shape,
                 what=f"a {model} contact solve")
    # checked for every model, the bearing one included (which uses neither): a bad value
    # is a caller's mistake whatever the model
    tol = check_contact_tol(tol)
    method = _check_method(method)
    if model == "bearing":
        if pressure is not None:  # the CLI refuses --pressure the same way
            raise InputError(f"pressure={pressure!r} is not for model='bearing': it cuts the "
                             "heights at area_fraction= and has no pressure")
        return solve_bearing(heights, _check_bearing_area(area_fraction))
    if area_fraction is not None:
        raise InputError(
            f"area_fraction={area_fraction!r} is only for model='bearing'; the {model} model "
            "is load controlled (pressure=)"
        )
    if pressure is None:
        raise InputError(f"the {model} model needs pressure= (mean pressure in E* gbar)")
    if model == "elastic":
        load = require_positive("pressure", pressure)
        if adhesion is not None:
            raise InputError("adhesion= is only for model='adhesive'")
        check_resolved_load(load, surface.gbar, heights.shape)
        if hardness is not None:
            require_below_hardness(load, hardness, load_text=f"pressure {load:g} E*",
                                   hardness_text=f"hardness={hardness:g} E*")
    else:
        load = require_finite("pressure", pressure)
        if not isinstance(adhesion, Adhesion):
            raise InputError(f"model='adhesive' needs adhesion=Adhesion(...), got {adhesion!r}")
        if method != "gfmd":
            raise InputError(f"model='adhesive' needs method='gfmd', got {method!r}")
    check_pressure_scale(load)  # first: a pressure in pascals is the likelier mistake
    if model == "adhesive" and load <= -adhesion.max_tension:
        # the mean tension of cells each pulling at most max_tension: no equilibrium, and
        # the solve would run its max_iter steps before saying so
        raise InputError(
            f"the tensile load {load:g} E* is beyond the adhesion's largest tension "
            f"{adhesion.max_tension:.4g} E* (every cell at its peak pull): no equilibrium "
            "exists (the surfaces separate)")
    if max_iter is None:
        max_iter = CONTACT_MAX_ITER[method]
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise InputError(f"max_iter must be a positive integer, got {max_iter!r}")
    if init is not None:
        if not isinstance(init, ContactResult):
            raise InputError(f"init must be a ContactResult, got {type(init).__name__}")
        if init.gap.shape != heights.shape:
            raise InputError(
                f"init has shape {init.gap.shape} but the surface has shape {heights.shape}"
            )
        # a nan start would leave the solver on nan: name it before any work
        require_field("init.gap", init.gap)
        require_field("init.contact_pressure", init.contact_pressure)

    lx, ly = float(surface.lx), float(surface.ly)
    if model == "adhesive":
        # the adhesion's validity on this grid and at this load (adhesion.check_setup); the
        # warning of an under-resolved zone comes with cold solves only, so that a search or
        # a ladder, which warm-starts all but its first solve, warns once
        check_setup(adhesion, heights, lx, ly, load, warn=init is None)
    if setup is not None:
        from .gfmd import HardWallSetup

        _require_hard_wall("setup", setup, HardWallSetup, "prepare", model, method)
        if setup.heights is not surface.heights or (setup.lx, setup.ly) != (lx, ly):
            raise InputError("setup was prepared for another surface (contact.prepare(surface) "
                             "of the surface being solved)")
        if backend == "cpu" and array_module(setup.h) is not np:
            raise InputError("setup was prepared with backend='cupy'; solve with "
                             "backend='cupy' or prepare(surface) for the CPU")
    if work is not None:
        from .gfmd import HardWallWork

        _require_hard_wall("work", work, HardWallWork, "workspace", model, method)
        if work.shape != heights.shape:
            raise InputError(f"work is for a {work.shape} grid, the surface has shape "
                             f"{heights.shape}")
    if method == "cg":
        from .cg import polonsky_keer

        p0 = None
        if init is not None and init.model != "bearing":
            p0 = init.contact_pressure
        out = polonsky_keer(
            heights, lx, ly, load, tol=tol, max_iter=int(max_iter), p0=p0, threads=threads,
            hardness=hardness,
        )
    else:
        from .gfmd import gfmd

        # elastic surface height = heights + gap (exact for the hard wall; an adhesive
        # result's contact cells, whose gaps were set to zero, from their pressures)
        warm = init is not None
        if init is None and model == "adhesive":
            init = _adhesive_cold_start(surface, load, threads)
        u0 = None
        if init is not None:
            gap0 = init.gap
            if model == "adhesive" and init.model == "adhesive":
                gap0 = adhesion.physical_gap(init.gap, init.contact, init.contact_pressure)
            u0 = np.add(heights, gap0, out=work.u0 if work is not None else None)
            if init.plastic_depth is not None:  # the rigid surface's penetration: u < h
                u0 -= init.plastic_depth
        out = gfmd(
            heights, lx, ly, load, tol=tol, max_iter=int(max_iter), u0=u0,
            adhesion=adhesion if model == "adhesive" else None, threads=threads, setup=setup,
            work=work, backend=backend, hardness=hardness,
        )
        if (model == "adhesive" and load == 0 and warm and out.converged
                and float(out.gap.min()) >= adhesion.range):
            # at zero load a body out of the attraction's range is an equilibrium too, and
            # a warm start from a higher load flew off to it (released, its q = 0 mode
            # overshoots the range: a_c 0.67 at p = 3e-3, then 0 at p = 0, gamma = 16);
            # the attached state, which the cold start reaches from repulsive contact, has
            # the lower energy. Solved here, not by a cold call of solve, whose checks
            # this call made and whose zone warning a warm solve does not repeat.
            log.info("adhesive solve at zero load left the attraction's range from its "
                     "warm start; solving again from the cold start")
            spent = int(out.iterations)
            start = _adhesive_cold_start(surface, load, threads)
            out = gfmd(heights, lx, ly, load, tol=tol, max_iter=int(max_iter),
                       u0=heights + start.gap, adhesion=adhesion, threads=threads,
                       backend=backend)
            out = dataclasses.replace(out, iterations=int(out.iterations) + spent)
    if not out.converged:
        why = ""
        if model == "adhesive" and load < 0:
            # a tensile load beyond the pull-off force has no equilibrium: the body keeps
            # moving off; without this hint the error names only the residual, after what
            # can be minutes of steps (50000 steps at 256^2 take 85 s)
            largest = float(out.gap.max())
            gaps = (f"the largest gap is {largest:.3g}" if math.isfinite(largest)
                    else "the gaps grew without bound")
            why = (f"; the tensile load {load:g} may lie beyond the pull-off force (no "
                   f"equilibrium: the surfaces separate), {gaps} against the range "
                   f"{adhesion.range:.3g}")
        # a solver stops before max_iter only where no equilibrium is left to find (every
        # point beyond the attraction's range under tension) or its iterate is not finite
        stop = (f"within max_iter={max_iter}" if out.iterations >= max_iter else
                f"and stopped after {out.iterations} of max_iter={max_iter} iterations")
        if hardness is not None:  # the capped solve's stages: name the cap and the load
            why += f"; pressure {load:g} capped at the hardness {hardness:g} (same units)"
        raise ConvergenceError(
            f"contact solve ({model}, {method}) did not reach tol={tol:g} {stop}{why}",
            residual=float(out.residual), iterations=int(out.iterations),
        )
    if model == "adhesive":
        check_overlap(adhesion, load, out.pressure)
    return ContactResult(
        gap=out.gap,
        contact_pressure=out.pressure,
        contact=out.contact,
        area_fraction=float(out.contact.mean()),
        mean_gap=float(out.gap.mean()),
        pressure=float(load),
        iterations=int(out.iterations),
        residual=float(out.residual),
        converged=True,
        model=model,
        method=method,
        separation=float(out.separation),
        hardness=hardness,
        plastic=out.plastic,
        plastic_depth=out.plastic_depth,
        plastic_fraction=(float("nan") if out.plastic is None
                          else float(np.count_nonzero(out.plastic)) / out.plastic.size),
    )


def _adhesive_cold_start(surface: Surface, load: float, threads: int | None) -> ContactResult:
    """Where an adhesive solve starts cold: the repulsive contact at the load (at least a
    small one), so that the attraction acts from the first step (a flat start floats at
    zero load)."""
    return solve(surface, max(load, _ADHESIVE_START_LOAD), method="gfmd",
                 tol=_ADHESIVE_START_TOL, threads=threads)


def check_contact_tol(tol: float, name: str = "tol") -> float:
    """``tol`` of a contact solve as a float within [``CONTACT_TOL_MIN``,
    ``CONTACT_TOL_MAX``] (:mod:`roughflow.defaults`), else :class:`InputError` naming
    ``name``."""
    tol = require_positive(name, tol)
    if tol > CONTACT_TOL_MAX:
        raise InputError(f"{name} must be at most {CONTACT_TOL_MAX:g} (a gap error of 1 % of "
                         f"the rms height; a looser one returns the starting state), got "
                         f"{tol!r}")
    if tol < CONTACT_TOL_MIN:
        raise InputError(f"{name} must be at least {CONTACT_TOL_MIN:g} (a gap error the "
                         f"solvers reach in float64; a tighter one stalls on round-off and "
                         f"runs to the iteration cap), got {tol!r}")
    return tol


def check_pressure_scale(pressure: ArrayLike) -> None:
    """:class:`InputError` where a pressure (E*; a scalar or an array) exceeds
    ``CONTACT_PRESSURE_MAX`` E* in magnitude: no linear-elastic contact, but a pressure in
    pascals passed where roughflow takes units of E*."""
    p = np.asarray(pressure, dtype=np.float64).ravel()
    worst = float(p[np.argmax(np.abs(p))]) if p.size else 0.0
    if abs(worst) > CONTACT_PRESSURE_MAX:
        side = "above " if worst > 0 else "below -"
        raise InputError(
            f"pressure {worst:g} E* is {side}{CONTACT_PRESSURE_MAX:g} E*, beyond any "
            f"linear-elastic contact: pressures here are in units of the contact modulus E* "
            f"(from Python, convert pascals with roughflow.units.Scales.pressure_from_si)")


def resolved_load_floor(gbar: float, shape: tuple[int, int]) -> float:
    """The lowest elastic load (E*) a grid of ``shape`` resolves for a surface of rms
    gradient ``gbar``: where the small-load law puts :data:`CONTACT_MIN_CELLS` cells in
    contact (:func:`check_resolved_load` refuses a load below it)."""
    return gbar * elastic_load_for_cells(CONTACT_MIN_CELLS, shape[0] * shape[1])


def check_resolved_load(pressure: float, gbar: float, shape: tuple[int, int]) -> None:
    """:class:`InputError` where an elastic load is below what the grid resolves
    (:func:`resolved_load_floor`): the small-load law puts fewer than
    :data:`CONTACT_MIN_CELLS` cells in contact."""
    floor = resolved_load_floor(gbar, shape)
    if pressure < floor:
        raise InputError(
            f"pressure {pressure:g} E* is below what a {shape[0]} x {shape[1]} grid resolves "
            f"({floor:.3g} E* for its rms gradient {gbar:.3g}): the elastic law puts "
            f"{CONTACT_MIN_CELLS:g} of one cell in contact there, the contact is a single "
            "cell from about a thousand times that load down, and the solver's load balance "
            "reaches round-off")


def _check_hardness(hardness, model: str, backend: str) -> float:
    """``hardness=`` as a float: a positive finite number, for the elastic model, solved on
    the CPU (the hard wall's CUDA kernels have no pressure cap: ``backend="cupy"`` is
    refused)."""
    h = check_hardness(hardness, model)
    if backend == "cupy":
        raise InputError("hardness= is solved on the CPU, not with backend='cupy': the "
                         "GPU's hard-wall kernels have no pressure cap")
    return h


def _check_method(method: str | None) -> str:
    """``method``, None meaning "gfmd" (the default)."""
    if method is None:
        return "gfmd"
    if method not in METHODS:
        raise InputError(f"method must be one of {METHODS}, got {method!r}")
    return method


def _check_bearing_area(area_fraction) -> float:
    """The bearing model's target area: a number in [0, 1] (bools refused: True is no
    area)."""
    if area_fraction is None:
        raise InputError("the bearing model needs area_fraction=")
    if isinstance(area_fraction, (bool, np.bool_)):
        raise InputError(f"area_fraction must be a number in [0, 1], got {area_fraction!r}")
    a = require_finite("area_fraction", area_fraction)
    if not 0.0 <= a <= 1.0:
        raise InputError(f"area_fraction must lie in [0, 1], got {area_fraction!r}")
    return a


def _require_hard_wall(what: str, value, kind: type, maker: str, model: str,
                       method: str) -> None:
    """``setup=`` and ``work=`` come from ``contact.<maker>`` and serve elastic gfmd only."""
    if not isinstance(value, kind):
        raise InputError(f"{what} must come from contact.{maker}, got {type(value).__name__}")
    if model != "elastic" or method != "gfmd":
        raise InputError(f"{what}= is for model='elastic' with method='gfmd', got "
                         f"model={model!r}, method={method!r}")


def workspace(surface: Surface) -> HardWallWork:
    """The arrays of elastic gfmd solves of ``surface``'s grid, reused by every solve given
    ``work=`` (see :func:`solve`; about 64 bytes per grid point, a capped solve's plastic
    mask and depth included)."""
    from .gfmd import hard_wall_work

    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    return hard_wall_work(surface.shape)


def prepare(surface: Surface, threads: int | None = None,
            backend: str = DEFAULT_BACKEND) -> HardWallSetup:
    """What every elastic gfmd solve of ``surface`` derives from its heights alone (centred
    heights, rms height, preconditioner), built once for ``solve(..., setup=)``. Valid while
    the heights are not modified. ``backend="cupy"``: built on the GPU, for solves with
    ``backend="cupy"`` (a CPU-built one serves them too, copied to the GPU once)."""
    from .gfmd import hard_wall_setup

    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    check_backend(backend)
    heights = require_field("surface heights", surface.heights)
    setup = hard_wall_setup(heights, float(surface.lx), float(surface.ly), threads, backend)
    return dataclasses.replace(setup, heights=surface.heights)  # the array solve() checks
