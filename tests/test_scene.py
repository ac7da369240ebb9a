"""Scene runners, job planning and aggregation of the sweep workflow (tiny grids)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughflow.aggregate import aggregate, combine, load
from roughflow.cli import build_parser, main
from roughflow.defaults import FLOW_SIGMA_TOL, FLOW_TOL
from roughflow.errors import InputError
from roughflow.io import write_dataset
from roughflow.scenes import (
    ChannelsJob,
    LadderJob,
    SurfaceParams,
    ThresholdJob,
    expand_study,
    run_ladder,
    run_threshold,
)
from roughflow.surface import generate

TINY = SurfaceParams(gamma=1.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)


def test_expand_study_product_series_and_seed_groups():
    block = {"gamma": [1, 2], "hurst": [0.8], "l_over_lambda_r": [None], "eps_f": [0.0625],
             "seeds": [0, 1, 2], "seeds_per_job": 2, "points_per_lambda_s": 2,
             "series": [{"model": ["elastic"]}, {"model": ["bearing"], "gamma": [1]}]}
    jobs = expand_study("threshold_vs_gamma", block)
    # 2 gammas x 2 seed groups (elastic) + 1 gamma x 2 groups (bearing)
    assert len(jobs) == 6
    assert sorted({j.seeds for j in jobs.values()}) == [(0, 1), (2,)]
    g2 = [j for j in jobs.values() if j.surface.gamma == 2.0][0]
    assert g2.surface.size == pytest.approx(4 * np.sqrt(2))  # paper default size
    assert g2.surface.eps_t == pytest.approx(0.25)


def test_expand_study_names_unresolvable_sizes():
    block = {"gamma": [1], "seeds": [0], "points_per_lambda_s": 1.5}
    with pytest.raises(InputError, match="points_per_lambda_s=1.5"):
        expand_study("threshold_vs_gamma", block)
    block = {"gamma": [4], "l_over_lambda_r": [1.0], "seeds": [0]}
    with pytest.raises(InputError, match="larger than the cell"):
        expand_study("threshold_vs_gamma", block)


# Each of these planned cleanly and failed (or was ignored) only after the jobs ran.
_SMALL = {"seeds": [0], "points_per_lambda_s": 2, "eps_f": [0.25], "l_over_lambda_r": [4]}
_LADDER = {**_SMALL, "area_fraction": [0.2, 0.4]}


@pytest.mark.parametrize("name, block, match", [
    # the figure (and fit) refused the dataset after every job: one series only
    ("threshold_vs_size", {**_SMALL, "model": ["elastic", "bearing"]}, "one model"),
    ("threshold_vs_size", {**_SMALL, "hurst": [0.5, 0.8]}, "one hurst"),
    ("threshold_vs_hurst", {**_SMALL, "eps_f": [0.25, 0.125]}, "one eps_f"),
    ("threshold_vs_gamma", {**_SMALL, "hurst": [0.5, 0.8]}, "one hurst"),
    # (the flow studies draw a row of panels per setting: tests/test_flow_sweeps.py)
    # the gamma and H figures took a per-seed maximum over several sizes
    ("threshold_vs_gamma", {**_SMALL, "l_over_lambda_r": [4, 8]}, "one system size"),
    ("threshold_vs_hurst", {**_SMALL, "l_over_lambda_r": [4, 8]}, "one system size"),
    # keys nothing reads
    ("threshold_vs_gamma", {**_SMALL, "series": [{"area_fraction": [0.2]}]}, "area_fraction"),
    ("threshold_vs_gamma", {**_SMALL, "fit": {"bootstrap": 5}}, "threshold_vs_size only"),
    ("flow_anisotropic", {**_LADDER, "gamma": [2],
                          "adhesion": {"surface_energy_ratio": 0.5}}, "adhesive model"),
    ("flow_isotropic", {**_LADDER, "a_c_star": {"adhesive": 0.3}}, "a_c_star of adhesive"),
    ("flow_isotropic", {**_LADDER, "gamma": [2]}, "takes gamma = 1"),
    # the fit job's own range of nu (the schema asks only nu > 0)
    ("threshold_vs_size", {**_SMALL, "fit": {"nu": 10}}, "nu must lie in"),
    # ids agree to 6 digits: the second job was dropped without a word
    ("threshold_vs_gamma", {**_SMALL, "gamma": [1, 1.0000001]}, "get the id"),
])
def test_expand_study_refuses_what_its_jobs_or_figure_cannot_use(name, block, match):
    with pytest.raises(InputError, match=match):
        expand_study(name, block)


def test_expand_study_keeps_what_applies():
    # the same keys where they apply: several models of a flow study, each at one setting
    jobs = expand_study("flow_anisotropic", {
        **_LADDER, "gamma": [2], "model": ["elastic", "adhesive"],
        "adhesion": {"surface_energy_ratio": 0.5}, "a_c_star": {"adhesive": 0.3}})
    assert {j.model for j in jobs.values()} == {"elastic", "adhesive"}
    # the adhesion block's repulsion picks that wall's calibrated range unless one is given
    for repulsion, rho in (("harmonic", 0.42), ("hard", 0.8)):
        jobs = expand_study("flow_isotropic", {**_LADDER, "model": ["adhesive"],
                                               "adhesion": {"repulsion": repulsion}})
        (job,) = jobs.values()
        assert (job.repulsion, job.range_over_lambda_s) == (repulsion, rho)
    assert len(expand_study("threshold_vs_size", {**_SMALL, "l_over_lambda_r": [4, 8],
                                                  "fit": {"nu": 1.5}})) == 2


def _plan(name: str, block: dict) -> dict[str, list[str]]:
    return {jid: job.cli_args() for jid, job in expand_study(name, block).items()}


def test_config_edits_rerun_only_what_they_change():
    """A workflow audit: edits that change no result planned new jobs (Snakemake reruns a
    job whose id or arguments change), some of them hours of work at the paper's sizes."""
    base = {**_SMALL, "gamma": [1], "seeds": list(range(10)), "seeds_per_job": 5}
    plan = _plan("threshold_vs_gamma", base)
    # the config's order of seeds: the same jobs (it gave other arguments, or two jobs with
    # one id in two studies and a planning error)
    assert _plan("threshold_vs_gamma", {**base, "seeds": list(range(9, -1, -1))}) == plan
    # removing seed 0 reruns its own block only (seeds were grouped by position: every
    # later seed moved to another job, and all 10 searches ran again)
    fewer = _plan("threshold_vs_gamma", {**base, "seeds": list(range(1, 10))})
    assert len(set(fewer) - set(plan)) == 1 and len(set(plan) & set(fewer)) == 1
    # settings the bearing model does not use: contact_tol (exact sweep, no solves) and a
    # ladder's area_tol (exact cut); the elastic model's jobs do change
    for model, changed in (("bearing", False), ("elastic", True)):
        one = {**_SMALL, "model": [model]}
        a = _plan("threshold_vs_gamma", {**one, "contact_tol": 1e-4})
        b = _plan("threshold_vs_gamma", {**one, "contact_tol": 5e-5})
        assert (a != b) == changed, model
        a = _plan("flow_isotropic", {**_LADDER, "model": [model], "area_tol": 0.002})
        b = _plan("flow_isotropic", {**_LADDER, "model": [model], "area_tol": 0.004})
        assert (a != b) == changed, model


