"""``roughflow accuracy``: the accuracy study's command line (roughflow.convergence)."""

from __future__ import annotations

import json

import pytest

from roughflow.cli import build_parser, main
from roughflow.cli.accuracy import resolution_options, tolerance_options
from roughflow.convergence import measure
from roughflow.convergence.options import ResolutionOptions, ToleranceOptions
from roughflow.convergence.records import (
    load_records,
    report_files,
    resolution_file,
    tolerance_file,
)
from roughflow.errors import InputError

#: timings differ from run to run; every other field is a result
TIMES = ("time", "time_mid", "time_contact", "time_flow")


def _args(*argv: str):
    return build_parser().parse_args(["accuracy", *argv])


def test_defaults_are_the_option_classes():
    # the parser's defaults are read from the option classes (one place for each value)
    assert resolution_options(_args("resolution")) == ResolutionOptions()
    assert tolerance_options(_args("tol")) == ToleranceOptions()
    assert _args("report").out == _args("resolution").out == "results/benchmarks"


def test_every_option_reaches_the_library(tmp_path, monkeypatch):
    calls = {}
    monkeypatch.setattr(measure, "measure_resolution",
                        lambda out, opts, **kw: calls.setdefault("resolution", (out, opts)))
    monkeypatch.setattr(measure, "measure_tolerances",
                        lambda out, opts, **kw: calls.setdefault("tol", (out, opts)))
    out = str(tmp_path / "acc")
    assert main(["accuracy", "resolution", "--out", out, "--seeds", "3", "5", "--ppl", "3", "6",
                 "--gamma", "2", "--l-over-lambda-r", "2", "--no-sigma", "--fixed-targets",
                 "0.1", "0.3", "--bisect-tol", "2e-3", "--threshold-contact-tol", "2e-5",
                 "--contact-tol", "2e-6", "--area-tol", "4e-4"]) == 0
    assert calls["resolution"] == (out, ResolutionOptions(
        seeds=(3, 5), ppl=(3, 6), gamma=2.0, l_over_lambda_r=2.0, sigma=False,
        fixed_targets=(0.1, 0.3), bisect_tol=2e-3, threshold_contact_tol=2e-5,
        contact_tol=2e-6, area_tol=4e-4))
    assert main(["accuracy", "tol", "--out", out, "--seeds", "4", "--tol-ppl", "3",
                 "--contact-tols", "1e-3", "1e-7", "--threshold-contact-tols", "1e-4", "1e-6",
                 "--threshold-bisect-tol", "4e-3", "--bisect-tols", "0.02", "0.001",
                 "--threshold-contact-tol", "3e-5"]) == 0
    assert calls["tol"] == (out, ToleranceOptions(
        seeds=(4,), ppl=3, contact_tols=(1e-3, 1e-7), threshold_contact_tols=(1e-4, 1e-6),
        threshold_bisect_tol=4e-3, bisect_tols=(0.02, 0.001), threshold_contact_tol=3e-5))
    assert _args("resolution", "--sigma").sigma is True
    assert _args("report", "--fit-min-ppl", "8").fit_min_ppl == 8


