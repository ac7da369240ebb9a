"""Cross-check of the Reynolds flow solver against the peer code ``reynoldsflow``.

reynoldsflow (V. Yastrebov) discretises the same way on square grids: cell-centred
finite volumes, face conductance 2 a^3 b^3 / (a^3 + b^3) (the harmonic mean of u^3),
reservoirs at the outer cell faces with conductance 2 u^3 / dx, flow along axis 0,
periodic along axis 1, non-spanning cells removed. It omits the 1/(12 eta) of
Eq. 4 and uses dp = 1, L = 1, so our sigma = Q_peer / 12. With identical
discretisations the only difference is the linear-solver error: both sides solve to
<= 1e-8 (peer: 1e-12) relative residual and sigma comes from the dissipation
(ours) or the boundary flux at residual 1e-12 (peer), so 1e-6 is a safe bound
(measured agreement 1e-11 .. 1e-13).
"""

from __future__ import annotations

import logging

import numpy as np
import pytest

from roughflow.flow import conductance
from roughflow.surface import SurfaceSpec, generate

transport = pytest.importorskip("reynoldsflow.transport")

pytestmark = pytest.mark.peers


@pytest.fixture(autouse=True)
def _quiet_peer():
    """The peer logs each solve at INFO: WARNING for these tests, its level restored after
    them (it stayed WARNING for the rest of the session, a test audit)."""
    logger = logging.getLogger("reynoldsflow")
    level = logger.level
    logger.setLevel(logging.WARNING)
    yield
    logger.setLevel(level)


def peer_sigma(gap: np.ndarray) -> float:
    g, _p, flux = transport.solve_fluid_problem(gap, solver="scipy-spsolve")
    if g is None:
        return 0.0
    q, _err = transport.compute_total_flux(g, flux, gap.shape[0])
    return q / 12.0


@pytest.mark.parametrize("a_c", [0.1, 0.3, 0.45, 0.6])
def test_agrees_with_reynoldsflow_on_bearing_gaps(a_c):
    h = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=5)).heights  # 128^2
    g = np.maximum(np.quantile(h, 1.0 - a_c) - h, 0.0)
    sx, sy = conductance(g, method="rs")
    px = peer_sigma(g)
    py = peer_sigma(np.ascontiguousarray(g.T))  # the peer flows along axis 0 only
    # this surface's fluid stops spanning between a_c 0.58 and 0.59 along both axes: at 0.6
    # both codes find no path, below it both a real conductance (module docstring: rel 1e-6)
    assert (px == 0.0 and py == 0.0) == (a_c > 0.59) and (px > 0) == (py > 0)
    for ours, theirs in ((sx, px), (sy, py)):
        if theirs == 0.0:
            assert ours == 0.0
        else:
            assert ours == pytest.approx(theirs, rel=1e-6)