def test_aggregation_records_the_study_without_fit_options_and_labels():
    from roughflow.scenes.expand import aggregated_config

    block = {"gamma": [2], "fit": {"bootstrap": 200},
             "series": [{"label": "gamma = 2", "l_over_lambda_r": [8, 16]}]}
    assert aggregated_config(block) == aggregated_config(
        {**block, "fit": {"bootstrap": 20}, "series": [{"l_over_lambda_r": [8, 16]}]})
    assert aggregated_config(block) != aggregated_config({**block, "gamma": [4]})


@pytest.mark.parametrize("job", [
    LadderJob(surface=SurfaceParams(gamma=2.0, l_over_lambda_r=8.0, eps_f=1 / 32),
              model="adhesive", seeds=(3, 4), area_fractions=(0.1, 0.2), a_c_star=0.41,
              a_c_star_alt=0.5, area_tol=0.01, tabor=1.5, range_over_lambda_s=None),
    LadderJob(surface=SurfaceParams(aspect=0.5), model="bearing", area_fractions=(0.3,)),
    LadderJob(surface=SurfaceParams(), model="adhesive"),
    LadderJob(surface=SurfaceParams(), model="adhesive", repulsion="harmonic"),
    LadderJob(surface=SurfaceParams()),
    ThresholdJob(surface=TINY, model="bearing", seeds=(0, 1), tol=0.01),
    ThresholdJob(surface=SurfaceParams()),
    ThresholdJob(surface=SurfaceParams(), contact_tol=5e-5),  # not the default
    ChannelsJob(),
    ChannelsJob(gamma=2.0, hurst=0.3, l_over_lambda_r=8.0, eps_f=0.05, area_fraction=0.3,
                model="bearing", seed=7, points_per_lambda_s=3.0),
])
def test_cli_arguments_round_trip(job):
    # jobs.cli_args() is written by hand next to the argparse of cli/scene.py: every field
    # must survive the trip through the real parser
    from roughflow.cli.scene import job_from_args

    args = build_parser().parse_args(["scene", *job.cli_args(), "-o", "x.nc"])
    assert job_from_args(args) == job


def test_scene_cli_defaults_are_the_job_defaults():
    from roughflow.cli.scene import job_from_args

    for argv, job in (
        (["scene", "threshold", "-o", "x.nc"], ThresholdJob(surface=SurfaceParams())),
        (["scene", "ladder", "--area-fractions", "0.1", "-o", "x.nc"],
         LadderJob(surface=SurfaceParams(), area_fractions=(0.1,))),
        (["scene", "channels", "-o", "x.nc"], ChannelsJob()),
    ):
        assert job_from_args(build_parser().parse_args(argv)) == job


def test_threshold_scene_matches_search():
    from roughflow.search import threshold

    job = ThresholdJob(surface=TINY, model="bearing", seeds=(0, 1), tol=0.01)
    ds = run_threshold(job)
    assert ds["a_c_star"].dims == ("model", "gamma", "hurst", "eps_t", "eps_f", "seed", "axis")
    direct = threshold(generate(TINY.spec(1)), axis=None, model="bearing", tol=0.01)
    got = ds["a_c_star"].sel(seed=1).squeeze()
    # the scene only repackages the stage's result: equality to float precision
    assert float(got.sel(axis="x")) == pytest.approx(direct[0].a_c_star, abs=1e-12)
    assert float(got.sel(axis="y")) == pytest.approx(direct[1].a_c_star, abs=1e-12)
    for name in ds.data_vars:
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs


def test_elastic_threshold_scene_brackets():
    ds = run_threshold(ThresholdJob(surface=TINY, model="elastic", seeds=(0,), tol=0.01))
    lo, hi = ds["a_lo"].values.ravel(), ds["a_hi"].values.ravel()
    # the search stops when the bracket is below tol; the threshold lies inside it
    assert np.all(hi - lo <= 0.01 + 1e-12)
    a = ds["a_c_star"].values.ravel()
    assert np.all((lo <= a) & (a <= hi)) and np.all((a > 0.05) & (a < 0.95))
    assert np.all(ds["n_solves"].values > 0)


