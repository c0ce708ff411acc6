"""Surface-intrinsic diffusion: denoising, coherence and scale-space properties."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere, Torus
from cp_stylize.diffusion import DEFAULTS, MODES, SCHEMES, diffuse

PAPER_H = 0.0125


def scaled(h, **times):
    """The paper's times (given at h = 0.0125) for a grid of spacing h: same number of steps."""
    factor = (h / PAPER_H) ** 2
    return {k: v * factor for k, v in times.items()}


@pytest.fixture(params=[pytest.param(s, marks=pytest.mark.slow) if s == "reference" else s for s in SCHEMES],
                scope="module")
def scheme(request):
    """Every test of a filter's properties runs with both schemes (the reference's runs are slow)."""
    return request.param


# -- denoising on the torus (paper, Fig. 4) ------------------------------------------------


@pytest.fixture(scope="module")
def torus_runs(scheme):
    h = 0.05
    torus = Torus(1.0, 0.4)
    band = Band.build(torus, h, stencil="anisotropic")
    s, t = torus.parameters(band.cp)
    clean = (np.sin(2 * np.pi * (4 * s + t)) > 0).astype(np.float32)
    noisy = band.extend(clean + np.random.default_rng(0).normal(0, 0.3, band.size).astype(np.float32))
    T = scaled(h, T=7e-4)["T"]
    runs = {
        "gaussian": diffuse(band, noisy, mode="gaussian", T=T, scheme=scheme),
        "perona_malik": diffuse(band, noisy, mode="perona_malik", T=T, scheme=scheme, **scaled(h, sigma=1.2e-4)),
        "eed": diffuse(band, noisy, mode="eed", T=T, scheme=scheme, **scaled(h, sigma=1.2e-4, rho=3.5e-4)),
    }
    S, U = np.meshgrid((np.arange(400) + 0.5) / 400, (np.arange(160) + 0.5) / 160)
    M = band.interpolation_matrix(torus.point(S.ravel(), U.ravel()))
    phase = 2 * np.pi * (4 * S + U)
    d = np.abs(np.angle(np.exp(1j * phase)))
    images = {k: (M @ v).reshape(S.shape) for k, v in runs.items()}
    return images, (np.sin(phase) > 0), np.minimum(d, np.pi - d)


def _psnr(img, ref):
    return 10 * np.log10(1.0 / np.mean((img - ref) ** 2))


def test_eed_denoises_better_than_gaussian(torus_runs):
    images, bright, _ = torus_runs
    table = {k: _psnr(v, bright.astype(float)) for k, v in images.items()}
    print("\nPSNR (dB):", {k: round(v, 2) for k, v in table.items()})
    assert table["eed"] > table["gaussian"] + 2.0
    assert table["perona_malik"] > table["gaussian"]


def _edge_contrast(img, bright, dist):
    near = dist < 0.4  # a strip along the stripe edges
    return img[near & bright].mean() - img[near & ~bright].mean()


def _noise_along_edges(img, bright, dist):
    near = dist < 0.4
    sides = [img[near & side] - img[near & side].mean() for side in (bright, ~bright)]
    return np.concatenate(sides).std()


def test_eed_keeps_edges_sharp_where_gaussian_blurs(torus_runs):
    images, bright, dist = torus_runs
    eed, gauss = (_edge_contrast(images[k], bright, dist) for k in ("eed", "gaussian"))
    assert eed > 0.5 and gauss < 0.3 and eed > 2 * gauss


def test_perona_malik_keeps_edges_but_leaves_noise_along_them(torus_runs):
    images, bright, dist = torus_runs
    assert _edge_contrast(images["perona_malik"], bright, dist) > 2 * _edge_contrast(images["gaussian"], bright, dist)
    pm, eed = (_noise_along_edges(images[k], bright, dist) for k in ("perona_malik", "eed"))
    assert pm > 1.2 * eed


# -- coherence enhancement on the sphere ---------------------------------------------------


