"""Arrays a researcher hands the library: masks of other dtypes, nan heights, masked arrays
from netCDF4, xarray dims, unsigned heights, tiny grids. Each case below gave a wrong
number silently or a traceback from deep inside before (found by an input audit); now each
gives the right number or an InputError naming the value, before any work."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from roughflow import SurfaceSpec, accuracy, contact, flow, generate, percolation, search, theory
from roughflow.errors import InputError
from roughflow.surface import Surface, rms_gradient


@pytest.fixture(scope="module")
def surface() -> Surface:
    return generate(SurfaceSpec(nx=64, ny=48, lx=1.0, ly=0.75, hurst=0.8, gamma=1.0,
                                lambda_r=0.25, lambda_s=1 / 16, seed=0))


@pytest.fixture(scope="module")
def state(surface):
    return contact.solve(surface, 0.15)


def test_integer_contact_mask_is_refused_by_the_gap_theory(state):
    # a 0/255 mask (an image, a netCDF byte variable) gave grid_area_fraction 82.8 and a
    # sigma 357x too large; masks are refused unless boolean, as percolation refuses them
    with pytest.raises(InputError, match="contact mask must be a boolean array, got dtype uint8"):
        theory.gap_theory(state.gap, contact=state.contact.astype(np.uint8) * 255,
                          a_c_star=0.415, area_fraction=0.3)
    with pytest.raises(InputError, match="boolean"):
        theory.local_conductivity(state.gap, contact=state.contact.astype(int))


@pytest.mark.parametrize("call", [
    lambda m: flow.solve(m, 0),
    lambda m: theory.conductivity_peklenik(m),
    lambda m: theory.local_conductivity(m),
    lambda m: theory.bruggeman(m, a_c_star=0.415),
    lambda m: Surface.from_array(m),
    lambda m: rms_gradient(m, 1.0, 1.0),
], ids=["flow", "peklenik", "local_conductivity", "bruggeman", "surface", "rms_gradient"])
def test_a_mask_passed_where_numbers_belong_is_refused(state, call):
    # a contact mask where a gap or heights belong read as a field of ones and zeros: the
    # flow gave sigma 1/12 of an all-open mask, the Peklenik estimate a number
    with pytest.raises(InputError, match="boolean array"):
        call(state.contact)


def test_the_peklenik_number_of_a_contact_mask_is_its_pattern_s(surface, state):
    # a mask is a field of its own there (the contact pattern's anisotropy), read as 0 / 1
    cell = (surface.lx, surface.ly)
    assert theory.peklenik_number(state.contact, *cell) == theory.peklenik_number(
        state.contact.astype(float), *cell)


def test_nan_heights_are_refused_wherever_they_enter(surface):
    h = surface.heights.copy()
    h[3, 3] = np.nan
    with pytest.raises(InputError, match=r"heights has 1 non-finite values, first at \(3, 3\)"):
        Surface(h, 1.0, 0.75)
    # the exact bearing threshold returned numbers for such heights; the two sweeps disagreed
    # on where a nan cell opens (argsort: last; the keyed sweep: first)
    with pytest.raises(InputError, match="non-finite"):
        percolation.bearing_bracket(h, 1)
    with pytest.raises(InputError, match=r"key has 1 nan values, first at \(3, 3\)"):
        percolation.critical_open_count_by_key(-h, 1)
    # a Surface's own array is read-only; the caller's array it was made from can still
    # be changed in place after the check (the constructor does not copy)
    with pytest.raises(ValueError, match="read-only"):
        surface.heights[3, 3] = np.nan
    caller = surface.heights.copy()
    changed = Surface(caller, 1.0, 0.75)
    caller[3, 3] = np.nan
    with pytest.raises(InputError, match="non-finite"):
        search.threshold(changed, model="bearing")


def test_a_surface_does_not_follow_its_callers_array(surface):
    # an API audit: from_array kept the caller's array, so h *= 3 in a notebook changed the
    # surface, and a setup prepared before solved the old one (a_c 0.242 instead of 0.095)
    h = surface.heights.copy()
    s = Surface.from_array(h, lx=surface.lx, ly=surface.ly)
    before = contact.solve(s, 0.1)
    setup = contact.prepare(s)
    h *= 3
    assert np.array_equal(contact.solve(s, 0.1, setup=setup).gap, before.gap)
    assert np.array_equal(contact.solve(s, 0.1).gap, before.gap)
    with pytest.raises(ValueError, match="read-only"):
        s.heights[...] *= 3  # and not through the surface itself either


def test_masked_arrays_are_refused_not_read_through(state, surface):
    # netCDF4 returns masked arrays for variables with a fill value; np.asarray kept the data
    # behind the mask: sigma_x came out 24x too large here
    g = np.ma.masked_array(state.gap.copy(), mask=False)
    g.mask[:, 10] = True
    g.data[:, 10] = 0.05
    with pytest.raises(InputError, match=r"gap has 64 masked values, first at \(0, 10\)"):
        flow.conductance(g, lx=1.0, ly=0.75)
    with pytest.raises(InputError, match="masked values"):
        theory.gap_theory(g, a_c_star=0.415)
    hm = np.ma.masked_array(surface.heights.copy(), mask=False)
    hm.mask[0, 0] = True
    with pytest.raises(InputError, match="surface heights has 1 masked values"):
        Surface(hm, 1.0, 0.75)
    # a masked array with nothing masked is its data
    plain = np.ma.masked_array(state.gap.copy(), mask=False)
    assert flow.conductance(plain, lx=1.0, ly=0.75) == flow.conductance(state.gap, lx=1.0,
                                                                         ly=0.75)


def test_xarray_dims_in_y_x_order_are_refused(state):
    # roughflow arrays are [x, y]: a DataArray with dims (y, x) had sigma_x and sigma_y swapped
    with pytest.raises(InputError, match=r"dims \('y', 'x'\)"):
        flow.conductance(xr.DataArray(state.gap.T, dims=("y", "x")), lx=1.0, ly=0.75)
    ok = flow.conductance(xr.DataArray(state.gap, dims=("x", "y")), lx=1.0, ly=0.75)
    assert ok == flow.conductance(state.gap, lx=1.0, ly=0.75)


def test_rms_gradient_of_unsigned_heights_and_too_short_grids(surface):
    # np.diff of uint8 heights wrapped around: 13638 instead of 821
    u8 = np.clip(surface.heights * 40 + 128, 0, 255).astype(np.uint8)
    for periodic in (True, False):
        assert rms_gradient(u8, 1.0, 0.75, periodic=periodic) == pytest.approx(
            rms_gradient(u8.astype(float), 1.0, 0.75, periodic=periodic), rel=1e-12)
    with pytest.raises(InputError, match="2 points along each axis, got a 1 x 8 grid"):
        rms_gradient(np.zeros((1, 8)), 1.0, 1.0, periodic=False)
    with pytest.raises(InputError, match="non-finite"):
        rms_gradient(np.full((4, 4), np.nan), 1.0, 1.0)


def test_threshold_tolerance_below_one_cell_is_refused_up_front():
    # on 16^2 one cell is 0.0039 of the area > tol 0.002: the search ran its 40 solves and
    # ended with advice about the contact tolerance
    small = generate(SurfaceSpec(nx=16, ny=16, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0,
                                 lambda_r=0.25, lambda_s=0.125, seed=0))
    with pytest.raises(InputError, match=r"tol=0.002 is below the area of one cell .*1/256"):
        search.threshold(small)
    found = search.threshold(small, tol=0.01)
    assert all(0 < t.a_c_star < 1 for t in found.values())
    # the exact bearing bracket is one cell wide by construction: no such limit
    assert search.threshold(small, model="bearing")[0].a_hi - \
        search.threshold(small, model="bearing")[0].a_lo == pytest.approx(1 / 256)


def test_surface_made_from_a_list_works_everywhere(surface):
    # the constructor stored the list: contact converted it, threshold and rms_gradient
    # failed with AttributeError 'list' object has no attribute 'shape'
    listed = Surface(surface.heights.tolist(), 1.0, 0.75)
    assert isinstance(listed.heights, np.ndarray) and listed.heights.dtype == np.float64
    a = search.threshold(listed, model="bearing")
    b = search.threshold(surface, model="bearing")
    assert [t.a_c_star for t in a.values()] == [t.a_c_star for t in b.values()]
    with pytest.raises(InputError, match="lx"):
        Surface(surface.heights, 0.0, 0.75)


def test_degenerate_grids_get_input_errors():
    # one size rule for every surface (from_array had 4 x 4, the constructor none: a 1 x 8
    # surface was solved)
    for shape in ((1, 1), (2, 2), (1, 8), (8, 3)):
        with pytest.raises(InputError, match=rf"at least 4 x 4, got shape \({shape[0]}, "):
            Surface(np.zeros(shape), 1.0, 1.0)
        with pytest.raises(InputError, match="at least 4 x 4"):
            Surface.from_array(np.zeros(shape))
    with pytest.raises(InputError, match="empty"):
        accuracy.perimeter_corrected_area(np.zeros((0, 4), dtype=bool))


def test_memory_order_of_the_heights_does_not_change_a_bit(surface):
    """A Fortran-ordered or transposed-back array (xarray's .transpose("x", "y") gives one)
    summed its heights in another order: the solver's mean level differed in the last bit
    and the gaps by up to 3e-14. Surfaces keep their heights in C order."""
    h = surface.heights
    fortran = Surface.from_array(np.asfortranarray(h), lx=surface.lx, ly=surface.ly)
    view = Surface.from_array(np.ascontiguousarray(h.T).T, lx=surface.lx, ly=surface.ly)
    ref = contact.solve(surface, 0.1)
    for other in (fortran, view):
        assert other.heights.flags.c_contiguous
        assert np.array_equal(contact.solve(other, 0.1).gap, ref.gap)