def test_ladder_scene_flow_only_where_percolating():
    from roughflow import flow

    job = LadderJob(surface=TINY, model="bearing", seeds=(0,),
                    area_fractions=(0.05, 0.3, 0.8), a_c_star=0.5, a_c_star_alt=0.4)
    ds = run_ladder(job).squeeze(("model", "gamma", "hurst", "eps_t", "eps_f"))
    a = ds["area_fraction"].sel(seed=0).values
    np.testing.assert_allclose(a, [0.05, 0.3, 0.8], atol=1.5 / TINY.spec().nx ** 2)
    perc = ds["percolating"].sel(seed=0).values
    sig = ds["sigma"].sel(seed=0).values
    # at 80 % bearing contact (threshold 1/2) nothing percolates: sigma = 0, not solved
    assert np.all(perc[2] == 0) and np.all(sig[2] == 0) and np.all(
        ds["flow_iterations"].sel(seed=0).values[2] == 0)
    # which solver gave sigma: the sparse LU on these small grids, nothing where not solved
    np.testing.assert_array_equal(ds["flow_direct"].sel(seed=0).values, [[1, 1], [1, 1], [0, 0]])
    # an ordinary gap needs no lumping (flow.lump: a fallback for deep pockets)
    np.testing.assert_array_equal(ds["flow_lumped_cells"].sel(seed=0).values, 0)
    assert np.all(perc[0] == 1) and np.all(sig[0] > 0)
    # the ladder's conductance is the flow stage's (same gap: bearing is deterministic)
    from roughflow import contact

    s = generate(TINY.spec(0))
    gap = contact.solve(s, model="bearing", area_fraction=0.3).gap
    ref = flow.conductance(gap, 0, lx=s.lx, ly=s.ly)
    assert float(sig[1, 0]) == pytest.approx(ref, rel=1e-6)
    # conductance falls with contact area; sigma_ref (a_c -> 0+) is the largest
    assert np.all(sig[0] > sig[1]) and np.all(ds["sigma_ref"].values > sig[0])
    emt = ds["sigma_emt"].sel(seed=0, emt="isotropic", axis="x").values
    assert emt[2] == 0.0 and emt[0] > emt[1] > 0


def test_elastic_ladder_warm_starts_and_increasing_area():
    job = LadderJob(surface=TINY, model="elastic", seeds=(0,), area_fractions=(0.1, 0.2, 0.3))
    ds = run_ladder(job)
    a = ds["area_fraction"].values.ravel()
    a_cont = ds["area_fraction_corrected"].values.ravel()
    p = ds["pressure"].values.ravel()
    assert np.all(np.diff(a) > 0) and np.all(np.diff(p) > 0)
    # the elastic ladder aims at the perimeter-corrected (continuum) area, which lies below
    # the cell count (the correction subtracts c x perimeter x dx > 0) ...
    assert np.all(a_cont < a)
    # ... and hits the targets from an erf model plus a secant: within a few percent
    assert np.all(np.abs(a_cont - [0.1, 0.2, 0.3]) < 0.06)
    assert np.all(ds["contact_iterations"].values > 0)


#: TINY stretched along x (gamma = 2: x the easy direction) on a 2:1 cell (lx = sqrt(2),
#: ly = 1 / sqrt(2), 32 x 32 points), so that lx and ly swapped show
TINY_G2 = SurfaceParams(gamma=2.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2,
                        aspect=2.0)


@pytest.fixture(scope="module")
def ladder_g2():
    # a_c* 0.4, not the bearing model's 0.5: at 0.5 (D - 1 = 1) Eq. 7 and Eq. 9 coincide
    job = LadderJob(surface=TINY_G2, model="bearing", seeds=(0,), area_fractions=(0.1, 0.2),
                    a_c_star=0.4)
    return job, run_ladder(job).squeeze(("model", "gamma", "hurst", "eps_t", "eps_f"))


def test_anisotropic_bruggeman_columns_are_in_x_y_order(ladder_g2):
    """sigma_emt[..., axis] holds (sigma_x, sigma_y) of both anisotropic forms. Eq. 9's
    self-consistency gamma~ = gamma sqrt(sigma_y / sigma_x) holds for the stored gamma~ only
    in that order (swapped it gives gamma sqrt(sigma_x / sigma_y)); the solver accepts a
    solution whose relative error in it is below 1e-6 (bruggeman_anisotropic), hence rel
    1e-6. For gamma > 1 x is the easy direction: sigma_x > sigma_y in both forms."""
    _, ds = ladder_g2
    emt = ds["sigma_emt"].sel(seed=0)
    cor = emt.sel(emt="anisotropic_corrected")
    sx, sy = cor.sel(axis="x").values, cor.sel(axis="y").values
    np.testing.assert_allclose(ds["gamma_tilde"].sel(seed=0).values, 2.0 * np.sqrt(sy / sx),
                               rtol=1e-6)
    assert np.all(sx > sy) and np.all(sy > 0)
    per = emt.sel(emt="anisotropic_persson")
    assert np.all(per.sel(axis="x").values > per.sel(axis="y").values)
    assert not np.allclose(per.values, cor.values, rtol=1e-3)  # the two forms differ here


def test_sigma_ref_is_the_conductance_of_the_undeformed_gap(ladder_g2):
    """sigma_ref, the paper's normalisation, is the Reynolds conductance of the gap
    max(h) - h of the seed's surface along x and y. Both solves stop at a proven relative
    error of sigma below FLOW_SIGMA_TOL (1e-6) or at round-off, so they agree to twice it."""
    from roughflow import flow

    job, ds = ladder_g2
    s = generate(job.surface.spec(0))
    want = flow.conductance(s.heights.max() - s.heights, None, lx=s.lx, ly=s.ly)
    np.testing.assert_allclose(ds["sigma_ref"].sel(seed=0).values, list(want),
                               rtol=2 * FLOW_SIGMA_TOL)
    assert want[0] > want[1] > 0  # easy x, hard y: an x/y swap would show
    assert s.lx != s.ly  # and so would lx and ly swapped


