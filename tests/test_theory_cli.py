"""``roughflow theory``: both forms, netCDF output, clean errors."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.datasets.units import PRESSURE_UNITS, grid_coords
from roughflow.defaults import A_C_STAR_THEORY
from roughflow.io import write_dataset
from roughflow.surface import SurfaceSpec, generate
from roughflow.theory import bruggeman, bruggeman_anisotropic, closed_form, predict_conductance

SPEC = SurfaceSpec.from_sweep(gamma=2.0, points_per_lambda_s=2)


def _gap_file(path, levels=(0.2, 0.35)):
    """Bearing-model gaps of one surface at two contact fractions, dims (pressure, x, y)."""
    s = generate(SPEC)
    gaps = np.stack([np.maximum(s.heights - np.quantile(s.heights, a), 0.0) for a in levels])
    ds = xr.Dataset(
        {"gap": (("pressure", "x", "y"), gaps, {"units": "L", "long_name": "gap"})},
        coords={"pressure": ("pressure", [0.1, 0.2], {"units": "E* gbar",
                                                        "long_name": "pressure"}),
                **grid_coords(SPEC.nx, SPEC.ny, SPEC.lx, SPEC.ly)},
        attrs={"lx": SPEC.lx, "ly": SPEC.ly, "spec_gamma": SPEC.gamma, "model": "bearing"},
    )
    write_dataset(ds, path)
    return gaps


def test_gap_file(tmp_path, capsys):
    gaps = _gap_file(tmp_path / "r.nc")
    out = tmp_path / "t.nc"
    assert main(["theory", str(tmp_path / "r.nc"), "--a-c-star", "0.5", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "closed_form" in printed
    assert "Peklenik number of Eq. 7-9: gamma = 2, the surface's (heights)" in printed
    with xr.open_dataset(out) as ds:
        for name in ds.variables:
            assert ds[name].attrs.get("units") and ds[name].attrs.get("long_name"), name
        assert ds.attrs["kind"] == "bearing" and ds.attrs["gamma"] == 2.0
        assert ds["sigma_bruggeman"].dims == ("pressure",)
        for i, u in enumerate(gaps):
            sig = u**3 / 12
            assert ds["sigma_bruggeman"][i] == pytest.approx(
                bruggeman(sig, a_c_star=0.5).sigma, rel=1e-12)
            cor = bruggeman_anisotropic(sig, a_c_star=0.5, gamma=2.0)
            assert ds["sigma_x_corrected"][i] == pytest.approx(cor.sigma_x, rel=1e-12)
            assert ds["sigma_closed_form"][i] == pytest.approx(closed_form(
                u.mean(), (u == 0).mean(), a_c_star=0.5, kind="bearing"), rel=1e-12)
        # easy direction x for gamma > 1
        assert np.all(ds["sigma_x_corrected"] > ds["sigma_y_corrected"])


@pytest.mark.parametrize(("kind", "a_star"), [(None, 0.5), ("bearing", 0.5),
                                              ("elastic", 0.4), ("adhesive", 0.4)])
def test_default_a_c_star_is_the_theory_lines_value_of_the_kind(tmp_path, kind, a_star):
    # the flow figures draw their theory lines with defaults.A_C_STAR_THEORY; the command
    # once took the paper's elastic 0.415 for every kind, also for bearing gaps (exactly 0.5)
    _gap_file(tmp_path / "r.nc")  # model "bearing": the kind when --kind is not given
    out = tmp_path / "t.nc"
    argv = ["theory", str(tmp_path / "r.nc"), "-o", str(out)]
    assert main(argv + ([] if kind is None else ["--kind", kind])) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["a_c_star"] == a_star


def test_gap_file_conductivity_peklenik(tmp_path):
    _gap_file(tmp_path / "r.nc")
    out = tmp_path / "t.nc"
    main(["theory", str(tmp_path / "r.nc"), "--peklenik", "conductivity", "-o", str(out)])
    with xr.open_dataset(out) as ds:
        # bearing gaps inherit the height anisotropy (gamma = 2) up to sample scatter
        assert np.all(np.abs(ds["peklenik"].values / 2.0 - 1) < 0.3)


def test_conductivity_peklenik_of_a_full_contact_file_names_file_and_cause(tmp_path, capsys):
    # exit 2 said only "field is constant: its autocorrelation is undefined"
    path = tmp_path / "full.nc"
    write_dataset(xr.Dataset({"gap": (("x", "y"), np.zeros((8, 8)), {"units": "L",
                                                                   "long_name": "gap"})}),
                  path)
    with pytest.raises(SystemExit) as exc:
        main(["theory", str(path), "--peklenik", "conductivity"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"--peklenik conductivity of {path} ('gap')" in err
    assert "every cell is in contact" in err


def test_spec_form(tmp_path, capsys):
    out = tmp_path / "p.nc"
    main(["theory", "--points-per-lambda-s", "2", "--pressures", "0.01,0.1", "-o", str(out)])
    assert "mean_gap" in capsys.readouterr().out
    ref = predict_conductance(SurfaceSpec.from_sweep(points_per_lambda_s=2), [0.01, 0.1],
                              a_c_star=A_C_STAR_THEORY["elastic"])
    with xr.open_dataset(out) as ds:
        np.testing.assert_allclose(ds["mean_gap"].values, ref.mean_gap, rtol=1e-12)
        np.testing.assert_allclose(ds["sigma"].values, ref.sigma, rtol=1e-12)
        assert ds["pressure"].attrs["units"] == PRESSURE_UNITS
        # the library builds the same dataset (its units and long_names lived in the CLI)
        from roughflow.datasets import persson_dataset

        built = persson_dataset(ref, SurfaceSpec.from_sweep(points_per_lambda_s=2),
                                description=ds.attrs["source"])
        for name in ("area_fraction", "mean_gap", "sigma", "pressure"):
            np.testing.assert_array_equal(built[name].values, ds[name].values)
            assert built[name].attrs == {k: ds[name].attrs[k] for k in built[name].attrs}
        assert {k: v for k, v in built.attrs.items()} == {k: ds.attrs[k] for k in built.attrs}


def test_surface_file_form(tmp_path, capsys):
    surf = tmp_path / "s.nc"
    main(["surface", "--points-per-lambda-s", "2", "-o", str(surf)])
    main(["theory", str(surf), "--pressures", "0.05"])
    line = capsys.readouterr().out.strip().splitlines()[-1].split()
    ref = predict_conductance(SurfaceSpec.from_sweep(points_per_lambda_s=2), [0.05],
                              a_c_star=A_C_STAR_THEORY["elastic"])
    # printed as %12.5g: rounding to 5 significant digits is at most 5e-5 relative (measured
    # 1.4e-5: 0.012061 for 0.0120608); 1e-4 is twice the worst case
    assert float(line[2]) == pytest.approx(ref.mean_gap[0], rel=1e-4)


@pytest.mark.parametrize("args,msg", [
    (["--a-c-star", "1.5"], "a_c_star"),
    (["--pressures", "0.1,-1"], "pressure"),
    (["--pressures", "a,b"], "pressures"),
    (["/nonexistent/file.nc"], "does not exist"),
])
def test_bad_input_exits_2(args, msg, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["theory", "--points-per-lambda-s", "2", *args])
    assert exc.value.code == 2
    assert msg in capsys.readouterr().err


def test_negative_gap_file_exits_2(tmp_path, capsys):
    ds = xr.Dataset({"gap": (("x", "y"), -np.ones((8, 8)))})
    write_dataset(ds, tmp_path / "bad.nc")
    with pytest.raises(SystemExit) as exc:
        main(["theory", str(tmp_path / "bad.nc")])
    assert exc.value.code == 2
    assert "negative" in capsys.readouterr().err


def test_flow_file_values_are_carried(tmp_path, capsys):
    # a flow file for a single gap field: its sigma_x, sigma_y appear next to the theory
    s = generate(SPEC)
    gap = np.maximum(s.heights - np.quantile(s.heights, 0.2), 0.0)
    write_dataset(xr.Dataset({"gap": (("x", "y"), gap)}, attrs={"lx": 1.0, "ly": 1.0}),
                  tmp_path / "c.nc")
    from roughflow import flow
    from roughflow.datasets import flow_dataset

    res = {ax: flow.solve(gap, ax, lx=1.0, ly=1.0) for ax in (0, 1)}
    write_dataset(flow_dataset(res, gap <= 0, lx=1.0, ly=1.0, eta=1.0, tol=1e-8),
                  tmp_path / "f.nc")
    out = tmp_path / "t.nc"
    main(["theory", str(tmp_path / "c.nc"), "--flow", str(tmp_path / "f.nc"), "-o", str(out)])
    assert "sx_reynolds" in capsys.readouterr().out
    with xr.open_dataset(out) as ds:
        assert float(ds["sigma_x_reynolds"][0]) == res[0].sigma
        assert float(ds["sigma_y_reynolds"][0]) == res[1].sigma
        assert ds["sigma_x_reynolds"].attrs["units"]


def test_gap_file_eta_reaches_every_column(tmp_path):
    """The gap-file form once ignored --eta. Every conductance is u^3/(12 eta) times a
    function of the gaps alone, so every sigma column at eta 2 is half of eta 1 (rtol 1e-12:
    halving is exact in floating point, what is left is the order of the operations)."""
    _gap_file(tmp_path / "r.nc")
    got = {}
    for eta in ("1", "2"):
        out = tmp_path / f"t{eta}.nc"
        assert main(["theory", str(tmp_path / "r.nc"), "--eta", eta, "-o", str(out)]) == 0
        got[eta] = xr.load_dataset(out)
    names = [n for n in got["1"].data_vars if n.startswith("sigma")]
    assert len(names) >= 5, names
    for n in names:
        assert np.all(got["1"][n].values > 0), n
        np.testing.assert_allclose(got["2"][n].values, got["1"][n].values / 2, rtol=1e-12,
                                   err_msg=n)


@pytest.mark.parametrize("gamma", [1.0, 2.0])
def test_persson_says_its_sigma_is_isotropic(gamma, capsys):
    # Persson's a_c(p), u(p) and Eq. 16 have no direction: for an anisotropic spec the one
    # sigma column was printed without a word that gamma does not enter it
    assert main(["theory", "--gamma", str(gamma), "--points-per-lambda-s", "2",
                 "--pressures", "0.05,0.1"]) == 0
    printed = capsys.readouterr().out
    note = f"sigma is isotropic: the surface's Peklenik number gamma = {gamma:g}"
    assert (note in printed) == (gamma != 1.0)
