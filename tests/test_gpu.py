"""The CuPy backend (``roughflow.gpu``, ``contact.solve(..., backend="cupy")``).

CI has no GPU: there the tests of the refusals run, and the ``gpu`` tests skip. The ``gpu``
tests run on a machine with CuPy and a CUDA GPU (``benchmarks/gpu_on_device.sh``).
"""

from __future__ import annotations

import functools
import importlib.util

import numpy as np
import pytest

from roughflow import gpu
from roughflow.cli import main
from roughflow.contact import _kernels as K
from roughflow.contact import solve
from roughflow.errors import InputError
from roughflow.surface import SurfaceSpec, generate


def _gpu_available() -> bool:
    if importlib.util.find_spec("cupy") is None:
        return False
    try:
        gpu.cupy()
    except InputError:
        return False
    return True


HAVE_GPU = _gpu_available()
needs_gpu = pytest.mark.skipif(not HAVE_GPU, reason="needs CuPy and a CUDA GPU")
without_gpu = pytest.mark.skipif(HAVE_GPU, reason="checks the refusal where CuPy is missing")


@pytest.fixture(scope="module")
def rough():
    return generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=3))


@pytest.fixture
def surface_file(tmp_path):
    path = tmp_path / "s.nc"
    assert main(["surface", "--points-per-lambda-s", "2", "-o", str(path)]) in (0, None)
    return path


def test_unknown_backend_is_named(rough):
    from roughflow.search import threshold

    for call in (lambda: solve(rough, 0.1, backend="tpu"),
                 lambda: threshold(rough, backend="tpu")):
        with pytest.raises(InputError, match="backend must be one of.*'tpu'"):
            call()


def test_threshold_backend_cupy_refuses_other_models(rough):
    from roughflow.search import threshold

    with pytest.raises(InputError, match="backend='cupy' serves model='elastic'"):
        threshold(rough, model="bearing", backend="cupy")


@pytest.mark.parametrize(
    "kwargs",
    [{"model": "bearing", "area_fraction": 0.3}, {"method": "cg"}, {"work": "workspace"}],
)
def test_backend_cupy_refuses_what_it_does_not_serve(rough, kwargs):
    # refused whether or not CuPy is installed: the check comes first
    from roughflow.contact import workspace

    if kwargs.get("work") == "workspace":  # host arrays: the GPU solve keeps its own
        kwargs = {"work": workspace(rough)}
    pressure = None if kwargs.get("model") == "bearing" else 0.1
    with pytest.raises(InputError, match="backend='cupy' serves model='elastic'"):
        solve(rough, pressure, backend="cupy", **kwargs)


@without_gpu
def test_backend_cupy_without_cupy_is_refused_before_work(rough, monkeypatch):
    import roughflow.contact.gfmd as G

    def fail(*args, **kwargs):
        raise AssertionError("the solver ran")

    monkeypatch.setattr(G, "gfmd", fail)
    with pytest.raises(InputError, match="backend='cupy'"):
        solve(rough, 0.1, backend="cupy")


@without_gpu
def test_cli_backend_cupy_without_cupy_exits_2(surface_file, tmp_path, capsys):
    out = tmp_path / "c.nc"
    with pytest.raises(SystemExit) as exc:
        main(["contact", str(surface_file), "--pressure", "0.1", "--backend", "cupy",
              "-o", str(out)])
    assert exc.value.code == 2
    assert "backend='cupy' needs CuPy" in capsys.readouterr().err
    assert not out.exists()


def test_array_module_of_numpy_is_numpy():
    assert gpu.array_module(np.zeros(3)) is np
    a = np.zeros(3)
    assert gpu.to_host(a) is a


# --- on a GPU -------------------------------------------------------------------------


