"""The optional CuPy backend: the array module, and cuFFT plans with the buffer interface of
:class:`roughflow.fft.RealFFT2`.

The CPU (numpy, pyFFTW, numba) is the default and never imports CuPy. A solver that takes
``backend="cupy"`` runs the same algorithm on the GPU: its arrays are ``cupy`` arrays, its
transforms the plans below, and its fused loops the CUDA forms of the numba kernels
(``contact._cuda_kernels``; their array-module twins, ``contact._kernels``, suffix ``_np``,
run on either device). Install with ``pip install "roughflow[gpu]"`` (CuPy
for CUDA 12; on CUDA 13 install ``cupy-cuda13x`` instead).
"""

from __future__ import annotations

from functools import lru_cache
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from roughflow.defaults import BACKENDS, DEFAULT_MODEL
from roughflow.errors import InputError
from roughflow.fft import PlanPair, per_thread_cache
from roughflow.resources import check_memory as _check_memory

if TYPE_CHECKING:
    import cupy as cp


def check_backend(backend: str, model: str = DEFAULT_MODEL, method: str | None = None,
                  work: bool = False) -> str:
    """``backend`` or :class:`InputError` naming it (checked before any work): the GPU serves
    the elastic model's gfmd solves without a CPU workspace (``work``) only, and needs CuPy
    to import and see a GPU."""
    if backend not in BACKENDS:
        raise InputError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "cupy":
        if model != "elastic" or method not in (None, "gfmd") or work:
            raise InputError(f"backend={backend!r} serves model='elastic' with method='gfmd' "
                             f"and no work=, got model={model!r}, method={method!r}"
                             + (", work=" if work else ""))
        cupy()
    return backend


@lru_cache(maxsize=1)
def cupy() -> ModuleType:
    """The ``cupy`` module, or :class:`InputError` saying what is missing."""
    try:
        import cupy as cp
    except ImportError as exc:
        raise InputError(
            f"backend='cupy' needs CuPy ({exc}); install roughflow[gpu] or the cupy-cudaXXx "
            "wheel matching your CUDA"
        ) from None
    try:
        count = cp.cuda.runtime.getDeviceCount()
    except Exception as exc:  # CUDA driver or runtime missing: CuPy imports but cannot run
        raise InputError(f"backend='cupy': CuPy cannot reach a CUDA GPU ({exc})") from None
    if count < 1:
        raise InputError("backend='cupy': CuPy sees no CUDA GPU")
    return cp


def available_bytes() -> int:
    """GPU memory a solve can use: the device's free memory plus what CuPy's pool holds
    unused."""
    cp = cupy()
    free, _ = cp.cuda.runtime.memGetInfo()
    pool = cp.get_default_memory_pool()
    return int(free + pool.total_bytes() - pool.used_bytes())


def check_memory(shape: tuple[int, int], what: str) -> None:
    """:class:`roughflow.errors.ResourceError` before any work if ``what`` on a grid of
    ``shape`` needs more GPU memory than :func:`available_bytes` (model: the task
    ``gpu_contact`` of :mod:`roughflow.resources`)."""
    _check_memory("gpu_contact", shape, limit=available_bytes(), what=what)


def describe(backend: str) -> str:
    """Where ``backend``'s solves run, for provenance: ``"cpu"``, or e.g.
    ``"cupy 14.2.0 on NVIDIA H200"`` (the round-off depends on the GPU model)."""
    if check_backend(backend) == "cpu":
        return "cpu"
    cp = cupy()
    name = cp.cuda.runtime.getDeviceProperties(cp.cuda.Device().id)["name"]
    name = name.decode() if isinstance(name, bytes) else str(name)
    return f"cupy {cp.__version__} on {name}"


def array_module(a: np.ndarray | cp.ndarray) -> ModuleType:
    """``cupy`` for a CuPy array, else ``numpy`` (CuPy is imported only for its arrays)."""
    if type(a).__module__.split(".")[0] == "cupy":
        return cupy()
    return np


def to_host(a: np.ndarray | cp.ndarray) -> np.ndarray:
    """A numpy array of ``a`` (a copy from the GPU for a CuPy array, ``a`` itself otherwise)."""
    if array_module(a) is np:
        return a
    return a.get()


class CupyRealFFT2(PlanPair):
    """A forward/inverse pair of real 2D cuFFT plans for one shape, with the buffers and the
    conventions of :class:`roughflow.fft.RealFFT2` (``execute_inverse`` destroys its input);
    ``single``: float32 / complex64."""

    def __init__(self, shape: tuple[int, int], single: bool = False):
        cp = cupy()
        from cupy.cuda import cufft
        from cupyx.scipy.fftpack import get_fft_plan

        nx, ny = shape
        self.shape = (int(nx), int(ny))
        self.spectral_shape = (int(nx), int(ny) // 2 + 1)
        real, cplx = (np.float32, np.complex64) if single else (np.float64, np.complex128)
        self._real = cp.zeros(self.shape, dtype=real)
        self._cplx = cp.zeros(self.spectral_shape, dtype=cplx)
        self._cplx_in = cp.zeros(self.spectral_shape, dtype=cplx)
        self._real_out = cp.zeros(self.shape, dtype=real)
        self._fwd = get_fft_plan(self._real, axes=(0, 1), value_type="R2C")
        self._inv = get_fft_plan(self._cplx_in, shape=self.shape, axes=(0, 1),
                                 value_type="C2R")
        self._forward_dir = cufft.CUFFT_FORWARD
        self._inverse_dir = cufft.CUFFT_INVERSE

    def execute_forward(self) -> cp.ndarray:
        self._fwd.fft(self._real, self._cplx, self._forward_dir)
        return self._cplx

    def execute_inverse(self) -> cp.ndarray:
        self._inv.fft(self._cplx_in, self._real_out, self._inverse_dir)
        return self._real_out


@per_thread_cache(maxsize=4)
def _plan(shape: tuple[int, int], single: bool) -> CupyRealFFT2:
    return CupyRealFFT2(shape, single)


def plan(shape: tuple[int, int], single: bool = False) -> CupyRealFFT2:
    """:class:`CupyRealFFT2` for ``shape``, cached per Python thread as ``fft.plan``'s (its
    buffers are shared within a thread, never between threads)."""
    return _plan((int(shape[0]), int(shape[1])), bool(single))
