"""roughflow: elastic contact, percolation and Reynolds flow of randomly rough surfaces.

Stages (one module each, data flows one way):
``surface`` -> ``contact`` -> ``percolation`` -> ``flow`` -> ``theory``; ``search`` drives
contact solves to a target area or to the percolation threshold a_c*; then the sweep side:
``datasets`` and ``io`` (netCDF), ``scenes`` (workflow jobs), ``aggregate``, ``fits``,
``figures``, ``cli``. ``defaults`` holds every default value once.

Array convention: ``a[ix, iy]``, axis 0 is x, axis 1 is y; a Peklenik number
gamma > 1 stretches the surface along x. Units are dimensionless by default:
contact modulus E* = 1, rms gradient 1, cell side L = 1, viscosity eta = 1.
"""

from importlib import import_module

from roughflow.errors import ConvergenceError, InputError
from roughflow.progress import log_progress

__version__ = "0.1.0"

# Imported on first use (PEP 562), so that ``import roughflow`` and ``roughflow --help``
# do not load pyFFTW, numba, pyamg, xarray or matplotlib.
_LAZY = {"Surface": "roughflow.surface", "SurfaceSpec": "roughflow.surface",
         "generate": "roughflow.surface", "references": "roughflow.citation"}
__all__ = ["ConvergenceError", "InputError", "Surface", "SurfaceSpec", "__version__",
           "generate", "log_progress", "references"]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'roughflow' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