def coherence_measure(band, u, sigma, rho):
    """Mean normalised coherence (mu1 - mu2) / (mu1 + mu2) of the structure tensor over the band."""
    from cp_stylize.stencils import gradient_matrices
    from cp_stylize.structure import eigen_2x2, reduce_to_tangent, structure_tensor
    from cp_stylize.tangent import tangent_basis

    J = structure_tensor(band, np.array(u[None, :], dtype=np.float32), sigma, rho, gradient_matrices(band),
                         dt=0.15 * band.h**2)
    mu1, mu2, _, _ = eigen_2x2(*reduce_to_tangent(J.astype(np.float64), *tangent_basis(band).transpose(2, 1, 0)))
    return float(np.mean((mu1 - mu2) / np.maximum(mu1 + mu2, 1e-12)))


def test_ced_raises_coherence_of_a_ridge_pattern(scheme):
    h = 0.05
    band = Band.build(Sphere(), h, stencil="anisotropic")
    x, y, z = band.cp.T
    ridges = 0.5 + 0.5 * np.sin(14 * (z + 0.3 * x * x - 0.2 * y))
    rng = np.random.default_rng(1)
    u0 = band.extend((ridges + rng.normal(0, 0.25, band.size)).astype(np.float32))
    params = scaled(h, sigma=1e-4, rho=4e-4)
    u = diffuse(band, u0, mode="ced", T=scaled(h, T=6e-4)["T"], alpha=1e-3, b_rel=1e-3, scheme=scheme, **params)
    before, after = (coherence_measure(band, v, **scaled(h, sigma=2e-5, rho=4e-4)) for v in (u0, u))
    print(f"\ncoherence before {before:.3f}, after {after:.3f}")
    assert after > before + 0.1


# -- scale-space properties (Wu, Deng, Chen and Tai, section 5) ------------------------------

H = 0.1
FEW_STEPS = 10 * 0.15 * H**2


@pytest.fixture(scope="module")
def small_band():
    return Band.build(Sphere(), H, stencil="anisotropic")


def _image_at(p):
    x, y, z = p.T
    u = 0.5 + 0.3 * np.tanh(8 * (x * y + 0.3 * z)) + 0.1 * np.sin(5 * x)
    return u + 0.05 * np.sin(40 * x + 31 * y) * np.cos(37 * z)


def _image(band, dtype=np.float32):
    return band.extend(_image_at(band.cp).astype(dtype))


def _parallels(band):
    """A direction field on a sphere band: the parallels about z, fading to nothing at the poles."""
    n = band.cp / np.linalg.norm(band.cp, axis=1)[:, None]
    return np.cross([0.0, 0.0, 1.0], n)


def _run(band, u, mode, scheme="fast", **kw):
    kw.setdefault("T", FEW_STEPS)
    if mode == "flow":
        kw.setdefault("field", _parallels(band))
    return diffuse(band, u, mode=mode, scheme=scheme, **scaled(H, **{k: v for k, v in DEFAULTS[mode].items()
                                                      if k in ("sigma", "rho")}), **kw)


@pytest.mark.parametrize("mode", MODES)
def test_constant_image_stays_constant(small_band, mode, scheme):
    u = _run(small_band, np.full(small_band.size, 0.3, np.float32), mode, scheme)
    np.testing.assert_allclose(u, 0.3, atol=1e-6)


@pytest.mark.parametrize("mode", MODES)
def test_shift_invariance(small_band, mode, scheme):
    u = _image(small_band, np.float64)
    a = _run(small_band, u + 3.0, mode, scheme, clamp=False)
    b = _run(small_band, u, mode, scheme, clamp=False) + 3.0
    np.testing.assert_allclose(a, b, atol=1e-9)


@pytest.mark.parametrize("mode", MODES)
def test_reverse_contrast(small_band, mode, scheme):
    u = _image(small_band, np.float64)
    np.testing.assert_allclose(_run(small_band, -u, mode, scheme), -_run(small_band, u, mode, scheme), atol=1e-12)


def _surface_mean(band, u, n=20000):
    p = np.random.default_rng(3).normal(size=(n, 3))
    p /= np.linalg.norm(p, axis=1)[:, None]
    return float(np.mean(band.interpolate(u, p)))


