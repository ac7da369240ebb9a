"""Non-periodic scans in the periodic solvers (docs/measured.md, "Non-periodic scans").

The contact solver (FFT Green's function) and the percolation and flow stages assume a
periodic cell; a measured scan is not periodic: its wrap-around joins opposite edges with a
step. :func:`embed` turns a scan into an :class:`Embedding`: the periodic cell the contact
solver sees, the window of that cell holding the analysed scan, the factor between the
cell's mean pressure and the nominal pressure on the window, and whether the window is
analysed periodic across the flow. Methods (:data:`~roughflow.defaults.BOUNDARY_METHODS`):

- ``"mirror"``: the scan mirror-tiled to a 2 nx x 2 ny cell (heights continuous across
  every edge). The contact solution is mirror-symmetric, so the scan's quadrant carries it
  with symmetric (zero-slope) edges; the quadrant is analysed with walls across the flow.
  Four times the grid of the scan.
- ``"pad"``: the scan in a 2 nx x 2 ny cell, the rest a flat region far below it, so the
  scan's periodic images are a scan's width apart and interact only through the
  long-wavelength elastic field; the cell's mean pressure is the nominal one times the
  scan's share of the area (1/4). Analysed with walls across the flow. At high load the
  elastic sag of the whole cell brings the padding into contact; a state where it is
  refuses to be observed (InputError) rather than give the scan's results wrong.
- ``"window"``: the scan solved as if it were periodic (wrap-around step included); an
  interior window, :data:`~roughflow.defaults.WINDOW_MARGIN` of each side dropped, is
  analysed with walls across the flow.
- ``"periodic"``: the scan is the periodic cell (right for periodic surfaces, e.g.
  generated ones, and the baseline of the measurement).

The default for non-periodic scans, :data:`~roughflow.defaults.BOUNDARY`, is the method
whose effect on a_c, a_c* and sigma was smallest on windows cut from periodic surfaces
(benchmarks/nonperiodic.py).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from roughflow.contact import ContactResult
from roughflow.defaults import BOUNDARY_METHODS, WINDOW_MARGIN
from roughflow.errors import InputError
from roughflow.surface import Surface, mirror_tiled

__all__ = ["PAD_DEPTH", "Embedding", "cell_points", "embed"]

#: "pad": the padding lies this many height ranges (max - min) below the scan's lowest
#: point, far below any elastic displacement of the surroundings of the scan.
PAD_DEPTH = 2.0

_ALL = (slice(None), slice(None))


@dataclass(frozen=True, eq=False)
class Embedding:
    """A scan placed in a periodic solver cell (see the module docstring).

    surface: the periodic cell the contact solver sees (lengths and heights in L).
    window: the cells of ``surface`` holding the analysed part of the scan.
    load_factor: mean pressure on the cell / nominal pressure on the window.
    periodic: whether the window is analysed periodic across the flow (``"periodic"``
        only; otherwise closed by walls there).
    """

    method: str
    surface: Surface
    window: tuple[slice, slice]
    load_factor: float
    periodic: bool

    @property
    def shape(self) -> tuple[int, int]:
        """Grid of the analysed window."""
        nx, ny = self.surface.shape
        return (len(range(*self.window[0].indices(nx))), len(range(*self.window[1].indices(ny))))

    @property
    def lx(self) -> float:
        return self.surface.dx * self.shape[0]

    @property
    def ly(self) -> float:
        return self.surface.dy * self.shape[1]

    def cell_pressure(self, nominal: float) -> float:
        """Mean pressure of the solver cell for the nominal pressure on the window."""
        return float(nominal) * self.load_factor

    def nominal_pressure(self, cell: float) -> float:
        """Nominal pressure on the window for the mean pressure of the solver cell."""
        return float(cell) / self.load_factor

    def observe(self, result: ContactResult) -> ContactResult:
        """The contact state of the window (area and mean gap of the window, nominal
        pressure); the state itself for a window covering the whole cell."""
        if self.window == _ALL:
            return result
        if self.method == "pad":
            self._check_padding_free(result)
        gap = result.gap[self.window]
        contact = result.contact[self.window]
        return dataclasses.replace(
            result, gap=gap, contact=contact,
            contact_pressure=result.contact_pressure[self.window],
            area_fraction=float(contact.mean()), mean_gap=float(gap.mean()),
            pressure=self.nominal_pressure(result.pressure))

    def _check_padding_free(self, result: ContactResult) -> None:
        """InputError where the padding of ``"pad"`` is in contact: at high load the elastic
        sag of the whole cell (of order p L / E*) exceeds the padding's depth, the padding
        takes part of the load and the scan's area, gap and sigma come out wrong (measured
        on a generated 128^2 scan: 0.4 of the load on the padding at 1 E* gbar)."""
        outside = result.contact.copy()
        outside[self.window] = False
        touching = int(outside.sum())
        if touching:
            total = float(result.contact_pressure.sum())
            share = float(result.contact_pressure[outside].sum()) / total if total else 0.0
            raise InputError(
                f"at the nominal pressure {self.nominal_pressure(result.pressure):.4g} E* the "
                f"padding of boundary 'pad' touches ({touching} cells outside the scan, "
                f"{share:.0%} of the load): the scan's results would be wrong. Use boundary "
                f"'mirror' or 'window' (the sealing search tries pressures up to 4 E* gbar), "
                f"or lower pressures")


def cell_points(shape: tuple[int, int], method: str) -> int:
    """Grid points of the solver cell :func:`embed` builds for a scan of ``shape`` (mirror
    and pad double each side; for memory estimates before the scan is read)."""
    if method not in BOUNDARY_METHODS:
        raise InputError(f"boundary method must be one of {BOUNDARY_METHODS}, got {method!r}")
    factor = 4 if method in ("mirror", "pad") else 1
    return factor * int(shape[0]) * int(shape[1])


def embed(surface: Surface, method: str, *, margin: float = WINDOW_MARGIN) -> Embedding:
    """The periodic solver cell for ``surface`` by ``method`` (module docstring)."""
    if not isinstance(surface, Surface):
        raise InputError(f"surface must be a roughflow Surface, got {type(surface).__name__}")
    if method not in BOUNDARY_METHODS:
        raise InputError(f"boundary method must be one of {BOUNDARY_METHODS}, got {method!r}")
    h = surface.heights
    nx, ny = h.shape
    lx, ly = surface.lx, surface.ly
    if method == "periodic":
        return Embedding(method, surface, _ALL, 1.0, True)
    if method == "mirror":
        cell = Surface(heights=mirror_tiled(h), lx=2 * lx, ly=2 * ly)
        return Embedding(method, cell, (slice(0, nx), slice(0, ny)), 1.0, False)
    if method == "pad":
        low = h.min() - PAD_DEPTH * (h.max() - h.min())
        padded = np.full((2 * nx, 2 * ny), low)
        padded[:nx, :ny] = h
        cell = Surface(heights=padded, lx=2 * lx, ly=2 * ly)
        return Embedding(method, cell, (slice(0, nx), slice(0, ny)), 0.25, False)
    if not 0 <= margin < 0.5:
        raise InputError(f"window margin must lie in [0, 0.5), got {margin!r}")
    mx, my = round(margin * nx), round(margin * ny)
    if nx - 2 * mx < 4 or ny - 2 * my < 4:
        raise InputError(f"window margin {margin!r} leaves less than 4 x 4 of the {nx} x {ny} "
                         "scan")
    return Embedding(method, surface, (slice(mx, nx - mx), slice(my, ny - my)), 1.0, False)
