"""Finite differences in the band: central gradients and the 19-point div(G grad) of eq. (51)."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.stencils import DivergenceOperator, gershgorin_step, gradient_matrices


@pytest.fixture(scope="module")
def band():
    return Band.build(Sphere(), 0.05, stencil="anisotropic")


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


def test_central_gradients_are_exact_on_linear_functions(band):
    g = np.array([0.4, -1.1, 0.25])
    u = band.points @ g + 3.0
    for axis, D in enumerate(gradient_matrices(band, np.float64)):
        np.testing.assert_allclose((D @ u)[band.inner], g[axis], atol=1e-10)
    every = gradient_matrices(band, np.float64, rows="all")[0]
    assert every.getnnz(axis=1).astype(bool).sum() > band.inner.sum()   # rows beyond the inner points


def test_the_operator_is_canonical_and_its_stable_step_leaves_it_so(band):
    div = DivergenceOperator(band, np.float32)
    A = div.template()
    div.fill(np.random.default_rng(4).random((6, band.size)).astype(np.float32), A.data)
    before = A.indices.copy(), A.data.copy()
    assert A.has_sorted_indices
    step = DivergenceOperator.stable_step(A)
    assert np.array_equal(A.indices, before[0]) and np.array_equal(A.data, before[1])
    assert step == pytest.approx(gershgorin_step(np.abs(A.data).reshape(-1, 19).sum(axis=1)), rel=1e-6)
    # constants are stationary: every row sums to zero
    np.testing.assert_allclose((A @ np.ones(band.size, np.float32))[div.rows], 0.0, atol=1e-2 * np.abs(A.data).max())