@pytest.mark.parametrize("mode", ["gaussian", "perona_malik", "eed", "ced"])
def test_mean_grey_level_drifts_by_less_than_one_percent(small_band, mode, scheme):
    u0 = _image(small_band)
    u = _run(small_band, u0, mode, scheme, T=4 * FEW_STEPS)
    m0, m = _surface_mean(small_band, u0), _surface_mean(small_band, u)
    assert abs(m - m0) < 0.01 * abs(m0)
    assert np.abs(u - u0).max() > 0.05  # the image really changed


@pytest.mark.parametrize("mode", ["gaussian", "perona_malik"])
def test_gaussian_and_perona_malik_stay_within_the_initial_range(small_band, mode, scheme):
    u0 = _image(small_band)
    u = _run(small_band, u0, mode, scheme, T=4 * FEW_STEPS, clamp=False)
    span = u0.max() - u0.min()
    assert u.min() >= u0.min() - 1e-3 * span and u.max() <= u0.max() + 1e-3 * span


@pytest.mark.parametrize("mode", ["perona_malik", "eed", "ced", "beltrami", "flow"])
def test_scale_invariance(mode, scheme):
    # radius 2 at twice the spacing, times four times as long, relative parameters unchanged
    small = Band.build(Sphere(1.0), H, stencil="anisotropic")
    big = Band.build(Sphere(2.0), 2 * H, stencil="anisotropic")
    # the grids are similar; rounding may put a point on the band's rim in one and not the other
    same = big.lookup(small.ijk)
    assert np.mean(same >= 0) > 0.999 and np.all(small.inner[same < 0] == 0)
    u0 = _image(small, np.float64)
    params = scaled(H, **{k: v for k, v in DEFAULTS[mode].items() if k in ("sigma", "rho")})
    fields = ({"field": _parallels(small)}, {"field": _parallels(big)}) if mode == "flow" else ({}, {})
    if mode == "flow":
        params["contrast"] = 3.0                             # relative to T: the same at both sizes
    a = diffuse(small, u0, mode=mode, T=FEW_STEPS, scheme=scheme, **params, **fields[0])
    b = diffuse(big, big.extend(_image_at(big.cp / 2)), mode=mode, T=4 * FEW_STEPS, scheme=scheme,
                **{k: v if k == "contrast" else 4 * v for k, v in params.items()}, **fields[1])
    assert np.abs(a - u0).max() > 0.03  # the image really changed
    np.testing.assert_allclose(a[same >= 0], b[same[same >= 0]], atol=1e-9)


@pytest.mark.parametrize("mode", MODES)
def test_colour_channels_share_one_tensor(small_band, mode, scheme):
    grey = _image(small_band, np.float64)
    rgb = _run(small_band, np.repeat(grey[:, None], 3, axis=1), mode, scheme)
    single = _run(small_band, grey, mode, scheme)
    assert rgb.shape == (small_band.size, 3)
    for k in range(3):
        np.testing.assert_allclose(rgb[:, k], single, atol=1e-12)


# -- robustness and interface ----------------------------------------------------------------


@pytest.mark.parametrize("mode", MODES)
def test_a_single_spike_spreads_within_the_range(small_band, mode, scheme):
    # a lone bright point on the surface: the worst case for the gradient-driven diffusivities
    i = int(np.argmax(small_band.inner))
    u0 = small_band.extend(np.exp(-np.sum((small_band.cp - small_band.cp[i]) ** 2, axis=1) / (0.5 * H) ** 2)
                           .astype(np.float32))
    u = _run(small_band, u0, mode, scheme, clamp=False)   # raises FloatingPointError on NaN or inf
    near = np.linalg.norm(small_band.cp - small_band.cp[i], axis=1) < 2 * H
    assert u.max() < 0.9 * u0.max()                          # the peak falls
    assert u[near & (u0 < 0.1)].max() > 0.01                 # and its neighbours rise
    span = u0.max() - u0.min()
    assert u.min() > u0.min() - 0.05 * span and u.max() < u0.max()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_the_values_keep_their_precision(small_band, dtype, scheme):
    u0 = _image(small_band, dtype)
    for values in (u0, np.repeat(u0[:, None], 3, axis=1)):
        u = _run(small_band, values, "eed", scheme)
        assert u.dtype == dtype and u.shape == values.shape


