"""Random-phase surfaces (paper Eq. 1-2, exponent corrected per docs/physics.md Sect. 2)."""

from __future__ import annotations

import numpy as np
import pytest

from roughflow import fft
from roughflow.errors import InputError
from roughflow.surface import (
    SurfaceSpec,
    fft_friendly,
    generate,
    peklenik_wavenumber,
    rms_gradient,
    spectrum,
)


def spec(**kw) -> SurfaceSpec:
    base = dict(nx=128, ny=128, lx=1.0, ly=1.0, hurst=0.8, gamma=1.0,
                lambda_r=0.25, lambda_s=1 / 32, seed=3)
    base.update(kw)
    return SurfaceSpec(**base)


def full_spectrum_ratio(s: SurfaceSpec):
    """|FFT(h)|^2 / C(q_P) on the full grid, plus the mask inside the cutoff ellipse."""
    h = generate(s).heights
    power = np.abs(np.fft.fft2(h)) ** 2
    qx = 2 * np.pi * np.fft.fftfreq(s.nx, d=s.dx)
    qy = 2 * np.pi * np.fft.fftfreq(s.ny, d=s.dy)
    c = spectrum(peklenik_wavenumber(qx[:, None], qy[None, :], s.gamma), s)
    return h, power, c


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"gamma": 4.0, "nx": 64, "ny": 256, "lambda_r": 0.125, "lambda_s": 1 / 64},
        {"gamma": 0.25, "nx": 256, "ny": 64, "lambda_r": 0.125, "lambda_s": 1 / 64},
        {"nx": 64, "ny": 256, "lx": 0.5, "ly": 2.0},  # the paper's Fig. 1 cell
        {"nx": 65, "ny": 67},  # odd sizes: no Nyquist self-conjugate modes
        {"rolloff": "plateau"},
    ],
)
def test_amplitudes_follow_spectrum_exactly(kw):
    s = spec(**kw)
    h, power, c = full_spectrum_ratio(s)
    inside = c > 0
    ratio = power[inside] / c[inside]
    # Random-phase approximation: amplitudes are deterministic, so |h~|^2 / C is one
    # constant up to round-off (1e-10 leaves room for ~1e4 ulp of FFT error).
    assert np.ptp(ratio) / ratio.mean() < 1e-10
    # Outside the ellipse (and at q = 0) the transform is round-off only.
    assert power[~inside].max() < 1e-20 * power[inside].max()
    assert np.isrealobj(h) and h.dtype == np.float64
    assert abs(h.mean()) < 1e-14 * np.abs(h).max()


def test_radial_spectrum_slope_is_minus_two_one_plus_h():
    """Between q_r and q_s the 2D spectrum falls as q^(-2(1+H)) (the paper's slip corrected)."""
    for hurst in (0.3, 0.8):
        s = spec(nx=512, ny=512, lambda_r=1 / 2, lambda_s=1 / 128, hurst=hurst)
        h = generate(s).heights
        power = np.abs(np.fft.fft2(h)) ** 2
        qx = 2 * np.pi * np.fft.fftfreq(s.nx, d=s.dx)
        q = np.hypot(qx[:, None], qx[None, :]).ravel()
        qr, qs = 2 * np.pi / s.lambda_r, 2 * np.pi / s.lambda_s
        # Fit well inside the self-affine range, where (1 + (q/qr)^2)^-(1+H) is a power law to
        # within (qr/q)^2 ~ 2 %: from 8 q_r to q_s.
        sel = (q > 8 * qr) & (q < qs)
        slope = np.polyfit(np.log(q[sel]), np.log(power.ravel()[sel]), 1)[0]
        # The remaining roll-off curvature biases the slope by < 0.02 (computed from the
        # analytic C over the same range); a paper-style exponent -(1+H) would be off by ~1.
        assert slope == pytest.approx(-2 * (1 + hurst), abs=0.03)


