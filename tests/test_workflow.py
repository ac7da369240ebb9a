"""The Snakemake workflow end to end on config/test.yaml, dry runs and bad configs.

Snakemake runs in a subprocess in a temporary copy of the workflow (Snakefile, workflow/,
config/, profiles/), as a user would run it from a fresh checkout.
"""

from __future__ import annotations

import math
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml
from dataset_checks import assert_yes_no_variables_are_flagged
from workflow_copy import copy_workflow

ROOT = Path(__file__).resolve().parents[1]
SNAKEMAKE = Path(sys.executable).with_name("snakemake")
STUDIES = ("channels", "threshold_vs_gamma", "threshold_vs_size", "threshold_vs_hurst",
           "flow_isotropic", "flow_anisotropic", "measured")

pytestmark = pytest.mark.skipif(not SNAKEMAKE.exists(), reason="snakemake not installed")


def snakemake(cwd: Path, *args: str, timeout: int = 600) -> subprocess.CompletedProcess:
    env = {**os.environ, "ROUGHFLOW_FFT_THREADS": "1", "MPLBACKEND": "Agg"}
    return subprocess.run([str(SNAKEMAKE), *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=timeout)


def job_counts(output: str) -> dict[str, int]:
    """The 'Job stats' table of a snakemake (dry) run."""
    table = output.split("Job stats:")[1].split("total")[0]
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)}


@pytest.fixture(scope="module")
def test_run(local_test_run):
    # the session's one local run of config/test.yaml (tests/conftest.py)
    return local_test_run


@pytest.mark.slow
def test_every_study_produces_dataset_and_figures(test_run):
    wd, _ = test_run
    for study in STUDIES:
        for ext in ("png", "pdf"):
            fig = wd / "results" / study / f"figure.{ext}"
            assert fig.exists() and fig.stat().st_size > 5000, fig
        assert (wd / "results" / study / "dataset.nc").exists()
    assert (wd / "results" / "threshold_vs_size" / "fit.nc").exists()
    # every job logged its progress to its log file
    logs = list((wd / "results" / "logs" / "jobs").rglob("*.log"))
    assert logs and all("INFO" in p.read_text() for p in logs)


@pytest.mark.slow
def test_threshold_datasets_are_complete_and_physical(test_run):
    wd, _ = test_run
    cfg = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())["studies"]
    with xr.open_dataset(wd / "results" / "threshold_vs_gamma" / "dataset.nc") as ds:
        assert set(ds["a_c_star"].dims) == {"model", "gamma", "hurst", "eps_t", "eps_f",
                                            "seed", "axis"}
        assert sorted(ds["gamma"].values) == sorted(cfg["threshold_vs_gamma"]["gamma"])
        assert list(ds["seed"].values) == cfg["threshold_vs_gamma"]["seeds"]
        a = ds["a_c_star"].squeeze(("hurst", "eps_t", "eps_f"))
        # every configured job ran: no NaN; thresholds are contact fractions well inside
        # (0, 1) (small systems scatter by +-0.15 around 0.4-0.5)
        assert np.isfinite(a.values).all()
        assert ((a > 0.15) & (a < 0.85)).all()
        assert (ds["a_hi"] - ds["a_lo"] <= 0.01 + 1e-9).all()
    with xr.open_dataset(wd / "results" / "threshold_vs_size" / "dataset.nc") as ds:
        a = ds["a_c_star"]
        # sparse sweep: the pairs (gamma, eps_t) that were not run stay NaN, the others not
        ran = np.isfinite(a).any(("seed", "axis"))
        assert ran.sum() == 4 and np.isfinite(a.where(ran)).sum() == 4 * 2 * 2
    with xr.open_dataset(wd / "results" / "threshold_vs_size" / "fit.nc") as fit:
        a_star = float(fit["a_star"].sel(group="anisotropic", fit="joint", nu_mode="fixed"))
        assert 0.2 < a_star < 0.7


