"""``roughflow surface``: netCDF output and clean errors."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main
from roughflow.io import read_surface
from roughflow.surface import SurfaceSpec, generate, rms_gradient


def test_surface_file_is_self_describing(tmp_path):
    out = tmp_path / "s.nc"
    assert main(["surface", "--gamma", "4", "--seed", "2", "--points-per-lambda-s", "2",
                 "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert ds["heights"].dims == ("x", "y")
        for name in ("heights", "x", "y"):
            assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
        assert ds.attrs["spec_gamma"] == 4.0 and ds.attrs["spec_seed"] == 2
    s = read_surface(out)
    expected = generate(SurfaceSpec.from_sweep(gamma=4, seed=2, points_per_lambda_s=2))
    assert s.spec == expected.spec
    np.testing.assert_array_equal(s.heights, expected.heights)


def test_explicit_grid(tmp_path):
    out = tmp_path / "s.nc"
    main(["surface", "--nx", "64", "--ny", "256", "--lx", "0.5", "--ly", "2",
          "--lambda-r", "0.25", "--lambda-s", "0.025", "-o", str(out)])
    assert read_surface(out).heights.shape == (64, 256)


def test_sweep_form_takes_the_rms_slope(tmp_path):
    """--rms-slope was once dropped in the sweep form (no --nx): the surface came out with
    the default rms gradient 1. generate() scales the heights to the spec's rms gradient,
    measured here spectrally on the periodic map; rel 1e-12 is round-off of that scaling."""
    out = tmp_path / "s.nc"
    assert main(["surface", "--points-per-lambda-s", "2", "--rms-slope", "0.3",
                 "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert ds.attrs["spec_rms_slope"] == 0.3
    s = read_surface(out)
    assert rms_gradient(s.heights, s.spec.lx, s.spec.ly) == pytest.approx(0.3, rel=1e-12)


def _run(*args):
    return subprocess.run([sys.executable, "-m", "roughflow", *args],
                          capture_output=True, text=True)


def test_bad_input_exits_with_message_and_writes_nothing(tmp_path):
    out = tmp_path / "s.nc"
    r = _run("surface", "--hurst", "1.5", "-o", str(out))
    assert r.returncode == 2 and "hurst" in r.stderr and "1.5" in r.stderr
    assert not out.exists()
    r = _run("surface", "--nx", "64", "-o", str(out))
    assert r.returncode == 2 and "--lambda-r" in r.stderr


def test_help_documents_every_option():
    r = _run("surface", "--help")
    assert r.returncode == 0
    for opt in ("--hurst", "--gamma", "--seed", "--nx", "--lambda-s", "--eps-f",
                "--points-per-lambda-s", "--aspect", "--output"):
        assert opt in r.stdout


def test_aspect_sets_the_cell(tmp_path):
    """--aspect is lx / ly of a unit-area cell: 4 gives lx = 2, ly = 0.5 (exact in binary)."""
    out = tmp_path / "s.nc"
    assert main(["surface", "--points-per-lambda-s", "2", "--aspect", "4", "-o", str(out)]) == 0
    with xr.open_dataset(out) as ds:
        assert (ds.attrs["spec_lx"], ds.attrs["spec_ly"]) == (2.0, 0.5)