def test_rms_gradient_normalised():
    for kw in ({}, {"gamma": 4.0, "nx": 64, "ny": 256, "lambda_r": 0.125, "lambda_s": 1 / 64},
               {"rms_slope": 0.3}):
        s = spec(**kw)
        h = generate(s).heights
        # Spectral gradient over the same discrete modes: exact up to round-off.
        assert rms_gradient(h, s.lx, s.ly) == pytest.approx(s.rms_slope, rel=1e-12)
        # Independently of the library's half-spectrum weights (generate normalises with
        # rms_gradient itself): Parseval on the full numpy grid, round-off only.
        qx = 2 * np.pi * np.fft.fftfreq(s.nx, d=s.lx / s.nx)
        qy = 2 * np.pi * np.fft.fftfreq(s.ny, d=s.ly / s.ny)
        q2 = qx[:, None] ** 2 + qy[None, :] ** 2
        full = np.sqrt((q2 * np.abs(np.fft.fft2(h)) ** 2).sum()) / h.size
        assert full == pytest.approx(s.rms_slope, rel=1e-12)


@pytest.mark.parametrize("periodic", [True, False])
def test_rms_gradient_refuses_heights_whose_squares_leave_the_float_range(periodic):
    # |h| ~ 1e200 gave nan (with RuntimeWarnings) and 1e-200 gave 0: the same check as
    # contact.solve's (errors.require_squares_in_range), naming the heights' size
    h = np.random.default_rng(0).standard_normal((16, 16))
    for scale, flow in ((1e200, "overflow"), (1e-200, "underflow")):
        with pytest.raises(InputError, match=f"gradients on the 1 x 1 cell out of range: "
                           rf"their squares {flow} \(largest \|h\| 3.11e[+-]200"):
            rms_gradient(h * scale, 1.0, 1.0, periodic=periodic)
    # ordinary heights on a tiny cell: the message names the cell, not only the heights
    with pytest.raises(InputError, match="gradients on the 1e-300 x 1 cell out of range"):
        rms_gradient(h, 1e-300, 1.0, periodic=periodic)
    assert rms_gradient(h * 1e150, 1.0, 1.0, periodic=periodic) == pytest.approx(
        rms_gradient(h, 1.0, 1.0, periodic=periodic) * 1e150, rel=1e-12)
    assert rms_gradient(np.full((8, 8), 3.0), 1.0, 1.0, periodic=periodic) == 0.0  # flat


@pytest.mark.parametrize("gamma", [0.25, 1.0, 4.0])
def test_phases_inside_the_cutoff_ellipse_are_random(gamma):
    """Every mode inside the ellipse has a phase of its own: were the phase box smaller than
    the ellipse along one axis (its extents swapped between x and y, say), the modes outside
    it would keep phase 0 (a real amplitude), a coherent part of the surface."""
    s = spec(gamma=gamma, nx=256, ny=256, lambda_s=1 / 48)
    c = np.fft.rfft2(generate(s).heights)
    qx, qy = fft.wavevectors(s.nx, s.ny, s.lx, s.ly)
    qp = peklenik_wavenumber(qx, qy, gamma) * np.ones(c.shape)
    inside = (qp > 0) & (qp < 0.95 * 2 * np.pi / s.lambda_s) & (np.abs(c) > 0)
    phase = np.angle(c[inside])
    # a real amplitude has |sin| < 1e-9 (round-off); uniform phases give that with
    # probability 6e-10 per mode, so among the ~4000 modes none should
    assert inside.sum() > 1000
    assert np.mean(np.abs(np.sin(phase)) < 1e-9) < 0.01
    # and uniform: the circular mean of e^(i phase) over N modes is ~ 1/sqrt(N); 5 sigma
    assert abs(np.exp(1j * phase).mean()) < 5 / np.sqrt(phase.size)


def test_phases_come_from_the_raw_pcg64_stream():
    """The phases use numpy's bit-generator stream (fixed across numpy versions, NEP 19),
    2 pi (r >> 11) 2^-53; today that is also Generator.uniform(0, 2 pi) of the same seed, so
    a seed's surface is the one earlier versions made."""
    from roughflow.surface import _phase_box

    s = spec(seed=2**40 + 3, gamma=2.0)
    phases, _, _ = _phase_box(s)
    raw = np.random.PCG64(s.seed).random_raw(phases.size).reshape(phases.shape)
    np.testing.assert_array_equal(phases, (raw >> np.uint64(11)) * 2.0**-53 * (2 * np.pi))
    np.testing.assert_array_equal(
        phases, np.random.default_rng(s.seed).uniform(0.0, 2 * np.pi, size=phases.shape))