@pytest.mark.slow
def test_flow_datasets_are_physical(test_run):
    wd, _ = test_run
    for study in ("flow_isotropic", "flow_anisotropic"):
        with xr.open_dataset(wd / "results" / study / "dataset.nc") as ds:
            # models may run at different sizes: (model, eps_t) pairs not run stay NaN
            ran = ds["area_fraction"].notnull()
            assert int(ran.sum()) > 0
            assert ran.any(("seed", "step")).sum() == ds.sizes["model"]
            sig = ds["sigma"].where(ran)
            a = ds["area_fraction"].where(ran)
            assert np.isfinite(sig.values[np.broadcast_to(ran.values[..., None],
                                                          sig.shape)]).all()
            assert (sig.fillna(0) >= 0).all()
            # non-percolating directions carry exactly zero, percolating ones more
            perc = ds["percolating"]
            assert ((sig == 0) == (perc == 0)).where(ran).fillna(True).all()
            # conductance never exceeds its a_c -> 0+ value and falls along the ladder
            assert (sig <= ds["sigma_ref"] * 1.0001).where(ran).fillna(True).all()
            assert (sig.diff("step") <= 1e-30).where(sig.diff("step").notnull()) \
                .fillna(True).all()
            assert ((a > 0) & (a < 1)).where(ran).fillna(True).all()
            for name in ds.data_vars:
                assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
    with xr.open_dataset(wd / "results" / "channels" / "dataset.nc") as ds:
        # every parameter of the job as an attribute (hurst and the sizes were only inside
        # job_parameters' command line)
        assert {k: ds.attrs[k] for k in ("gamma", "l_over_lambda_r", "eps_f",
                                         "points_per_lambda_s", "hurst")} == {
            "gamma": 4.0, "l_over_lambda_r": 4.0, "eps_f": 0.125, "points_per_lambda_s": 2.0,
            "hurst": 0.8}
        for name in ("iso", "aniso"):
            assert abs(ds.attrs[f"{name}_area_fraction"] - 0.4) < 0.01
            phase = ds[f"phase_{name}"]
            assert set(np.unique(phase.values)) <= {0, 1, 2}
            # the library's one encoding (the scene once had its own, with 1 and 2 swapped)
            from roughflow.percolation import percolation_map

            np.testing.assert_array_equal(phase.values, percolation_map(phase.values == 0, 0))
            assert bool((phase == 2).any()) == bool(ds.attrs[f"{name}_fluid_percolates_x"])
            assert phase.attrs["flag_meanings"].split()[2] == "percolating_fluid"


@pytest.mark.slow
def test_conductance_ratio_axis_is_labelled_in_plain_numbers(test_run):
    # chi spans about a decade, where matplotlib also labels minor ticks; its default
    # formatter wrote them as "2 x 10^0" (mathtext \times), which a reader has to decode
    import matplotlib

    matplotlib.use("Agg")
    from roughflow.figures.flow_anisotropic import draw

    wd, _ = test_run
    with xr.open_dataset(wd / "results" / "flow_anisotropic" / "dataset.nc") as ds:
        fig = draw(ds)
    fig.canvas.draw()
    ratio = fig.axes[-1]
    labels = [t.get_text() for t in ratio.get_yticklabels(minor=True)
              + ratio.get_yticklabels()]
    shown = [t for t in labels if t]
    assert shown and not any("times" in t or "^" in t for t in shown), shown


@pytest.mark.slow
def test_measured_study_gives_leak_curves_in_physical_units(test_run):
    from roughflow.defaults import BOUNDARY

    wd, _ = test_run
    cfg = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())["studies"]["measured"]
    with xr.open_dataset(wd / "results" / "measured" / "dataset.nc") as ds:
        assert list(ds["scan"].values) == ["afm"] and ds.attrs["boundary"] == BOUNDARY
        # "1MPa:100GPa:6": six log-spaced nominal pressures, in Pa
        np.testing.assert_allclose(ds["pressure"].values, np.geomspace(1e6, 1e11, 6),
                                   rtol=1e-12)
        d = ds.isel(scan=0)
        q, perc = d["leak_rate"], d["percolating"]
        assert ((q > 0) == (perc == 1)).all() and (q >= 0).all()
        assert (d["area_fraction"].diff("pressure") >= 0).all()
        assert (q.diff("pressure") <= 0).all()  # pressing harder never opens the seal more
        # the sealing bracket agrees with the curve: leaking below it, sealed above it
        for axis in ("x", "y"):
            lo = float(d["sealing_pressure_lo"].sel(axis=axis))
            hi = float(d["sealing_pressure"].sel(axis=axis))
            assert 0 < lo < hi, (axis, lo, hi)
            p = d["pressure"]
            assert (perc.sel(axis=axis).where(p <= lo, 1) == 1).all()
            assert (perc.sel(axis=axis).where(p >= hi, 0) == 0).all()
        assert float(d["modulus"]) == 200e9 and cfg["modulus"] == "200GPa"
    table = (wd / "results" / "measured" / "afm.txt").read_text()
    assert "sealing pressure along x" in table and "sealing pressure along y" in table