def test_eps_t_is_the_easy_direction_s_lambda_r_over_l():
    """eps_t = max(sqrt(gamma), 1 / sqrt(gamma)) lambda_r / L: gamma = 2 and 1/2 stretch
    by the same factor, along x and along y, so at one L they share eps_t = sqrt(2) / L
    (sqrt(gamma) alone gives gamma = 1/2 half of it, sqrt(2)/4 at L = 2). The property
    rounds to 12 significant digits (datasets.sweep.rnd), hence rel 1e-11."""
    for gamma in (2.0, 0.5):
        p = SurfaceParams(gamma=gamma, l_over_lambda_r=2.0, eps_f=0.125,
                          points_per_lambda_s=2)
        assert p.eps_t == pytest.approx(np.sqrt(2) / 2, rel=1e-11), gamma
    assert TINY.eps_t == pytest.approx(0.5, rel=1e-11)


def _tiny_threshold_file(tmp_path, gamma, seeds):
    p = SurfaceParams(gamma=gamma, l_over_lambda_r=4 * max(np.sqrt(gamma), 1 / np.sqrt(gamma)),
                      eps_f=0.125, points_per_lambda_s=2)
    ds = run_threshold(ThresholdJob(surface=p, model="bearing", seeds=seeds, tol=0.01))
    return write_dataset(ds, tmp_path / f"g{gamma}_{seeds[0]}.nc")


def test_aggregate_outer_join_keeps_missing_as_nan(tmp_path):
    files = [_tiny_threshold_file(tmp_path, 1.0, (0, 1)), _tiny_threshold_file(tmp_path, 1.0, (2,)),
             _tiny_threshold_file(tmp_path, 2.0, (0, 1))]
    out = aggregate(files, tmp_path / "study.nc", study="test")
    assert dict(out.sizes)["seed"] == 3 and dict(out.sizes)["gamma"] == 2
    back = load(tmp_path / "study.nc")
    a = back["a_c_star"].squeeze(("model", "hurst", "eps_t", "eps_f"))
    assert np.isnan(a.sel(gamma=2.0, seed=2)).all()  # job not run: NaN, not zero
    assert np.isfinite(a.sel(gamma=1.0)).all()
    # integer variable: stored as int32 with fill value -1, decoded as NaN where missing
    with xr.open_dataset(tmp_path / "study.nc", mask_and_scale=False) as raw:
        assert raw["n_solves"].dtype == np.int32
        assert int(raw["n_solves"].attrs["_FillValue"]) == -1
        for c in ("gamma", "eps_t", "eps_f", "hurst"):
            assert "_FillValue" not in raw[c].attrs
    assert np.isnan(back["n_solves"].sel(gamma=2.0, seed=2)).all()
    # per-job variables keep their dimensions: with data_vars="all", the seed groups of
    # gamma = 1 gave nx, ny, ... a seed dimension (a sum of nx * ny over the study counted
    # each grid once per seed)
    for name in ("nx", "ny", "points_per_lambda_s", "l_over_lambda_r"):
        assert "seed" not in back[name].dims, name
    # an attribute that differs between jobs is not kept, whatever groups combine_by_coords
    # made first (a job's id and command line survived in a study of three models)
    assert "job_id" not in back.attrs and "job_parameters" not in back.attrs
    # the order the files are listed in changes nothing, the list of jobs included
    rev = aggregate(files[::-1], tmp_path / "reversed.nc", study="test")
    xr.testing.assert_identical(rev.drop_attrs(), out.drop_attrs())
    skip = {"created", "history", "wall_time_s", "command"}  # provenance of the run itself
    assert {k: str(v) for k, v in rev.attrs.items() if k not in skip} \
        == {k: str(v) for k, v in out.attrs.items() if k not in skip}


def test_ladder_records_the_flow_solver_and_combines_with_files_that_do_not(monkeypatch):
    import roughflow.flow.linsolve as linsolve

    job = LadderJob(surface=TINY, model="bearing", seeds=(1,), area_fractions=(0.05, 0.3),
                    a_c_star=0.5, a_c_star_alt=0.4)
    direct = run_ladder(job)
    monkeypatch.setattr(linsolve, "DIRECT_MAX_UNKNOWNS", 0)  # auto picks AMG on any grid
    monkeypatch.setattr(linsolve, "DIRECT_MAX_FLOWING_FRACTION", 0.0)  # and any state
    amg = run_ladder(job)
    assert (direct["flow_direct"] == 1).all() and (amg["flow_direct"] == 0).all()
    # the flux imbalance of each solve (a check the sigma from the dissipation does not make):
    # direct solves are balanced to the flow tolerance; AMG solves stop once sigma is
    # proven accurate to FLOW_SIGMA_TOL, their fluxes then balanced to 1e-7 - 2e-5 on such
    # states (benchmarks/bench_sigma_tol.py), well inside 1e-2; 0 where no solve ran
    for ds, most in ((direct, FLOW_TOL), (amg, 1e-2)):
        imbalance = ds["flow_imbalance"].values
        assert np.isfinite(imbalance).all() and (imbalance <= most).all()
        assert (imbalance[ds["percolating"].values == 0] == 0).all()
        assert ds.attrs["error_budget_flow_sigma_tol"] == FLOW_SIGMA_TOL
        # what round-off leaves of it: positive where a solve ran, 0 where none did
        floor = ds["flow_imbalance_floor"].values
        solved = ds["percolating"].values == 1
        assert solved.any() and (floor[solved] > 0).all() and (floor[~solved] == 0).all()
    # sigma's error bound: direct solves end at round-off, where r^T A^-1 r / Q measured
    # 1e-24 - 2e-15 (benchmarks/bench_sigma_error.py, the default workflow's ladders) and
    # the allowances for round-off add 1e-14 and far less, so 1e-12 leaves two decades; AMG
    # solves end at the first iterate whose bound is within FLOW_SIGMA_TOL
    solved = direct["percolating"].values == 1
    error = direct["flow_sigma_error"].values
    assert (error[solved] < 1e-12).all() and (error[~solved] == 0).all()
    bound = amg["flow_sigma_error"].values
    assert (bound[solved] > 0).all() and (bound[solved] <= FLOW_SIGMA_TOL).all()
    assert (bound[~solved] == 0).all()
    attrs = direct["flow_sigma_error"].attrs
    assert attrs["units"] and "r^T A^-1 r / Q" in attrs["long_name"]
    assert "upper bound" in attrs["long_name"]
    # the same sigma either way, to the AMG solves' bounds: each sigma is at least the exact
    # one, so the AMG sigma lies at most its bound above the direct one (and at most the
    # direct one's error below it)
    amg_sigma, direct_sigma = amg["sigma"].values[solved], direct["sigma"].values[solved]
    distance = (amg_sigma - direct_sigma) / amg_sigma
    assert (distance <= bound[solved]).all() and (distance >= -error[solved]).all()
    # job files written before the variable existed still combine: NaN where it is missing
    older = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(2,),
                                 area_fractions=(0.05, 0.3), a_c_star=0.5, a_c_star_alt=0.4))
    out = combine([direct, older.drop_vars(["flow_direct", "flow_imbalance",
                                            "flow_imbalance_floor", "flow_sigma_error",
                                            "flow_lumped_cells"])])
    assert np.isnan(out["flow_lumped_cells"].sel(seed=2)).all()
    assert np.isnan(out["flow_direct"].sel(seed=2)).all()
    assert np.isnan(out["flow_imbalance"].sel(seed=2)).all()
    assert np.isnan(out["flow_sigma_error"].sel(seed=2)).all()
    assert (out["flow_direct"].sel(seed=1) == 1).all()