@needs_gpu
@pytest.mark.parametrize("single", [False, True])
@pytest.mark.parametrize("shape", [(64, 48), (30, 17)])
def test_cufft_plan_matches_numpy(shape, single):
    cp = gpu.cupy()
    rng = np.random.default_rng(0)
    a = rng.standard_normal(shape)
    plan = gpu.plan(shape, single)
    spec = gpu.to_host(plan.forward(cp.asarray(a)))
    # float32: FFT round-off about 1e-7 sqrt(log n) of the largest coefficient
    rtol = 1e-5 if single else 1e-12
    ref = np.fft.rfft2(a)
    np.testing.assert_allclose(spec, ref, rtol=0, atol=rtol * np.abs(ref).max())
    back = gpu.to_host(plan.inverse(cp.asarray(ref)))
    np.testing.assert_allclose(back, a, rtol=0, atol=rtol * np.abs(a).max())


def _gpu_kernels(impl: str) -> dict:
    """The hard-wall kernels of one GPU implementation by their numba names."""
    if impl == "cuda":
        from roughflow.contact import _cuda_kernels as C

        return {name: getattr(C, name) for name in (
            "cg_update", "cg_precondition", "cg_direction", "cg_feasible", "cg_stiffness",
            "max_abs", "max_abs_free")}
    return {name[:-3]: getattr(K, name) for name in (
        "cg_update_np", "cg_precondition_np", "cg_direction_np", "cg_feasible_np",
        "cg_stiffness_np", "max_abs_np", "max_abs_free_np")}