@pytest.mark.slow
def test_every_units_attribute_parses(test_run):
    from roughflow.units import registry

    wd, _ = test_run
    files = sorted((wd / "results").rglob("*.nc"))
    kinds = set()
    for path in files:
        assert_yes_no_variables_are_flagged(path)
        with xr.open_dataset(path) as ds:
            kinds.add(ds.attrs.get("title", path.parent.name))
            ureg = registry(ds.attrs)
            for name, v in ds.variables.items():
                if "units" in v.attrs:
                    ureg.parse_units(v.attrs["units"])  # raises if it does not parse
                elif v.dtype.kind in "fiu":  # README: every numeric variable, coordinates too
                    pytest.fail(f"{path.name}: numeric variable {name} has no units")
    assert len(kinds) >= 6, kinds


def test_outputs_record_their_provenance(test_run):
    # issue 18: job files their parameters, study datasets (and the fit) the study's config
    import json

    wd, _ = test_run
    cfg = yaml.safe_load((ROOT / "config" / "test.yaml").read_text())["studies"]
    job = sorted((wd / "results" / "jobs" / "threshold").glob("*.nc"))[0]
    with xr.open_dataset(job) as ds:
        assert ds.attrs["job_parameters"].startswith("threshold --gamma")
        assert "-v scene threshold" in ds.attrs["command"]
    # the study block without what does not change the dataset (fit options, labels: editing
    # them must not re-aggregate); the fit file records its own options
    from roughflow.scenes.expand import aggregated_config

    study = cfg["threshold_vs_size"]
    for name in ("dataset", "fit"):
        with xr.open_dataset(wd / "results" / "threshold_vs_size" / f"{name}.nc") as ds:
            assert ds.attrs["study_config"] == aggregated_config(study)
            assert "fit" not in json.loads(ds.attrs["study_config"])
            assert ds.attrs["roughflow_version"] and ds.attrs["history"]
    with xr.open_dataset(wd / "results" / "threshold_vs_size" / "fit.nc") as ds:
        assert ds.attrs["n_boot"] == study["fit"]["bootstrap"]


@pytest.mark.slow
def test_second_invocation_does_nothing(test_run):
    wd, _ = test_run
    again = snakemake(wd, "--configfile", "config/test.yaml", "--cores", "2")
    assert again.returncode == 0
    assert "Nothing to be done" in again.stdout + again.stderr


@pytest.mark.slow
def test_report_shows_every_figure(test_run):
    wd, _ = test_run
    res = snakemake(wd, "--configfile", "config/test.yaml", "--report", "report.html")
    assert res.returncode == 0, res.stderr[-2000:]
    assert (wd / "report.html").stat().st_size > 10000
    assert res.stdout.count("Adding figure.png") + res.stderr.count("Adding figure.png") \
        == len(STUDIES)
    # every caption is the library's, rendered by figure.rst from the rule's caption
    # parameter (the report once had a hand-copied set that had drifted, and none for the
    # measured study). "<p>" + the text: the rendered caption; the report also lists each
    # job's parameters, where the caption stands without the paragraph tag.
    import html

    from roughflow.figures.captions import CAPTIONS

    text = (wd / "report.html").read_text()
    for study in STUDIES:
        # the first 300 characters hold text of each study's own (after the shared note)
        assert "<p>" + html.escape(CAPTIONS[study][:300], quote=False) in text, study

    from roughflow.figures.captions import _CORRECTED, CAPTIONS

    text = (wd / "report.html").read_text()
    for study in STUDIES:
        caption = CAPTIONS[study].removeprefix(_CORRECTED)
        for part in (caption[:60], caption[-60:]):
            assert html.escape(part.strip(), quote=False) in text, (study, part)

    # each caption says which study block computed the figure (a report of the test config
    # looked like one of the paper's)
    plain = re.sub(r"<[^>]*>", "", text.replace("&quot;", '"').replace('\\"', '"'))
    for study in STUDIES:
        assert f"Computed with studies.{study}: {{" in plain, study

    html = (wd / "report.html").read_text()
    for study in STUDIES:
        start = CAPTIONS[study].split(". ")[0][:60].replace("*", "\\*")
        assert start.split("(")[0].strip()[:40] in html.replace("\\*", "*") or \
            CAPTIONS[study][:40] in html, study


