"""Jobs that several studies share run once; two different jobs with one id are refused,
naming both studies and how the jobs differ (roughflow.scenes.pool_jobs)."""

from __future__ import annotations

import pytest

from roughflow.errors import InputError
from roughflow.scenes import expand_study, pool_jobs

FLOW = {"l_over_lambda_r": [4], "eps_f": [0.125], "seeds": [0], "points_per_lambda_s": 2,
        "area_fraction": [0.1, 0.2]}


@pytest.mark.parametrize("adhesion", [{"surface_energy_ratio": 0.05},
                                      {"repulsion": "harmonic"}, {"tabor": 0.1}])
def test_an_adhesion_block_does_not_split_the_elastic_ladder(adhesion):
    # the adhesion settings are the adhesive model's: before, the elastic ladder of the
    # study with an adhesion block differed from the other study's in fields its command
    # never uses, and the plan stopped ("two different jobs share the id")
    jobs = {"flow_isotropic": expand_study("flow_isotropic", {
                **FLOW, "model": ["elastic", "adhesive"], "adhesion": adhesion}),
            "flow_anisotropic": expand_study("flow_anisotropic", {
                **FLOW, "gamma": [1], "model": ["elastic"]})}
    pooled = pool_jobs(jobs)
    assert sorted(job.model for job in pooled.values()) == ["adhesive", "elastic"]
    # the adhesive ladder keeps its settings
    (adhesive,) = [job for job in pooled.values() if job.model == "adhesive"]
    for key, value in adhesion.items():
        assert getattr(adhesive, key) == value


def test_two_studies_whose_jobs_share_an_id_are_named():
    block = {"gamma": [2], "seeds": [0], "points_per_lambda_s": 2, "eps_f": [0.125],
             "tol": 0.01}
    jobs = {"threshold_vs_gamma": expand_study("threshold_vs_gamma", block),
            "threshold_vs_size": expand_study("threshold_vs_size", {
                **block, "l_over_lambda_r": [5.65685, 8]})}
    with pytest.raises(InputError, match=r"studies.threshold_vs_gamma and "
                                         r"studies.threshold_vs_size: .*\(surface."
                                         r"l_over_lambda_r 5.656854249492381 vs 5.65685;"):
        pool_jobs(jobs)
    # the same jobs in two studies are one job
    same = pool_jobs({"threshold_vs_gamma": jobs["threshold_vs_gamma"],
                      "threshold_vs_hurst": expand_study("threshold_vs_hurst", block)})
    assert len(same) == 1
