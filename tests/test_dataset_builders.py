"""The dataset builders of roughflow.datasets check what the caller says against the results
(axis, cell, adhesion) instead of recording it as given."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from roughflow import contact, datasets, flow, search
from roughflow.contact import Adhesion
from roughflow.errors import InputError
from roughflow.surface import SurfaceSpec, generate

SPEC = SurfaceSpec(nx=32, ny=32, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0, lambda_r=0.5,
                   lambda_s=0.125, seed=1)


@pytest.fixture(scope="module")
def solved():
    surface = generate(SPEC)
    res = contact.solve(surface, 0.1)
    flows = {ax: flow.solve(res.gap, ax, lx=surface.lx, ly=surface.ly) for ax in (0, 1)}
    return surface, res, flows


@pytest.fixture(scope="module")
def threshold_x(solved):
    return search.threshold(solved[0], axis=0, tol=0.05)


def test_flow_dataset_refuses_a_key_other_than_the_results_axis(solved):
    # an x-flow passed under key 1 was written as sigma_y (the key alone named the axis)
    surface, res, flows = solved
    with pytest.raises(InputError, match=r"key 1 \(axis y\).*along axis x"):
        datasets.flow_dataset({1: flows[0]}, res.contact, lx=surface.lx, ly=surface.ly,
                              eta=1.0, tol=1e-8)


def test_flow_dataset_takes_axis_names_as_keys(solved):
    # 'x' / 'y' keys crashed with a bare TypeError (tuple indices must be integers)
    surface, res, flows = solved
    kw = dict(lx=surface.lx, ly=surface.ly, eta=1.0, tol=1e-8)
    named = datasets.flow_dataset({"y": flows[1], "x": flows[0]}, res.contact, **kw)
    numbered = datasets.flow_dataset(flows, res.contact, **kw)
    assert float(named["sigma_x"]) == flows[0].sigma
    assert float(named["sigma_y"]) == flows[1].sigma
    assert named.identical(numbered)
    with pytest.raises(InputError, match="axis x given twice"):
        datasets.flow_dataset({0: flows[0], "x": flows[0]}, res.contact, **kw)


@pytest.mark.parametrize(("name", "lx", "ly"), [("lx", 5.0, 1.0), ("ly", 1.0, 7.0)])
def test_flow_dataset_refuses_a_cell_other_than_the_results(solved, name, lx, ly):
    # lx, ly were recorded as passed, though the results were solved on a unit cell
    _, res, flows = solved
    given = lx if name == "lx" else ly
    with pytest.raises(InputError, match=rf"{name}={given!r} .* {name}=1\.0"):
        datasets.flow_dataset(flows, res.contact, lx=lx, ly=ly, eta=1.0, tol=1e-8)


def test_flow_dataset_refuses_a_contact_mask_of_another_grid(solved):
    # a mask of another shape crashed inside xarray with a ValueError about conflicting sizes
    surface, res, flows = solved
    with pytest.raises(InputError, match=r"\(32, 32\) grid, the contact mask \(16, 16\)"):
        datasets.flow_dataset(flows, res.contact[:16, :16], lx=surface.lx, ly=surface.ly,
                              eta=1.0, tol=1e-8)


def test_threshold_dataset_refuses_a_key_other_than_the_thresholds_axis(solved, threshold_x):
    # a threshold along x passed under key 1 was stored as axis y
    with pytest.raises(InputError, match=r"key 1 \(axis y\).*along axis x"):
        datasets.threshold_dataset({1: threshold_x}, solved[0])


def test_threshold_dataset_takes_a_single_threshold_and_axis_names(solved, threshold_x):
    # a single Threshold (what search.threshold(s, axis=0) returns) raised a bare TypeError,
    # and so did an 'x' key
    surface = solved[0]
    single = datasets.threshold_dataset(threshold_x, surface)
    assert list(single.axis.values) == ["x"]
    assert float(single["a_c_star"].sel(axis="x")) == threshold_x.a_c_star
    assert single.identical(datasets.threshold_dataset({"x": threshold_x}, surface))
    assert single.identical(datasets.threshold_dataset({0: threshold_x}, surface))
    with pytest.raises(InputError, match="mapping of axis"):
        datasets.threshold_dataset([threshold_x], surface)


def test_contact_dataset_needs_the_adhesion_of_an_adhesive_result(solved):
    # an adhesive result without adhesion= was written with model 'adhesive' and no
    # adhesion_* attributes at all
    surface, res, _ = solved
    # the builder reads only result.model: an adhesive solve (seconds on 32^2) is not needed
    adhesive = dataclasses.replace(res, model="adhesive")
    with pytest.raises(InputError, match="adhesion="):
        datasets.contact_dataset(surface, adhesive)
    ds = datasets.contact_dataset(surface, adhesive,
                                  Adhesion(surface_energy=0.002, range=0.05))
    assert ds.attrs["adhesion_surface_energy"] == 0.002
    assert ds.attrs["adhesion_range"] == 0.05


def test_contact_dataset_refuses_a_result_of_another_grid(solved):
    # a result of another shape crashed inside xarray with a ValueError about conflicting sizes
    _, res, _ = solved
    other = generate(dataclasses.replace(SPEC, nx=16, ny=16))
    with pytest.raises(InputError, match=r"result's grid \(32, 32\) is not the surface's"):
        datasets.contact_dataset(other, res)
    assert np.array_equal(datasets.contact_dataset(generate(SPEC), res)["gap"].values,
                          res.gap)