def test_ladders_of_different_lengths_keep_each_variable_s_dimensions():
    """Ladders of 3 and 4 steps differ in ``step``: combine_by_coords concatenates along it,
    and with data_vars="all" gave every variable a ``step`` dimension, so a study's wall
    time and sigma_ref were repeated per step (summing wall_time over step counted each
    ladder 4 times). Each variable keeps its job's dimensions; a shorter ladder's missing
    step is NaN, and each job's values are where they were."""
    short = [run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(seed,),
                                  area_fractions=(0.1, 0.2, 0.3))) for seed in (0, 1)]
    other = SurfaceParams(gamma=2.0, l_over_lambda_r=2.0, eps_f=0.125, points_per_lambda_s=2)
    long = run_ladder(LadderJob(surface=other, model="bearing", seeds=(0,),
                                area_fractions=(0.1, 0.2, 0.3, 0.35)))
    jobs = [short[0], long, short[1]]
    study = combine(jobs)
    for name, v in study.data_vars.items():
        assert v.dims == long[name].dims, name
    assert "step" not in study["wall_time"].dims and "step" not in study["sigma_ref"].dims
    assert study.sizes["step"] == 4 and study["step"].values.tolist() == [0, 1, 2, 3]
    assert float(study["wall_time"].sum()) == pytest.approx(
        sum(float(j["wall_time"].sum()) for j in jobs))
    # the short ladders' missing step is NaN (integers: the fill value once written), and
    # NaN nowhere else on their cells
    for job in jobs:
        cell = {d: job[d].values for d in ("model", "gamma", "hurst", "eps_t", "eps_f", "seed")}
        for name in ("area_fraction", "pressure", "wall_time", "sigma_ref"):
            got = study[name].sel(cell)
            if "step" in got.dims:
                assert np.isnan(got.isel(step=slice(job.sizes["step"], None))).all(), name
                got = got.isel(step=slice(0, job.sizes["step"]))
            np.testing.assert_array_equal(got.values, job[name].values, err_msg=name)


def test_combine_rejects_empty():
    with pytest.raises(InputError, match="nothing to aggregate"):
        combine([])


def test_cli_scene_threshold_and_bad_input(tmp_path, capsys):
    out = tmp_path / "t.nc"
    assert main(["scene", "threshold", "--model", "bearing", "--l-over-lambda-r", "2",
                 "--eps-f", "0.125", "--points-per-lambda-s", "2", "--seeds", "0",
                 "-o", str(out)]) == 0
    assert load(out)["a_c_star"].size == 2
    with pytest.raises(SystemExit) as exc:
        main(["scene", "threshold", "--hurst", "1.5", "-o", str(tmp_path / "bad.nc")])
    assert exc.value.code == 2
    assert "hurst" in capsys.readouterr().err
    assert not (tmp_path / "bad.nc").exists()


def test_a_failed_ladder_flow_solve_keeps_its_gap_and_no_dataset(tmp_path, capsys,
                                                                 monkeypatch):
    """A Reynolds solve of a ladder that does not converge ends the job with exit status 3
    and no dataset, and leaves OUTPUT.failed.npz with the gap, axis and cell that reproduce
    it (a near-threshold failure of the paper's largest ladder was lost for want of it). A
    later run that succeeds (Snakemake's retry) removes it."""
    import roughflow.flow
    from roughflow.errors import ConvergenceError

    def failing(gap, axis, **kw):
        raise ConvergenceError("Reynolds solver (rs) did not reach relative residual 1e-08",
                               residual=7.5e-7, iterations=500)

    monkeypatch.setattr(roughflow.flow.axes, "solve", failing)
    out = tmp_path / "ladder.nc"
    with pytest.raises(SystemExit) as exc:
        main(["scene", "ladder", "--model", "bearing", "--l-over-lambda-r", "2", "--eps-f",
              "0.125", "--points-per-lambda-s", "2", "--seeds", "3", "--area-fractions", "0.2",
              "-o", str(out)])
    assert exc.value.code == 3
    assert not out.exists()
    err = capsys.readouterr().err
    assert "residual 7.500e-07" in err and "ladder.nc.failed.npz" in err
    saved = np.load(tmp_path / "ladder.nc.failed.npz")
    surface = generate(TINY.spec(3))
    assert saved["gap"].shape == surface.shape and saved["gap"].min() == 0.0
    assert int(saved["axis"]) == 0 and int(saved["seed"]) == 3
    assert float(saved["target"]) == 0.2 and float(saved["lx"]) == surface.lx
    saved.close()
    monkeypatch.undo()
    assert main(["scene", "ladder", "--model", "bearing", "--l-over-lambda-r", "2", "--eps-f",
                 "0.125", "--points-per-lambda-s", "2", "--seeds", "3", "--area-fractions",
                 "0.2", "-o", str(out)]) == 0
    assert out.exists() and not (tmp_path / "ladder.nc.failed.npz").exists()