@pytest.mark.slow
def test_figure_style_change_does_not_rerun_simulations(test_run):
    wd, _ = test_run
    # touching the figure's caption (a report input) or the library must not rerun jobs;
    # forcing the figure reruns only the figure
    dry = snakemake(wd, "--configfile", "config/test.yaml", "-n", "--forcerun", "figure")
    counts = job_counts(dry.stdout)
    assert counts.get("figure") == len(STUDIES) and "scene" not in counts
    assert "leak" not in counts and "import_scan" not in counts


@pytest.mark.slow
def test_deleted_job_output_reruns_only_when_named(test_run):
    # docs/workflow.md "Deleted outputs": Snakemake does not recreate a missing intermediate
    # file whose dependents are up to date; naming it as a target reruns that one job, and
    # the next plain run then refreshes the study it belongs to. (Last of the tests on the
    # shared run: it leaves the run complete again.)
    wd, _ = test_run
    job = sorted((wd / "results" / "jobs" / "threshold").glob("bearing_*.nc"))[0]
    job.unlink()
    dry = snakemake(wd, "--configfile", "config/test.yaml", "-n")
    assert "Nothing to be done" in dry.stdout + dry.stderr
    named = snakemake(wd, "--configfile", "config/test.yaml", "--cores", "1",
                      str(job.relative_to(wd)))
    assert named.returncode == 0 and job.exists()
    assert job_counts(named.stdout + named.stderr) == {"scene": 1}
    dry = snakemake(wd, "--configfile", "config/test.yaml", "-n")
    counts = job_counts(dry.stdout)
    assert "scene" not in counts and counts.get("aggregate", 0) >= 1
    done = snakemake(wd, "--configfile", "config/test.yaml", "--cores", "2")
    assert done.returncode == 0


def test_only_requested_targets_run(tmp_path):
    wd = copy_workflow(tmp_path)
    dry = snakemake(wd, "--configfile", "config/test.yaml", "-n",
                    "results/threshold_vs_gamma/figure.png")
    assert dry.returncode == 0, dry.stderr
    counts = job_counts(dry.stdout)
    # 2 gammas x 2 models, seeds grouped 2 per job: 4 threshold jobs, no ladder/channels
    assert counts == {"scene": 4, "aggregate": 1, "figure": 1}
    assert "ladder" not in dry.stdout
    # each job requests the library's memory estimate plus the Snakemake wrapper
    # (roughflow.scenes.requests.requested_mem_mb) and the cost model's time with its margin
    from roughflow.scenes import estimated_memory, expand_study
    from roughflow.scenes.requests import WRAPPER_MB, requested_mem_mb, requested_runtime_min

    cfg = yaml.safe_load((wd / "config" / "test.yaml").read_text())["studies"]
    jobs = expand_study("threshold_vs_gamma", cfg["threshold_vs_gamma"])
    requested = {job_id: (minutes, mb) for job_id, minutes, mb in re.findall(
        r"wildcards: kind=threshold, job=(\S+)\s+resources: .*?runtime=(\d+), mem_mb=(\d+)",
        dry.stdout + dry.stderr)}
    assert requested.keys() == jobs.keys()
    for job_id, (minutes, mb) in requested.items():
        assert int(mb) == requested_mem_mb(jobs[job_id])
        assert int(mb) == WRAPPER_MB + math.ceil(estimated_memory(jobs[job_id]) / 1e6)
        assert int(minutes) == requested_runtime_min(jobs[job_id])