def test_anisotropic_slope_ratio_approaches_one_over_gamma_squared():
    gamma = 4.0
    s = SurfaceSpec.from_sweep(gamma=gamma, points_per_lambda_s=4, seed=11)
    h = generate(s).heights
    c = fft.rfft2(h)
    qx, qy = fft.wavevectors(s.nx, s.ny, s.lx, s.ly)
    w = fft.rfft_weights(s.ny)
    gx2 = (w * qx**2 * np.abs(c) ** 2).sum()
    gy2 = (w * qy**2 * np.abs(c) ** 2).sum()
    # Continuum value 1/gamma^2 holds for the ellipse integral; on a finite grid the
    # discrete modes sample the ellipse unevenly. With L/lambda_r = 8 there are ~10^5
    # modes inside the ellipse and the lattice-sum error is of order 1 %; 3 % bounds it.
    assert gx2 / gy2 == pytest.approx(1 / gamma**2, rel=0.03)
    # And the stretch direction is right: the opposite would give gamma^2 = 16 x larger.


def test_same_seed_same_heights_different_seed_differs():
    a = generate(spec(seed=5)).heights
    b = generate(spec(seed=5)).heights
    c = generate(spec(seed=6)).heights
    assert np.array_equal(a, b)
    assert np.abs(a - c).max() > 0.1 * np.abs(a).max()


def test_rectangular_cell_uses_true_wavevectors():
    """On a 0.5 x 2 cell, x-modes are spaced 4 pi and y-modes pi/1: power sits on those q."""
    s = spec(nx=64, ny=256, lx=0.5, ly=2.0)
    h, power, c = full_spectrum_ratio(s)
    qs = 2 * np.pi / s.lambda_s
    qx = 2 * np.pi * np.fft.fftfreq(s.nx, d=s.dx)
    assert qx[1] == pytest.approx(4 * np.pi)
    # The mode (1, 0) has |q| = 4 pi < q_s and must carry power C(4 pi); the mode
    # (0, 2) has |q| = 2 pi. Using square-cell q = 2 pi k would swap those amplitudes.
    ratio = power[1, 0] / power[0, 2]
    qr = 2 * np.pi / s.lambda_r
    expected = ((1 + (2 * np.pi / qr) ** 2) / (1 + (4 * np.pi / qr) ** 2)) ** (1 + s.hurst)
    assert ratio == pytest.approx(expected, rel=1e-10)
    assert qs > 4 * np.pi


def test_from_sweep_paper_defaults():
    s = SurfaceSpec.from_sweep(gamma=4.0, points_per_lambda_s=4)
    assert s.lx == pytest.approx(1.0) and s.ly == pytest.approx(1.0)
    assert 1 / s.lambda_r == pytest.approx(8.0)  # 4 max(sqrt(gamma), 1/sqrt(gamma))
    assert s.lambda_s == pytest.approx(s.lambda_r / 16)
    # >= 4 points per shortest wavelength along each axis
    assert s.lambda_s * 2 / s.dx >= 4 and s.lambda_s / 2 / s.dy >= 4
    t = SurfaceSpec.from_sweep(aspect=0.25, l_over_lambda_r=4, eps_f=0.1, points_per_lambda_s=4)
    assert (t.lx, t.ly, t.lambda_r) == pytest.approx((0.5, 2.0, 0.25))


def test_fft_friendly():
    assert [fft_friendly(n) for n in (1, 5, 7, 97, 128, 129)] == [4, 6, 8, 100, 128, 144]


@pytest.mark.parametrize(
    ("kw", "needle"),
    [
        ({"hurst": 0.0}, "hurst"),
        ({"hurst": 1.2}, "hurst"),
        ({"hurst": float("nan")}, "hurst"),
        ({"gamma": 0.0}, "gamma"),
        ({"gamma": -2.0}, "gamma"),
        ({"gamma": float("inf")}, "gamma"),
        ({"lambda_s": 1 / 100}, "lambda_s"),  # under two grid spacings (dx = 1/128)
        ({"lambda_r": 2.0}, "lambda_r"),
        ({"lx": 0.0}, "lx"),
        ({"ly": -1.0}, "ly"),
        ({"nx": 0}, "nx"),
        ({"seed": -1}, "seed"),
        ({"rolloff": "sharp"}, "rolloff"),
    ],
)
def test_bad_input_names_the_value(kw, needle):
    with pytest.raises(InputError, match=needle):
        spec(**kw)


