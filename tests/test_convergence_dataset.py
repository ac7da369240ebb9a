"""The accuracy study's netCDF datasets: the record log written whole when a run completes
(roughflow.convergence.dataset), read by the report and declared by the workflow.

Runs are the smallest the study accepts (L/lambda_r = 1, 2 and 4 points per lambda_s: 32^2
and 64^2 grids; the tolerance study at 2 points per lambda_s, 128^2).
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest
import xarray as xr
from workflow_copy import copy_workflow

from roughflow.cli import main
from roughflow.convergence import measure
from roughflow.convergence.anisotropic import anisotropic_records_draft
from roughflow.convergence.dataset import (
    records_from_dataset,
    records_to_dataset,
    write_records_dataset,
)
from roughflow.convergence.options import ResolutionOptions, ToleranceOptions
from roughflow.convergence.records import (
    load_records,
    resolution_file,
    tolerance_file,
)
from roughflow.convergence.report import records_draft
from roughflow.convergence.tables import publish_reports
from roughflow.errors import ConvergenceError, InputError
from roughflow.io import read_dataset, write_dataset
from roughflow.units import registry

NAN = float("nan")
RESOLUTION = ["accuracy", "resolution", "--seeds", "0", "--ppl", "2", "4",
              "--l-over-lambda-r", "1"]
TOLERANCE = ["accuracy", "tol", "--seeds", "0", "--tol-ppl", "2", "--contact-tols", "1e-3",
             "1e-6", "--threshold-contact-tols", "1e-3", "1e-5", "--bisect-tols", "0.01",
             "0.002"]


def _same(a: list[dict], b: list[dict]) -> bool:
    """Equal lists of records: the same keys, values and types (NaN equal to NaN)."""
    return ([json.dumps(r, sort_keys=True) for r in a]
            == [json.dumps(r, sort_keys=True) for r in b])


def _log(path: Path, records: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in records))


# records of every kind, as the study writes them, with what a log may hold besides: NaN
# (no bracket, no percolation), null (the paper's L/lambda_r), fields absent from a kind or
# from an older record (no gamma, no face counts), text, empty text
HAND_BUILT = [
    dict(kind="threshold", seed=0, ppl=2, n=32, ny=32, gamma=1.0, l_over_lambda_r=None,
         dx=1 / 32, dy=1 / 32, bisect_tol=1e-3, contact_tol=1e-5, time=0.5, n_solves=9,
         a_star_0=0.43, a_star_corrected_0=0.41, a_lo_0=0.4299, a_hi_0=0.4301, a_mid_0=NAN,
         perim_0=NAN, tx_0=NAN, ty_0=NAN, a_star_1=0.44, time_mid=0.01, perim_mid=NAN),
    dict(kind="sigma", seed=0, ppl=2, target=0.35, p_fixed=0.18, a_fixed=0.39, sigma=NAN,
         sigma_raw=0.0, mean_gap=0.004, n_contact_solves=3, time_contact=0.1, time_flow=0.05,
         flow_residual=1e-15, flux_imbalance=6e-11, contact_tol=1e-6, area_tol=3e-4),
    dict(kind="fixed", seed=12, ppl=4, gamma=2.0, l_over_lambda_r=2.0, target=0.2,
         a_fixed=0.25, tx_fixed=0.17, ty_fixed=0.2),
    dict(kind="threshold", seed=1, ppl=4, a_star_0=0.42, a_star_1=0.45, perim_mid=0.2),
    dict(kind="contact_tol", seed=0, ppl=2, target=0.2, p=0.101, contact_tol=1e-3,
         a=0.2447, mean_gap=0.0072, sigma=3.1e-9, iterations=12),
    dict(kind="threshold_contact_tol_failed", seed=0, ppl=2, contact_tol=1e-3,
         bisect_tol=1e-3, error="the search did not bracket a_c*: 80 solves"),
    dict(kind="bisect_tol_failed", seed=1, ppl=2, bisect_tol=0.01, contact_tol=1e-5,
         error=""),
    dict(kind="bisect_tol", seed=1, ppl=2, bisect_tol=0.01, contact_tol=1e-5, time=0.01,
         n_solves=4, a_star_0=0.446, a_star_1=0.449, width_0=0.0077, width_1=0.0077),
]


def test_hand_built_records_round_trip_exactly(tmp_path):
    ds = records_to_dataset(HAND_BUILT, study="resolution")
    assert _same(records_from_dataset(ds), HAND_BUILT)
    # and through the file: integers come back as integers, null as None, absent as absent
    write_dataset(ds, tmp_path / "r.nc")
    back = records_from_dataset(read_dataset(tmp_path / "r.nc"))
    assert _same(back, HAND_BUILT)
    assert back[0]["l_over_lambda_r"] is None and "gamma" not in back[3]
    assert math.isnan(back[0]["a_mid_0"]) and back[6]["error"] == ""
    assert [type(r["seed"]) for r in back] == [int] * len(HAND_BUILT)


def test_large_integers_in_every_record_come_back_exactly(tmp_path):
    # seeds go up to 2^63 - 1: a column xarray decodes through a fill value as float64
    # rounded 2^53 + 1 to 2^53, and two seeds became one in the report
    recs = [dict(kind="fixed", seed=2**53 + 1, ppl=2), dict(kind="fixed", seed=2**63 - 1,
                                                            ppl=4)]
    write_dataset(records_to_dataset(recs, study="resolution"), tmp_path / "r.nc")
    ds = read_dataset(tmp_path / "r.nc")
    assert ds["seed"].dtype == "int64" and ds["ppl"].dtype == "int64"
    assert records_from_dataset(ds) == recs


def test_integers_and_floats_of_one_field_and_unknown_fields(tmp_path):
    # a field with integers in some records and floats in others comes back as floats,
    # equal in value (the documented rule); an integer that is the fill value stays itself
    recs = [dict(kind="fixed", seed=0, target=1), dict(kind="fixed", seed=1, target=0.2),
            dict(kind="fixed", seed=2, ppl=-1), dict(kind="fixed", seed=3)]
    write_dataset(records_to_dataset(recs, study="resolution"), tmp_path / "r.nc")
    back = records_from_dataset(read_dataset(tmp_path / "r.nc"))
    assert back == recs and back[0]["target"] == 1.0 and back[2]["ppl"] == -1
    with pytest.raises(InputError, match="record field 'colour' is not a field"):
        records_to_dataset([dict(kind="fixed", colour="red")], study="resolution")
    with pytest.raises(InputError, match="record field 'seed' holds bool values"):
        records_to_dataset([dict(kind="fixed", seed=True)], study="resolution")
    with pytest.raises(InputError, match="holds no records of the accuracy study"):
        records_from_dataset(xr.Dataset({"a": ((), 1.0)}))


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """Both phases run by the command line into one folder, and its report."""
    out = tmp_path_factory.mktemp("study")
    assert main([*RESOLUTION, "--out", str(out)]) == 0
    assert main([*TOLERANCE, "--out", str(out)]) == 0
    assert main(["accuracy", "report", "--out", str(out), "--fit-min-ppl", "2"]) == 0
    return out


def test_each_run_writes_its_whole_log_as_a_dataset(study):
    for log, dataset, name, phase in (
            (resolution_file(study, 1.0), resolution_file(study, 1.0, dataset=True),
             "resolution", "resolution"),
            (tolerance_file(study), tolerance_file(study, dataset=True), "tolerance", "tol")):
        assert dataset == log.with_suffix(".nc")  # beside the log, of its stem
        ds = read_dataset(dataset)
        assert _same(records_from_dataset(ds), load_records(log))
        assert ds.sizes["record"] == len(load_records(log)) > 0
        a = ds.attrs
        assert a["study"] == name and a["records_log"] == log.name
        assert a["command"].startswith(f"roughflow accuracy {phase} ")
        assert "WM21" in a["references"].split() and a["wall_time_s"] > 0
        assert {"roughflow_version", "created", "history"} <= set(a)


def test_every_variable_has_units_and_long_name(study):
    for path in (resolution_file(study, 1.0, dataset=True), tolerance_file(study, dataset=True)):
        with xr.open_dataset(path) as ds:
            ureg = registry(ds.attrs)
            assert len(ds.variables) > 10
            for name, v in ds.variables.items():
                assert v.attrs.get("long_name"), (path.name, name)
                if v.dtype.kind in "OUS":  # text (kind, error, field): no units, as elsewhere
                    continue
                # every numeric variable, coordinates too (README), in units pint parses
                ureg.parse_units(v.attrs["units"])
            assert ds["field_state"].attrs["flag_meanings"] == "absent value null"


def test_report_from_the_datasets_equals_the_report_from_the_records(study, tmp_path):
    # the report job reads the datasets; the records of the logs make byte-identical tables
    res, tol = load_records(resolution_file(study, 1.0)), load_records(tolerance_file(study))
    drafts = [records_draft(res, tol, fit_min_ppl=2),
              anisotropic_records_draft(res, fit_min_ppl=2)]
    publish_reports(tmp_path, drafts)
    for name in ("convergence.md", "convergence.csv", "convergence_anisotropic.md",
                 "convergence_anisotropic.csv"):
        assert (study / name).read_bytes() == (tmp_path / name).read_bytes(), name
    # the logs are no input of the report: without them it is the same
    rerun = tmp_path / "datasets_only"
    rerun.mkdir()
    for path in (resolution_file(study, 1.0, dataset=True), tolerance_file(study, dataset=True)):
        (rerun / path.name).write_bytes(path.read_bytes())
    assert main(["accuracy", "report", "--out", str(rerun), "--fit-min-ppl", "2"]) == 0
    assert (rerun / "convergence.md").read_bytes() == (study / "convergence.md").read_bytes()


def test_a_log_without_its_dataset_makes_no_report(tmp_path, capsys):
    # an interrupted run leaves its log but no dataset: nothing is reported from it
    _log(resolution_file(tmp_path, 1.0), HAND_BUILT[:1])
    with pytest.raises(SystemExit) as exc:
        main(["accuracy", "report", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "convergence_resolution*.nc" in err, err


def _stale_dataset(log: Path) -> Path:
    """A complete-looking dataset of an earlier run beside ``log``."""
    _log(log, [])
    return write_records_dataset(log, study="resolution")


def test_a_failed_run_removes_the_stale_dataset_and_writes_none(tmp_path, monkeypatch):
    opts = ResolutionOptions(seeds=(0,), ppl=(2, 4), l_over_lambda_r=1.0)
    log = resolution_file(tmp_path, 1.0)
    stale = _stale_dataset(log)

    def fail(*args, **kwargs):
        raise ConvergenceError("stub", residual=1.0, iterations=0)

    monkeypatch.setattr(measure, "_sigma_targets", fail)
    with pytest.raises(ConvergenceError):
        measure.measure_resolution(tmp_path, opts, warm=False)
    assert not stale.exists()
    assert [r["kind"] for r in load_records(log)] == ["threshold"]  # kept to resume from
    assert not list(tmp_path.glob("*.part"))


@pytest.mark.parametrize("study", ["resolution", "tolerance"])
def test_a_refused_run_leaves_the_log_and_its_dataset_as_they_were(tmp_path, study):
    # records of another run: refused before any work, and the earlier run's files (a
    # complete log and its dataset) stay a consistent pair
    if study == "resolution":
        log, run = resolution_file(tmp_path, 1.0), measure.measure_resolution
        opts = ResolutionOptions(seeds=(0,), ppl=(2, 4), l_over_lambda_r=1.0)
        other = dict(kind="threshold", seed=0, ppl=2, l_over_lambda_r=2.0)
    else:
        log, run = tolerance_file(tmp_path), measure.measure_tolerances
        opts = ToleranceOptions(seeds=(0,))
        other = dict(kind="contact_tol", seed=0, ppl=8)
    _log(log, [other])
    dataset = write_records_dataset(log, study=study)
    before = dataset.read_bytes()
    with pytest.raises(InputError, match="another run"):
        run(tmp_path, opts, warm=False)
    assert dataset.read_bytes() == before and load_records(log) == [other]


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGKILL])
def test_a_killed_run_leaves_no_dataset(tmp_path, signum):
    stale = _stale_dataset(resolution_file(tmp_path, 1.0))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(Path(__file__).resolve().parents[1] / "src"), os.environ.get("PYTHONPATH", "")])}
    # six seeds at three resolutions: seconds of work left after the first record
    argv = [sys.executable, "-m", "roughflow", "accuracy", "resolution", "--out",
            str(tmp_path), "--seeds", "0", "1", "2", "3", "4", "5", "--ppl", "2", "4", "8",
            "--l-over-lambda-r", "1"]
    with subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                          env=env) as proc:
        first = json.loads(proc.stdout.readline())  # measuring: its first record is out
        proc.send_signal(signum)
        proc.communicate(timeout=120)
    assert proc.returncode in (-signum, 128 + signum), proc.returncode
    assert first["kind"] == "threshold" and load_records(resolution_file(tmp_path, 1.0))
    assert not stale.exists()
    assert not list(tmp_path.glob("*.part"))


def test_workflow_declares_the_datasets(tmp_path):
    # the measuring jobs' outputs and the report's inputs are the datasets; the logs are
    # the jobs' logs, no output or input
    snakemake = Path(sys.executable).with_name("snakemake")
    if not snakemake.exists():
        pytest.skip("snakemake not installed")
    wd = copy_workflow(tmp_path)
    (wd / "config" / "case.yaml").write_text((wd / "config" / "test.yaml").read_text())
    res = subprocess.run([str(snakemake), "accuracy", "-n", "--cores", "1", "--configfile",
                          "config/case.yaml"], cwd=wd, capture_output=True, text=True,
                         timeout=300, env={**os.environ, "MPLBACKEND": "Agg"})
    assert res.returncode == 0, res.stderr[-2000:]
    rules, rule = {}, None
    for line in res.stdout.splitlines():
        if line.startswith("rule "):
            rule = rules.setdefault(line[5:].rstrip(":"), {})
        elif rule is not None and line.startswith("    ") and ": " in line:
            key, value = line.strip().split(": ", 1)
            rule[key] = value.split(", ")
    out = "results/benchmarks"
    resolution = str(resolution_file(out, 1.0, dataset=True))
    tolerance = str(tolerance_file(out, dataset=True))
    assert resolution.endswith(".nc") and tolerance.endswith(".nc")
    assert rules["accuracy_resolution"]["output"] == [resolution]
    assert rules["accuracy_tolerances"]["output"] == [tolerance]
    assert sorted(rules["accuracy"]["input"]) == sorted([resolution, tolerance])
    assert str(resolution_file(out, 1.0)) in rules["accuracy_resolution"]["log"]
    assert str(tolerance_file(out)) in rules["accuracy_tolerances"]["log"]
