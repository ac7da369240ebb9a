"""``roughflow threshold``: the command line of the threshold search."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.io import surface_to_dataset, write_dataset
from roughflow.scenes.jobs import SurfaceParams, ThresholdJob
from roughflow.scenes.threshold import run_threshold
from roughflow.search import SearchOptions, threshold
from roughflow.search.critical import SCOUT_TOL_FACTOR
from roughflow.surface import SurfaceSpec, generate


@pytest.fixture()
def surface_file(tmp_path):
    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, l_over_lambda_r=2, seed=1))
    path = tmp_path / "s.nc"
    write_dataset(surface_to_dataset(s), path)
    return s, path


def test_cli_threshold_bearing_both_axes(surface_file, tmp_path):
    s, path = surface_file
    out = tmp_path / "t.nc"
    assert main(["threshold", str(path), "--axis", "both", "--model", "bearing",
                 "-o", str(out)]) == 0
    ref = threshold(s, model="bearing")
    with xr.open_dataset(out) as ds:
        assert list(ds["axis"].values) == ["x", "y"]
        assert ds["a_c_star"].attrs["units"] == "1"
        for i in (0, 1):
            assert float(ds["a_c_star"][i]) == ref[i].a_c_star
        assert ds.attrs["model"] == "bearing"


def test_cli_threshold_elastic_one_axis(surface_file, tmp_path, capsys):
    s, path = surface_file
    out = tmp_path / "t.nc"
    assert main(["threshold", str(path), "--axis", "y", "--tol", "4e-3", "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert list(ds["axis"].values) == ["y"]
        lo, hi = float(ds["a_lo"][0]), float(ds["a_hi"][0])
        assert 0 < hi - lo <= 4e-3
        assert ds.sizes["solve"] == ds.attrs["n_solves"] >= 2
        assert float(ds["p_lo"][0]) < float(ds["p_hi"][0])
        raw, corrected = float(ds["a_c_star"][0]), float(ds["a_c_star_corrected"][0])
    # the summary names both values: they differ by a few hundredths on this coarse grid
    # (2 points per lambda_s), more than the search's tolerance
    printed = capsys.readouterr().out
    assert f"a_c* (raw contact area) y {raw:.4f}" in printed
    assert f"perimeter-corrected y {corrected:.4f}" in printed
    assert abs(raw - corrected) > 4e-3


def test_scouts_are_marked_and_full_solves_meet_the_contact_tol(surface_file, tmp_path):
    # the threshold scenes' contact_residual reached 30 x contact_tol: the maximum took in the
    # scouts, solved to SCOUT_TOL_FACTOR x contact_tol by design, and read as unconverged
    s, path = surface_file
    out = tmp_path / "t.nc"
    assert main(["threshold", str(path), "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        scout = ds["solve_scout"].values.astype(bool)
        residual = ds["solve_residual"].values
    contact_tol = SearchOptions().contact_tol
    assert scout.any() and (~scout).any()  # this surface's search has both
    assert residual[~scout].max() <= contact_tol < residual[scout].max()
    assert residual[scout].max() <= SCOUT_TOL_FACTOR * contact_tol
    job = ThresholdJob(surface=SurfaceParams(points_per_lambda_s=2, l_over_lambda_r=2),
                       seeds=(1,))
    ds = run_threshold(job)
    assert ds["contact_residual"].values.ravel().tolist() == [residual[~scout].max()]


def test_cli_threshold_errors(surface_file, tmp_path, capsys):
    _, path = surface_file
    out = tmp_path / "t.nc"
    # each with its message: exit 2 is also argparse's for an option it does not know
    for argv, message in (
            (["--tol", "0"], "tol"),
            (["--model", "adhesive", "--surface-energy", "1e-4"], "adhesion-range"),
            (["--adhesion-range", "0.01"], "adhesive"),
            (["--p-max", "0.01"], "still spans"),  # always percolates below p = 1e-2
    ):
        with pytest.raises(SystemExit) as e:
            main(["threshold", str(path), *argv, "-o", str(out)])
        assert e.value.code == 2
        err = capsys.readouterr().err
        assert message in err and "unrecognized" not in err, (argv, err)
    assert not out.exists()
    assert main(["threshold", str(path), "--p-max", "0.01", "--allow-unbracketed",
                 "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert np.all(ds["bracketed"].values == 0) and np.all(np.isnan(ds["a_c_star"]))


def test_cli_threshold_adhesive_defaults_to_the_papers_case(surface_file, tmp_path):
    # no --surface-energy/--adhesion-range: the paper's adhesive case, as `roughflow contact`
    # takes it (gamma_s = 0.1 v_ela^full, rho = 0.8 lambda_s of the file's spec); the file
    # records them, and a_c* is the API search's with those parameters (deterministic solves)
    from roughflow.contact import full_contact_energy
    from roughflow.contact.adhesion import adhesion_for

    s, path = surface_file
    out = tmp_path / "t.nc"
    assert main(["threshold", str(path), "--model", "adhesive", "--axis", "y", "--tol", "4e-3",
                 "-o", str(out)]) == 0
    ad = adhesion_for(s.heights, s.lx, s.ly, gamma_over_v_full=0.1,
                      range=0.8 * s.spec.lambda_s)
    ref = threshold(s, 1, model="adhesive", adhesion=ad, tol=4e-3)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["model"] == "adhesive"
        assert ds.attrs["adhesion_surface_energy"] == pytest.approx(
            0.1 * full_contact_energy(s.heights, s.lx, s.ly), rel=1e-12)
        assert ds.attrs["adhesion_range"] == pytest.approx(0.8 * s.spec.lambda_s, rel=1e-12)
        assert ds.attrs["adhesion_gamma_over_v_full"] == pytest.approx(0.1, rel=1e-12)
        assert float(ds["a_c_star"][0]) == ref.a_c_star


def test_cli_threshold_contact_tol_reaches_the_search(surface_file, tmp_path, monkeypatch):
    """--contact-tol was once left out of the SearchOptions: the search solved to the
    default. The options the search receives carry a non-default value (the search itself
    is replaced: what it would do with the value is tested in test_search_threshold)."""
    import roughflow.search
    from roughflow.defaults import THRESHOLD_CONTACT_TOL

    class Reached(Exception):
        pass

    def search(surface, axis=None, *, options, **kw):
        raise Reached(options)

    monkeypatch.setattr(roughflow.search, "threshold", search)
    _, path = surface_file
    assert THRESHOLD_CONTACT_TOL != 5e-5
    with pytest.raises(Reached) as got:
        main(["threshold", str(path), "--contact-tol", "5e-5", "-o", str(tmp_path / "t.nc")])
    assert got.value.args[0].contact_tol == 5e-5
