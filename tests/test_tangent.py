"""Tangent bases: the Householder construction (paper, eq. (31)) and normals from the closest point function."""

import numpy as np
import pytest

from cp_stylize.tangent import householder_basis


@pytest.mark.parametrize("normal", [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, 0, -1), (0.6, 0.0, 0.8), (-0.6, 0.48, 0.64)])
def test_householder_basis_is_orthonormal_and_tangent(normal):
    n = np.array([normal], dtype=np.float64)
    Q = householder_basis(n)[0]                              # (3, 2)
    np.testing.assert_allclose(Q.T @ Q, np.eye(2), atol=1e-14)
    np.testing.assert_allclose(n[0] @ Q, 0.0, atol=1e-14)
    # with n, a right- or left-handed frame: |det [n q0 q1]| = 1
    assert abs(np.linalg.det(np.column_stack([n[0], Q]))) == pytest.approx(1.0)


def test_householder_basis_is_continuous_near_e1():
    # n and the reflection vector n + sign(n_1) e_1 never cancel: bases on both sides of +e1 are close
    eps = 1e-7
    a = householder_basis(np.array([[1.0, eps, 0.0]]) / np.hypot(1.0, eps))[0]
    b = householder_basis(np.array([[1.0, -eps, 0.0]]) / np.hypot(1.0, eps))[0]
    assert np.abs(a - b).max() < 1e-6
