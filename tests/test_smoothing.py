"""The fast scheme's Gaussians on the band and on a coarse grid (cp_stylize.smoothing)."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere, Torus
from cp_stylize.smoothing import GaussianSmoother, GridGaussian, taper


@pytest.fixture(scope="module")
def band():
    return Band.build(Sphere(), 0.05, stencil="anisotropic")


def _smoothers(band, t, dtype=np.float64):
    return {
        "band passes": GaussianSmoother(band, t, weights=taper(band.dist, band.width), dtype=dtype),
        "grid": GridGaussian(band, t, weights=taper(band.dist, 3 * band.h), dtype=dtype),
    }


def test_smoothing_keeps_constants_and_the_range(band):
    rng = np.random.default_rng(0)
    values = rng.uniform(0.2, 0.7, band.size)
    for name, smooth in _smoothers(band, 2e-3).items():
        assert smooth.covered[band.inner].all(), name
        np.testing.assert_allclose(smooth(np.full((1, band.size), 0.4))[0][smooth.covered], 0.4, atol=1e-12)
        out = smooth(values[None])[0][smooth.covered]
        assert out.min() >= 0.2 - 1e-12 and out.max() <= 0.7 + 1e-12, name
        assert out.std() < 0.5 * values.std(), name  # it really smooths


@pytest.mark.parametrize("h", [0.05, 0.025])
def test_smoothing_follows_the_surface_heat_flow(h):
    """x y and z on the unit sphere decay as exp(-6 t) and exp(-2 t) under the heat flow."""
    band = Band.build(Sphere(), h, stencil="anisotropic")
    x, y, z = band.cp.T
    u = x * y + 0.5 * z
    t = 2e-3
    exact = x * y * np.exp(-6 * t) + 0.5 * z * np.exp(-2 * t)
    near = np.abs(band.dist) < 0.5 * h
    change = np.abs(exact - u)[near].max()
    smoothers = _smoothers(band, t)
    assert smoothers["grid"].factor == (1 if h == 0.05 else 2)  # deviations 1.3 h and 2.5 h
    for name, smooth in smoothers.items():
        error = np.abs(smooth(u[None])[0] - exact)
        print(f"\n{name} at h = {h}: error / change {error[near].max() / change:.3f} at the surface, "
              f"{error[band.inner].max() / change:.3f} at the points E reads")
        assert error[near].max() < 0.2 * change, name
        assert error[band.inner].max() < 1.5 * change, name


def test_the_grid_gaussian_picks_a_coarser_grid_only_for_wide_kernels(band):
    factors = {std: GridGaussian(band, 0.5 * (std * band.h) ** 2).factor for std in (1.0, 2.1, 4.0, 8.0)}
    assert factors == {1.0: 1, 2.1: 2, 4.0: 3, 8.0: 4}  # deviations in grid spacings


def test_bad_weights_are_refused(band):
    with pytest.raises(ValueError, match="non-negative"):
        GridGaussian(band, 1e-3, weights=-np.ones(band.size))
