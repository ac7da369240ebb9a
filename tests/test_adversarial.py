"""Adversarial inputs against every subcommand: each must be refused with exit status 2 and a
message naming the offending file or value, before any work and without a traceback.

The bad files are generated here from small valid ones (32 x 32 grids): a directory, an
empty file, a text file, a truncated netCDF file, a surface without its ``lx`` attribute,
3-D or non-finite heights, and every valid file of the wrong kind. The cases of issue 13
("Reliability") are here too, by their number. Everything runs through
``roughflow.cli.main`` in this process (an unexpected exception fails the test with its
traceback, as a user would see it).
"""

from __future__ import annotations

import math
import os
import stat

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main

TINY = ["--l-over-lambda-r", "4", "--eps-f", "0.25", "--points-per-lambda-s", "2"]


def run(argv, capsys) -> tuple[int, str]:
    """(exit status, stderr) of ``roughflow argv``."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as exc:
        code = exc.code
    return code, capsys.readouterr().err


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Valid files of every kind and bad files of every sort, made once."""
    d = tmp_path_factory.mktemp("adv")
    f = {k: d / f"{k}.nc" for k in ("surface", "contact", "flow", "threshold", "job", "job2",
                                    "ladder", "study", "fit")}

    def ok(*argv):
        try:
            code = main([str(a) for a in argv])
        except SystemExit as exc:
            code = exc.code
        assert code in (0, None), argv

    ok("surface", *TINY, "-o", f["surface"])
    ok("contact", f["surface"], "--pressure", "0.1", "-o", f["contact"])
    ok("flow", f["contact"], "-o", f["flow"])
    ok("threshold", f["surface"], "--tol", "0.01", "-o", f["threshold"])
    ok("scene", "threshold", "--model", "bearing", *TINY, "--seeds", "0", "1", "-o", f["job"])
    ok("scene", "threshold", "--model", "bearing", *TINY, "--seeds", "2", "-o", f["job2"])
    ok("scene", "ladder", "--model", "bearing", *TINY, "--area-fractions", "0.1", "0.3",
       "-o", f["ladder"])
    ok("aggregate", f["job"], f["job2"], "-o", f["study"])
    ok("fit", f["study"], "--bootstrap", "0", "-o", f["fit"])

    bad = {"directory": d / "folder.nc", "empty": d / "empty.nc", "text": d / "text.nc",
           "truncated": d / "truncated.nc", "no_lx": d / "no_lx.nc", "heights_3d": d / "h3.nc",
           "heights_nan": d / "hnan.nc", "missing": d / "missing.nc"}
    bad["directory"].mkdir()
    bad["empty"].write_bytes(b"")
    bad["text"].write_text("x,y,height\n0,0,1.0\n")
    data = f["contact"].read_bytes()
    bad["truncated"].write_bytes(data[: len(data) // 2])
    with xr.open_dataset(f["surface"]) as ds:
        s = ds.load()
    s.drop_attrs().assign_attrs(ly=1.0).to_netcdf(bad["no_lx"])
    h = s["heights"].values
    xr.Dataset({"heights": (("x", "y", "z"), np.stack([h, h], axis=-1))},
               attrs={"lx": 1.0, "ly": 1.0}).to_netcdf(bad["heights_3d"])
    hn = h.copy()
    hn[3, 4] = np.nan
    s.assign(heights=(("x", "y"), hn)).to_netcdf(bad["heights_nan"])
    return {**f, **{f"bad_{k}": v for k, v in bad.items()}, "dir": d}


GENERIC = ("bad_directory", "bad_empty", "bad_text", "bad_truncated", "bad_missing")
#: subcommand -> (argv with {} for the input file, the inputs of the wrong kind or broken)
COMMANDS = {
    "contact": (["contact", "{}", "--pressure", "0.1", "-o", "{out}.nc"],
                GENERIC + ("bad_no_lx", "bad_heights_3d", "bad_heights_nan", "flow",
                           "threshold", "job", "study", "fit")),
    "threshold": (["threshold", "{}", "--tol", "0.01", "-o", "{out}.nc"],
                  GENERIC + ("bad_no_lx", "bad_heights_3d", "bad_heights_nan", "flow",
                             "threshold", "job", "ladder", "fit")),
    "flow": (["flow", "{}", "-o", "{out}.nc"],
             GENERIC + ("surface", "threshold", "job", "study", "fit")),
    "theory": (["theory", "{}"],
               GENERIC + ("bad_no_lx", "bad_heights_3d", "flow", "threshold", "job", "fit")),
    "aggregate": (["aggregate", "{}", "-o", "{out}.nc"],
                  GENERIC + ("surface", "contact", "flow", "threshold", "study", "fit")),
    "fit": (["fit", "{}", "-o", "{out}.nc"],
            GENERIC + ("surface", "contact", "flow", "threshold", "job", "ladder")),
    "figure": (["figure", "threshold_vs_gamma", "{}", "-o", "{out}.png"],
               GENERIC + ("surface", "contact", "flow", "threshold", "ladder", "fit")),
}
CASES = [(cmd, bad) for cmd, (_, bads) in COMMANDS.items() for bad in bads]


@pytest.mark.parametrize(("command", "bad"), CASES, ids=[f"{c}-{b}" for c, b in CASES])
def test_bad_input_file_exits_2_naming_it(files, capsys, command, bad):
    template, _ = COMMANDS[command]
    out = files["dir"] / f"out_{command}_{bad}"
    argv = [a.replace("{}", str(files[bad])).replace("{out}", str(out)) for a in template]
    code, err = run(argv, capsys)
    assert code == 2, err
    assert files[bad].name in err and "Traceback" not in err
    assert not list(files["dir"].glob(f"out_{command}_{bad}*")), "nothing may be written"


OUTPUT_CASES = {
    "existing directory": lambda d: d / "folder.nc",
    "parent is a file": lambda d: d / "text.nc" / "x.nc",
    "not writable": lambda d: "/proc/roughflow-test.nc",
}


@pytest.mark.parametrize("case", sorted(OUTPUT_CASES))
@pytest.mark.parametrize("command", ["surface", "contact", "flow", "threshold", "theory",
                                     "scene", "aggregate", "fit"])
def test_bad_output_path_exits_2_before_any_work(files, capsys, command, case):
    # issue 13 item 9: the output path is checked before the computation
    bad = OUTPUT_CASES[case](files["dir"])
    argv = {
        "surface": ["surface", *TINY, "-o", bad],
        "contact": ["contact", files["surface"], "--pressure", "0.1", "-o", bad],
        "flow": ["flow", files["contact"], "-o", bad],
        "threshold": ["threshold", files["surface"], "-o", bad],
        "theory": ["theory", files["contact"], "-o", bad],
        "scene": ["scene", "threshold", *TINY, "--model", "bearing", "-o", bad],
        "aggregate": ["aggregate", files["job"], "-o", bad],
        "fit": ["fit", files["study"], "-o", bad],
    }[command]
    code, err = run(argv, capsys)
    assert code == 2, err
    assert str(bad) in err


# ---------------------------------------------------------------------------------------
# the defects of issue 13, by number
# ---------------------------------------------------------------------------------------

def _job(d, name, *argv):
    path = d / f"{name}.nc"
    if not path.exists():
        assert main(["scene", "threshold", "--model", "bearing", "--eps-f", "0.125", *argv,
                     "-o", str(path)]) == 0
    return path


def test_01_aggregate_refuses_overlapping_seeds(files, capsys):
    d = files["dir"]
    a = _job(d, "a01", "--points-per-lambda-s", "2", "--seeds", "0", "1", "--tol", "0.01")
    b = _job(d, "b01", "--points-per-lambda-s", "2", "--seeds", "0", "--tol", "0.002")
    for order in ((a, b), (b, a)):
        code, err = run(["aggregate", *order, "-o", d / "ab.nc"], capsys)
        assert code == 2 and "seeds [0]" in err, err
    assert not (d / "ab.nc").exists()


def test_01_aggregate_refuses_jobs_differing_only_in_resolution(files, capsys):
    d = files["dir"]
    a = _job(d, "a01", "--points-per-lambda-s", "2", "--seeds", "0", "1", "--tol", "0.01")
    c = _job(d, "c01", "--points-per-lambda-s", "3", "--seeds", "2", "--tol", "0.01")
    code, err = run(["aggregate", a, c, "-o", d / "ac.nc"], capsys)
    assert code == 2 and "points_per_lambda_s" in err, err


def test_01_aggregate_refuses_disjoint_seeds_of_different_settings(files, capsys):
    """Jobs of the same parameters on disjoint seeds but a different --tol: only their
    job_settings tell them apart (no variable records tol), and the study dataset has no
    dimension for it. (a01 and b01 above share seed 0, so the seed check refused them
    first and the settings were never compared.)"""
    d = files["dir"]
    a = _job(d, "a01", "--points-per-lambda-s", "2", "--seeds", "0", "1", "--tol", "0.01")
    e = _job(d, "e01", "--points-per-lambda-s", "2", "--seeds", "2", "--tol", "0.002")
    code, err = run(["aggregate", a, e, "-o", d / "ae.nc"], capsys)
    assert code == 2 and "job_settings" in err and "different settings" in err, err
    assert "0.01" in err and "0.002" in err, err
    assert not (d / "ae.nc").exists()


def test_01_aggregate_keeps_every_seed_of_disjoint_jobs(files, capsys):
    code, _ = run(["aggregate", files["job"], files["job2"], "-o", files["dir"] / "ok.nc"],
                  capsys)
    assert code == 0
    with xr.open_dataset(files["dir"] / "ok.nc") as ds:
        assert ds["seed"].values.tolist() == [0, 1, 2]
        assert np.isfinite(ds["a_c_star"].values).all()


def test_02_huge_grids_are_refused_before_allocating(capsys, tmp_path):
    # 2e5 x 2e5 points need terabytes on any machine; the refusal names the grid and memory
    never = tmp_path / "never.nc"
    code, err = run(["surface", "--nx", "200000", "--ny", "200000", "--lambda-r", "0.25",
                     "--lambda-s", "0.001", "-o", never], capsys)
    assert code == 2 and "200000 x 200000" in err and "TB" in err, err
    for argv in (["surface", "--eps-f", "1e-5", "-o", never],
                 ["scene", "threshold", "--eps-f", "1e-5", "-o", never],
                 ["scene", "ladder", "--eps-f", "1e-5", "--area-fractions", "0.1",
                  "-o", never],
                 ["scene", "channels", "--eps-f", "1e-5", "-o", never],
                 ["theory", "--eps-f", "1e-5"]):
        code, err = run(argv, capsys)
        assert code == 2 and "memory" in err, (argv, err)
    assert list(tmp_path.iterdir()) == []


def test_03_flow_tol_has_an_upper_bound(files, capsys):
    code, err = run(["flow", files["contact"], "--tol", "1e6", "-o", files["dir"] / "x.nc"],
                    capsys)
    assert code == 2 and "tol" in err and "1000000" in err


def test_04_fit_of_a_single_size_is_flagged_not_reported(files, capsys):
    # the study has one system size: no fit can determine an amplitude (or a free nu)
    with xr.open_dataset(files["fit"]) as fit:
        assert np.isnan(fit["a_star"].values).all()
        # (an isotropic study has only the joint fit: x and y pooled)
        assert (fit["underdetermined"].sel(group="isotropic", fit="joint") == 1).all()


@pytest.mark.parametrize("bad", [["--nu", "-1"], ["--nu", "inf"], ["--nu", "0"],
                                 ["--seed", "-1"], ["--bootstrap", "-3"]])
def test_04_fit_options_are_checked(files, capsys, bad):
    code, err = run(["fit", files["study"], *bad, "-o", files["dir"] / "x.nc"], capsys)
    assert code == 2 and "Traceback" not in err, err


def test_06_theory_refuses_a_flow_file_of_another_gap(files, capsys):
    d = files["dir"]
    other = d / "c_other.nc"
    assert main(["contact", str(files["surface"]), "--pressure", "0.2", "-o", str(other)]) == 0
    code, err = run(["theory", other, "--flow", files["flow"]], capsys)
    assert code == 2 and "another gap" in err, err
    code, err = run(["theory", files["contact"], "--flow", files["contact"]], capsys)
    assert code == 2 and "not a flow file" in err, err
    code, _ = run(["theory", files["contact"], "--flow", files["flow"]], capsys)
    assert code == 0


def test_07_figure_output_must_be_png_and_keeps_other_files(files, capsys):
    d = files["dir"]
    png = d / "fig.png"
    png.write_bytes(b"keep me")
    code, err = run(["figure", "threshold_vs_gamma", files["study"], "-o", d / "fig.nc"],
                    capsys)
    assert code == 2 and ".png" in err
    assert png.read_bytes() == b"keep me"


@pytest.mark.parametrize("bad", [["--gamma", "0"], ["--gamma", "-1"], ["--threads", "-3"],
                                 ["--threads", "0"], ["--seeds", "0", "0"],
                                 ["--hurst", "1.5"], ["--points-per-lambda-s", "nan"]])
def test_10_11_scene_options_are_checked(files, capsys, bad):
    code, err = run(["scene", "threshold", *TINY, *bad, "-o", files["dir"] / "x.nc"], capsys)
    assert code == 2 and "Traceback" not in err, err
    assert not (files["dir"] / "x.nc").exists()


@pytest.mark.parametrize("areas", [["0"], ["1"], ["nan"], ["0.3", "0.1"], ["-0.2"]])
def test_11_ladder_area_fractions_are_named(files, capsys, areas):
    code, err = run(["scene", "ladder", *TINY, "--area-fractions", *areas,
                     "-o", files["dir"] / "x.nc"], capsys)
    assert code == 2 and "area_fractions" in err, err


def test_12_huge_seed_is_refused_before_the_work(files, capsys):
    code, err = run(["surface", "--seed", "99999999999999999999999", "-o",
                     files["dir"] / "x.nc"], capsys)
    assert code == 2 and "seed" in err


def test_13_outputs_follow_the_umask(files, capsys, tmp_path):
    old = os.umask(0o022)
    try:
        assert main(["surface", *TINY, "-o", str(tmp_path / "s.nc")]) == 0
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "s.nc").stat().st_mode) == 0o644