def test_a_step_above_the_stable_one_is_taken_in_equal_stable_parts(small_band):
    from cp_stylize.stencils import DivergenceOperator

    L = small_band.laplacian_matrix(np.float64)
    stable = DivergenceOperator.stable_step(L)
    tau = 2.5 * stable                                       # three parts
    u0 = small_band.extend(np.random.default_rng(0).uniform(0, 1, small_band.size))
    # a single forward Euler step of this size overshoots the initial range: it is unstable
    naive = small_band.E @ (u0 + tau * (L @ u0))
    assert naive.max() > u0.max() + 0.01 or naive.min() < u0.min() - 0.01
    one = diffuse(small_band, u0, mode="gaussian", T=tau, tau=tau, scheme="reference", clamp=False)
    three = diffuse(small_band, u0, mode="gaussian", T=tau, tau=tau / 3, scheme="reference", clamp=False)
    np.testing.assert_allclose(one, three, rtol=0, atol=1e-13)
    assert u0.min() - 1e-9 <= one.min() and one.max() <= u0.max() + 1e-9


@pytest.fixture
def operator_builds(monkeypatch):
    from cp_stylize.diffusion_tensor import StepOperators

    builds = []
    operator = StepOperators.operator

    def counted(self, rows, progress=None):
        builds.append(rows.copy())
        return operator(self, rows, progress)

    monkeypatch.setattr(StepOperators, "operator", counted)
    return builds


def test_lag_decides_when_the_fast_scheme_rebuilds_the_operator(small_band, operator_builds):
    u0 = _image(small_band, np.float64)
    n_steps = 10                                             # FEW_STEPS at the paper's step
    every = _run(small_band, u0, "eed", lag=0.0)
    assert len(operator_builds) == n_steps
    operator_builds.clear()
    once = _run(small_band, u0, "eed", lag=1e9)
    assert len(operator_builds) == 1
    operator_builds.clear()
    lagged = _run(small_band, u0, "eed", lag=0.005)
    assert 1 < len(operator_builds) < n_steps
    # a rebuild happens when the values moved by more than lag (RMS over the inner points, relative to the range)
    inner, span = small_band.inner, u0.max() - u0.min()
    moved = [np.sqrt(np.mean((b[0, inner] - a[0, inner]) ** 2)) / span
             for a, b in zip(operator_builds, operator_builds[1:])]
    assert min(moved) > 0.005
    # the lagged run stays closer to rebuilding every step than a frozen operator does
    assert np.abs(lagged - every).max() < np.abs(once - every).max()
    assert np.abs(once - every).max() > 1e-3


def test_the_reference_scheme_rebuilds_every_step_whatever_the_lag(small_band, operator_builds):
    u0 = _image(small_band, np.float64)
    a = _run(small_band, u0, "eed", "reference", lag=1e9)
    assert len(operator_builds) == 10
    np.testing.assert_array_equal(a, _run(small_band, u0, "eed", "reference", lag=0.0))


def test_progress_rises_and_a_raising_callback_stops_the_run(small_band, scheme):
    u0 = _image(small_band)
    keep = u0.copy()
    seen = []
    _run(small_band, u0, "eed", scheme, progress=seen.append)
    assert seen[-1] == pytest.approx(1.0) and np.all(np.diff(seen) >= 0) and len(seen) >= 10

    def cancel(fraction):
        if fraction > 0.3:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        _run(small_band, u0, "ced", scheme, progress=cancel)
    np.testing.assert_array_equal(u0, keep)