def _forbid(*_, **__):
    raise AssertionError("this job must not call this solver")


def test_threshold_jobs_never_solve_flow(monkeypatch):
    import roughflow.flow
    import roughflow.flow.axes
    import roughflow.flow.core

    # every name the flow solver is reached by (the package, its core, flow_both_axes)
    for module in (roughflow.flow, roughflow.flow.core, roughflow.flow.axes):
        monkeypatch.setattr(module, "solve", _forbid)
    monkeypatch.setattr(roughflow.flow, "conductance", _forbid)
    monkeypatch.setattr(roughflow.flow.core, "conductance", _forbid)
    ds = run_threshold(ThresholdJob(surface=TINY, model="elastic", seeds=(0,), tol=0.02))
    assert np.isfinite(ds["a_c_star"]).all()


def test_bearing_ladder_never_solves_elasticity(monkeypatch):
    import roughflow.contact.cg
    import roughflow.contact.gfmd

    monkeypatch.setattr(roughflow.contact.cg, "polonsky_keer", _forbid)
    monkeypatch.setattr(roughflow.contact.gfmd, "gfmd", _forbid)
    ds = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(0,),
                              area_fractions=(0.1, 0.3)))
    assert np.isfinite(ds["sigma"]).all()


def test_flow_is_solved_only_along_percolating_directions(monkeypatch):
    import roughflow.flow

    calls = []
    real = roughflow.flow.solve

    def counting(gap, axis, **kw):
        calls.append(axis)
        return real(gap, axis, **kw)

    monkeypatch.setattr(roughflow.flow.axes, "solve", counting)
    ds = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(0,),
                              area_fractions=(0.1, 0.45, 0.55, 0.9)))
    # one solve per percolating (step, axis) pair and none elsewhere
    assert len(calls) == int((ds["percolating"] == 1).sum())
    assert int((ds["percolating"] == 0).sum()) >= 2  # 90 % contact: no fluid path


def test_adhesive_ladder_needs_less_load_and_records_its_adhesion():
    # The default adhesion (the paper's case: about 1/8 of the non-adhesive load for 10 %
    # contact, docs/contact.md) must reach each area at a clearly smaller load than the
    # elastic ladder; measured here: 0.09-0.13 of the elastic load, so "below half" leaves
    # ample room, while the paper's nominal mu_T = 2, 0.203 (too weak) gives 0.97 and fails.
    targets = (0.1, 0.2, 0.3)
    adh = run_ladder(LadderJob(surface=TINY, model="adhesive", seeds=(0,),
                               area_fractions=targets))
    ela = run_ladder(LadderJob(surface=TINY, model="elastic", seeds=(0,),
                               area_fractions=targets))
    a = adh["area_fraction"].values.ravel()
    # loads increase, so areas cannot shrink (on this 32^2 grid two steps may hit the same
    # cell count: zero-load adhesion already gives ~10 % contact here)
    assert np.all(np.diff(adh["pressure"].values.ravel()) > 0) and np.all(np.diff(a) >= 0)
    assert a[-1] > a[0]
    assert np.all(np.isnan(adh["area_fraction_corrected"].values))  # not calibrated
    p_ela = np.interp(a, ela["area_fraction"].values.ravel(), ela["pressure"].values.ravel())
    inside = (a >= ela["area_fraction"].values.min()) & (a <= ela["area_fraction"].values.max())
    assert inside.any()
    assert np.all(adh["pressure"].values.ravel()[inside] < 0.5 * p_ela[inside])
    # the adhesion per seed, as variables named as contact files name their attributes
    # (datasets.results.adhesion_attrs), plus the range in lambda_s
    assert adh["adhesion_gamma_over_v_full"].item() == pytest.approx(0.1)
    assert adh["adhesion_range_over_lambda_s"].item() == pytest.approx(0.8)
    assert adh["adhesion_tabor"].item() > 0 and str(adh["adhesion_repulsion"].item()) == "hard"
    assert adh["adhesion_contact_within"].item() == 0.5
    assert adh["adhesion_surface_energy"].dims[-1] == "seed"
    assert all(adh[k].attrs["units"] and adh[k].attrs["long_name"]
               for k in adh.data_vars if k.startswith("adhesion"))
    assert not [k for k in adh.attrs if "adhesion" in k or "tabor" in k or "energy" in k]
    # a study of both models keeps each model's adhesion and theory a_c*: as attributes,
    # a_c_star_theory (0.4 elastic, 0.5 bearing) was dropped as conflicting, and the
    # adhesive job's adhesion survived as if it held for every model
    bea = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(0,),
                               area_fractions=targets, a_c_star=0.5))
    study = combine([adh, ela, bea])
    assert study["a_c_star_theory"].sel(model="bearing").item() == 0.5
    assert study["a_c_star_theory"].sel(model="adhesive").item() == 0.4
    energy = study["adhesion_surface_energy"].squeeze()
    assert energy.sel(model="adhesive").item() > 0
    assert np.isnan(energy.sel(model="elastic").item())
    assert not [k for k in study.attrs if "adhesion" in k or "a_c_star" in k]
    assert "job_id" not in study.attrs and "job_parameters" not in study.attrs


