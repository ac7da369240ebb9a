"""The load search of the ladder and channels scenes (roughflow.search.load.LoadSearch): what it
keeps of its solved states, and what it returns."""

from __future__ import annotations

import os

import numpy as np
import pytest

from roughflow import contact
from roughflow.contact import ContactLaw, ContactResult
from roughflow.search.load import CompactState, LoadSearch, warm_start_compliance
from roughflow.surface import SurfaceSpec, generate

os.environ.setdefault("ROUGHFLOW_FFT_THREADS", "1")


@pytest.fixture(scope="module")
def surface():
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1))  # 128 x 128


def _search(surface, compliance: bool, bounds=None) -> LoadSearch:
    return LoadSearch(lambda p, init: contact.solve(surface, p, init=init, tol=1e-6),
                      ContactLaw(), bounds=bounds,
                      compliance=warm_start_compliance(surface) if compliance else None)


def test_with_a_compliance_states_are_kept_compact_and_results_whole(surface):
    """The paper's ladders (12 steps) kept 12-16 whole states of 17 bytes a cell; with the
    warm starts' compliance, q (4 bytes a cell) is all they read. The states a target
    returns are whole, and the compact warm starts end at the same contact as whole ones:
    the float32 rounding of q (6e-8 relative) is far below the contact tolerance (1e-6)."""
    compact, whole = _search(surface, True), _search(surface, False)
    for target in (0.1, 0.2, 0.3):
        a, b = compact.solve_for(target, 0.01), whole.solve_for(target, 0.01)
        assert isinstance(a.result, ContactResult) and a.met
        assert np.array_equal(a.result.contact, b.result.contact)
    assert all(isinstance(q.state, CompactState) and q.state.q.dtype == np.float32
               for q in compact.points)
    assert all(isinstance(q.state, ContactResult) for q in whole.points)


def test_an_out_of_reach_target_returns_the_closest_state_whole(surface):
    """A target beyond the load bounds takes no new solve and returns the closest state:
    the last solve as it came (no solve), or, when that state is kept compact only, solved
    again from itself at its load (one solve, the same contact)."""
    law = ContactLaw()
    p_max = law.control(0.2)  # bounds that cannot reach a_c = 0.3
    search = _search(surface, True, bounds=(law.bounds[0], p_max))
    first = search.solve_for(0.3, 0.005)  # solves up to the upper bound and stops there
    assert not first.met and search.points[-1].load == pytest.approx(p_max)
    again = search.solve_for(0.3, 0.005)  # the closest state is the last solve
    assert again.solves == 0 and again.result is search._latest
    search.solve_for(0.1, 0.01)  # now the closest state to 0.3 is no longer the last one
    closest = min(search.points, key=lambda q: abs(q.area - 0.3))
    resolved = search.solve_for(0.3, 0.005)
    assert resolved.solves == 1 and isinstance(resolved.result, ContactResult)
    assert resolved.result.converged and resolved.area == closest.area
    assert np.array_equal(resolved.result.contact, first.result.contact)