@pytest.mark.parametrize(("argv", "message"), [
    (["resolution", "--ppl", "3", "8"], "ppl 3 does not divide the largest, 8"),
    (["resolution", "--ppl", "3", "4", "10"], "ppl 3, 4 do not divide the largest, 10"),
    (["resolution", "--ppl", "1", "2"], "ppl entry must be >= 2, got 1"),
    (["resolution", "--seeds", "1", "1"], "seeds must be distinct"),
    (["resolution", "--area-tol", "0"], "area_tol must be positive"),
    (["tol", "--bisect-tols", "0.01", "-1"], "bisect_tols entry must be positive"),
    (["tol", "--tol-ppl", "1"], "tol_ppl must be >= 2"),
])
def test_bad_input_is_refused_before_any_work(tmp_path, monkeypatch, capsys, argv, message):
    def no_work(*a, **kw):
        raise AssertionError("work started")

    monkeypatch.setattr(measure, "warm_up", no_work)
    monkeypatch.setattr(measure, "generate", no_work)
    with pytest.raises(SystemExit) as exc:
        main(["accuracy", *argv, "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and message in err, err
    assert list(tmp_path.iterdir()) == []


def test_library_refuses_a_resolution_that_is_not_a_sampling():
    with pytest.raises(InputError, match="ppl 6 does not divide the largest, 16"):
        ResolutionOptions(ppl=(2, 6, 16))


def test_output_folder_and_missing_records_are_refused(tmp_path, capsys):
    a_file = tmp_path / "file"
    a_file.write_text("")
    for phase in ("resolution", "tol", "report"):
        with pytest.raises(SystemExit) as exc:
            main(["accuracy", phase, "--out", str(a_file)])
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "is a file" in err, err
    with pytest.raises(SystemExit) as exc:  # nothing measured yet: nothing to report
        main(["accuracy", "report", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert exc.value.code == 2 and "run `roughflow accuracy resolution` first" in err, err
    # an option of another phase is no option of this one
    with pytest.raises(SystemExit) as exc:
        main(["accuracy", "report", "--seeds", "0", "--out", str(tmp_path)])
    assert exc.value.code == 2 and "unrecognized arguments: --seeds" in capsys.readouterr().err


def _results(records: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k not in TIMES} for r in records]


def test_resolution_tol_and_report_end_to_end(tmp_path, capsys):
    # the smallest affordable study: one seed, 32^2 and 64^2 grids (L / lambda_r = 1), two
    # tolerances each; the command's records are the library's, and a rerun adds none
    out = tmp_path / "acc"
    res = ["accuracy", "resolution", "--out", str(out), "--seeds", "0", "--ppl", "2", "4",
           "--l-over-lambda-r", "1"]
    assert main(res) == 0
    printed = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    records = load_records(resolution_file(out, 1.0))
    assert printed == records
    assert [(r["kind"], r["ppl"], r.get("target")) for r in records] == [
        ("threshold", 2, None), ("sigma", 2, 0.2), ("sigma", 2, 0.35),
        ("threshold", 4, None), ("sigma", 4, 0.2), ("sigma", 4, 0.35)]
    assert [r["n"] for r in records if r["kind"] == "threshold"] == [32, 64]
    for r in records:
        if r["kind"] == "sigma":
            # within --area-tol, or a pixel where the grid cannot come closer
            assert abs(r["a"] - r["target"]) <= max(3e-4, 1 / (r["n"] * r["ny"]))
            assert r["sigma_raw"] > 0
    assert main(res) == 0  # resumed: everything is there already
    assert load_records(resolution_file(out, 1.0)) == records
    capsys.readouterr()

    assert main(["accuracy", "tol", "--out", str(out), "--seeds", "0", "--tol-ppl", "2",
                 "--contact-tols", "1e-3", "1e-6", "--threshold-contact-tols", "1e-3", "1e-5",
                 "--bisect-tols", "0.01", "0.002"]) == 0
    tol = load_records(tolerance_file(out))
    assert sorted({r["kind"] for r in tol}) == ["bisect_tol", "contact_tol",
                                                "threshold_contact_tol"]
    api = tmp_path / "api"
    measure.measure_tolerances(api, ToleranceOptions(
        seeds=(0,), ppl=2, contact_tols=(1e-3, 1e-6), threshold_contact_tols=(1e-3, 1e-5),
        bisect_tols=(0.01, 0.002)), warm=False)
    assert _results(load_records(tolerance_file(api))) == _results(tol)
    capsys.readouterr()

    assert main(["accuracy", "report", "--out", str(out), "--fit-min-ppl", "2"]) == 0
    for name in report_files():
        assert (out / name).stat().st_size > 0, name
    md = (out / "convergence.md").read_text()
    assert md.startswith("# Convergence study (generated by roughflow accuracy report)")
    for section in ("## Contact area and mean gap at fixed load",
                    "## a_c* against resolution (both axes)",
                    "## sigma_x at fixed a_c against resolution",
                    "## Contact solver tolerance (ppl 2", "## Bisection tolerance (ppl 2"):
        assert section in md, section
    assert md in capsys.readouterr().out
    csv = (out / "convergence.csv").read_text().splitlines()
    assert csv[0] == "quantity,variant,ppl,seed,value,reference,error,time_s"
    assert {line.split(",")[0] for line in csv[1:]} == {
        "a_c_star_x", "a_c_star_y", "ln_sigma_0.2", "ln_sigma_0.35"}
    assert not list(out.glob("*.part"))  # written together, nothing left half-way