@pytest.mark.parametrize("kwargs, message", [
    (dict(mode="blur"), "mode must be one of"),
    (dict(mode="eed", scheme="quick"), "scheme must be one of"),
    (dict(mode="eed", sigma=-1.0), "sigma must be a non-negative number"),
    (dict(mode="ced", alpha=2.0), r"alpha must lie in \[0, 1\]"),
    (dict(mode="eed", T=-1.0), "time must be a non-negative number"),
])
def test_bad_parameters_are_reported(small_band, kwargs, message):
    kwargs.setdefault("T", 0.01)
    with pytest.raises(ValueError, match=message):
        diffuse(small_band, np.zeros(small_band.size), **kwargs)


def test_anisotropic_modes_need_the_wide_band():
    band = Band.build(Sphere(), 0.2)
    with pytest.raises(ValueError, match="stencil='anisotropic'"):
        diffuse(band, np.zeros(band.size), mode="eed", T=0.01)


def test_nan_input_is_refused(small_band):
    u = np.zeros(small_band.size)
    u[3] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        diffuse(small_band, u, mode="gaussian", T=0.01)


def test_a_tiny_stop_time_takes_one_step_with_full_size_smoothing_steps(small_band):
    calls = []
    _run(small_band, _image(small_band), "ced", "reference", T=1e-9, progress=calls.append)
    # one outer step; the structure tensor's heat solves keep their own 0.15 h^2 steps
    assert calls[-1] == 1.0 and len(calls) < 100


def test_jacobian_tangent_basis_matches_the_analytic_one(small_band, scheme):
    from cp_stylize.tangent import jacobian_normals

    n = jacobian_normals(small_band)
    exact = small_band.cp / np.linalg.norm(small_band.cp, axis=1)[:, None]
    assert np.degrees(np.arccos(np.clip(np.abs(np.sum(n * exact, axis=1)), 0, 1))).max() < 1.0
    u0 = _image(small_band)
    a = _run(small_band, u0, "eed", scheme)
    b = _run(small_band, u0, "eed", scheme, normals="jacobian")
    assert np.abs(a - b).max() < 0.02 and np.abs(a - u0).max() > 0.05


# -- the fast scheme against the reference -------------------------------------------------


def _surface_psnr(band, a, b, n=20000):
    """PSNR (values in [0, 1]) between two band functions at random surface points."""
    p = band.surface.closest_point(np.random.default_rng(5).uniform(-1.5, 1.5, (n, 3)))[0]
    return 10 * np.log10(1.0 / np.mean((band.interpolate(a, p) - band.interpolate(b, p)) ** 2))


@pytest.mark.slow
@pytest.mark.parametrize("mode, surface", [("eed", Torus(1.0, 0.4)), ("ced", Sphere())])
def test_fast_scheme_matches_the_reference(mode, surface):
    h = 0.08
    band = Band.build(surface, h, stencil="anisotropic")
    rng = np.random.default_rng(7)
    x, y, z = band.cp.T
    if mode == "eed":
        clean = (np.sin(9 * x + 4 * z) > 0).astype(np.float32)
        u0 = band.extend(np.clip(clean + rng.normal(0, 0.3, band.size), 0, 1).astype(np.float32))
        kw = dict(T=scaled(h, T=7e-4)["T"], **scaled(h, sigma=1.2e-4, rho=3.5e-4))
    else:  # Starry Night: a smooth image with two thirds of the points replaced by random colours
        u0 = np.stack([0.5 + 0.4 * np.sin(3 * x + y), 0.5 + 0.4 * np.cos(2 * z), 0.5 + 0.3 * x * y], axis=1)
        noisy = rng.random(band.size) < 0.67
        u0[noisy] = rng.random((int(noisy.sum()), 3))
        u0 = u0.astype(np.float32)
        kw = dict(T=scaled(h, T=1.1e-4 * (0.0125 / 0.008) ** 2)["T"], b_rel=1e-6,
                  **scaled(h, sigma=1e-4 * (0.0125 / 0.008) ** 2, rho=5e-4 * (0.0125 / 0.008) ** 2))
    fast = diffuse(band, u0, mode=mode, scheme="fast", **kw)
    reference = diffuse(band, u0, mode=mode, scheme="reference", **kw)
    psnr = _surface_psnr(band, fast, reference)
    changed = _surface_psnr(band, u0, reference)
    print(f"\n{mode}: fast vs reference {psnr:.1f} dB; input vs reference {changed:.1f} dB")
    assert psnr >= 30.0 and changed < 25.0