def test_a_local_run_shares_the_machines_memory_among_its_jobs(tmp_path):
    # Snakemake starts as many local jobs as --cores allows, whatever their mem_mb, unless
    # the run has a global mem_mb: the workflow gives it this machine's memory (16 cores had
    # started 16 jobs of the paper's sizes at once); a user's --resources mem_mb stands
    from roughflow.resources import total_bytes

    wd = copy_workflow(tmp_path)
    target = "results/measured/surfaces/afm.nc"  # one import job of a few seconds

    def provided(*args: str) -> int:
        run = snakemake(wd, target, "--configfile", "config/test.yaml", "--cores", "1", *args,
                        "--forcerun", "import_scan")
        assert run.returncode == 0, run.stderr[-2000:]
        [line] = [ln for ln in (run.stdout + run.stderr).splitlines()
                  if ln.startswith("Provided resources")]
        return int(re.search(r"mem_mb\D*(\d+)", line).group(1))

    assert provided() == total_bytes() // 10**6
    assert provided("--resources", "mem_mb=12345") == 12345


def test_a_failed_leak_job_keeps_its_log_and_no_half_table(tmp_path):
    # Every simulation rule keeps a failed attempt's log (KEEP_FAILED_LOG; a retry's log
    # replaces it). The leak rule's own clean-up of its half-written table ended the shell
    # with `exit`, before the copy, so its failures left no log (a crash audit).
    wd = copy_workflow(tmp_path)
    surface = wd / "results" / "measured" / "surfaces" / "afm.nc"
    run = snakemake(wd, str(surface.relative_to(wd)), "--configfile", "config/test.yaml",
                    "--cores", "1")
    assert run.returncode == 0, run.stderr[-2000:]
    # a netCDF file with a grid that is no surface: planning passes, `roughflow leak` fails
    xr.Dataset({"gap": (("x", "y"), np.zeros((8, 8)), {"units": "L", "long_name": "a gap"})}
               ).to_netcdf(surface)
    run = snakemake(wd, "results/jobs/leak/afm.nc", "--configfile", "config/test.yaml",
                    "--cores", "1")
    assert run.returncode != 0
    (kept,) = (wd / "results" / "logs" / "jobs" / "leak").glob("afm.log.failed-*")
    assert "roughflow leak: error" in kept.read_text()
    assert not list((wd / "results" / "measured").glob("afm.txt*"))


def test_paper_config_dry_run_job_counts(tmp_path):
    wd = copy_workflow(tmp_path)
    dry = snakemake(wd, "--configfile", "config/paper.yaml", "-n", timeout=300)
    assert dry.returncode == 0, dry.stderr[-3000:]
    counts = job_counts(dry.stdout)
    # Counted by hand from config/paper.yaml (10 seeds; one seed per elastic threshold job,
    # all 10 in one job for the cheap bearing model, one seed per ladder job):
    #   threshold_vs_gamma: 7 gammas x (elastic 1/16, elastic 1/64) = 14 elastic points,
    #     7 bearing points
    #   threshold_vs_size: gamma 2 at 5 sizes + 4 gammas at L = 32 + isotropic at 6 sizes
    #     (the gamma = 2 series' eps_t and 32; issue 20) = 15, minus the points shared
    #     with threshold_vs_gamma (gamma 2 at L 5.66, gamma 1 at L 4) = 13
    #   threshold_vs_hurst: 7 gammas x H 0.3 (H 0.8 is shared with threshold_vs_gamma) = 7
    #   -> 34 elastic points x 10 jobs + 7 bearing jobs = 347 threshold jobs
    #   flow: 3 isotropic + 2 anisotropic models x 10 seeds = 50 ladder jobs
    assert counts["scene"] == 347 + 50
    assert counts["channels"] == 1
    assert counts["aggregate"] == 5 and counts["fit"] == 1 and counts["figure"] == 6


