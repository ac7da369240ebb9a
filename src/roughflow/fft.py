"""Real 2D FFTs through pyFFTW with plans cached per shape and thread count.

Every stage that needs FFTs goes through this module. The thread count is an
argument; its default comes from the environment variable
``ROUGHFLOW_FFT_THREADS`` (default 1: on a shared two-core machine one thread is
usually fastest when the other core is busy). The planner effort comes from
``ROUGHFLOW_FFTW_EFFORT`` (default ``FFTW_MEASURE``: algorithms picked by timing, with
the timings kept per machine by :mod:`roughflow.wisdom`; ``FFTW_ESTIMATE`` plans at once
by heuristics, and its transforms take 1.4-2.6x as long from 1024^2 on).

Normalisation follows numpy: ``irfft2(rfft2(a)) == a``.
"""

from __future__ import annotations

import functools
import os
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import TypeVar

import numpy as np

from roughflow import wisdom
from roughflow.errors import InputError, require_int

#: More FFT threads than this is a typo, not a machine.
MAX_THREADS = 4096

_EFFORTS = ("FFTW_ESTIMATE", "FFTW_MEASURE", "FFTW_PATIENT", "FFTW_EXHAUSTIVE")

#: The planner effort unless ``ROUGHFLOW_FFTW_EFFORT`` names another.
DEFAULT_EFFORT = "FFTW_MEASURE"


def default_threads() -> int:
    """Thread count from ``ROUGHFLOW_FFT_THREADS`` (default 1)."""
    raw = os.environ.get("ROUGHFLOW_FFT_THREADS", "1")
    try:
        n = int(raw)
    except ValueError:
        raise InputError(f"ROUGHFLOW_FFT_THREADS must be a positive integer, got {raw!r}") from None
    if not 1 <= n <= MAX_THREADS:
        raise InputError(f"ROUGHFLOW_FFT_THREADS must be an integer from 1 to {MAX_THREADS}, "
                         f"got {raw!r}")
    return n


def check_threads(threads: int | None) -> int | None:
    """``threads`` (None: the environment's default) or :class:`InputError` unless it is a
    positive integer (0 or a negative count reached FFTW as an OverflowError)."""
    if threads is None:
        return None
    return require_int("threads", threads, minimum=1, maximum=MAX_THREADS)


def effort() -> str:
    """FFTW's planner effort from ``ROUGHFLOW_FFTW_EFFORT`` (default :data:`DEFAULT_EFFORT`)."""
    effort = os.environ.get("ROUGHFLOW_FFTW_EFFORT", DEFAULT_EFFORT)
    if effort not in _EFFORTS:
        raise InputError(f"ROUGHFLOW_FFTW_EFFORT must be one of {_EFFORTS}, got {effort!r}")
    return effort


def check_environment() -> None:
    """:class:`InputError` naming the value unless ``ROUGHFLOW_FFT_THREADS``,
    ``ROUGHFLOW_FFTW_EFFORT`` and ``ROUGHFLOW_FFTW_WISDOM`` are valid: the command line checks
    them before any work, not at its first FFT plan."""
    default_threads()
    effort()
    wisdom.directory()


class PlanPair:
    """What a forward/inverse pair of real 2D FFT plans offers on top of its two executes
    and its four buffers (``_real``, ``_cplx``, ``_cplx_in``, ``_real_out``): the buffers by
    role, and transforms of given arrays. Shared by :class:`RealFFT2` (pyFFTW) and
    ``roughflow.gpu.CupyRealFFT2`` (cuFFT)."""

    shape: tuple[int, int]

    @property
    def real_in(self) -> np.ndarray:
        """Input buffer of :meth:`execute_forward` (solvers write into it directly)."""
        return self._real

    @property
    def spectral_out(self) -> np.ndarray:
        """Output buffer of :meth:`execute_forward`."""
        return self._cplx

    @property
    def spectral_in(self) -> np.ndarray:
        """Input buffer of :meth:`execute_inverse` (destroyed by it)."""
        return self._cplx_in

    @property
    def real_out(self) -> np.ndarray:
        """Output buffer of :meth:`execute_inverse`."""
        return self._real_out

    def execute_forward(self) -> np.ndarray:
        """Forward transform of :attr:`real_in` (preserved) into :attr:`spectral_out`, no copies."""
        raise NotImplementedError

    def execute_inverse(self) -> np.ndarray:
        """Unnormalised inverse of :attr:`spectral_in` into :attr:`real_out` (the caller folds
        1/(nx ny) into its spectral factors: one pass over memory less than :meth:`inverse`)."""
        raise NotImplementedError

    def forward(self, a: np.ndarray) -> np.ndarray:
        """Unnormalised forward transform (numpy's ``rfft2`` convention)."""
        self._real[...] = a
        return self.execute_forward()

    def inverse(self, c: np.ndarray) -> np.ndarray:
        """Inverse transform normalised by 1/(nx ny) (numpy's ``irfft2``)."""
        self._cplx_in[...] = c
        self.execute_inverse()
        self._real_out *= 1.0 / (self.shape[0] * self.shape[1])
        return self._real_out