# -- the reference scheme stays as it was ------------------------------------------------------


def _reference_cases():
    """Reference-scheme runs of every mode, grey (float32) and colour (float64), on a sphere and a torus."""
    for name, surface, h in (("sphere", Sphere(1.0), 0.2), ("torus", Torus(1.0, 0.4), 0.12)):
        band = Band.build(surface, h, stencil="anisotropic")
        p = band.cp
        rng = np.random.default_rng(7)
        grey = (np.sin(5 * p[:, 0]) * np.cos(3 * p[:, 1]) + 0.3 * rng.standard_normal(band.size)).astype(np.float32)
        colour = np.stack([np.sin(4 * p[:, 0] + p[:, 2]), np.cos(5 * p[:, 1]), p[:, 2] ** 2], axis=1)
        colour = colour + 0.2 * rng.standard_normal(colour.shape)
        for mode in ("gaussian", "perona_malik", "eed", "ced", "beltrami"):
            kw = dict(mode=mode, T=3 * 0.15 * h * h, scheme="reference")
            if mode != "gaussian":
                kw.update(sigma=0.5 * h * h)
            if mode in ("eed", "ced"):
                kw.update(rho=2 * h * h)
            for kind, u in (("grey", grey), ("colour", colour)):
                yield f"{name}_{mode}_{kind}", diffuse(band, u, **kw)


@pytest.mark.slow
def test_the_reference_scheme_gives_the_recorded_output():
    """The arrays are bit-identical to those recorded (tests/data/reference_scheme.json) where NumPy, SciPy
    and the CPU's vector features are those of the record; elsewhere their sums agree to rounding."""
    import hashlib
    import json
    import os

    import scipy

    try:                                 # where NumPy keeps the CPU's vector features (2.x, then 1.x: no warning)
        from numpy._core._multiarray_umath import __cpu_features__
    except ImportError:
        from numpy.core._multiarray_umath import __cpu_features__
    with open(os.path.join(os.path.dirname(__file__), "data", "reference_scheme.json"), encoding="utf-8") as fh:
        record = json.load(fh)
    here = {"numpy": np.__version__, "scipy": scipy.__version__,
            "cpu": sorted(k for k, v in __cpu_features__.items() if v)}
    exact = here == record["recorded_with"]
    found = dict(_reference_cases())
    assert sorted(found) == sorted(record["cases"])
    for name, out in found.items():
        expected = record["cases"][name]
        assert [str(out.dtype), list(out.shape)] == [expected["dtype"], expected["shape"]], name
        if exact:
            assert hashlib.sha256(np.ascontiguousarray(out).tobytes()).hexdigest() == expected["sha256"], name
        else:
            rtol = 1e-4 if out.dtype == np.float32 else 1e-9
            assert float(out.sum(dtype=np.float64)) == pytest.approx(expected["sum"], rel=rtol, abs=rtol * out.size)
            assert float(np.sqrt((out.astype(np.float64) ** 2).sum())) == pytest.approx(expected["norm"], rel=rtol)
    print(f"\nexact comparison: {exact}")


# -- flow textures along a direction field (Diewald and Rumpf) -------------------------------


@pytest.fixture(scope="module")
def torus_noise():
    from cp_stylize.heat_flow import heat

    h = 0.05
    torus = Torus(1.0, 0.4)
    band = Band.build(torus, h, stencil="anisotropic")
    x, y, _ = band.cp.T
    parallels = np.column_stack([-y, x, np.zeros_like(x)]) / np.hypot(x, y)[:, None]
    meridians = np.cross(torus.normal(band.cp), parallels)
    # Diewald and Rumpf's initial data: white noise, briefly smoothed
    noise = heat(band, band.extend(np.random.default_rng(0).uniform(0, 1, band.size)), 0.5 * h * h)
    return band, noise, parallels, meridians


