"""results/README.md, the page on reading a study dataset, stays reachable and true: the
README links it, and its Python example runs on a study dataset made as the workflow makes
one (tests/test_docs_commands.py runs the python blocks of docs/*.md only)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from roughflow.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "results" / "README.md"


def test_the_readme_links_the_page():
    assert "(results/README.md)" in (ROOT / "README.md").read_text()


@pytest.fixture(scope="module")
def study_folder(tmp_path_factory):
    """A tiny threshold_vs_gamma study: one `roughflow scene threshold` job of two seeds,
    combined by `roughflow aggregate` into results/threshold_vs_gamma/dataset.nc."""
    wd = tmp_path_factory.mktemp("results_page")
    job = wd / "job.nc"
    assert cli_main(["-q", "scene", "threshold", "--gamma", "1", "--eps-f", "0.25",
                     "--points-per-lambda-s", "2", "--seeds", "0", "1", "-o", str(job)]) in (
        0, None)
    out = wd / "results" / "threshold_vs_gamma" / "dataset.nc"
    out.parent.mkdir(parents=True)
    assert cli_main(["-q", "aggregate", str(job), "--study", "threshold_vs_gamma",
                     "-o", str(out)]) in (0, None)
    return wd


def test_the_pages_example_runs_on_a_study_dataset(study_folder, monkeypatch):
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(), flags=re.S)
    assert blocks, "results/README.md has no Python example"
    monkeypatch.chdir(study_folder)
    names: dict = {}
    try:
        for code in blocks:
            exec(compile(code, str(PAGE), "exec"), names)
        # the seed mean and standard error per parameter point and axis, as the page says
        assert names["mean"].dims == names["se"].dims
        assert "seed" not in names["mean"].dims and "axis" in names["mean"].dims
        assert np.isfinite(names["mean"].values).all()
        assert np.isfinite(names["se"].values).all()
    finally:
        if "ds" in names:
            names["ds"].close()


def test_the_pages_description_of_a_dataset_holds(study_folder):
    from roughflow.units import registry

    text = " ".join(PAGE.read_text().split())
    with xr.open_dataset(study_folder / "results" / "threshold_vs_gamma" / "dataset.nc") as ds:
        # "dimensions model, gamma, hurst, eps_t, eps_f (the parameters), then seed and axis"
        assert ds["a_c_star"].dims == ("model", "gamma", "hurst", "eps_t", "eps_f", "seed",
                                       "axis")
        assert "`model`, `gamma`, `hurst`, `eps_t`, `eps_f` (the parameters), then `seed`" \
            in text
        # per-job settings are over the parameters, a seed's own numbers over seed too
        assert ds["nx"].dims == ds["a_c_star"].dims[:5]
        assert ds["wall_time"].dims == ds["a_c_star"].dims[:6]
        # every numeric variable has units and long_name; the units parse with the registry
        ureg = registry(ds.attrs)
        for name, var in ds.variables.items():
            if var.dtype.kind in "fiu":
                assert {"units", "long_name"} <= set(var.attrs), name
                ureg(var.attrs["units"])
        for key in ("roughflow_commit", "study_config", "jobs"):
            assert f"`{key}`" in text
        assert "jobs" in ds.attrs and "roughflow_commit" in ds.attrs
