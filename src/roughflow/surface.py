"""Random-phase rough surfaces, isotropic and Peklenik-anisotropic (paper Sect. 2.1, Eq. 1-2).

Fourier amplitudes are deterministic, |h~(q)| = sqrt(C(q_P)), phases uniform on
[0, 2 pi) (random-phase approximation), with the effective wavenumber (Eq. 1)

    q_P = sqrt(gamma q_x^2 + q_y^2 / gamma),

so gamma > 1 stretches the surface along x (axis 0). The spectrum (Eq. 2, with the
exponent corrected as in docs/physics.md Sect. 2: the 2D spectrum of a self-affine
surface falls as q^(-2(1+H)))

    C(q) ~ Theta(q_s - q) / (1 + (q/q_r)^2)^(1+H)          (rolloff="smooth")
    C(q) ~ Theta(q_s - q) min(1, (q/q_r)^(-2(1+H)))        (rolloff="plateau")

Heights are normalised to the rms gradient ``rms_slope`` computed spectrally from
the discrete spectrum with the true q_x, q_y (rectangular cells work). Units:
lengths in units of the cell's linear size (default L = 1), heights in the same
unit, slopes dimensionless.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from roughflow import defaults, fft
from roughflow._repr import summary_repr
from roughflow.defaults import ROLLOFF_FORMS
from roughflow.errors import (
    MAX_SEED,
    InputError,
    require_field,
    require_finite,
    require_int,
    require_positive,
    require_squares_in_range,
)
from roughflow.gpu import array_module

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

__all__ = ["paper_l_over_lambda_r", "SurfaceSpec", "fft_friendly", "ScanInfo", "Surface",
           "spec_power", "mirror_tiled", "spectrum", "peklenik_wavenumber",
           "rms_gradient", "spectral_rms_gradient", "generate"]


def paper_l_over_lambda_r(gamma: float) -> float:
    """The paper's default size L / lambda_r = 4 max(sqrt(gamma), 1/sqrt(gamma)): four
    roll-off wavelengths in the easy direction."""
    s = math.sqrt(require_positive("gamma", gamma))
    return defaults.PAPER_SIZE_FACTOR * max(s, 1.0 / s)


@dataclass(frozen=True)
class SurfaceSpec:
    """Parameters of a random-phase surface on an ``nx`` x ``ny`` grid of size ``lx`` x ``ly``.

    ``lambda_r`` and ``lambda_s`` are the roll-off and short-cutoff wavelengths of the
    underlying isotropic surface (q_r = 2 pi / lambda_r, q_s = 2 pi / lambda_s).
    Validation happens on construction; bad values raise :class:`InputError`.
    """

    nx: int
    ny: int
    lx: float
    ly: float
    hurst: float
    gamma: float
    lambda_r: float
    lambda_s: float
    seed: int
    rms_slope: float = 1.0
    rolloff: str = defaults.ROLLOFF

    def __post_init__(self) -> None:
        for name in ("nx", "ny"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 4:
                raise InputError(f"{name} must be an integer >= 4, got {v!r}")
        # stored as the floats they were checked as: a number given as a string ("0.8")
        # otherwise failed later, with a TypeError deep in the spectrum
        for name in ("lx", "ly", "gamma", "lambda_r", "lambda_s", "rms_slope"):
            object.__setattr__(self, name, require_positive(name, getattr(self, name)))
        h = require_finite("hurst", self.hurst)
        if not 0 < h <= 1:
            raise InputError(f"hurst must lie in (0, 1], got {self.hurst!r}")
        object.__setattr__(self, "hurst", h)
        require_int("seed", self.seed, minimum=0, maximum=MAX_SEED)
        if self.rolloff not in ROLLOFF_FORMS:
            raise InputError(f"rolloff must be one of {ROLLOFF_FORMS}, got {self.rolloff!r}")
        if self.lambda_s > self.lambda_r:
            raise InputError(
                f"lambda_s={self.lambda_s!r} exceeds lambda_r={self.lambda_r!r}"
            )
        sg = math.sqrt(self.gamma)
        # Shortest wavelength kept along each axis: the cutoff ellipse q_P = q_s.
        shortest = (("x", self.lambda_s * sg, self.dx), ("y", self.lambda_s / sg, self.dy))
        for axis, lam, d in shortest:
            if lam < 2 * d * (1 - defaults.GRID_ROUNDING_SLACK):  # as from_sweep rounds
                raise InputError(
                    f"lambda_s={self.lambda_s!r} is under two grid spacings along {axis}: the "
                    f"shortest wavelength there is {lam:.4g} but the spacing is {d:.4g} "
                    f"(gamma={self.gamma!r}); use a finer grid or a larger lambda_s"
                )
        longest = (("x", self.lambda_r * sg, self.lx), ("y", self.lambda_r / sg, self.ly))
        for axis, lam, length in longest:
            if lam > length * (1 + 1e-12):
                raise InputError(
                    f"lambda_r={self.lambda_r!r} is larger than the cell: its stretched length "
                    f"along {axis} is {lam:.4g} > l{axis}={length!r} (gamma={self.gamma!r})"
                )

    @property
    def dx(self) -> float:
        return self.lx / self.nx

    @property
    def dy(self) -> float:
        return self.ly / self.ny

    def as_attrs(self) -> dict:
        """Parameters as a flat dict (for netCDF attributes)."""
        return asdict(self)

    @classmethod
    def from_sweep(
        cls,
        *,
        gamma: float = defaults.GAMMA,
        hurst: float = defaults.HURST,
        l_over_lambda_r: float | None = None,
        eps_f: float = defaults.EPS_F,
        points_per_lambda_s: float = defaults.POINTS_PER_LAMBDA_S,
        aspect: float = defaults.ASPECT,
        seed: int = 0,
        rolloff: str = defaults.ROLLOFF,
        area: float = 1.0,
        multiple_of: int = 1,
    ) -> SurfaceSpec:
        """Spec from the sweep's dimensionless numbers.

        The cell has area ``area`` (default 1) and aspect ratio ``aspect = lx / ly``;
        ``L = sqrt(lx ly)``. ``l_over_lambda_r`` defaults to the paper's
        ``4 max(sqrt(gamma), 1/sqrt(gamma))``; ``lambda_s = eps_f lambda_r``.
        The grid has at least ``points_per_lambda_s`` points per shortest wavelength
        along each axis (lambda_s sqrt(gamma) along x, lambda_s / sqrt(gamma) along y),
        rounded up to an FFT-friendly size (2^a 3^b 5^c, even), or with ``multiple_of`` = k
        to k times one (so that taking every k-th point, or every j-th for j dividing k,
        gives whole grids: the accuracy study's sampled-down resolutions).
        """
        gamma = require_positive("gamma", gamma)
        area = require_positive("area", area)
        aspect = require_positive("aspect", aspect)
        eps_f = require_positive("eps_f", eps_f)
        ppl = require_positive("points_per_lambda_s", points_per_lambda_s)
        if ppl < 2:
            raise InputError(f"points_per_lambda_s must be >= 2, got {points_per_lambda_s!r}")
        if eps_f > 1:
            raise InputError(f"eps_f = lambda_s/lambda_r must be <= 1, got {eps_f!r}")
        sg = math.sqrt(gamma)
        if l_over_lambda_r is None:
            l_over_lambda_r = paper_l_over_lambda_r(gamma)
        l_over_lambda_r = require_positive("l_over_lambda_r", l_over_lambda_r)
        length = math.sqrt(area)
        lx, ly = length * math.sqrt(aspect), length / math.sqrt(aspect)
        lambda_r = length / l_over_lambda_r
        lambda_s = eps_f * lambda_r
        k = require_int("multiple_of", multiple_of, minimum=1)
        slack = defaults.GRID_ROUNDING_SLACK
        nx = k * fft_friendly(math.ceil(math.ceil(ppl * lx / (lambda_s * sg) - slack) / k))
        ny = k * fft_friendly(math.ceil(math.ceil(ppl * ly / (lambda_s / sg) - slack) / k))
        return cls(
            nx=nx, ny=ny, lx=lx, ly=ly, hurst=hurst, gamma=gamma,
            lambda_r=lambda_r, lambda_s=lambda_s, seed=seed, rolloff=rolloff,
        )


def fft_friendly(n: int) -> int:
    """Smallest even integer >= max(n, 4) whose prime factors are 2, 3 and 5."""
    m = max(int(n), 4)
    while True:
        if m % 2 == 0:
            k = m
            for p in (2, 3, 5):
                while k % p == 0:
                    k //= p
            if k == 1:
                return m
        m += 1


@dataclass(frozen=True)
class ScanInfo:
    """Where an imported (measured) surface came from and how it was prepared.

    ``length_scale``: the reference length L in metres (sqrt(lx ly) of the scan as
    imported; heights and lengths of the :class:`Surface` are in units of L).
    ``rms_gradient``: rms gradient of the imported heights (finite differences, the scan
    being non-periodic); the scan keeps it, so its dimensionless pressures are in E*, not
    E* gbar. ``detrend``, ``fill``: the choices of :func:`roughflow.scan.read_scan`; ``filled``: the
    number of missing points filled; ``crop``: the grid window kept ("none" or
    "i0:i1,j0:j1"); ``periodic``: whether the surface is periodic (a scan is not; the
    contact and flow stages then use :mod:`roughflow.boundary`); ``warnings``: what the
    import warned about ("; "-joined, "" for nothing), kept so that a workflow's results
    say it and not only the import's log. ``missing_value``: the value that marked
    missing points in the file ("none", or the number as given).
    """

    source: str
    reader: str
    channel: str
    length_scale: float
    rms_gradient: float
    detrend: str
    fill: str
    filled: int
    crop: str = "none"
    periodic: bool = False
    warnings: str = ""
    missing_value: str = "none"

    def as_attrs(self) -> dict:
        """Fields as a flat dict (for netCDF attributes, prefixed ``scan_``)."""
        return asdict(self)


@dataclass(frozen=True, eq=False)
class Surface:
    """Heights ``heights[ix, iy]`` (float64) of a cell of size ``lx`` x ``ly``: periodic
    (generated, ``spec``) or an imported scan (``scan``, usually not periodic).

    ``heights`` is held as a read-only view, so the surface cannot be changed through it
    (a prepared solver setup or a recorded gbar would then describe another surface). The
    constructor does not copy the array it is given; :meth:`from_array` does."""

    __repr__ = summary_repr

    heights: np.ndarray
    lx: float
    ly: float
    spec: SurfaceSpec | None = None
    scan: ScanInfo | None = None

    def __post_init__(self) -> None:
        # stored as checked: a list, nan heights or a masked scan failed (or went wrong)
        # only later, in whichever stage met them first
        # C order: sums over the heights (the mean level of the solvers) run in memory
        # order, so a Fortran-ordered or transposed array gave other last bits
        heights = np.ascontiguousarray(require_field("surface heights", self.heights))
        if min(heights.shape) < 4:  # the one size rule of every surface (from_array too)
            raise InputError(f"heights must be at least 4 x 4, got shape {heights.shape}")
        view = heights.view()
        view.flags.writeable = False
        object.__setattr__(self, "heights", view)
        for name in ("lx", "ly"):
            object.__setattr__(self, name, require_positive(name, getattr(self, name)))

    @property
    def periodic(self) -> bool:
        """False for a non-periodic (measured) scan; True otherwise."""
        return self.scan is None or bool(self.scan.periodic)

    @cached_property  # the heights are read-only: computed once (0.2 s at 2048^2)
    def gbar(self) -> float:
        """The rms gradient gbar that contact pressures scale with (pressures are in E*; a
        generated surface's gbar is its spec's rms slope, 1 by default, so there E* gbar =
        E*): a scan's recorded value (finite differences, its edges not joined), else
        :func:`rms_gradient` of the heights."""
        if self.spec is not None:
            return float(self.spec.rms_slope)
        if self.scan is not None:
            return float(self.scan.rms_gradient)
        return rms_gradient(self.heights, self.lx, self.ly, periodic=self.periodic)

    @property
    def shape(self) -> tuple[int, int]:
        return self.heights.shape

    @property
    def dx(self) -> float:
        return self.lx / self.heights.shape[0]

    @property
    def dy(self) -> float:
        return self.ly / self.heights.shape[1]

    @classmethod
    def from_array(cls, heights: ArrayLike, lx: float = 1.0, ly: float | None = None) -> Surface:
        """Wrap a user height map (validated: 2D, finite, at least 4 x 4) as a periodic
        cell. Heights, ``lx`` and ``ly`` are in one length unit (the solvers take E* = 1,
        so pressures come out in E*). ``ly=None`` means square pixels,
        ``ly = lx * ny / nx`` for heights of shape (nx, ny): a 128 x 256 map with ``lx=1``
        gets a 1 x 2 cell, so give ``ly`` for any other cell. A measured map is better read
        with :func:`roughflow.scan.read_scan`: it records the physical units, and leak
        calculations then treat its edges as non-periodic (docs/measured.md). A file
        written by ``roughflow surface`` or ``roughflow import`` is read back, cell and
        scale included, with :func:`roughflow.io.read_surface`."""
        from roughflow.errors import require_field

        h = require_field("heights", heights)
        lx = require_positive("lx", lx)
        ly = lx * h.shape[1] / h.shape[0] if ly is None else require_positive("ly", ly)
        # a copy: the caller's array, changed in place later (h *= 1e-6 in a notebook),
        # changed the surface under a prepared setup, which then solved the old one
        return cls(heights=np.array(h, dtype=np.float64, order="C", copy=True), lx=lx, ly=ly)


def spec_power(spec: SurfaceSpec) -> tuple[np.ndarray, np.ndarray]:
    """|q| and the power w |h_q|^2 of each rfft mode (w: :func:`roughflow.fft.rfft_weights`,
    each mode of the full plane counted once) of the heights that :func:`generate` makes
    from ``spec``, whatever its seed: the amplitudes are deterministic, the seed sets the
    phases only. sum(q^2 power) = rms_slope^2. A spectral moment of a spec's surfaces
    (its full-contact energy, its curvature) costs this, not a surface."""
    from roughflow.resources import check_memory

    check_memory("spectrum", (spec.nx, spec.ny), what="the spectrum (mode powers) of a spec")
    qx, qy = fft.wavevectors(spec.nx, spec.ny, spec.lx, spec.ly)
    q = np.sqrt(qx * qx + qy * qy)
    power = spectrum(peklenik_wavenumber(qx, qy, spec.gamma), spec) * fft.rfft_weights(spec.ny)
    m2 = float((q * q * power).sum())
    if m2 == 0:
        raise InputError(f"spectrum of {spec} has no modes inside the cutoff")
    return q, power * (spec.rms_slope**2 / m2)


def mirror_tiled(heights: np.ndarray) -> np.ndarray:
    """The 2 x 2 periodic cell of a non-periodic height map and its mirror images along x,
    y and both: continuous across every seam, so its spectrum has no wrap-around step."""
    top = np.concatenate([heights, heights[:, ::-1]], axis=1)
    return np.concatenate([top, top[::-1, :]], axis=0)


def spectrum(q: np.ndarray, spec: SurfaceSpec) -> np.ndarray:
    """Unnormalised C(q) of Eq. (2) (corrected exponent), zero at q = 0 and beyond q_s."""
    qr = 2 * np.pi / spec.lambda_r
    qs = 2 * np.pi / spec.lambda_s
    x = q / qr
    if spec.rolloff == "smooth":
        c = (1.0 + x * x) ** (-(1.0 + spec.hurst))
    else:
        with np.errstate(divide="ignore"):
            c = np.minimum(1.0, x ** (-2.0 * (1.0 + spec.hurst)))
    return np.where((q > 0) & (q <= qs * (1 + 1e-12)), c, 0.0)


def peklenik_wavenumber(qx: np.ndarray, qy: np.ndarray, gamma: float) -> np.ndarray:
    """Effective wavenumber q_P = sqrt(gamma q_x^2 + q_y^2 / gamma), Eq. (1)."""
    return np.sqrt(gamma * qx * qx + qy * qy / gamma)


def rms_gradient(heights: np.ndarray, lx: float, ly: float, *, periodic: bool = True) -> float:
    """Rms gradient sqrt(<|grad h|^2>) of a height map: spectral for a periodic map, from
    forward differences inside the map for a non-periodic one (a scan's wrap-around step
    would dominate the spectral value). Heights whose squares overflow or underflow raise
    :class:`InputError` (:func:`roughflow.errors.require_squares_in_range`), not a nan or 0."""
    heights = require_field("heights", heights)  # an unsigned dtype wrapped in np.diff
    nx, ny = heights.shape
    if not periodic and min(nx, ny) < 2:
        raise InputError(f"a non-periodic rms gradient needs 2 points along each axis, "
                         f"got a {nx} x {ny} grid")
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):  # checked below
        if periodic:
            g = spectral_rms_gradient(fft.rfft2(heights), (nx, ny), lx, ly)
        else:
            gx = np.diff(heights, axis=0) * (nx / lx)
            gy = np.diff(heights, axis=1) * (ny / ly)
            g = float(np.sqrt(np.mean(gx * gx) + np.mean(gy * gy)))
    # the cell's size enters too: on a 1e-300 wide cell ordinary heights overflow
    return require_squares_in_range(f"heights' gradients on the {lx:g} x {ly:g} cell", g,
                                    heights)


def spectral_rms_gradient(spectrum: np.ndarray, shape: tuple[int, int], lx: float,
                          ly: float) -> float:
    """Rms gradient of a periodic height map of ``shape`` from its (unnormalised) rfft2
    ``spectrum``: sqrt(sum |q|^2 |h(q)|^2) / N, by Parseval."""
    nx, ny = shape
    xp = array_module(spectrum)  # numpy, or CuPy for a spectrum on the GPU
    qx, qy = (xp.asarray(q) for q in fft.wavevectors(nx, ny, lx, ly))
    w = xp.asarray(fft.rfft_weights(ny))
    return float(xp.sqrt((w * (qx**2 + qy**2) * xp.abs(spectrum) ** 2).sum())) / (nx * ny)


def _phase_box(spec: SurfaceSpec) -> tuple[np.ndarray, int, int]:
    """Uniform phases on the integer wavevectors |k_x| <= K_x, 0 <= k_y <= K_y enclosing the cutoff.

    The box depends only on the cell, gamma, lambda_s and the seed, not on the grid, so one
    seed gives the same physical surface at every resolution (a band-limited function
    sampled on finer grids): resolution studies compare like with like. Its extents change
    with gamma, and every phase with them: one seed at two gammas, or at gamma and 1/gamma,
    is two unrelated surfaces (docs/physics.md, "What a seed fixes").

    The phases are 2 pi (r >> 11) 2^-53 of the raw 64-bit outputs r of PCG64 seeded with
    ``seed``: numpy keeps a bit generator's raw stream fixed across versions (NEP 19), not
    the streams of ``Generator`` methods. (``Generator.uniform`` gives the same numbers
    today.)
    """
    qs = 2 * np.pi / spec.lambda_s
    kx_max = int(np.floor(qs / math.sqrt(spec.gamma) * spec.lx / (2 * np.pi)
                      + defaults.GRID_ROUNDING_SLACK))
    ky_max = int(np.floor(qs * math.sqrt(spec.gamma) * spec.ly / (2 * np.pi)
                      + defaults.GRID_ROUNDING_SLACK))
    shape = (2 * kx_max + 1, ky_max + 1)
    raw = np.random.PCG64(spec.seed).random_raw(shape[0] * shape[1]).reshape(shape)
    phases = (raw >> np.uint64(11)).astype(np.float64) * (2.0**-53 * 2 * np.pi)
    return phases, kx_max, ky_max


def generate(spec: SurfaceSpec) -> Surface:
    """Random-phase surface for ``spec``: real, zero mean, rms gradient ``spec.rms_slope``.

    Amplitudes sqrt(C(q_P)) are deterministic; phases come from :func:`_phase_box`, so the
    same seed gives the same surface on any grid with more than 2 points per lambda_s
    (coarse = fine[::2, ::2]; at exactly 2 the modes at the cutoff lie on the Nyquist row
    or column, where a real grid keeps only their cosine part: 3e-3 of the rms height).
    Exact Hermitian symmetry on the half (rfft) spectrum: in the columns q_y = 0 and
    q_y = Nyquist the phase of -q is minus that of q (a difference of two independent
    uniform phases is again uniform); the self-conjugate modes (q_x and q_y each 0 or
    Nyquist) get a real amplitude of random sign. Peak memory about 32 bytes per point.
    """
    from roughflow.resources import check_memory

    if not isinstance(spec, SurfaceSpec):
        raise InputError(f"generate needs a SurfaceSpec, got {type(spec).__name__}")
    nx, ny = spec.nx, spec.ny
    check_memory("surface", (nx, ny), what="generating a surface")
    box, kx_max, ky_max = _phase_box(spec)
    qx, qy = fft.wavevectors(nx, ny, spec.lx, spec.ly)
    half = peklenik_wavenumber(qx, qy, spec.gamma)
    half = np.sqrt(spectrum(half, spec)).astype(np.complex128)

    kx = np.rint(np.fft.fftfreq(nx) * nx).astype(np.int64)
    ky = np.arange(ny // 2 + 1)
    rows = np.flatnonzero(np.abs(kx) <= kx_max)
    cols = ky[ky <= ky_max]
    phase = np.zeros(half.shape)
    phase[np.ix_(rows, cols)] = box[np.ix_(kx[rows] + kx_max, cols)]
    self_conj_rows = [0] + ([nx // 2] if nx % 2 == 0 else [])
    for col in [0] + ([ny // 2] if ny % 2 == 0 else []):
        if col > ky_max:
            continue
        b = box[:, col]
        phi = b[kx[rows] + kx_max] - b[np.clip(-kx[rows], -kx_max, kx_max) + kx_max]
        phase[rows, col] = phi
        for r in self_conj_rows:
            if abs(kx[r]) <= kx_max:
                phase[r, col] = np.pi * (np.cos(b[kx[r] + kx_max]) < 0)
    half *= np.exp(1j * phase)
    del phase
    heights = fft.irfft2(half, (nx, ny))
    heights -= heights.mean()
    g = rms_gradient(heights, spec.lx, spec.ly)
    if g == 0:
        raise InputError(f"spectrum of {spec} has no modes inside the cutoff")
    heights *= spec.rms_slope / g
    return Surface(heights=heights, lx=spec.lx, ly=spec.ly, spec=spec)