def _stroke_alignment(band, u, field, where=True):
    """Mean |cos| between the strokes of u (the minor eigenvector of its structure tensor) and a field,
    over the inner band points ``where`` it is True."""
    from cp_stylize.stencils import gradient_matrices
    from cp_stylize.structure import eigen_2x2, reduce_to_tangent, structure_tensor
    from cp_stylize.tangent import tangent_basis

    h = band.h
    J = structure_tensor(band, u[None].astype(np.float64), 0.25 * h * h, 4 * h * h,
                         gradient_matrices(band, np.float64), dt=0.15 * h * h)
    Q = tangent_basis(band).transpose(2, 1, 0)
    _, _, c1, s1 = eigen_2x2(*reduce_to_tangent(J, *Q))
    across = (Q[0] * c1 + Q[1] * s1).T
    along = np.cross(band.surface.normal(band.cp), across)
    return float(np.mean(np.abs(np.sum(along * field, axis=1))[band.inner & where]))


@pytest.mark.parametrize("which", ["parallels", "meridians"])
def test_a_flow_texture_draws_its_strokes_along_the_field(torus_noise, which):
    band, noise, parallels, meridians = torus_noise
    field, other = (parallels, meridians) if which == "parallels" else (meridians, parallels)
    u = diffuse(band, noise, mode="flow", T=20 * band.h**2, field=field, contrast=5.0)
    along, across = _stroke_alignment(band, u, field), _stroke_alignment(band, u, other)
    print(f"\nstrokes along the {which}: mean |cos| {along:.3f}; against the other field {across:.3f}")
    assert along >= 0.95 and across <= 0.3
    # the noise itself has no direction
    assert 0.5 < _stroke_alignment(band, noise, field) < 0.75


def test_contrast_pushes_the_values_apart_within_their_range(torus_noise):
    band, noise, parallels, _ = torus_noise
    T = 20 * band.h**2
    plain = diffuse(band, noise, mode="flow", T=T, field=parallels)
    sharp = diffuse(band, noise, mode="flow", T=T, field=parallels, contrast=5.0)
    assert sharp.std() > 4 * plain.std()
    assert noise.min() <= sharp.min() and sharp.max() <= noise.max()
    # a contrast far above the diffusion's stable step is taken in smaller steps and stays bounded: unclamped,
    # only the interpolation's overshoot at the sharp fronts leaves the range, and the contrast term pulls it back
    from cp_stylize.heat_flow import heat

    coarse = Band.build(band.surface, 2 * band.h, stencil="anisotropic")
    noise = heat(coarse, coarse.extend(np.random.default_rng(1).uniform(0, 1, coarse.size)), 0.5 * coarse.h**2)
    x, y, _ = coarse.cp.T
    parallels = np.column_stack([-y, x, np.zeros_like(x)]) / np.hypot(x, y)[:, None]
    T = 20 * coarse.h**2
    strong = diffuse(coarse, noise, mode="flow", T=T, field=parallels, contrast=100.0, clamp=False)
    finer = diffuse(coarse, noise, mode="flow", T=T, field=parallels, contrast=100.0, clamp=False,
                    tau=0.075 * coarse.h**2)
    span = noise.max() - noise.min()
    assert noise.min() - 0.2 * span <= strong.min() and strong.max() <= noise.max() + 0.2 * span
    assert np.mean(np.abs(strong - finer)) < 0.05 * span      # the time steps resolve the contrast term


def test_a_flow_on_a_sphere_falls_back_where_its_curvature_directions_are_undefined():
    from cp_stylize.curvature import principal_curvatures

    band = Band.build(Sphere(), 0.1, stencil="anisotropic")
    curvature = principal_curvatures(band)
    assert curvature.confidence.max() < 0.01
    u0 = _image(band, np.float64)
    u = diffuse(band, u0, mode="flow", T=FEW_STEPS, field=curvature.e2 * curvature.confidence[:, None])
    isotropic = diffuse(band, u0, mode="flow", T=FEW_STEPS, field=np.zeros((band.size, 3)))
    assert np.abs(u - u0).max() > 0.01                       # it smoothed
    assert np.abs(u - isotropic).max() < 0.05 * np.abs(isotropic - u0).max()   # as the isotropic fallback does