BAD = {
    "unknown key": (lambda c: c["studies"]["threshold_vs_gamma"].update(colour="red"),
                    ["studies.threshold_vs_gamma", "colour"]),
    "gamma <= 0": (lambda c: c["studies"]["threshold_vs_gamma"].update(gamma=[1, -2]),
                   ["studies.threshold_vs_gamma.gamma.1", "-2"]),
    "hurst > 1": (lambda c: c["studies"]["threshold_vs_hurst"].update(hurst=[0.3, 1.5]),
                  ["studies.threshold_vs_hurst.hurst.1", "1.5"]),
    "under-resolved": (lambda c: c["studies"]["flow_isotropic"].update(points_per_lambda_s=1),
                       ["studies.flow_isotropic", "points_per_lambda_s", "1"]),
    "empty seeds": (lambda c: c["studies"]["threshold_vs_size"].update(seeds=[]),
                    ["studies.threshold_vs_size.seeds", "[]"]),
    "unknown study": (lambda c: c["studies"].update(fig9={"seeds": [0]}),
                      ["studies", "fig9"]),
    "unit that does not parse": (lambda c: c["studies"]["measured"].update(modulus="200 GPx"),
                                 ["studies.measured", "modulus", "200 GPx"]),
    "not a pressure": (lambda c: c["studies"]["measured"].update(fluid_pressure="2mm"),
                       ["studies.measured", "fluid_pressure", "not a pressure"]),
    "pressure range in the wrong order": (
        lambda c: c["studies"]["measured"].update(pressures="1GPa:1MPa:5"),
        ["studies.measured", "pressures", "wrong order"]),
    "missing scan file": (
        lambda c: c["studies"]["measured"]["scans"][0].update(file="tests/data/nope.npy"),
        ["studies.measured", "nope.npy", "does not exist"]),
    "zero seal width": (lambda c: c["studies"]["measured"].update(seal_width="0mm"),
                        ["studies.measured", "seal_width", "0mm"]),
    "crop that does not parse": (
        lambda c: c["studies"]["measured"]["scans"][0].update(crop="0-32,0-32"),
        ["studies.measured", "crop", "0-32,0-32"]),
    # issue 13 item 5: valid for the schema, but every job would fail
    "adhesive threshold study": (
        lambda c: c["studies"]["threshold_vs_gamma"]["series"][0].update(model=["adhesive"]),
        ["studies.threshold_vs_gamma.series[0]", "adhesive"]),
    # item 5: paths go into the jobs' shell commands unquoted
    "results with a space": (lambda c: c.update(results="res space"),
                             ["'results'", "res space"]),
    # item 1: the series differ only in a setting that is not a dimension of the dataset
    "series differ in resolution only": (
        lambda c: c["studies"]["threshold_vs_size"]["series"][1].update(
            gamma=[2], l_over_lambda_r=[2.8284271247461903], points_per_lambda_s=3),
        ["studies.threshold_vs_size", "points-per-lambda-s 2.0 vs 3.0"]),
    # item 2: about 54 TB per job (mem_mb 5e7)
    "job larger than the machine": (
        lambda c: c["studies"]["threshold_vs_size"].update(
            points_per_lambda_s=64, series=[{"l_over_lambda_r": [64], "eps_f": [0.01]}]),
        ["studies.threshold_vs_size", "TB", "max_mem_mb"]),
    # the accuracy target samples the finest grid down: 3 of 8 failed in its job, after the
    # tolerance job had run; 4.5 reached the script's integer option
    "accuracy resolution not dividing the finest": (
        lambda c: c.update(accuracy={"points_per_lambda_s": [3, 8]}),
        ["accuracy.points_per_lambda_s", "ppl 3 does not divide the largest, 8"]),
    # the report extrapolates from the two finest: one resolution planned and ran both
    # measuring jobs, then the report job failed
    "accuracy with one resolution": (
        lambda c: c.update(accuracy={"points_per_lambda_s": [4]}),
        ["accuracy.points_per_lambda_s", "[4]"]),
    "accuracy resolution not whole": (
        lambda c: c.update(accuracy={"points_per_lambda_s": [4.5, 9]}),
        ["accuracy.points_per_lambda_s", "4.5 is not of type 'integer'"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_config_fails_before_any_job(tmp_path, case):
    wd = copy_workflow(tmp_path)
    cfg = yaml.safe_load((wd / "config" / "test.yaml").read_text())
    edit, needles = BAD[case]
    edit(cfg)
    (wd / "config" / "bad.yaml").write_text(yaml.safe_dump(cfg))
    res = snakemake(wd, "--configfile", "config/bad.yaml", "-n")
    out = res.stdout + res.stderr
    assert res.returncode != 0
    assert "invalid config" in out
    for needle in needles:
        assert needle in out, (needle, out[-2000:])
    assert not (wd / "results").exists()


@pytest.mark.slow
def test_killed_job_leaves_no_trusted_output(tmp_path):
    wd = copy_workflow(tmp_path)
    cfg = {"studies": {"threshold_vs_gamma": {
        # a job of several seconds (6 seeds at 512^2), so that it is surely still running
        # 1 s after its first seed started
        "gamma": [1], "l_over_lambda_r": [8], "eps_f": [0.0625], "seeds": [0, 1, 2, 3, 4, 5],
        "seeds_per_job": 6, "points_per_lambda_s": 4, "tol": 0.002}}}
    (wd / "config" / "kill.yaml").write_text(yaml.safe_dump(cfg))
    # a killed snakemake leaves its runtime cache and temporary folder: in tmp_path, not in
    # ~/.cache/snakemake and /tmp (one of each per run, a test audit)
    (tmp_path / "tmp").mkdir()
    env = {**os.environ, "ROUGHFLOW_FFT_THREADS": "1", "XDG_CACHE_HOME": str(tmp_path / "cache"),
           "TMPDIR": str(tmp_path / "tmp")}
    proc = subprocess.Popen([str(SNAKEMAKE), "--configfile", "config/kill.yaml", "--cores", "1"],
                            cwd=wd, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    logs = wd / "results" / "logs" / "jobs" / "threshold"
    deadline = time.time() + 120
    while time.time() < deadline:
        started = [p for p in logs.glob("*.log") if "seed 0" in p.read_text()] \
            if logs.exists() else []
        if started:
            break
        time.sleep(0.2)
    else:
        proc.kill()
        pytest.fail("the job never started")
    time.sleep(1.0)
    os.killpg(proc.pid, signal.SIGKILL)  # snakemake and its job die without cleaning up
    proc.wait()
    jobs = list((wd / "results" / "jobs").rglob("*.nc"))
    assert jobs == [], "a killed job left an output file"
    # the rerun plans the job again (Snakemake also marks it incomplete)
    dry = snakemake(wd, "--configfile", "config/kill.yaml", "-n")
    assert dry.returncode == 0, dry.stderr
    assert job_counts(dry.stdout).get("scene") == 1


def test_cluster_profile_settings_take_effect(monkeypatch):
    # Snakemake loads profiles/default (the workflow profile) on top of --profile, key by key:
    # nothing in it may replace a setting of the cluster profile
    from snakemake.cli import parse_args

    monkeypatch.chdir(ROOT)
    _, args = parse_args(["--profile", "profiles/slurm", "-n"])
    assert args.executor == "slurm"
    assert (args.keep_going, args.latency_wait, args.retries) == (True, 60, 1)
    assert args.slurm_status_command == "squeue"
    # CPUs per job come from each rule's threads, not from a default resource
    assert "cpus_per_task" not in args.default_resources.keys()
    _, local = parse_args(["-n"])
    assert (local.executor, local.keep_going, local.retries) == (None, False, 0)


def test_compare_results_reports_every_difference():
    # workflow/scripts/compare_results.py checks that a change keeps the results of
    # config/test.yaml: a comparison with a tolerance, or one that takes NaN for a
    # difference, or skips a variable of one side, would say "identical" wrongly (or never)
    import importlib.util

    path = ROOT / "workflow" / "scripts" / "compare_results.py"
    spec = importlib.util.spec_from_file_location("compare_results", path)
    compare = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(compare)
    old = xr.Dataset({"a": ("x", [1.0, np.nan, 3.0]), "n": ("x", [1, 2, 3])})
    assert compare.differences(old, old.copy(deep=True)) == []  # NaN equals NaN
    new = old.copy(deep=True)
    new["a"].values[0] = 1.0 + 1e-12  # above one ulp of 1 (2.2e-16): a real difference
    [said] = compare.differences(old, new)
    assert said.startswith("a: max |diff| 1e-12"), said
    new = old.copy(deep=True)
    new["a"].values[1] = 2.0  # NaN against a number
    [said] = compare.differences(old, new)
    assert said.startswith("a:") and "NaN in one only: 1" in said, said
    new = old.copy(deep=True)
    new["n"].values[2] = 4
    assert compare.differences(old, new) == ["n: differs"]
    assert compare.differences(old, old.assign(b=("x", [0.0, 0.0, 0.0]))) == ["b: only in new"]
    assert compare.differences(old.assign(b=("x", [0.0] * 3)), old) == ["b: only in old"]