@pytest.mark.parametrize("key", ["unit", "height_unit"])
def test_measured_scan_units_are_checked_at_planning(tmp_path, monkeypatch, key):
    # a unit roughflow import cannot read passed planning and failed in the import job
    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    block = {"modulus": "1GPa", "pressures": "1MPa:10MPa:3", "fluid_pressure": "1MPa",
             "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
             "scans": [{"file": "scan.npy", "size": "500nm", "unit": "nm", key: "banana"}]}
    with pytest.raises(InputError, match=f"scan 'scan'.*{key}.*banana"):
        expand_study("measured", block)


def test_a_measured_study_without_the_scan_reader_stops_the_plan(tmp_path, monkeypatch):
    """Without SurfaceTopography (a plain `pip install -e .`, as the README's main command
    does) a config with scans passed planning; its import jobs failed ("reading scans needs
    SurfaceTopography") after the other studies' jobs had run. The plan now stops first,
    and reading a scan says the same."""
    import importlib.util

    from roughflow.scan import read_scan

    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    block = {"modulus": "1GPa", "pressures": "1MPa:10MPa:3", "fluid_pressure": "1MPa",
             "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
             "scans": [{"file": "scan.npy", "size": "500nm", "unit": "nm"}]}
    assert expand_study("measured", block)
    found = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "SurfaceTopography" else found(name, *a))
    message = r"reading scans needs SurfaceTopography, .*pip install 'roughflow\[topography\]'"
    with pytest.raises(InputError, match=r"^config studies.measured: " + message):
        expand_study("measured", block)
    with pytest.raises(InputError, match=message):
        read_scan(tmp_path / "scan.npy", size=(5e-7, 5e-7))


def test_a_study_records_how_its_jobs_computed(tmp_path, monkeypatch, caplog):
    """A study dataset computes nothing: it recorded the FFT settings of the aggregating
    process (threads 2, MEASURE) while its jobs ran with others (1, ESTIMATE). It records
    the jobs' values, and says "mixed" where they differ."""
    monkeypatch.setenv("ROUGHFLOW_FFTW_EFFORT", "FFTW_ESTIMATE")
    monkeypatch.setenv("ROUGHFLOW_FFT_THREADS", "1")
    a = _tiny_threshold_file(tmp_path, 1.0, (0,))
    monkeypatch.setenv("ROUGHFLOW_FFT_THREADS", "2")
    monkeypatch.setenv("ROUGHFLOW_FFTW_EFFORT", "FFTW_MEASURE")
    aggregate([a], tmp_path / "one.nc", study="test")
    with xr.open_dataset(tmp_path / "one.nc") as ds, xr.open_dataset(a) as job:
        assert ds.attrs["fftw_effort"] == "FFTW_ESTIMATE" and int(ds.attrs["fft_threads"]) == 1
        assert ds.attrs["backend"] == "cpu"
        assert ds.attrs.get("jobs_roughflow_commit") == job.attrs.get("roughflow_commit")
    b = _tiny_threshold_file(tmp_path, 2.0, (0,))
    with caplog.at_level("WARNING", logger="roughflow.aggregate"):
        aggregate([a, b], tmp_path / "two.nc", study="test")
    assert "differ in fftw_effort" in caplog.text
    with xr.open_dataset(tmp_path / "two.nc") as ds:
        assert ds.attrs["fftw_effort"] == "mixed: FFTW_ESTIMATE, FFTW_MEASURE"
        assert ds.attrs["fft_threads"] == "mixed: 1, 2"
    # a fit passes its study's on: it recorded its own process's (and no jobs' commit)
    from roughflow.cli import main

    monkeypatch.setenv("ROUGHFLOW_FFT_THREADS", "3")
    main(["fit", str(tmp_path / "one.nc"), "--bootstrap", "0", "-o", str(tmp_path / "f.nc")])
    with xr.open_dataset(tmp_path / "f.nc") as fit, xr.open_dataset(a) as job:
        assert int(fit.attrs["fft_threads"]) == 1 and fit.attrs["fftw_effort"] == "FFTW_ESTIMATE"
        # (neither is recorded outside a git checkout, e.g. a source archive)
        assert fit.attrs.get("jobs_roughflow_commit") == job.attrs.get("roughflow_commit")


def test_a_bad_study_level_quantity_is_named_as_the_study_s(tmp_path, monkeypatch):
    """A modulus without unit given for the whole study was reported as the first scan's."""
    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    block = {"modulus": "2e11", "pressures": "1MPa:10MPa:3", "fluid_pressure": "1MPa",
             "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
             "scans": [{"file": "scan.npy", "size": "500nm", "unit": "nm"}]}
    with pytest.raises(InputError, match=r"^config studies.measured: modulus: '2e11' has no"):
        expand_study("measured", block)


def test_measured_jobs_are_the_same_whatever_the_units_they_are_written_in(tmp_path,
                                                                          monkeypatch):
    """A config edit of units alone ("200GPa" -> "200000 MPa", "2mm" -> "2000um", sizes in
    nm instead of um, "um" -> "micrometer") changed the job's arguments, so Snakemake reran
    every import, contact solve and sealing search of the study. The arguments now spell
    one meaning one way; a changed value still changes them."""
    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    question = {"modulus": "200GPa", "pressures": "100MPa:20GPa:5", "fluid_pressure": "1MPa",
                "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm"}
    same = {"modulus": "200000 MPa", "pressures": "0.1GPa:20000MPa:5",
            "fluid_pressure": "10 bar", "viscosity": "1 cP", "seal_width": "2000um",
            "seal_length": "0.06 m"}
    scans = [{"file": "scan.npy", "size": "0.125", "unit": "um"},
             {"file": "scan.npy", "size": "125nm,125nm", "unit": "micrometer"},
             {"file": "scan.npy", "size": "125nm", "height_unit": "µm"}]
    def job(block):
        (only,) = expand_study("measured", block).values()
        return only

    jobs = [job({**q, "scans": [scan]}) for q in (question, same) for scan in scans]
    assert len({tuple(j.import_args()) for j in jobs}) == 1
    assert len({tuple(j.cli_args()) for j in jobs}) == 1
    other = job({**question, "modulus": "201GPa", "scans": scans[:1]})
    assert other.cli_args() != jobs[0].cli_args()
    # numbers without a unit stay as given: the file's own unit applies to them
    bare = job({**question, "scans": [{"file": "scan.npy", "size": "125"}]})
    assert bare.import_args()[bare.import_args().index("--size") + 1] == "125"
    # an instrument's placeholder for missing points, in one spelling that argparse reads
    marked = job({**question, "missing_value": -999999, "scans": scans[:1]})
    args = marked.import_args()
    assert "--missing-value=-999999.0" in args
    assert build_parser().parse_args(["import", "s.npy", *args, "-o", "s.nc"]).missing_value \
        == -999999.0
    with pytest.raises(InputError, match="missing_value must be a finite number"):
        job({**question, "missing_value": "n/a", "scans": scans[:1]})
    # YAML reads 1e38 as a string
    assert "--missing-value=1e+38" in job({**question, "missing_value": "1e38",
                                            "scans": scans[:1]}).import_args()


