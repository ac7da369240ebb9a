"""Options that do not apply, or contradict each other, are refused before any work (exit 2,
naming the option and its value) instead of being ignored."""

from __future__ import annotations

import pytest
from cli_checks import refused

from roughflow.cli import main
from roughflow.errors import InputError

SMALL = ["--l-over-lambda-r", "2", "--eps-f", "0.125", "--points-per-lambda-s", "4"]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A small surface file and a (bearing) gap file of it."""
    d = tmp_path_factory.mktemp("contradictions")
    surface, gap = d / "s.nc", d / "c.nc"
    assert main(["surface", *SMALL, "-o", str(surface)]) == 0
    assert main(["contact", str(surface), "--model", "bearing", "--area-fraction", "0.3",
                 "-o", str(gap)]) == 0
    return {"surface": str(surface), "gap": str(gap), "dir": d}


def _out(files, name: str = "out.nc") -> str:
    return str(files["dir"] / name)


# --- D6: the channels scene's gamma -------------------------------------------------------

@pytest.mark.parametrize("gamma, shown", [("0", "0.0"), ("-1", "-1.0"), ("inf", "inf"),
                                          ("1e4", "10000")])
def test_channels_scene_names_a_bad_gamma(files, capsys, gamma, shown):
    out = _out(files, "channels.nc")
    refused(["scene", "channels", *SMALL, "--gamma", gamma, "-o", out], capsys, "gamma", shown)


def test_channels_job_names_a_bad_gamma():
    from roughflow.scenes import ChannelsJob

    with pytest.raises(InputError, match="gamma"):
        ChannelsJob(gamma=0.0)


# --- D7: options the channels scene has no field for ---------------------------------------

@pytest.mark.parametrize("extra, name", [(["--seeds", "1", "2"], "--seeds 1 2"),
                                         (["--aspect", "7"], "--aspect 7")])
def test_channels_scene_refuses_options_it_would_ignore(files, capsys, extra, name):
    refused(["scene", "channels", *SMALL, *extra, "-o", _out(files, "ch.nc")], capsys, name)


# --- D8: contradictory options --------------------------------------------------------------

def test_surface_refuses_the_other_forms_options(files, capsys):
    refused(["surface", "--lx", "2", "--l-over-lambda-r", "2", "-o", _out(files)], capsys,
            "--lx 2.0")
    refused(["surface", "--nx", "64", "--ny", "64", "--lambda-r", "0.5", "--lambda-s", "0.1",
             "--eps-f", "0.5", "--aspect", "3", "-o", _out(files)], capsys,
            "--eps-f 0.5", "--aspect 3.0")


@pytest.mark.parametrize("extra", [["--method", "cg"], ["--tol", "1e-3"],
                                   ["--max-iter", "5"]])
def test_contact_bearing_refuses_solver_options(files, capsys, extra):
    refused(["contact", files["surface"], "--model", "bearing", "--area-fraction", "0.3",
             *extra, "-o", _out(files)], capsys, extra[0])


@pytest.mark.parametrize("kwargs, name", [({"method": "foo"}, "method"), ({"tol": -1}, "tol"),
                                          ({"area_fraction": True}, "area_fraction")])
def test_contact_api_bearing_checks_its_arguments(files, kwargs, name):
    from roughflow.contact import solve
    from roughflow.io import read_surface

    args = {"model": "bearing", "area_fraction": 0.3, **kwargs}
    with pytest.raises(InputError, match=name):
        solve(read_surface(files["surface"]), **args)


@pytest.mark.parametrize("extra", [["--p-min", "0.01"], ["--p-guess", "0.1"],
                                   ["--method", "cg"], ["--contact-tol", "0.001"],
                                   ["--strategy", "bisect"]])
def test_threshold_bearing_refuses_search_options(files, capsys, extra):
    refused(["threshold", files["surface"], "--model", "bearing", *extra, "-o", _out(files)],
            capsys, " ".join(extra))


def test_threshold_first_pressure_outside_the_range_is_refused(files, capsys):
    from roughflow.search import SearchOptions

    # the command names its option and the value as given; the library, its own words
    refused(["threshold", files["surface"], "--p-guess", "-1", "-o", _out(files)], capsys,
            "--p-guess -1.0 is not a positive")
    refused(["threshold", files["surface"], "--p-guess", "5", "-o", _out(files)], capsys,
            "first_pressure must lie in pressure_range")
    with pytest.raises(InputError, match="first_pressure"):
        SearchOptions(first_pressure=-1)
    with pytest.raises(InputError, match="first_pressure"):
        SearchOptions(first_pressure=0.5, pressure_range=(1e-3, 0.1))


def test_ladder_scene_refuses_adhesion_options_without_adhesion(files, capsys):
    refused(["scene", "ladder", *SMALL, "--model", "bearing", "--area-fractions", "0.2",
             "--tabor", "1", "-o", _out(files)], capsys, "--tabor 1.0", "--model bearing")


@pytest.mark.parametrize("which, extra, names", [
    ("gap", ["--pressures", "0.1", "--hurst", "0.5"], ("--pressures 0.1", "--hurst 0.5")),
    ("gap", ["--gamma", "2", "--peklenik", "conductivity"], ("--gamma 2.0",)),
    ("surface", ["--hurst", "0.5"], ("--hurst 0.5",)),
    ("surface", ["--peklenik", "conductivity"], ("--peklenik conductivity",)),
    (None, ["--peklenik", "height"], ("--peklenik height",)),
])
def test_theory_refuses_options_of_the_other_forms(files, capsys, which, extra, names):
    inputs = [] if which is None else [files[which]]
    refused(["theory", *inputs, *extra, "-o", _out(files)], capsys, *names)


def test_cite_refuses_selections_it_would_ignore(files, capsys):
    refused(["cite", files["surface"], "--method", "gfmd"], capsys, "--method gfmd")
    refused(["cite", "--format", "cff", files["surface"]], capsys, "--format cff")
    refused(["cite", "--format", "cff", "--method", "gfmd"], capsys, "--method gfmd")


def test_refusals_leave_no_output(files, capsys):
    out = files["dir"] / "never.nc"
    refused(["surface", "--ly", "2", "-o", str(out)], capsys, "--ly")
    assert not out.exists()


def test_long_options_are_never_taken_by_a_prefix(tmp_path, capsys):
    # argparse took `scene ladder --surface-energy 0.05` (the absolute gamma_s of `contact`)
    # as --surface-energy-ratio, a different quantity, without a word
    with pytest.raises(SystemExit) as exc:
        main(["scene", "ladder", "--model", "adhesive", "--surface-energy", "0.05",
              "--area-fractions", "0.1", "-o", str(tmp_path / "x.nc")])
    assert exc.value.code == 2
    assert "unrecognized arguments: --surface-energy" in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()


@pytest.mark.parametrize(("argv", "usage"), [
    (["leak", "S", "--modulus", "1GPa", "--pressures", "1MPa:10MPa:2", "--fluid-pressure",
      "1kPa", "--viscosity", "1mPa.s", "--seal-width", "2mm", "--seal-length", "6mm",
      "--no-such"], "usage: roughflow leak "),
    (["contact", "S", "--pressure", "0.1", "--bogus", "1"], "usage: roughflow contact "),
    (["scene", "threshold", "--bogus"], "usage: roughflow scene threshold "),
])
def test_an_unknown_option_gets_its_commands_usage(files, argv, usage, capsys):
    # argparse reported an unknown option of a subcommand with the main parser's usage
    # ("roughflow [-h] [--version] ... COMMAND ..."), which lists no option of the command
    argv = [files["surface"] if a == "S" else a for a in argv]
    with pytest.raises(SystemExit) as stop:
        main([*argv, "-o", _out(files, "unknown.nc")])
    err = capsys.readouterr().err
    assert stop.value.code == 2 and err.startswith(usage)
    assert "error: unrecognized arguments: " in err


@pytest.mark.parametrize(("argv", "says"), [
    (["--model", "elastic"], "--model elastic needs --pressure"),
    (["--area-fraction", "0.3"], "--model elastic needs --pressure"),
    (["--model", "bearing"], "--model bearing needs --area-fraction"),
])
def test_a_missing_load_is_named_by_its_option(files, argv, says, capsys):
    # the library's words reached the command line: "the elastic model needs pressure="
    err = refused(["contact", files["surface"], *argv, "-o", _out(files)], capsys, says)
    assert "pressure=" not in err and "area_fraction=" not in err
