"""``roughflow contact``: file in, self-describing file out, clean errors."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.contact import solve
from roughflow.defaults import CONTACT_TOL
from roughflow.io import read_surface


def test_cli_elastic_matches_api(cli_surface_file, tmp_path):
    out = tmp_path / "c.nc"
    main(["contact", str(cli_surface_file), "--pressure", "0.1", "-o", str(out)])
    ref = solve(read_surface(cli_surface_file), 0.1)
    with xr.open_dataset(out) as ds:
        for name in ("gap", "contact", "contact_pressure"):
            assert ds[name].dims == ("x", "y")
            assert "units" in ds[name].attrs and "long_name" in ds[name].attrs
        np.testing.assert_array_equal(ds["gap"].values, ref.gap)
        np.testing.assert_array_equal(ds["contact"].values.astype(bool), ref.contact)
        for key, value in ref.scalars().items():
            got = ds.attrs[key]
            if isinstance(value, str):
                assert got == value
            else:
                assert float(got) == pytest.approx(float(value))
        assert ds.attrs["spec_seed"] == 1
        assert ds.attrs["spec_hurst"] == pytest.approx(0.8)


def test_cli_bearing(cli_surface_file, tmp_path):
    out = tmp_path / "b.nc"
    main(["contact", str(cli_surface_file), "--model", "bearing", "--area-fraction", "0.4",
          "-o", str(out)])
    with xr.open_dataset(out) as ds:
        # a_c = round(0.4 N) / N: within half a cell of 0.4 (0.400024 on 128^2; off by one
        # cell would be 3.7e-5 or 8.5e-5)
        assert ds.attrs["area_fraction"] == pytest.approx(0.4, abs=0.5 / ds["contact"].size)
        assert ds.attrs["model"] == "bearing"


@pytest.mark.parametrize(
    ("extra", "code", "message"),
    [
        (["--pressure", "-1"], 2, "pressure"),
        (["--model", "bearing", "--area-fraction", "1.5"], 2, "area_fraction"),
        (["--pressure", "0.1", "--tol", "0"], 2, "tol"),
        (["--model", "adhesive", "--pressure", "0.1", "--surface-energy", "1e-4"], 2,
         "needs both --surface-energy and --adhesion-range"),
        (["--pressure", "0.1", "--max-iter", "2"], 3, "did not converge"),
        (["--pressure", "0.1", "--repulsion", "harmonic"], 2,
         "--repulsion are only for --model adhesive"),
        # refused before any work (adhesion.check_setup): it ran 50000 FIRE steps and exited
        # 3, with --repulsion harmonic it returned a detached state as converged
        (["--model", "adhesive", "--pressure", "0", "--surface-energy", "1e-4",
          "--adhesion-range", "1e-9"], 2, "grid spacings"),
        (["--model", "adhesive", "--pressure", "0", "--surface-energy", "1e-4",
          "--adhesion-range", "1e-9", "--repulsion", "harmonic"], 2, "grid spacings"),
        # a range of 10 L (500 rms heights) gave a_c = 1
        (["--model", "adhesive", "--pressure", "0.01", "--surface-energy", "1e-4",
          "--adhesion-range", "10"], 2, "height range"),
        # gamma_s = 1e-6 v_ela^full on the harmonic wall gave a_c = 1, mean gap 0, exit 0
        (["--model", "adhesive", "--pressure", "0.01", "--surface-energy", "3.5e-9",
          "--adhesion-range", "0.013125", "--repulsion", "harmonic"], 2,
         "cannot hold the load"),
    ],
)
def test_cli_errors(cli_surface_file, tmp_path, capsys, extra, code, message):
    # the message too: exit 2 is also argparse's for an option it does not know
    with pytest.raises(SystemExit) as exc:
        main(["contact", str(cli_surface_file), *extra, "-o", str(tmp_path / "x.nc")])
    assert exc.value.code == code
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x.nc").exists()


def test_cli_adhesive_defaults_to_the_papers_case(cli_surface_file, tmp_path):
    # no --surface-energy/--range: gamma_s = 0.1 v_ela^full, rho = 0.8 lambda_s of the file's
    # spec, and the result equals the API call with those parameters (same deterministic solve)
    from roughflow.contact import full_contact_energy
    from roughflow.contact.adhesion import adhesion_for

    out = tmp_path / "a.nc"
    main(["contact", str(cli_surface_file), "--model", "adhesive", "--pressure", "0.05",
          "-o", str(out)])
    s = read_surface(cli_surface_file)
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=0.1,
                      range=0.8 * s.spec.lambda_s)
    ref = solve(s, 0.05, model="adhesive", adhesion=ad)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["adhesion_surface_energy"] == pytest.approx(
            0.1 * full_contact_energy(s.heights, s.lx, s.ly), rel=1e-12)
        assert ds.attrs["adhesion_range"] == pytest.approx(0.8 * s.spec.lambda_s, rel=1e-12)
        assert ds.attrs["adhesion_repulsion"] == "hard"
        assert ds.attrs["adhesion_contact_within"] == 0.5
        assert "B06" in ds.attrs["references"].split()  # FIRE ran: cited
        assert ds.attrs["area_fraction"] == pytest.approx(ref.area_fraction, abs=1e-12)


def test_cli_adhesive_harmonic_takes_its_own_calibration(cli_surface_file, tmp_path):
    # --repulsion harmonic without adhesion values: the harmonic wall's calibrated range
    # (0.42 lambda_s, defaults.ADHESION_RANGE_OVER_LAMBDA_S), overlap as contact
    out = tmp_path / "h.nc"
    main(["contact", str(cli_surface_file), "--model", "adhesive", "--pressure", "0.05",
          "--repulsion", "harmonic", "-o", str(out)])
    s = read_surface(cli_surface_file)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["adhesion_range"] == pytest.approx(0.42 * s.spec.lambda_s, rel=1e-12)
        assert ds.attrs["adhesion_repulsion"] == "harmonic"
        assert ds.attrs["adhesion_contact_within"] == 0.0
        assert "B06" not in ds.attrs["references"].split()  # the adhesive CG, not FIRE


def test_cli_missing_file(tmp_path):
    with pytest.raises(SystemExit) as exc:
        main(["contact", str(tmp_path / "nope.nc"), "--pressure", "0.1",
              "-o", str(tmp_path / "x.nc")])
    assert exc.value.code == 2


def test_adhesion_range_has_the_same_name_as_in_threshold():
    from roughflow.cli import build_parser

    for flag in ("--adhesion-range", "--range"):  # --range: the older name, still taken
        args = build_parser().parse_args(["contact", "s.nc", "--pressure", "0.1", "-o", "x.nc",
                                          "--model", "adhesive", "--surface-energy", "1e-4",
                                          flag, "0.01"])
        assert args.adhesion_range == 0.01


def test_cli_tol_reaches_the_solver_and_the_file(cli_surface_file, tmp_path):
    """--tol is the solve's (a looser one stops earlier, its residual within it) and the file
    says which it was; the default is recorded too."""
    got = {}
    for tol in (1e-3, None):
        out = tmp_path / f"c{tol}.nc"
        main(["contact", str(cli_surface_file), "--pressure", "0.1", "-o", str(out)]
             + ([] if tol is None else ["--tol", str(tol)]))
        with xr.open_dataset(out) as ds:
            got[tol] = dict(ds.attrs)
    assert got[1e-3]["tol"] == 1e-3 and got[None]["tol"] == CONTACT_TOL
    for attrs in got.values():
        assert attrs["residual"] <= attrs["tol"]
    assert got[1e-3]["iterations"] < got[None]["iterations"]


def test_a_pressure_with_its_unit_and_the_modulus(tmp_path, capsys):
    # "a contact map of my face at 400 MPa against steel" meant dividing by E* by hand:
    # --pressure takes a unit with --modulus, and the file records E*, so that
    # units.registry converts its pressures back to Pa
    from roughflow.units import registry

    s = tmp_path / "s.nc"
    assert main(["surface", "--l-over-lambda-r", "2", "--points-per-lambda-s", "2",
                 "-o", str(s)]) == 0
    out, ref = tmp_path / "c.nc", tmp_path / "ref.nc"
    assert main(["contact", str(s), "--pressure", "20GPa", "--modulus", "200GPa",
                 "-o", str(out)]) == 0
    assert "p = 0.1 (2e+10 Pa)" in capsys.readouterr().out
    assert main(["contact", str(s), "--pressure", "0.1", "-o", str(ref)]) == 0
    with xr.open_dataset(out) as ds, xr.open_dataset(ref) as plain:
        assert ds.attrs["ref_pressure_Pa"] == 200e9 and "ref_pressure_Pa" not in plain.attrs
        xr.testing.assert_equal(ds["gap"], plain["gap"])
        ureg = registry(ds.attrs)
        mean = ureg.Quantity(float(ds["contact_pressure"].mean()),
                             ds["contact_pressure"].attrs["units"]).to("GPa").magnitude
        assert mean == pytest.approx(20, rel=1e-5)  # the load balance of gfmd's tol 1e-6


@pytest.mark.parametrize(("argv", "says"), [
    (["--pressure", "400MPa"], "has a unit: give --modulus"),
    (["--pressure", "0.1", "--modulus", "200GPa"], "is a number in E*"),
    (["--pressure", "400mm", "--modulus", "200GPa"], "--pressure"),
])
def test_a_pressure_and_modulus_that_do_not_fit_are_refused(tmp_path, capsys, argv, says):
    from cli_checks import refused

    s = tmp_path / "s.nc"
    assert main(["surface", "--l-over-lambda-r", "2", "--points-per-lambda-s", "2",
                 "-o", str(s)]) == 0
    refused(["contact", str(s), *argv, "-o", str(tmp_path / "c.nc")], capsys, says)


def test_a_tension_with_its_unit_and_zero_load_take_the_modulus_too(tmp_path, capsys):
    # the adhesive model's tension as a quantity was refused ("must be a positive
    # pressure"), although the same tension as a number in E* runs; zero is zero in any unit
    s = tmp_path / "s.nc"
    assert main(["surface", "--l-over-lambda-r", "2", "--points-per-lambda-s", "2",
                 "-o", str(s)]) == 0
    capsys.readouterr()
    for load, shown in (("-2MPa", "p = -1e-05 (-2e+06 Pa)"), ("0", "p = 0 (0 Pa)")):
        assert main(["contact", str(s), "--model", "adhesive", f"--pressure={load}",
                     "--modulus", "200GPa", "-o", str(tmp_path / "a.nc")]) == 0
        assert shown in capsys.readouterr().out
