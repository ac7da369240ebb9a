"""The adhesive model at zero load: the mean separation, held only by the few contacts, is
converged to the tolerance the solve reports (the residual's load term is measured against
the pressure the contacts hold, not k_min rms(h); contact._gfmd_common.load_scale)."""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

from roughflow import contact
from roughflow.contact._gfmd_common import load_scale, one_cell_scale
from roughflow.contact.adhesion import adhesion_for
from roughflow.contact.elastic import cell_compliance
from roughflow.surface import SurfaceSpec, generate


def test_a_weakly_adhering_body_at_zero_load_has_its_mean_gap_to_tol():
    """128^2 (H 0.8, eps_f 1/8, 4 points per lambda_s, seed 0), gamma_s 0.003 v_ela^full,
    range 0.8 lambda_s: at zero load a_c is 0.0024, and with the load term measured against
    k_min rms(h) a solve to tol 1e-4 returned a mean gap 512 tol rms(h) from the converged
    one, 13 contact cells off (over three seeds and two energies: 13 - 512 tol). Against the
    pressure the contacts hold, at least one held cell's stiffness, it is 1.2 tol (0.14 -
    1.5 over the same six cases); 3 tol allows for the attraction's softening, which the
    one-cell floor does not see."""
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=4, eps_f=1 / 8, l_over_lambda_r=4,
                                        seed=0))
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=0.003,
                      range=0.8 * s.spec.lambda_s)
    reference = contact.solve(s, 0.0, model="adhesive", adhesion=ad, tol=1e-9)
    assert 0.001 < reference.area_fraction < 0.005
    tol = 1e-4
    r = contact.solve(s, 0.0, model="adhesive", adhesion=ad, tol=tol)
    assert abs(r.mean_gap - reference.mean_gap) / s.heights.std() < 3 * tol
    assert np.array_equal(r.contact, reference.contact)


def test_the_load_term_scale_follows_the_held_pressure_within_its_bounds():
    """k_min rms(h) where the contacts hold more than that; the held pressure where less;
    never below the one-cell floor (a body lifted out of the attraction's range kept a
    spurious tension of 1e-17 and no solve converged against it); k_min rms(h) where
    nothing is held (a detached body: its mean is free)."""
    kmin, hscale = np.pi, 0.01
    assert load_scale(kmin, hscale, 1.0, 1e-6) == kmin * hscale
    assert load_scale(kmin, hscale, 1e-4, 1e-6) == 1e-4
    assert load_scale(kmin, hscale, 1e-17, 1e-6) == 1e-6
    assert load_scale(kmin, hscale, 0.0, 1e-6) == kmin * hscale
    assert load_scale(kmin, hscale, 1e-4) == 1e-4  # no adhesion: the load, as before


@pytest.mark.parametrize("n", [64, 256])
def test_the_floor_is_the_stiffness_of_one_held_cell(n):
    """The floor is the mean pressure that moves the body's mean by rms(h) with one cell held:
    a unit pressure on one cell moves it by cell_compliance against the mean, so the mean
    pressure 1 / (nx ny) of it moves the mean by that much (about dx / E*: the floor falls
    as 1 / n)."""
    floor = one_cell_scale((n, n), 1.0, 1.0, 1.0)
    # the same IEEE operations on the same cell_compliance: equal on any build (measured);
    # 1e-15 (4 ulps) allows only a reordering of the two products
    assert floor == pytest.approx(1.0 / (n * n * cell_compliance((n, n), 1.0, 1.0)), rel=1e-15)
    assert 0.5 / n < floor < 2.0 / n


def test_the_detached_zero_load_state_still_converges(caplog):
    """A start lifted out of the attraction's range is an equilibrium at zero load whose mean
    is free: nothing holds it, so the load term keeps k_min rms(h) and the solve converges
    (then solves again from the cold start)."""
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=4, eps_f=1 / 8, l_over_lambda_r=4,
                                        seed=1))
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=0.1,
                      range=0.8 * s.spec.lambda_s)
    cold = contact.solve(s, 0.0, model="adhesive", adhesion=ad)
    lift = float(np.ptp(s.heights)) + 2 * ad.range
    detached = dataclasses.replace(cold, gap=cold.gap + lift,
                                   contact=np.zeros_like(cold.contact),
                                   contact_pressure=np.zeros_like(cold.contact_pressure))
    with caplog.at_level(logging.INFO, logger="roughflow.contact"):
        again = contact.solve(s, 0.0, model="adhesive", adhesion=ad, init=detached)
    assert any("solving again from the cold start" in r.message for r in caplog.records)
    np.testing.assert_array_equal(again.contact, cold.contact)