class RealFFT2(PlanPair):
    """A forward/inverse pair of real 2D FFT plans for one shape.

    ``forward(a)`` and ``inverse(c)`` return views of internal buffers that
    the next call overwrites: copy them if you keep them. ``single=True``: float32 and
    complex64 buffers (FFTW's single-precision library; about 0.6-0.7 of the time of a
    double pair here), for iterations whose transforms need only relative accuracy.
    """

    def __init__(self, shape: tuple[int, int], threads: int, single: bool = False,
                 planner: str | None = None):
        import pyfftw  # here, not at import: it loads scipy.fft (1 s in python -X importtime)

        nx, ny = shape
        self.shape = (int(nx), int(ny))
        self.spectral_shape = (int(nx), int(ny) // 2 + 1)
        self.threads = threads
        planner = effort() if planner is None else planner
        self.effort = planner
        real, cplx = (np.float32, np.complex64) if single else (np.float64, np.complex128)
        # planning with FFTW_MEASURE overwrites the buffers: they are filled only after it
        self._real = pyfftw.empty_aligned(self.shape, dtype=real)
        self._cplx = pyfftw.empty_aligned(self.spectral_shape, dtype=cplx)
        self._cplx_in = pyfftw.empty_aligned(self.spectral_shape, dtype=cplx)
        self._real_out = pyfftw.empty_aligned(self.shape, dtype=real)
        with wisdom.shared(planner):
            self._fwd = pyfftw.FFTW(
                self._real, self._cplx, axes=(0, 1), direction="FFTW_FORWARD",
                flags=(planner,), threads=threads,
            )
            # FFTW_DESTROY_INPUT is the default for c2r; the input buffer is private.
            self._inv = pyfftw.FFTW(
                self._cplx_in, self._real_out, axes=(0, 1), direction="FFTW_BACKWARD",
                flags=(planner,), threads=threads,
            )

    def execute_forward(self) -> np.ndarray:
        self._fwd.execute()
        return self._cplx

    def execute_inverse(self) -> np.ndarray:
        self._inv.execute()
        return self._real_out


T = TypeVar("T")


def per_thread_cache(maxsize: int) -> Callable[[Callable[..., T]], Callable[..., T]]:
    """``functools.lru_cache`` with one cache per Python thread, for plans with buffers.

    A plan's buffers are written and read by every solve that uses it, and pyFFTW's
    executes (cuFFT's too) and the numba kernels release the GIL: two threads sharing one
    plan overwrite each other's transforms and return wrong numbers. With a cache per
    thread, each thread plans its own shapes (from FFTW's wisdom, so the same algorithm
    and bit-identical results) and the plans go with the thread. ``cache_clear()`` empties
    the calling thread's cache."""
    def decorate(make: Callable[..., T]) -> Callable[..., T]:
        local = threading.local()

        def entries() -> OrderedDict:
            if not hasattr(local, "entries"):
                local.entries = OrderedDict()
            return local.entries

        @functools.wraps(make)
        def cached(*key):
            cache = entries()
            if key in cache:
                cache.move_to_end(key)
                return cache[key]
            value = cache[key] = make(*key)
            if len(cache) > maxsize:
                cache.popitem(last=False)
            return value

        cached.cache_clear = lambda: entries().clear()
        return cached
    return decorate


@per_thread_cache(maxsize=16)
def _plan(shape: tuple[int, int], threads: int, single: bool, planner: str) -> RealFFT2:
    return RealFFT2(shape, threads, single, planner)


def plan(shape: tuple[int, int], threads: int | None = None, single: bool = False) -> RealFFT2:
    """:class:`RealFFT2` for ``shape``, cached per Python thread (reused plans share their
    buffers within a thread, never between threads); ``single``: the float32 plan of the
    same shape. ``threads`` None takes ``ROUGHFLOW_FFT_THREADS`` as it is now, and the
    planner effort is ``ROUGHFLOW_FFTW_EFFORT`` as it is now, so a plan of the settings in
    force is returned (not those of the first call), as the files' provenance records."""
    threads = check_threads(threads)
    return _plan((int(shape[0]), int(shape[1])),
                 default_threads() if threads is None else threads, bool(single), effort())


plan.cache_clear = _plan.cache_clear


def rfft2(a: np.ndarray, threads: int | None = None) -> np.ndarray:
    """Forward real FFT of a 2D array; returns a new array."""
    a = np.asarray(a, dtype=np.float64)
    if a.ndim != 2:
        raise InputError(f"rfft2 takes a 2D array, got shape {a.shape}")
    return plan(a.shape, threads).forward(a).copy()


def irfft2(c: np.ndarray, shape: tuple[int, int], threads: int | None = None) -> np.ndarray:
    """Inverse of :func:`rfft2` for a real array of ``shape``; returns a new array."""
    shape = tuple(int(v) for v in shape)
    half = (shape[0], shape[1] // 2 + 1) if len(shape) == 2 else None
    if half is None or np.shape(c) != half:
        # the plan's buffer would broadcast a single row over every row without a word
        raise InputError(f"irfft2 of a {shape} array takes a spectrum of shape {half}, got "
                         f"{np.shape(c)}")
    return plan(shape, threads).inverse(c).copy()


def wavevectors(nx: int, ny: int, lx: float, ly: float) -> tuple[np.ndarray, np.ndarray]:
    """Wavevector components ``(qx, qy)`` on the rfft2 grid, broadcastable to (nx, ny//2+1).

    ``qx = 2 pi k / lx`` for k in numpy's ``fftfreq`` order, ``qy`` for ``rfftfreq``.
    """
    qx = 2 * np.pi * np.fft.fftfreq(nx, d=lx / nx)
    qy = 2 * np.pi * np.fft.rfftfreq(ny, d=ly / ny)
    return qx[:, None], qy[None, :]


def rfft_weights(ny: int) -> np.ndarray:
    """Multiplicity of each rfft2 column in the full spectrum (1 or 2), shape (1, ny//2+1).

    Sums over the full spectrum equal ``(weights * f(half spectrum)).sum()``.
    """
    w = np.full(ny // 2 + 1, 2.0)
    w[0] = 1.0
    if ny % 2 == 0:
        w[-1] = 1.0
    return w[None, :]