@needs_gpu
@pytest.mark.parametrize("impl", ["cuda", "twins"])
@pytest.mark.parametrize("n", [24 * 20, 1031 * 517])  # one block; many, with a ragged tail
def test_gpu_kernels_match_numba(impl, n):
    # each CG kernel on CuPy arrays (the fused CUDA form, or the array-module twin) against
    # the numba kernel on the same data: the same outputs to double round-off (sums in
    # another order: 1e-12 relative; float32 outputs to their last bit, 1e-6)
    cp = gpu.cupy()
    k = _gpu_kernels(impl)
    rng = np.random.default_rng(1)
    nx = 24 if n == 24 * 20 else 1031
    shape = (nx, n // nx)
    g = np.maximum(rng.standard_normal(n), 0.0)
    f = rng.standard_normal(n)
    d = rng.standard_normal(n)
    z = rng.standard_normal(n).astype(np.float32)
    active = (g == 0) & (f < 0)
    s_in = np.zeros(n, dtype=np.float32)
    args = (z, d.copy(), g, f, 0.3, 0.7, s_in, active)
    dev = [cp.asarray(x) if isinstance(x, np.ndarray) else x for x in args]  # copies
    want = K.cg_direction(*args)
    got = k["cg_direction"](*dev)
    assert got[0] == want[0]
    np.testing.assert_allclose(got[1:], want[1:], rtol=1e-12)
    # fused multiply-adds on the GPU (z + beta d): see cg_update below
    np.testing.assert_allclose(gpu.to_host(dev[1]), args[1], rtol=1e-12,
                               atol=1e-15 * float(np.abs(args[1]).max()))
    np.testing.assert_allclose(gpu.to_host(dev[6]), args[6], rtol=1e-6,
                               atol=1e-7 * float(np.abs(args[6]).max()))

    fks = rng.standard_normal(n).astype(np.float32)
    for t in (0.6, 0.0):
        host = [g.copy(), f.copy(), d, fks, t, 0.7, 1e-12, np.zeros(n, np.float32),
                active.copy()]
        dev = [cp.asarray(x) if isinstance(x, np.ndarray) else x for x in host]
        want = K.cg_update(*host)
        assert k["cg_update"](*dev) == pytest.approx(want, rel=1e-12)
        for i in (0, 1, 7, 8):
            # the GPU contracts f + t fks into one fused multiply-add: one rounding instead of
            # two, i.e. up to an ulp of the terms, which is large against a result that
            # nearly cancels (measured for d = z + beta d: 4e-17 on |d| ~ 1, 1.4e-12
            # relative to a 3e-5 result)
            np.testing.assert_allclose(gpu.to_host(dev[i]), host[i], rtol=1e-12,
                                       atol=1e-15 * float(np.abs(host[i]).max()))

    nh = shape[1] // 2 + 1
    spec = (nx, nh)
    rt = (rng.standard_normal(spec) + 1j * rng.standard_normal(spec)).astype(np.complex64)
    pre = rng.random(spec)
    host = [rt, pre, rt[::-1].copy(), np.zeros_like(rt), shape[1]]
    dev = [cp.asarray(x) if isinstance(x, np.ndarray) else x for x in host]
    np.testing.assert_allclose(k["cg_precondition"](*dev), K.cg_precondition(*host),
                               rtol=1e-12)
    for i in (2, 3):
        np.testing.assert_allclose(gpu.to_host(dev[i]), host[i], rtol=1e-6)
    neg_k = -pre.astype(np.float32)
    host = [rt, neg_k, np.zeros_like(rt), shape[1]]
    dev = [cp.asarray(x) if isinstance(x, np.ndarray) else x for x in host]
    assert k["cg_stiffness"](*dev) == pytest.approx(K.cg_stiffness(*host), rel=1e-12)
    np.testing.assert_allclose(gpu.to_host(dev[2]), host[2], rtol=1e-6)
    assert k["cg_feasible"](cp.asarray(g), cp.asarray(d), 0.7) == pytest.approx(
        K.cg_feasible(g, d, 0.7), rel=1e-12)
    assert k["max_abs_free"](cp.asarray(z), cp.asarray(active)) == K.max_abs_free(z, active)
    assert k["max_abs"](cp.asarray(z)) == K.max_abs(z)
    z[n // 2] = np.nan
    assert np.isnan(k["max_abs"](cp.asarray(z)))


@needs_gpu
@pytest.mark.parametrize("pressure", [0.02, 0.1, 0.3])
def test_gpu_solve_matches_cpu(rough, pressure):
    # the same algorithm: both converge to tol 1e-8 (the residual bounds the gap error in
    # units of rms(h)), so their gaps differ by a few tolerances at most (1e-6 leaves a
    # factor 50); their single-precision transforms (cuFFT, FFTW) round differently, so the
    # iteration counts may differ by a few, and a point within round-off of the wall may
    # flip (at most 0.1 % of the points)
    tol = 1e-8
    a = solve(rough, pressure, tol=tol)
    b = solve(rough, pressure, tol=tol, backend="cupy")
    assert isinstance(b.gap, np.ndarray) and b.converged and b.residual <= tol
    hrms = float(rough.heights.std())
    np.testing.assert_allclose(b.gap, a.gap, rtol=0, atol=1e-6 * hrms)
    assert np.count_nonzero(a.contact != b.contact) <= 1e-3 * a.contact.size
    assert b.area_fraction == pytest.approx(a.area_fraction, abs=1e-3)
    assert abs(b.iterations - a.iterations) <= 5
    assert b.contact_pressure.mean() == pytest.approx(pressure, rel=1e-6)


@needs_gpu
def test_gpu_solve_repeats_bit_for_bit_and_twins_agree(rough):
    # the fused kernels reduce in a fixed order: a solve repeats exactly; the array-module
    # twins (another summation order) reach the same solution within the tolerance
    from roughflow.contact import gfmd as G

    run = functools.partial(G.gfmd, rough.heights, rough.lx, rough.ly, 0.1, tol=1e-8,
                            max_iter=2000, backend="cupy")
    a, b, c = run(), run(), run(use_numba=False)
    assert a.iterations == b.iterations
    np.testing.assert_array_equal(a.gap, b.gap)
    assert abs(c.iterations - a.iterations) <= 3
    np.testing.assert_allclose(c.gap, a.gap, rtol=0, atol=1e-6 * rough.heights.std())


@needs_gpu
def test_gpu_warm_start_and_setup(rough):
    # a CPU-built set-up serves GPU solves (copied once) and a warm start from a GPU result
    # saves iterations; both solves converge to the default tol 1e-6, so their gaps agree to
    # a few 1e-6 rms(h) (1e-4 leaves a factor of about 30 for the discrete conditioning)
    from roughflow.contact import prepare

    setup = prepare(rough)
    cold = solve(rough, 0.1, backend="cupy", setup=setup)
    warm = solve(rough, 0.12, init=cold, backend="cupy", setup=setup)
    ref = solve(rough, 0.12, init=solve(rough, 0.1))
    assert warm.iterations < cold.iterations
    np.testing.assert_allclose(warm.gap, ref.gap, rtol=0, atol=1e-4 * rough.heights.std())


@needs_gpu
def test_cli_backend_cupy(surface_file, tmp_path):
    out = tmp_path / "c.nc"
    assert main(["contact", str(surface_file), "--pressure", "0.1", "--backend", "cupy",
                 "-o", str(out)]) in (0, None)
    assert out.exists()


@needs_gpu
def test_gpu_setup_matches_cpu_setup(rough):
    from roughflow.contact import prepare

    a, b = prepare(rough), prepare(rough, backend="cupy")
    assert gpu.array_module(b.h) is not np and gpu.array_module(a.h) is np
    # the same arithmetic on the heights (exact: levels and h0 identical); the spectral
    # sums differ by the transforms' round-off (1e-15 relative; 1e-12 allowed)
    assert b.h0 == a.h0
    np.testing.assert_array_equal(b.levels, a.levels)
    np.testing.assert_array_equal(gpu.to_host(b.h), a.h)
    for name in ("hscale", "gbar", "band_ratio"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-12)
    np.testing.assert_allclose(gpu.to_host(b.pre), a.pre, rtol=1e-12)
    with pytest.raises(InputError, match="prepared with backend='cupy'"):
        solve(rough, 0.1, setup=b)


@needs_gpu
def test_gpu_threshold_matches_cpu():
    # the same search on both backends: each solve agrees to its tolerance, so a_c* agrees
    # to far inside the bisection tolerance (the brackets may differ where a solve's area
    # moves by round-off across a spanning test: allowed up to the tolerance itself)
    from roughflow.search import threshold

    s = generate(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=5, gamma=2.0))
    a = threshold(s, tol=0.01)
    b = threshold(s, tol=0.01, backend="cupy")
    for ax in (0, 1):
        assert b[ax].a_c_star == pytest.approx(a[ax].a_c_star, abs=0.01)
        assert b[ax].a_hi - b[ax].a_lo <= 0.01


@needs_gpu
def test_cli_threshold_backend_cupy_records_the_gpu(surface_file, tmp_path):
    import xarray as xr

    out = tmp_path / "t.nc"
    assert main(["threshold", str(surface_file), "--tol", "0.02", "--backend", "cupy",
                 "-o", str(out)]) in (0, None)
    with xr.open_dataset(out) as ds:
        assert ds.attrs["backend"].startswith("cupy ") and " on " in ds.attrs["backend"]


def test_gpu_memory_is_checked_before_any_work(rough, monkeypatch):
    # the model (256 B a point, the peak of CuPy's pool measured 184-256 B from 1024^2 to
    # 16384^2) against the GPU's free memory plus the pool's unused blocks: a 2048^2 solve
    # (1.1 GB) is refused on a GPU with 0.5 GB free, before the solver runs; a stand-in for
    # CuPy reports the memory, so this runs without a GPU
    from types import SimpleNamespace

    from roughflow.contact import gfmd as G
    from roughflow.errors import ResourceError
    from roughflow.search import threshold
    from roughflow.surface import Surface

    pool = SimpleNamespace(total_bytes=lambda: 300 * 2**20, used_bytes=lambda: 100 * 2**20)
    fake = SimpleNamespace(
        cuda=SimpleNamespace(runtime=SimpleNamespace(getDeviceCount=lambda: 1,
                                                     memGetInfo=lambda: (300 * 2**20, 8e10))),
        get_default_memory_pool=lambda: pool)
    monkeypatch.setattr(gpu, "cupy", lambda: fake)
    assert gpu.available_bytes() == 500 * 2**20

    def fail(*args, **kwargs):
        raise AssertionError("the solver ran")

    monkeypatch.setattr(G, "gfmd", fail)
    monkeypatch.setattr(G, "hard_wall_setup", fail)
    big = Surface(heights=np.zeros((2048, 2048)), lx=1.0, ly=1.0)
    refusal = r"on the GPU on a 2048 x 2048 grid .* 1\.14 GB of GPU memory, but the GPU has 524 MB"
    for call in (lambda: solve(big, 0.1, backend="cupy"),
                 lambda: threshold(big, backend="cupy")):
        with pytest.raises(ResourceError, match=refusal):
            call()