def test_14_aggregate_refuses_mixed_scenes(files, capsys):
    code, err = run(["aggregate", files["job"], files["ladder"], "-o", files["dir"] / "x.nc"],
                    capsys)
    assert code == 2 and "one scene" in err, err
    code, err = run(["aggregate", files["surface"], files["job"], "-o", files["dir"] / "x.nc"],
                    capsys)
    assert code == 2 and files["surface"].name in err, err


def test_15_bruggeman_of_an_extreme_contrast():
    from roughflow.theory import bruggeman

    # two equal halves with a contrast of 1e600 (beyond the float range): the low half
    # controls, sigma = c s_low with 0.5 (1 - c)/(1 + (D - 1) c) + 0.5 = 0 -> c = 2/(2 - D)
    r = bruggeman([1e-300, 1e300], a_c_star=0.4)
    d = 1 / 0.6
    assert math.isclose(r.sigma, 2 / (2 - d) * 1e-300, rel_tol=1e-9)


def test_every_file_argument_goes_through_the_shared_layer():
    # a file argument (metavar NAME.nc / NAME.png) declared without add_input/add_output
    # would bypass the kind, readability and output checks; a new subcommand must not
    import argparse

    from roughflow.cli import build_parser

    def parsers(p, name):
        subs = [a for a in p._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs:
            yield name, p
        for sub in subs:
            for k, v in sub.choices.items():
                yield from parsers(v, f"{name} {k}".strip())

    files = 0
    for name, p in parsers(build_parser(), ""):
        declared = {d for d, *_ in (p.get_default("_inputs") or [])} | \
                   {d for d, *_ in (p.get_default("_outputs") or [])}
        for a in p._actions:
            if str(a.metavar or "").endswith((".nc", ".png")):
                files += 1
                assert a.dest in declared, f"roughflow {name}: {a.dest} bypasses the checks"
    assert files >= 15


@pytest.fixture(scope="module")
def two_eps_f(files):
    """A threshold study that mixes two eps_f (bearing jobs, 32^2 and 64^2)."""
    d = files["dir"]
    for eps_f in ("0.25", "0.125"):
        argv = ["scene", "threshold", "--model", "bearing", "--l-over-lambda-r", "4",
                "--eps-f", eps_f, "--points-per-lambda-s", "2", "--seeds", "0", "1",
                "-o", d / f"mix_{eps_f}.nc"]
        assert main([str(a) for a in argv]) in (0, None)
    study = d / "mixed_study.nc"
    assert main(["aggregate", str(d / "mix_0.25.nc"), str(d / "mix_0.125.nc"),
                 "-o", str(study)]) in (0, None)
    return study


def test_fit_of_a_study_mixing_eps_f_is_refused(files, two_eps_f, capsys):
    # it wrote an all-NaN fit (underdetermined = 0) with exit 0 and only a warning
    out = files["dir"] / "mixed_fit.nc"
    code, err = run(["fit", two_eps_f, "--bootstrap", "0", "-o", out], capsys)
    assert code == 2 and "one eps_f, the dataset has 2: 0.125, 0.25" in err, err
    assert not out.exists()


@pytest.mark.parametrize("study", ["threshold_vs_size", "threshold_vs_hurst"])
def test_figure_of_a_study_mixing_eps_f_is_refused(files, two_eps_f, capsys, study):
    # both drew with eps_f left as a dimension and stopped on an IndexError (exit 1)
    out = files["dir"] / f"mixed_{study}.png"
    code, err = run(["figure", study, two_eps_f, "-o", out], capsys)
    assert code == 2 and "one eps_f" in err and "Traceback" not in err, err
    assert not out.exists()


def test_figure_checks_its_pdf_path_before_drawing(files, capsys):
    # a directory in the PDF's place failed after the PNG was written, leaving a stray
    # "fig.part.pdf" behind
    d = files["dir"] / "pdf_taken"
    (d / "fig.pdf").mkdir(parents=True)
    code, err = run(["figure", "threshold_vs_gamma", files["study"], "-o", d / "fig.png"],
                    capsys)
    assert code == 2 and "fig.pdf" in err and "is a directory" in err, err
    assert sorted(p.name for p in d.iterdir()) == ["fig.pdf"]


def test_flow_plot_into_a_new_folder(files, capsys):
    # the flux plot did not create its folder (exit 1 after the flow file was written)
    d = files["dir"] / "plots"
    code, err = run(["flow", files["contact"], "--plot", d / "new" / "flux.png",
                     "-o", d / "flow.nc"], capsys)
    assert code == 0, err
    assert (d / "new" / "flux.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(p.name for p in (d / "new").iterdir()) == ["flux.png"]


def test_save_figure_leaves_nothing_when_rendering_fails(tmp_path):
    from matplotlib.figure import Figure

    from roughflow.io import save_figure

    class Broken(Figure):
        def savefig(self, fname, **kw):
            with open(fname, "wb") as fh:
                fh.write(b"half a figure")
            raise RuntimeError("renderer died")

    with pytest.raises(RuntimeError, match="renderer died"):
        save_figure(Broken(), tmp_path / "fig.png")
    assert list(tmp_path.iterdir()) == []


def test_messages_name_the_file_and_do_not_misdirect(files, capsys, monkeypatch):
    d = files["dir"]
    with xr.open_dataset(files["contact"]) as ds:
        ds = ds.load()
    gap = ds["gap"].values.copy()
    gap[3, 4] = np.nan
    ds.assign(gap=(ds["gap"].dims, gap)).to_netcdf(d / "nan_gap.nc")
    code, err = run(["flow", d / "nan_gap.nc", "-o", d / "x.nc"], capsys)
    # a contact file with a bad value is not "a surface file" (the old hint)
    assert code == 2 and "non-finite" in err and "looks like" not in err, err
    with xr.open_dataset(files["surface"]) as ds:
        ds = ds.load()
    ds.attrs["lx"] = -1.0
    ds.to_netcdf(d / "neg_lx.nc")
    code, err = run(["contact", d / "neg_lx.nc", "--pressure", "0.1", "-o", d / "x.nc"], capsys)
    assert code == 2 and "neg_lx.nc" in err and "-1.0" in err, err
    ds.attrs["lx"] = 2.0  # the spec_* attributes say 1 x 1
    ds.to_netcdf(d / "other_lx.nc")
    code, err = run(["contact", d / "other_lx.nc", "--pressure", "0.1", "-o", d / "x.nc"],
                    capsys)
    assert code == 2 and "other_lx.nc" in err and "spec_* attributes say" in err, err
    big = ds.assign(heights=ds["heights"] * 1e300)
    big.attrs["lx"] = 1.0
    big.to_netcdf(d / "huge.nc")
    code, err = run(["contact", d / "huge.nc", "--pressure", "0.1", "-o", d / "x.nc"], capsys)
    assert code == 2 and "out of range" in err, err  # was a ValueError on a NaN level
    code, err = run(["surface", *TINY, "-o", ""], capsys)
    assert code == 2 and "empty" in err, err
    monkeypatch.setenv("ROUGHFLOW_FFT_THREADS", "99999")
    code, err = run(["surface", *TINY, "-o", d / "x.nc"], capsys)
    assert code == 2 and "from 1 to 4096" in err, err
    assert not (d / "x.nc").exists()


def test_gap_whose_conductivity_overflows_is_refused():
    # a gap of 1e200 gave sigma = 0 with exit 0 (u^3 overflowed to inf)
    from roughflow.errors import InputError
    from roughflow.flow import conductance

    with pytest.raises(InputError, match="u\\^3 / \\(12 eta\\) overflows"):
        conductance(np.full((8, 8), 1e200), lx=1.0, ly=1.0)
    # so did a legal gap with a tiny viscosity (every cell inf, then closed as unresolved)
    with pytest.raises(InputError, match="eta 1e-310"):
        conductance(np.ones((8, 8)), lx=1.0, ly=1.0, eta=1e-310)


def test_api_arguments_of_the_wrong_type_are_named():
    # each of these passed silently or failed later with a TypeError / AttributeError
    from roughflow.errors import InputError
    from roughflow.flow import solve
    from roughflow.surface import SurfaceSpec, generate

    gap = np.full((16, 16), 0.01)
    with pytest.raises(InputError, match="periodic must be True or False, got 'no'"):
        solve(gap, 0, lx=1.0, ly=1.0, periodic="no")
    with pytest.raises(InputError, match="gap must be real"):
        solve(gap + 1e-3j, 0, lx=1.0, ly=1.0)
    with pytest.raises(InputError, match="needs a SurfaceSpec, got NoneType"):
        generate(None)
    spec = dict(nx=32, ny=32, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0, lambda_r=0.25,
                lambda_s=0.0625, seed=0)
    with pytest.raises(InputError, match="hurst must be a number, got 'abc'"):
        SurfaceSpec(**{**spec, "hurst": "abc"})
    # a number given as a string is the number (as require_finite reads it everywhere)
    assert np.array_equal(generate(SurfaceSpec(**{**spec, "hurst": "0.8", "lx": "1"})).heights,
                          generate(SurfaceSpec(**spec)).heights)


def test_aggregate_study_config_must_be_an_object(files, capsys):
    out = files["dir"] / "agg_cfg.nc"
    code, err = run(["aggregate", files["job"], files["job2"], "--study-config", "[1, 2]",
                     "-o", out], capsys)
    assert code == 2 and "must be a JSON object" in err, err
    assert not out.exists()


def test_gamma_figure_refuses_two_sizes_of_one_point(files, capsys):
    # it drew the per-seed maximum over the sizes: a point matching neither
    d = files["dir"]
    for size in ("4", "8"):
        argv = ["scene", "threshold", "--model", "bearing", "--l-over-lambda-r", size,
                "--eps-f", "0.25", "--points-per-lambda-s", "2", "--seeds", "0", "1",
                "-o", d / f"size_{size}.nc"]
        assert main([str(a) for a in argv]) in (0, None)
    study = d / "two_sizes.nc"
    assert main(["aggregate", str(d / "size_4.nc"), str(d / "size_8.nc"),
                 "-o", str(study)]) in (0, None)
    code, err = run(["figure", "threshold_vs_gamma", study, "-o", d / "g.png"], capsys)
    assert code == 2 and "one system size per point" in err, err
    assert not (d / "g.png").exists()


def test_figure_of_another_study_is_refused(files, capsys):
    # a flow_anisotropic dataset drawn as flow_isotropic averaged x and y without a word
    d = files["dir"]
    study = d / "named_study.nc"
    assert main(["aggregate", str(files["job"]), str(files["job2"]), "--study",
                 "threshold_vs_size", "-o", str(study)]) in (0, None)
    code, err = run(["figure", "threshold_vs_gamma", study, "-o", d / "other.png"], capsys)
    assert code == 2 and "is the 'threshold_vs_size' study" in err, err
    assert not (d / "other.png").exists()


def test_flow_file_and_its_plot_appear_together(files, capsys, monkeypatch, tmp_path):
    # the flow file was published before the plot was drawn: a failed or killed plot left a
    # complete flow file without the plot asked for
    from matplotlib.figure import Figure

    def broken(self, *a, **k):
        raise RuntimeError("renderer died")

    monkeypatch.setattr(Figure, "savefig", broken)
    with pytest.raises(RuntimeError, match="renderer died"):
        main(["flow", str(files["contact"]), "-o", str(tmp_path / "f.nc"),
              "--plot", str(tmp_path / "f.png")])
    assert list(tmp_path.iterdir()) == []
    capsys.readouterr()


def test_out_of_memory_exits_4_saying_so(files, capsys, monkeypatch, tmp_path):
    """A MemoryError inside a command is exit status 4 with a line, not a traceback."""
    from roughflow.cli import flow as flow_cli

    def exhausted(args):
        raise MemoryError

    monkeypatch.setattr(flow_cli, "run", exhausted)
    code, err = run(["flow", files["contact"], "-o", tmp_path / "f.nc"], capsys)
    assert code == 4 and "roughflow flow: out of memory" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_exits_5_naming_the_output(files, capsys, monkeypatch, tmp_path):
    import errno

    def full(self, path, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(xr.Dataset, "to_netcdf", full)
    code, err = run(["flow", files["contact"], "-o", tmp_path / "f.nc"], capsys)
    assert code == 5 and "f.nc" in err and "no space left" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["SIGTERM", "SIGUSR1", "SIGUSR2", "SIGHUP"])
def test_sigterm_removes_the_temporary_files_like_ctrl_c(files, capsys, monkeypatch, tmp_path,
                                                         name):
    # SIGTERM (kill, scancel, a time limit) ended the process where it stood and left
    # tmpXXXX.png.part files; it now unwinds like Ctrl-C and exits 128 + the signal. So do
    # SIGUSR1/2 (SLURM's --signal ahead of a time limit) and SIGHUP, which left .part files
    # without a word
    import os
    import signal

    from matplotlib.figure import Figure

    sig = getattr(signal, name)
    finished = []

    def killed_while_rendering(self, fname, *a, **k):
        open(fname, "wb").write(b"half a figure")
        os.kill(os.getpid(), sig)
        finished.append(fname)  # the signal waits for the writer (files.signals_held)

    before = signal.getsignal(sig)
    monkeypatch.setattr(Figure, "savefig", killed_while_rendering)
    code, err = run(["figure", "threshold_vs_gamma", files["study"], "-o",
                     tmp_path / "fig.png"], capsys)
    if before is signal.SIG_IGN:
        # a run under nohup ignores SIGHUP, and so does roughflow: the command completes
        assert code == 0, err
    else:
        assert code == 128 + int(sig) and f"terminated ({name})" in err, err
        assert list(tmp_path.iterdir()) == []
        # raised inside the writer, the exception left netCDF's file lock held, and the
        # write's own cleanup then waited for it forever (a crash audit: 3 of 7 SIGTERMs to
        # an aggregate hung); now the writer ends first, and nothing is published
        assert len(finished) == 1
    assert signal.getsignal(sig) is before  # main() restores the handler


def test_a_signal_whose_exception_python_dropped_still_stops_the_command(capsys, monkeypatch,
                                                                         tmp_path):
    # A SIGTERM handled inside a destructor raises there, and Python drops the exception
    # ("Exception ignored in ..."): a threshold scene then finished and exited 0 (2 of 8
    # SIGTERMs, a crash audit). The handler notes the signal: nothing is published, the
    # status is 143, and a later library call is not stopped by the old note.
    import os
    import signal
    import sys

    import roughflow.surface as surface_module
    from roughflow.files import Terminated
    from roughflow.io import write_dataset

    generate = surface_module.generate
    dropped = []  # what Python hands to sys.unraisablehook instead of raising
    monkeypatch.setattr(sys, "unraisablehook", lambda u: dropped.append(u.exc_type))

    class SignalOnCollection:
        def __del__(self):
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(100):  # Python runs the handler here, inside __del__
                pass

    def generate_with_a_dropped_signal(spec):
        SignalOnCollection()  # collected at once: its __del__ gets the signal
        return generate(spec)

    monkeypatch.setattr(surface_module, "generate", generate_with_a_dropped_signal)
    out = tmp_path / "s.nc"
    code, err = run(["surface", "--l-over-lambda-r", "1", "--points-per-lambda-s", "2",
                     "-o", out], capsys)
    assert dropped == [Terminated]  # the handler's exception was indeed dropped
    assert code == 128 + int(signal.SIGTERM) and "terminated (SIGTERM)" in err, err
    assert list(tmp_path.iterdir()) == []
    write_dataset(xr.Dataset({"a": ("x", [1.0], {"units": "1", "long_name": "a"})}),
                  tmp_path / "later.nc")
    assert (tmp_path / "later.nc").exists()


def test_a_killed_writers_leftover_is_removed_by_the_next_write(tmp_path):
    # SIGKILL (out of memory, KillWait) leaves the temporary file: every command left one
    # per kill, and a re-run removed none. They are named after their output and removed
    # once older than files.STALE_TEMPORARY_S; a fresh one (a writer still at work) stays.
    import os
    import time

    from roughflow.files import STALE_TEMPORARY_S, part_prefix
    from roughflow.io import write_dataset

    out = tmp_path / "r.nc"
    old = tmp_path / f"{part_prefix(out)}abc123.part"
    fresh = tmp_path / f"{part_prefix(out)}def456.part"
    other = tmp_path / f"{part_prefix(tmp_path / 'other.nc')}ghi789.part"
    for p in (old, fresh, other):
        p.write_bytes(b"half")
    stale = time.time() - 2 * STALE_TEMPORARY_S
    for p in (old, other):
        os.utime(p, (stale, stale))
    write_dataset(xr.Dataset({"a": ("x", [1.0], {"units": "1", "long_name": "a"})}), out)
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        [out.name, fresh.name, other.name])
    assert out.name.startswith("r.nc") and not fresh.name.endswith(".nc")  # no *.nc glob
