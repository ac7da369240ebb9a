"""Fourier stiffness of a periodic elastic half-space, shared by every solver.

See docs/physics.md Sect. 3.1.

Each Fourier mode of the surface displacement has stiffness k(q) = |q| E*/2 per unit
area, so the pressure needed to hold a displacement u is p~(q) = (|q| E*/2) u~(q), and
the displacement caused by a pressure field is u~(q) = 2 p~(q) / (|q| E*). The q = 0
mode has no stiffness; it is fixed by the load constraint (mean pressure = load).
Units: lengths in L, pressures in E* (E* = 1 by default).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from roughflow import fft


@lru_cache(maxsize=8)
def _qabs(nx: int, ny: int, lx: float, ly: float) -> np.ndarray:
    qx, qy = fft.wavevectors(nx, ny, lx, ly)
    q = np.sqrt(qx * qx + qy * qy)
    q.setflags(write=False)
    return q


def stiffness(shape: tuple[int, int], lx: float, ly: float, e_star: float = 1.0) -> np.ndarray:
    """k(q) = |q| E*/2 on the rfft2 grid, shape (nx, ny//2+1); k(0) = 0."""
    return 0.5 * e_star * _qabs(int(shape[0]), int(shape[1]), float(lx), float(ly))


@lru_cache(maxsize=8)
def _compliance(nx: int, ny: int, lx: float, ly: float) -> np.ndarray:
    q = _qabs(nx, ny, lx, ly)
    c = np.zeros_like(q)
    c[q > 0] = 2.0 / q[q > 0]
    c.setflags(write=False)
    return c


def compliance(shape: tuple[int, int], lx: float, ly: float, e_star: float = 1.0) -> np.ndarray:
    """2/(|q| E*) on the rfft2 grid with the q = 0 entry set to 0 (load constraint)."""
    c = _compliance(int(shape[0]), int(shape[1]), float(lx), float(ly))
    return c if e_star == 1.0 else c / e_star


def cell_compliance(shape: tuple[int, int], lx: float, ly: float, e_star: float = 1.0) -> float:
    """Displacement of one grid cell under unit pressure on that cell alone (units L / E*):
    the mean of 2/(|q| E*) over the full spectrum (about 1.76 * 2 dx / (pi E*) on square
    cells)."""
    nx, ny = int(shape[0]), int(shape[1])
    return spectrum_mean(compliance((nx, ny), lx, ly, e_star), (nx, ny))


def spectrum_mean(half: np.ndarray, shape: tuple[int, int]) -> float:
    """Mean over the full spectrum of a real grid of ``shape`` of a field given on its rfft2
    half spectrum ``half`` (of a kernel: its real-space value at the origin)."""
    return float((fft.rfft_weights(int(shape[1])) * half).sum()) / (int(shape[0]) * int(shape[1]))


def full_contact_energy(heights: np.ndarray, lx: float, ly: float, e_star: float = 1.0) -> float:
    """v_ela^full: elastic energy per unit area to flatten ``heights`` completely.

    v = (1/4) E* sum_q |q| |h~(q)|^2 with h~ = FFT(h)/N (docs/physics.md Sect. 3.3).
    """
    nx, ny = heights.shape
    c = fft.rfft2(heights) / (nx * ny)
    w = fft.rfft_weights(ny)
    return power_contact_energy(_qabs(nx, ny, float(lx), float(ly)), w * np.abs(c) ** 2,
                                e_star)


def power_contact_energy(q: np.ndarray, power: np.ndarray, e_star: float = 1.0) -> float:
    """v_ela^full from the modes' |q| and power w |h~(q)|^2 (:func:`full_contact_energy`;
    a spec's surfaces: :func:`roughflow.surface.spec_power`)."""
    return float(0.25 * e_star * (q * power).sum())
