"""The structure tensor: products, its tangent reduction, invariants and closed-form eigen-decomposition."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.stencils import TENSOR_COMPONENTS, gradient_matrices
from cp_stylize.structure import eigen_2x2, invariants, products, reduce_to_tangent
from cp_stylize.tangent import tangent_basis


def _rows(M):
    """Symmetric tensors (N, 3, 3) as rows (6, N)."""
    return np.stack([M[:, a, b] for a, b in TENSOR_COMPONENTS])


def test_eigen_2x2_matches_numpy_including_equal_eigenvalues():
    rng = np.random.default_rng(0)
    a, b, d = rng.normal(size=(3, 2000))
    a[:100], b[:100], d[:100] = 0.7, 0.0, 0.7            # equal eigenvalues (a multiple of I)
    a[100:200], b[100:200], d[100:200] = 0.0, 0.0, 0.0  # the zero tensor
    mu1, mu2, c1, s1 = eigen_2x2(a, b, d)
    M = np.stack([np.stack([a, b], -1), np.stack([b, d], -1)], -2)
    values, vectors = np.linalg.eigh(M)
    np.testing.assert_allclose(mu1, values[:, 1], atol=1e-12)
    np.testing.assert_allclose(mu2, values[:, 0], atol=1e-12)
    assert np.all(np.isfinite(c1)) and np.all(np.isfinite(s1))
    np.testing.assert_allclose(np.hypot(c1, s1), 1.0, atol=1e-12)
    # (c1, s1) is an eigenvector of mu1 (any unit vector where mu1 == mu2)
    Mv = np.einsum("nij,nj->ni", M, np.column_stack([c1, s1]))
    np.testing.assert_allclose(Mv, mu1[:, None] * np.column_stack([c1, s1]), atol=1e-9)
    assert np.all(c1[:200] == 1.0) and np.all(s1[:200] == 0.0)


def test_the_tangent_reduction_is_q_transpose_j_q():
    rng = np.random.default_rng(1)
    n = 500
    A = rng.normal(size=(n, 3, 3))
    M = A + A.transpose(0, 2, 1)
    Q, _ = np.linalg.qr(rng.normal(size=(n, 3, 2)))
    a, b, d = reduce_to_tangent(_rows(M), *Q.transpose(2, 1, 0))
    expected = np.einsum("nji,njk,nkl->nil", Q, M, Q)
    np.testing.assert_allclose(a, expected[:, 0, 0], atol=1e-12)
    np.testing.assert_allclose(b, expected[:, 0, 1], atol=1e-12)
    np.testing.assert_allclose(d, expected[:, 1, 1], atol=1e-12)


def test_invariants_of_a_tangent_tensor_are_the_trace_and_determinant_of_its_2x2_form():
    rng = np.random.default_rng(2)
    n = 300
    Q, _ = np.linalg.qr(rng.normal(size=(n, 3, 2)))
    B = rng.normal(size=(n, 2, 2))
    small = B @ B.transpose(0, 2, 1)                       # the tangent form J~
    J = np.einsum("nik,nkl,njl->nij", Q, small, Q)         # J = Q J~ Q^T, rank 2
    trace, second = invariants(_rows(J))
    np.testing.assert_allclose(trace, np.trace(small, axis1=1, axis2=2), atol=1e-10)
    np.testing.assert_allclose(second, np.linalg.det(small), atol=1e-10)


def test_products_are_the_outer_product_of_the_central_gradient():
    band = Band.build(Sphere(), 0.1)
    g = np.array([0.3, -0.2, 0.5])
    linear = (band.points @ g)[None, :]                    # its central gradient is g exactly
    J = products(linear, gradient_matrices(band, np.float64))
    inner = band.inner
    expected = np.array([g[a] * g[b] for a, b in TENSOR_COMPONENTS])
    np.testing.assert_allclose(J[:, inner], np.broadcast_to(expected[:, None], (6, inner.sum())), atol=1e-12)
    assert np.all(J[:, ~inner] == 0)   # rows only at the inner points


def test_the_basis_used_on_the_sphere_reduces_a_radial_tensor_to_zero():
    band = Band.build(Sphere(), 0.2)
    n = band.cp / np.linalg.norm(band.cp, axis=1)[:, None]
    radial = np.einsum("ni,nj->nij", n, n)                   # n n^T: nothing in the tangent plane
    a, b, d = reduce_to_tangent(_rows(radial), *tangent_basis(band).transpose(2, 1, 0))
    assert max(np.abs(a).max(), np.abs(b).max(), np.abs(d).max()) < 1e-12
