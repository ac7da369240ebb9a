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

from roughflow.errors import ConvergenceError, InputError
from roughflow.surface import Surface, SurfaceSpec, generate

__all__ = ["ConvergenceError", "InputError", "Surface", "SurfaceSpec", "generate"]
__version__ = "0.1.0"
