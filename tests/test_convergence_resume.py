"""The accuracy study's record files: resuming, refusing other runs' records, truncated
lines, reports that cannot be made, and publishing the reports together.

Grids are the smallest the study accepts (L/lambda_r = 1, 2 and 4 points per lambda_s:
32^2 and 64^2); where only the bookkeeping is tested, the solver calls are replaced.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from roughflow.convergence import measure
from roughflow.convergence.dataset import write_records_dataset
from roughflow.convergence.options import ResolutionOptions, ToleranceOptions
from roughflow.convergence.records import (
    ANISOTROPIC_STEM,
    REPORT_STEM,
    load_records,
    resolution_file,
    tolerance_file,
)
from roughflow.convergence.report import write_reports
from roughflow.errors import InputError, ResourceError
from roughflow.surface import SurfaceSpec

TINY = dict(seeds=(0,), ppl=(2, 4), l_over_lambda_r=1.0)


def _grid(ppl: int) -> tuple[int, int]:
    spec = SurfaceSpec.from_sweep(l_over_lambda_r=1.0, points_per_lambda_s=ppl)
    return spec.nx, spec.ny


def _threshold(ppl: int, **changed) -> dict:
    """A threshold record as a run of ResolutionOptions(**TINY) writes it (its settings)."""
    nx, ny = _grid(ppl)
    opts = ResolutionOptions(**TINY)
    rec = dict(kind="threshold", seed=0, ppl=ppl, n=nx, ny=ny, gamma=1.0,
               l_over_lambda_r=1.0, bisect_tol=opts.bisect_tol,
               contact_tol=opts.threshold_contact_tol)
    return {**rec, **changed}


def _write(path: Path, records: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("".join(json.dumps(r) + "\n" for r in records))


def _no_solves(monkeypatch) -> None:
    def refuse(*args, **kwargs):
        raise AssertionError("a solve ran")
    monkeypatch.setattr(measure, "warm_up", refuse)
    monkeypatch.setattr(measure, "threshold_record", refuse)
    monkeypatch.setattr(measure, "_sigma_targets", refuse)
    monkeypatch.setattr(measure, "_fixed_loads", refuse)


@pytest.mark.parametrize("changed", [dict(l_over_lambda_r=2.0), dict(bisect_tol=0.01),
                                     dict(contact_tol=1e-4), dict(n=16)])
def test_resume_refuses_records_of_other_settings(tmp_path, monkeypatch, changed):
    # before: records of another L/lambda_r or tolerance counted as done, the rerun computed
    # nothing and the report mixed the two runs
    path = resolution_file(tmp_path, 1.0)
    _write(path, [_threshold(2, **changed)])
    _no_solves(monkeypatch)
    [field] = changed
    with pytest.raises(InputError, match=f"another run: {field}"):
        measure.measure_resolution(tmp_path, ResolutionOptions(**TINY))
    assert len(load_records(path)) == 1


def test_resume_fills_in_the_missing_sigma_targets(tmp_path, monkeypatch):
    # before: a seed and resolution with its threshold record was skipped whole, so sigma
    # records lost to an interrupted run were never measured
    path = resolution_file(tmp_path, 1.0)
    done_sigma = dict(kind="sigma", seed=0, ppl=2, target=0.2, gamma=1.0, l_over_lambda_r=1.0,
                      contact_tol=1e-6)
    _write(path, [_threshold(2), done_sigma, _threshold(4)])
    _no_solves(monkeypatch)
    calls = []
    monkeypatch.setattr(measure, "_sigma_targets",
                        lambda surf, base, targets, opts, emit: calls.append(
                            (base["ppl"], surf.shape, targets)))
    measure.measure_resolution(tmp_path, ResolutionOptions(**TINY), warm=False)
    assert calls == [(2, _grid(2), (0.35,)), (4, _grid(4), (0.2, 0.35))]


def test_complete_file_resumes_without_work(tmp_path, monkeypatch):
    path = resolution_file(tmp_path, 1.0)
    sigma = [dict(kind="sigma", seed=0, ppl=p, target=t, gamma=1.0, l_over_lambda_r=1.0)
             for p in (2, 4) for t in (0.2, 0.35)]
    _write(path, [_threshold(2), _threshold(4), *sigma])
    _no_solves(monkeypatch)  # warm_up included: nothing to do, no warm-up either
    assert measure.measure_resolution(tmp_path, ResolutionOptions(**TINY)) == path


def test_truncated_line_is_named(tmp_path):
    path = resolution_file(tmp_path, 1.0)
    _write(path, [_threshold(2)])
    with path.open("a") as f:
        f.write('{"kind": "sigma", "seed": 1, "pp')
    with pytest.raises(InputError, match=r"convergence_resolution.jsonl:2 is not a complete"):
        load_records(path)


def test_largest_grid_is_checked_before_any_work(tmp_path, monkeypatch):
    # before: the coarser resolutions of the first seed ran, then the finest was refused
    from roughflow import resources

    monkeypatch.setattr(resources, "available_bytes", lambda: 10**8)
    _no_solves(monkeypatch)
    # the paper's L/lambda_r: 1024^2 at 16 points per lambda_s, about 1.7 GB for sigma
    with pytest.raises(ResourceError, match="largest grid on a 1024 x 1024"):
        measure.measure_resolution(tmp_path, ResolutionOptions(seeds=(0,), ppl=(2, 16)))
    with pytest.raises(ResourceError, match="largest grid on a 1024 x 1024"):
        measure.measure_tolerances(tmp_path, ToleranceOptions(seeds=(0,), ppl=16))
    assert not any(tmp_path.iterdir())


def test_tolerance_study_resumes_and_refuses_another_resolution(tmp_path, monkeypatch):
    opts = ToleranceOptions(seeds=(0,), ppl=2, contact_tols=(1e-3,),
                            threshold_contact_tols=(1e-3,), bisect_tols=(0.01,))
    path = tolerance_file(tmp_path)
    done = [dict(kind="contact_tol", seed=0, ppl=2, target=t, contact_tol=1e-3)
            for t in (0.2, 0.35)]
    done += [dict(kind="threshold_contact_tol_failed", seed=0, ppl=2, contact_tol=1e-3,
                  bisect_tol=opts.threshold_bisect_tol)]
    _write(path, done)
    calls = []

    def fake_threshold(surf, *, axis, tol, options):
        calls.append((tol, options.contact_tol))
        raise measure.ConvergenceError("stub", residual=1.0, iterations=0)
    monkeypatch.setattr(measure, "threshold", fake_threshold)
    monkeypatch.setattr(measure.contact, "solve",
                        lambda *a, **k: pytest.fail("a measured contact tol ran again"))
    measure.measure_tolerances(tmp_path, opts, warm=False)
    # only the bisection tolerance was missing; it is recorded (as failed, by the stub)
    assert calls == [(0.01, opts.threshold_contact_tol)]
    assert [r["kind"] for r in load_records(path)][-1] == "bisect_tol_failed"
    with pytest.raises(InputError, match="another run: ppl 2 there, 4 here"):
        measure.measure_tolerances(tmp_path, ToleranceOptions(seeds=(0,), ppl=4), warm=False)


@pytest.mark.parametrize("kwargs, message", [
    (dict(ppl=(2, 2, 4)), r"ppl must be distinct, got \[2, 2, 4\]"),
    (dict(fixed_targets=(0.2, 0.2)), "fixed_targets must be distinct"),
    (dict(fixed_targets=(0.2, 1.0)), r"must lie in \(0, 1\)"),
])
def test_options_refuse_what_the_report_cannot_use(kwargs, message):
    with pytest.raises(InputError, match=message):
        ResolutionOptions(**kwargs)


def test_tolerance_lists_must_be_distinct():
    with pytest.raises(InputError, match="contact_tols must be distinct"):
        ToleranceOptions(contact_tols=(1e-3, 1e-3))


def test_report_without_a_complete_seed_is_refused(tmp_path):
    # before: "Seeds []", empty tables and exit 0 (a single resolution: an IndexError)
    _write(resolution_file(tmp_path, 1.0), [_threshold(2)])
    write_records_dataset(resolution_file(tmp_path, 1.0), study="resolution")
    with pytest.raises(InputError, match="no seed with threshold records at two or more"):
        write_reports(tmp_path)
    assert not list(tmp_path.glob(f"{REPORT_STEM}.*"))


def test_reports_replace_every_file_of_an_earlier_report(tmp_path):
    # a gamma = 2 run alone makes the anisotropic report only: the isotropic files of an
    # earlier run in the same folder described other records and go
    opts = ResolutionOptions(seeds=(0,), ppl=(2, 4), gamma=2.0, l_over_lambda_r=2.0)
    measure.measure_resolution(tmp_path, opts, warm=False)
    stale = [tmp_path / f"{REPORT_STEM}.md", tmp_path / f"{REPORT_STEM}.csv"]
    for path in stale:
        path.write_text("an earlier report\n")
    written = write_reports(tmp_path, fit_min_ppl=2)
    assert len(written) == 1 and written[0].markdown.startswith("# Anisotropic")
    assert {p.name for p in written[0].paths} == {
        f"{ANISOTROPIC_STEM}{s}" for s in (".md", ".csv", ".png")}
    assert not any(p.exists() for p in stale)


def test_each_seed_measures_its_own_surface(tmp_path, monkeypatch):
    # every resolution of a seed is that seed's finest surface sampled down; a run that
    # generated one seed's surface for all measured seed scatter of zero
    generated, measured = [], []
    real = measure.generate

    def spy(spec):
        generated.append(spec.seed)
        return real(spec)

    def record(surf, **kwargs):
        measured.append(surf.heights.copy())
        return {"a_star_0": 0.4, "a_star_1": 0.4}

    monkeypatch.setattr(measure, "generate", spy)
    monkeypatch.setattr(measure, "threshold_record", record)
    monkeypatch.setattr(measure, "_sigma_targets", lambda *a, **k: None)
    measure.measure_resolution(tmp_path, ResolutionOptions(**{**TINY, "seeds": (0, 3)}),
                               warm=False)
    assert generated == [0, 3]
    # seed by seed, coarse first: seed 0 at 2 and 4 points per lambda_s, then seed 3
    assert [h.shape for h in measured] == [_grid(2), _grid(4)] * 2
    np.testing.assert_array_equal(measured[0], measured[1][::2, ::2])
    np.testing.assert_array_equal(measured[2], measured[3][::2, ::2])
    assert not np.array_equal(measured[1], measured[3])


def test_a_failed_tolerance_run_removes_the_stale_dataset(tmp_path, monkeypatch):
    log = tolerance_file(tmp_path)
    _write(log, [])
    stale = write_records_dataset(log, study="tolerance")

    def fail(*args, **kwargs):
        raise RuntimeError("a solve failed")

    monkeypatch.setattr(measure, "_contact_tolerances", fail)
    with pytest.raises(RuntimeError):
        measure.measure_tolerances(tmp_path, ToleranceOptions(seeds=(0,), ppl=2),
                                   warm=False)
    assert not stale.exists()


def test_a_second_run_on_the_same_log_is_refused(tmp_path, monkeypatch):
    # two runs on one log (a rerun while an orphaned run lives on) interleaved their
    # records; the first run now holds the log, and the second is refused before any work
    from roughflow.convergence.records import RecordLog

    path = resolution_file(tmp_path, 1.0)
    _write(path, [_threshold(2)])
    _no_solves(monkeypatch)
    with RecordLog(path), pytest.raises(InputError, match="being written by another run"):
        measure.measure_resolution(tmp_path, ResolutionOptions(**TINY))
    with RecordLog(tolerance_file(tmp_path)), \
            pytest.raises(InputError, match="being written by another run"):
        measure.measure_tolerances(tmp_path, ToleranceOptions(seeds=(0,), ppl=2))
    assert load_records(path) == [_threshold(2)]


def test_a_run_whose_log_was_replaced_writes_neither_log_nor_dataset(tmp_path, monkeypatch):
    # a run that lives on after its job was ended (its shell wrapper killed) while the
    # rerun removed the log and started a new one: before, the old run appended to the
    # new log by name and, at its end, wrote a dataset from it that looked complete
    path = resolution_file(tmp_path, 1.0)
    rerun = [_threshold(2, seed=7)]

    def record(surf, **kwargs):
        if surf.shape == _grid(2):  # the rerun replaces the log after the first record
            path.unlink(missing_ok=True)
            _write(path, rerun)
        return {"a_star_0": 0.4, "a_star_1": 0.4}

    monkeypatch.setattr(measure, "threshold_record", record)
    monkeypatch.setattr(measure, "_sigma_targets", lambda *a, **k: None)
    with pytest.raises(InputError, match="removed or replaced while this run wrote it"):
        measure.measure_resolution(tmp_path, ResolutionOptions(**TINY), warm=False)
    assert load_records(path) == rerun
    assert not path.with_suffix(".nc").exists()