def test_a_threshold_tol_below_one_cell_is_refused_when_the_job_is_made():
    # checked by the search after the other jobs of a run (a config with eps_f 1/4 at
    # L/lambda_r = 1 and 2 points per lambda_s: an 8 x 8 grid, tol 0.01 < 1/64); the
    # workflow makes every job while it plans, so the run now stops before any job
    small = SurfaceParams(l_over_lambda_r=1.0, eps_f=0.25, points_per_lambda_s=2.0)
    assert (small.spec(0).nx, small.spec(0).ny) == (8, 8)
    with pytest.raises(InputError, match=r"tol=0.01 is below the area of one cell of the "
                                         r"8 x 8 grid"):
        ThresholdJob(surface=small, tol=0.01)
    assert ThresholdJob(surface=small, tol=1 / 64).tol == 1 / 64
    # the exact bearing sweep finds a_c* to the cell and takes any tol, as the search does
    assert ThresholdJob(surface=small, model="bearing", tol=0.01).tol == 0.01


def test_ladder_seed_groups_without_a_second_threshold_combine():
    """a_c_star_alt is NaN without a second threshold (the CLI's default): as a per-job
    variable it was compared as [nan] != [nan], and two seed groups of one ladder setting
    were refused as 'different settings'."""
    a = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(1,), area_fractions=(0.2,)))
    b = run_ladder(LadderJob(surface=TINY, model="bearing", seeds=(2,), area_fractions=(0.2,)))
    study = combine([a, b])
    assert study.sizes["seed"] == 2 and np.isnan(study["a_c_star_alt"]).all()
    # a variable that only newer job files have is no conflict; another one still is
    old = a.drop_vars(["lx", "ly", "lambda_r", "lambda_s"])
    assert combine([old, b]).sizes["seed"] == 2
    with pytest.raises(InputError, match="different settings"):
        combine([a.drop_vars("points_per_lambda_s"), b])


def test_the_ladder_writes_every_number_of_the_adhesion():
    """ADHESION_FIELDS names what adhesion_attrs gives (plus the range in lambda_s): a key
    added to one and not the other was dropped, or raised, in every adhesive ladder."""
    from roughflow.contact import Adhesion
    from roughflow.datasets.results import (
        ADHESION_FIELDS,
        ADHESION_REPULSION_FIELD,
        adhesion_attrs,
    )
    from roughflow.surface import generate

    s = generate(TINY.spec(0))
    names = set(adhesion_attrs(s, Adhesion(surface_energy=1e-4, range=0.01)))
    assert names | {"adhesion_range_over_lambda_s"} == set(ADHESION_FIELDS) | {
        ADHESION_REPULSION_FIELD[0]}


def test_leak_memory_request_follows_the_imported_grid(tmp_path, monkeypatch):
    """A leak job's mem_mb: a placeholder grid until its scan is imported, then the
    imported grid embedded as its boundary treatment does (a padded cell holds more
    points than the scan), doubled on a second attempt."""
    from roughflow.boundary import cell_points
    from roughflow.io import surface_to_dataset, write_dataset
    from roughflow.scenes.requests import LEAK_GRID_BEFORE_IMPORT, leak_mem_mb, requested_mem_mb
    from roughflow.surface import Surface

    np.save(tmp_path / "scan.npy", np.zeros((8, 8)))
    monkeypatch.chdir(tmp_path)
    (job,) = expand_study("measured", {
        "modulus": "200GPa", "pressures": "100MPa:20GPa:5", "fluid_pressure": "1MPa",
        "viscosity": "1mPa.s", "seal_width": "2mm", "seal_length": "60mm",
        "scans": [{"file": "scan.npy", "size": "1um"}]}).values()
    imported = tmp_path / "surface.nc"
    before = leak_mem_mb(job, imported)
    assert before == requested_mem_mb(job, 1, cell_points(LEAK_GRID_BEFORE_IMPORT, job.boundary))
    heights = np.random.default_rng(0).normal(size=(3000, 2000))
    write_dataset(surface_to_dataset(Surface.from_array(heights, lx=1.5, ly=1.0)), imported)
    after = leak_mem_mb(job, imported)
    points = cell_points((3000, 2000), job.boundary)
    assert points >= 3000 * 2000
    assert after == requested_mem_mb(job, 1, points) > before
    assert leak_mem_mb(job, imported, attempt=2) == 2 * after
    # a damaged file (cut short outside roughflow, whose writes are atomic) stopped the
    # workflow's planning with a raw HDF error; now an InputError says what to do
    imported.write_bytes(imported.read_bytes()[:5000])
    with pytest.raises(InputError, match=r"surface\.nc.*delete it, and snakemake makes it"):
        leak_mem_mb(job, imported)
