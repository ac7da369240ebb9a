"""Results print short: a notebook showing a result saw pages of the gap's digits before
any scalar. Arrays of more than a few elements show as their dtype and shape."""

from __future__ import annotations

import numpy as np

from roughflow import contact, flow
from roughflow._repr import SHOWN_IN_FULL
from roughflow.percolation import cluster_stats
from roughflow.surface import SurfaceSpec, generate
from roughflow.theory import predict_conductance


def test_results_show_scalars_and_the_shapes_of_their_arrays():
    s = generate(SurfaceSpec.from_sweep(l_over_lambda_r=2, points_per_lambda_s=2, seed=0))
    r = contact.solve(s, 0.05)
    text = repr(r)
    assert text.startswith("ContactResult(gap=array(float64, 64 x 64), ")
    assert f"area_fraction={r.area_fraction!r}" in text and "converged=True" in text
    f = flow.solve(r.gap, axis=0, lx=s.lx, ly=s.ly)
    assert f"sigma={f.sigma!r}" in repr(f) and "flux_x=array(float64, 64 x 64)" in repr(f)
    stats = cluster_stats(r.contact)
    assert f"patch_sizes=array(int64, {stats.n_patches})" in repr(stats)
    assert repr(s).startswith("Surface(heights=array(float64, 64 x 64), lx=1.0, ly=1.0, ")
    for shown in (text, repr(f), repr(stats), repr(s)):
        assert len(shown) < 1000


def test_short_arrays_are_shown_in_full():
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=2, points_per_lambda_s=2, seed=0)
    pred = predict_conductance(spec, np.array([0.01, 0.05]), a_c_star=0.415)
    assert f"pressure={pred.pressure!r}" in repr(pred)
    assert SHOWN_IN_FULL >= 2