def test_bad_sweep_input():
    with pytest.raises(InputError, match="eps_f"):
        SurfaceSpec.from_sweep(eps_f=0)
    with pytest.raises(InputError, match="gamma"):
        SurfaceSpec.from_sweep(gamma=-1)
    with pytest.raises(InputError, match="points_per_lambda_s"):
        SurfaceSpec.from_sweep(points_per_lambda_s=1)


@pytest.mark.parametrize("gamma", [1.0, 4.0])
def test_same_seed_same_surface_at_every_resolution(gamma):
    """Refining the grid samples the same band-limited surface: coarse == fine[::2, ::2]
    (from 3 points per lambda_s; at exactly 2 the cutoff modes lie on the coarse grid's
    Nyquist row and column, where a real grid keeps only their cosine part)."""
    coarse = SurfaceSpec.from_sweep(gamma=gamma, points_per_lambda_s=3, seed=7)
    fine = SurfaceSpec(**{**coarse.as_attrs(), "nx": 2 * coarse.nx, "ny": 2 * coarse.ny})
    a, b = generate(coarse).heights, generate(fine).heights
    # Same modes, same phases, same normalisation: equal up to FFT round-off.
    np.testing.assert_allclose(b[::2, ::2], a, rtol=0, atol=1e-12 * np.abs(a).max())


def test_plateau_rolloff_is_flat_below_q_r_and_self_affine_above():
    """rolloff="plateau": C(q) = C(q_r) for q < q_r and C(q_r) (q/q_r)^(-2(1+H)) up to q_s.
    Checked on the generated heights' power against this formula written out here (the
    amplitudes are deterministic, so the ratio of two modes' powers is that of C)."""
    hurst = 0.8
    s = spec(nx=256, ny=256, lambda_r=1 / 4, lambda_s=1 / 64, hurst=hurst, rolloff="plateau")
    power = np.abs(np.fft.fft2(generate(s).heights)) ** 2
    q = 2 * np.pi * np.fft.fftfreq(s.nx, d=s.dx)
    qq = np.hypot(q[:, None], q[None, :])
    qr, qs = 2 * np.pi / s.lambda_r, 2 * np.pi / s.lambda_s
    ref = power[1, 0]  # q = 2 pi / L < q_r: on the plateau
    below = (qq > 0) & (qq < qr)
    np.testing.assert_allclose(power[below], ref, rtol=1e-9)
    above = (qq > qr) & (qq < qs)
    np.testing.assert_allclose(power[above], ref * (qq[above] / qr) ** (-2 * (1 + hurst)),
                               rtol=1e-9)


def test_spec_power_scales_with_the_rms_slope_squared():
    """At rms slope 1 the power's normalisation by gbar and by gbar^2 are one number: 0.3
    tells them apart. Parseval: sum q^2 power = gbar^2, and the full-contact energy from the
    spec's power is that of a generated surface; both exact up to round-off (1e-12)."""
    from dataclasses import replace

    from roughflow.contact.elastic import full_contact_energy, power_contact_energy
    from roughflow.surface import spec_power

    s = replace(SurfaceSpec.from_sweep(points_per_lambda_s=2, seed=1), rms_slope=0.3)
    q, power = spec_power(s)
    assert float((q * q * power).sum()) == pytest.approx(0.09, rel=1e-12)
    h = generate(s)
    assert power_contact_energy(q, power) == pytest.approx(
        full_contact_energy(h.heights, h.lx, h.ly), rel=1e-12)


def test_nonperiodic_rms_gradient_of_a_plane():
    """Forward differences are exact on a plane h = a x + b y: |grad h| = sqrt(a^2 + b^2)
    at every point (0.5 here), on a rectangular cell, up to round-off."""
    nx, ny, lx, ly, a, b = 32, 48, 2.0, 3.0, 0.3, -0.4
    x = (np.arange(nx) * lx / nx)[:, None]
    y = (np.arange(ny) * ly / ny)[None, :]
    assert rms_gradient(a * x + b * y, lx, ly, periodic=False) == pytest.approx(0.5, rel=1e-12)
