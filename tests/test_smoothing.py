"""The fast scheme's building blocks: grid Gaussians, split sparse products, neighbour tables."""

import numpy as np
import pytest
import scipy.sparse as sp

from cp_stylize import Band, Sphere, Torus
from cp_stylize.smoothing import GaussianSmoother, GridGaussian, taper
from cp_stylize.sparse import SplitMatrix
from cp_stylize.stencils import DivergenceOperator


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


def test_split_products_equal_the_plain_ones():
    band = Band.build(Torus(1.0, 0.4), 0.03)
    v = np.random.default_rng(1).random(band.size).astype(np.float32)
    split = SplitMatrix(band.extension_matrix(), parts=3)
    assert len(split.blocks) == 3
    np.testing.assert_array_equal(split @ v, band.extension_matrix() @ v)
    small = SplitMatrix(sp.identity(10, format="csr"), parts=4)  # too small to split
    assert len(small.blocks) == 1 and np.array_equal(small @ np.arange(10.0), np.arange(10.0))


def test_neighbour_tables_agree_with_lookups(band):
    offsets = np.array([[0, 0, 0], [1, 0, -1], [0, 0, 5], [-7, 0, 0], [2, -3, 1]])
    np.testing.assert_array_equal(band.neighbors(offsets), band.lookup(band.ijk[:, None, :] + offsets))


def test_divergence_weights_are_eq_51_in_either_precision(band):
    """A(G) u = div(G grad u) exactly for a constant G and a quadratic u; G = I gives the Laplacian."""
    div = DivergenceOperator(band, np.float64)
    inner = div.rows
    x, y, z = band.points.T
    u = x * x - 2 * y * y + 3 * x * z + y * z + 0.5 * x
    G = np.array([1.0, 0.7, 0.4, 0.2, -0.1, 0.15])  # xx, yy, zz, xy, xz, yz
    # div(G grad u) = sum_ab G_ab d_a d_b u, with d_a d_b u the constant Hessian of u
    exact = G[0] * 2 + G[1] * -4 + G[2] * 0 + 2 * (G[3] * 0 + G[4] * 3 + G[5] * 1)
    field = np.repeat(G[:, None], band.size, axis=1)
    np.testing.assert_allclose((div.matrix(field) @ u)[inner], exact, atol=1e-8)
    # SciPy sorts a matrix's indices in place for some operations: later matrices stay right
    assert DivergenceOperator.stable_step(div.matrix(field)) > 0
    np.testing.assert_allclose((div.matrix(field) @ u)[inner], exact, atol=1e-8)
    identity = np.repeat(np.array([1.0, 1, 1, 0, 0, 0])[:, None], band.size, axis=1)
    v = np.random.default_rng(3).random(band.size)
    np.testing.assert_allclose((div.matrix(identity) @ v)[inner], (band.laplacian_matrix(np.float64) @ v)[inner],
                               rtol=1e-12, atol=1e-9)
    # filled in place in float32 from a float32 field: the same weights to float32 precision
    single = DivergenceOperator(band, np.float32)
    varying = np.random.default_rng(2).random((6, band.size))
    A = single.template()
    single.fill(varying.astype(np.float32), A.data)
    np.testing.assert_allclose(A.data, div.matrix(varying).data, rtol=1e-5)
