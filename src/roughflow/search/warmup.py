"""Compile every numba kernel a threshold search runs, ahead of anything that is timed.

numba compiles a kernel at its first call, or loads it from its disk cache (``cache=True``):
5-7 s for the search's kernels on a fresh install, which a benchmark's first timed search
would otherwise include.
"""

from ..contact._kernels import warm_up as _contact_warm_up
from ..surface import SurfaceSpec, generate
from .critical import threshold

#: The warm-up surface's resolution: 2 points per lambda_s give a 128^2 grid at the default
#: sweep parameters, searched in about 0.03 s once compiled.
_WARM_UP_POINTS_PER_LAMBDA_S = 2


def warm_up() -> None:
    """Compile (or load from numba's cache) the contact kernels and those of an elastic and a
    bearing-model threshold search, by running both on a small surface."""
    _contact_warm_up()
    surface = generate(SurfaceSpec.from_sweep(
        points_per_lambda_s=_WARM_UP_POINTS_PER_LAMBDA_S, seed=0))
    threshold(surface, tol=0.01)
    threshold(surface, model="bearing")