@pytest.mark.parametrize("kwargs, message", [
    (dict(mode="flow"), "mode 'flow' needs field="),
    (dict(mode="eed", field=np.zeros((3, 3))), "field= is for the modes 'ced' and 'flow' only, not 'eed'"),
    (dict(mode="flow", field=np.zeros((3, 3))), "field must be a finite array of shape"),
])
def test_the_field_is_checked(small_band, kwargs, message):
    with pytest.raises(ValueError, match=message):
        diffuse(small_band, np.zeros(small_band.size), T=0.01, **kwargs)


def test_ink_lays_the_flow_texture_over_the_values_as_dark_strokes_along_the_field(torus_noise):
    band, _, parallels, meridians = torus_noise
    x, y, z = band.cp.T
    u0 = np.stack([0.6 + 0.3 * np.sin(3 * x), 0.5 + 0.2 * z, np.full_like(x, 0.8)], axis=1)
    u = diffuse(band, u0, mode="flow", T=20 * band.h**2, field=parallels, contrast=5.0, ink=0.7)
    shade = u / u0                                              # one shade for all channels: the tones stay
    np.testing.assert_allclose(shade, shade[:, :1] * np.ones((1, 3)), rtol=1e-12)
    assert shade.min() == pytest.approx(0.3) and shade.max() == pytest.approx(1.0)
    assert 0.2 < np.mean(shade[:, 0] < 0.9) < 0.6               # strokes, not a wash
    along, across = _stroke_alignment(band, shade[:, 0], parallels), _stroke_alignment(band, shade[:, 0], meridians)
    print(f"\nink strokes along the parallels: mean |cos| {along:.3f}; against the meridians {across:.3f}")
    assert along >= 0.9 and across <= 0.35


# -- CED's strokes along a given direction ---------------------------------------------------------


@pytest.mark.parametrize("which", ["parallels", "meridians"])
def test_ced_draws_its_strokes_along_a_given_field_where_it_is_confident(torus_noise, which):
    band, noise, parallels, meridians = torus_noise
    field, other = (parallels, meridians) if which == "parallels" else (meridians, parallels)
    T = 10 * band.h**2
    kw = dict(mode="ced", T=T, b_rel=1e-6, **scaled(band.h, sigma=1e-4, rho=5e-4))
    u = diffuse(band, noise, field=field, **kw)
    along, across = _stroke_alignment(band, u, field), _stroke_alignment(band, u, other)
    print(f"\nCED strokes along the {which}: mean |cos| {along:.3f}; against the other field {across:.3f}")
    assert along >= 0.9 and across <= 0.4
    # a line field: its sign does not matter, to the bit
    np.testing.assert_array_equal(diffuse(band, noise, field=-field, **kw), u)
    # no confidence, no change: the texture's own orientation
    np.testing.assert_array_equal(diffuse(band, noise, field=0 * field, **kw), diffuse(band, noise, **kw))


def test_ced_blends_towards_the_texture_where_the_field_is_unsure(torus_noise):
    band, noise, parallels, meridians = torus_noise
    # the texture: faint stripes across the parallels in the noise (strokes along the meridians);
    # the field: the parallels, trusted on the outer half of the torus only
    x, y, _ = band.cp.T
    stripes = band.extend(0.2 * (np.sin(12 * np.arctan2(y, x)) > 0) + noise)
    radius = np.hypot(x, y)
    field = parallels * (radius > 1.0)[:, None]
    u = diffuse(band, stripes, mode="ced", T=10 * band.h**2, b_rel=1e-6, field=field,
                **scaled(band.h, sigma=1e-4, rho=5e-4))
    outer, inner = radius > 1.15, radius < 0.85          # away from where the confidence jumps
    assert _stroke_alignment(band, stripes, parallels, outer) < 0.3      # the texture's strokes cross the field
    assert _stroke_alignment(band, u, parallels, outer) >= 0.85          # the field wins where it is trusted
    assert _stroke_alignment(band, u, meridians, inner) >= 0.95          # the texture's own elsewhere
