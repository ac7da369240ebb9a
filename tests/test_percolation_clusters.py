"""Cluster statistics and the percolating-channel map (paper Fig. 1 b, c)."""

from __future__ import annotations

import numpy as np
import pytest

from roughflow.errors import InputError
from roughflow.percolation import (
    cluster_sizes,
    cluster_stats,
    fisher_exponent,
    percolation_map,
    size_distribution,
)
from roughflow.percolation.clusters import CONTACT, FLUID, PERCOLATING
from roughflow.surface import SurfaceSpec, generate


def test_cluster_sizes_of_hand_made_mask():
    c = np.zeros((6, 6), dtype=bool)
    c[0, 0] = c[5, 5] = True  # corner cells: one patch only when 8-connected via both seams
    c[2:4, 2:5] = True  # a 2 x 3 block
    assert list(cluster_sizes(c)) == [6, 1, 1]
    assert list(cluster_sizes(c, connectivity=8)) == [6, 2]
    assert list(cluster_sizes(c, periodic=(False, False), connectivity=8)) == [6, 1, 1]


def test_fisher_exponent_recovers_a_power_law():
    rng = np.random.default_rng(0)
    tau = 2.2
    sizes = np.floor((1 - rng.random(200_000)) ** (-1 / (tau - 1))).astype(int)
    # Drawn from P(S >= s) = s^-(tau-1): density ~ s^-tau. Discreteness (floor) biases the
    # smallest bins, so fit from s = 4; 200000 samples give a slope good to about 0.05.
    assert fisher_exponent(sizes, s_min=4, s_max=1e4) == pytest.approx(tau, abs=0.07)


def test_size_distribution_density_integrates_to_count():
    sizes = np.array([1, 1, 2, 3, 5, 8, 13, 21, 34, 55, 89, 144])
    s, n = size_distribution(sizes, bins_per_decade=3)
    # rebuild the bin widths from the same rule and check sum(n * width) = count
    top = np.log10(sizes.max()) + 1e-9
    nb = int(np.ceil(top * 3))
    edges = np.unique(np.floor(np.logspace(0, top, nb + 1)).astype(int))
    edges[-1] = sizes.max() + 1
    counts, _ = np.histogram(sizes, bins=edges)
    width = np.diff(edges)[counts > 0]
    assert np.sum(n * width) == pytest.approx(sizes.size)
    assert np.all(np.diff(s) > 0)


def test_size_distribution_bad_input():
    with pytest.raises(InputError, match="sizes"):
        size_distribution(np.array([0, 3]))
    with pytest.raises(InputError, match="sizes"):
        size_distribution(np.array([]))


def test_percolation_map_marks_spanning_channel():
    c = np.ones((7, 5), dtype=bool)
    c[:, 1] = False  # a channel along x
    c[2, 3] = False  # an isolated pool
    m = percolation_map(c, axis=0)
    assert set(np.unique(m)) == {CONTACT, FLUID, PERCOLATING}
    assert np.all(m[:, 1] == PERCOLATING)
    assert m[2, 3] == FLUID
    assert np.all(m[c] == CONTACT)
    # along y nothing spans: the channel is light (non-percolating) fluid
    assert not np.any(percolation_map(c, axis=1) == PERCOLATING)


def test_cluster_stats_of_a_contact_state():
    spec = SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=2)
    h = generate(spec).heights
    c = h > np.quantile(h, 0.7)  # bearing contact at a_c = 0.3: fluid spans both ways
    st = cluster_stats(c)
    # the quantile's cut lies within one cell (1 / N = 6.1e-5 on 128^2) of 0.3 N cells;
    # measured 0.299988, 0.2 cells low
    assert st.area_fraction == pytest.approx(0.3, abs=1 / c.size)
    assert st.patch_sizes.sum() == c.sum() and st.fluid_sizes.sum() == (~c).sum()
    assert st.n_patches == st.patch_sizes.size > 10
    # at most the fluid's 0.7; at a_c 0.3, well below the bearing threshold 1/2, the spanning
    # cluster holds all but a few % of the fluid (this seed: 0.690 along x, 0.692 along y;
    # seeds 0-5: 0.65-0.69 where one spans). The hand-made mask below tells x from y exactly
    assert 0.6 < st.percolating_fraction_x <= 0.7 and 0.6 < st.percolating_fraction_y <= 0.7


def test_cluster_stats_of_a_hand_made_mask():
    """Exact counts that tell x from y and 4- from 8-connected fluid: one open column along x
    (8 of 48 cells span x, none spans y) and two pools touching only at a corner (two
    4-connected fluid clusters, as the paper counts them)."""
    c = np.ones((8, 6), dtype=bool)
    c[:, 1] = False
    c[3, 3] = c[4, 4] = False
    st = cluster_stats(c)
    assert st.percolating_fraction_x == 8 / 48
    assert st.percolating_fraction_y == 0.0
    assert st.n_fluid_clusters == 3


def test_contact_patches_are_4_connected_by_default_as_in_the_paper():
    # two contact cells touching at a corner are two patches (4-connected, the paper's
    # convention for patches); with patch_connectivity=8 they are one
    from roughflow.percolation import cluster_stats

    c = np.zeros((8, 8), bool)
    c[2, 2] = c[3, 3] = True
    assert cluster_stats(c).n_patches == 2
    assert cluster_stats(c, patch_connectivity=8).n_patches == 1


def test_helpers_refuse_fields_of_another_grid():
    """The low-level helpers took fields of mismatched grids: a (7, 5) mask for a (5, 7) gap
    ordered 35 cells without a word, an order of 35 cells on a 36-cell grid gave areas in
    35ths, and a 1D shape or a (5, 7)/(7, 5) pair died in numpy's unpacking and
    broadcasting."""
    from roughflow import fft
    from roughflow.percolation import critical_open_count, predicted_thresholds
    from roughflow.percolation.sweep import open_first_order, openness

    gap, pressure = np.ones((5, 7)), np.zeros((5, 7))
    for f in (open_first_order, openness):
        with pytest.raises(InputError, match=r"share one grid.*\(7, 5\)"):
            f(gap, np.zeros((7, 5), bool), pressure)
    with pytest.raises(InputError, match="each of the 6 x 6 cells once, got 35"):
        predicted_thresholds(np.arange(35), (6, 6))
    with pytest.raises(InputError, match=r"2D grid's \(nx, ny\), got \(8,\)"):
        critical_open_count(np.arange(8), (8,), 0)
    with pytest.raises(InputError, match=r"2D array, got shape \(8,\)"):
        fft.rfft2(np.ones(8))
    with pytest.raises(InputError, match=r"spectrum of shape \(8, 5\), got \(1, 5\)"):
        fft.irfft2(np.ones((1, 5)), (8, 8))  # a row broadcast over all 8 rows before
    # the round trip's round-off, O(eps log N): measured 2 ulps (4.4e-16); 1e-14 is 45 ulps
    # for other FFT builds
    np.testing.assert_allclose(fft.irfft2(fft.rfft2(gap), gap.shape), gap, atol=1e-14)
