"""An adhesive ladder whose adhesive zone the grid pins is refused at planning, from its
spec's spectrum (roughflow.surface.spec_power), with the adhesion its job would compute on
every seed's surface; before, the job failed after making its surface and its reference
flow solve."""

from __future__ import annotations

import pytest

from roughflow.contact.adhesion import (
    adhesion_for,
    adhesion_for_power,
    curvature_radius,
    power_curvature_radius,
)
from roughflow.contact.elastic import full_contact_energy, power_contact_energy
from roughflow.errors import InputError
from roughflow.scenes import expand_study
from roughflow.surface import SurfaceSpec, generate, spec_power

BLOCK = {"l_over_lambda_r": [4], "eps_f": [0.125], "model": ["adhesive"], "seeds": [0, 1],
         "points_per_lambda_s": 2, "area_fraction": [0.1]}


@pytest.mark.parametrize(("gamma", "seed"), [(1, 0), (1, 3), (4, 1)])
def test_spec_power_gives_the_moments_of_every_seed_s_surface(gamma, seed):
    # the amplitudes are the spec's, the seed sets phases only: the spectral moments of a
    # generated surface agree with the spec's to the FFT round trip's round-off (1e-15
    # relative measured; 1e-12 leaves room)
    spec = SurfaceSpec.from_sweep(gamma=gamma, l_over_lambda_r=4, eps_f=0.125,
                                  points_per_lambda_s=2, seed=seed)
    s = generate(spec)
    q, power = spec_power(spec)
    assert float((q * q * power).sum()) == pytest.approx(spec.rms_slope**2, rel=1e-12)
    assert power_contact_energy(q, power) == pytest.approx(
        full_contact_energy(s.heights, s.lx, s.ly), rel=1e-12)
    assert power_curvature_radius(q * q, power) == pytest.approx(
        curvature_radius(s.heights, s.lx, s.ly), rel=1e-12)
    on_surface = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=0.2, tabor=2.0)
    planned = adhesion_for_power(q, power, gamma_over_v_full=0.2, tabor=2.0)
    assert planned.surface_energy == pytest.approx(on_surface.surface_energy, rel=1e-12)
    assert planned.range == pytest.approx(on_surface.range, rel=1e-12)


@pytest.mark.parametrize(("adhesion", "needed"), [
    # the run-time refusals of the audit's configs: zones of 0.039, 0.0071 and 0.046
    # spacings (1.5 needed), ranges of at least 0.206, 0.145 and 4.58 lambda_s
    ({"tabor": 2.0, "surface_energy_ratio": 0.203}, "0.206"),
    ({"range_over_lambda_s": 0.01}, "0.145"),
    ({"surface_energy_ratio": 100}, "4.58"),
])
def test_a_pinned_adhesive_zone_is_refused_at_planning(adhesion, needed):
    with pytest.raises(InputError, match=rf"config studies.flow_isotropic: .*adhesion .*spans "
                                         rf".* grid spacings .*must be at least {needed} "
                                         r"lambda_s \(adhesion.range_over_lambda_s\)"):
        expand_study("flow_isotropic", {**BLOCK, "adhesion": adhesion})


def test_the_default_adhesion_plans():
    jobs = expand_study("flow_isotropic", BLOCK)  # one job per seed
    assert sorted((job.model, job.seeds) for job in jobs.values()) == [("adhesive", (0,)),
                                                                       ("adhesive", (1,))]
