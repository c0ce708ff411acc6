"""Principal curvatures and directions from the closest point representation (the fields that Diewald and
Rumpf's flow textures follow)."""

import numpy as np
import pytest

from cp_stylize import Band, Ellipsoid, Sphere, Torus
from cp_stylize.curvature import principal_curvatures
from cp_stylize.mesh import TriangleMesh, parametric_mesh


def _angles(a, b):
    """Angles in degrees between line fields a and b (N, 3): the sign of either does not count."""
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(a * b, axis=1)), 0.0, 1.0)))


def _torus_truth(torus, cp):
    """Unit parallel direction and the curvature along it; the meridian's is 1/r, the larger one."""
    x, y, _ = (cp - torus.center).T
    parallel = np.column_stack([-y, x, np.zeros_like(x)])
    parallel /= np.linalg.norm(parallel, axis=1)[:, None]
    rho = np.hypot(x, y)
    return parallel, (rho - torus.R) / (torus.r * rho)     # cos(theta) / (R + r cos(theta))


@pytest.fixture(scope="module")
def torus_fields():
    rows = {}
    for h in (0.1, 0.05):
        band = Band.build(Torus(1.0, 0.4), h, stencil="anisotropic")
        rows[h] = band, principal_curvatures(band)
    return rows


def test_torus_directions_are_the_parallels_and_meridians(torus_fields):
    band, c = torus_fields[0.05]
    parallel, _ = _torus_truth(band.surface, band.cp)
    angles = _angles(c.e2, parallel)
    print(f"\nangle to the parallels: 95th percentile {np.percentile(angles, 95):.3f}, max {angles.max():.3f} degrees")
    assert np.percentile(angles, 95) < 5.0 and angles.max() < 1.0
    # e1, e2 and the normal form an orthonormal frame
    np.testing.assert_allclose(np.sum(c.e1 * c.e2, axis=1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.sum(c.e1 * c.normals, axis=1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(c.e1, axis=1), 1.0, atol=1e-12)


def test_torus_curvatures_converge_at_second_order(torus_fields):
    errors = []
    for h in (0.1, 0.05):
        band, c = torus_fields[h]
        _, k_parallel = _torus_truth(band.surface, band.cp)
        errors.append((np.abs(c.k1 - 1 / 0.4).max(), np.abs(c.k2 - k_parallel).max()))
    errors = np.array(errors)
    orders = np.log2(errors[0] / errors[1])
    print(f"\nmax errors {errors.tolist()}, orders {orders}")
    assert np.all(orders > 1.8) and errors[1, 0] < 0.02 * 2.5
    # a torus has no umbilics: the directions are defined everywhere
    assert torus_fields[0.05][1].confidence.min() > 0.2


def test_ellipsoid_curvatures_and_directions_at_its_vertices():
    a, b, c = axes = (1.0, 0.8, 0.6)
    band = Band.build(Ellipsoid(axes), 0.05, stencil="anisotropic")
    curv = principal_curvatures(band)
    assert np.degrees(np.arcsin(np.abs(np.sum(curv.e1 * curv.e2, axis=1)).max())) < 2.0
    vertices = np.array([[a, 0, 0], [0, b, 0], [0, 0, c]])
    # (min, max) curvature and their directions at each vertex
    exact = [((a / b**2, 1), (a / c**2, 2)), ((b / a**2, 0), (b / c**2, 2)), ((c / a**2, 0), (c / b**2, 1))]
    M = band.interpolation_matrix(vertices, np.float64)
    k1, k2 = M @ curv.k1, M @ curv.k2
    nearest = np.argmin(np.linalg.norm(band.cp[None] - vertices[:, None], axis=2), axis=1)
    for v, ((kmin, axis_min), (kmax, axis_max)) in enumerate(exact):
        assert k2[v] == pytest.approx(kmin, rel=0.05) and k1[v] == pytest.approx(kmax, rel=0.05)
        i = nearest[v]
        assert _angles(curv.e1[i:i + 1], np.eye(3)[axis_max][None])[0] < 2.0
        assert _angles(curv.e2[i:i + 1], np.eye(3)[axis_min][None])[0] < 2.0


def test_a_sphere_is_umbilic_everywhere():
    band = Band.build(Sphere(2.0), 0.1, stencil="anisotropic")
    c = principal_curvatures(band)
    assert np.all(np.isfinite(c.e1)) and np.all(np.isfinite(c.e2))
    np.testing.assert_allclose(c.k1, 0.5, rtol=0.01)
    np.testing.assert_allclose(c.k2, 0.5, rtol=0.01)
    assert c.confidence.max() < 0.01


def test_curvatures_scale_like_one_over_the_size(torus_fields):
    small_band, small = torus_fields[0.05]
    big_band = Band.build(Torus(3.0, 1.2), 0.15, stencil="anisotropic")
    big = principal_curvatures(big_band)
    same = big_band.lookup(small_band.ijk)
    ok = same >= 0
    assert ok.mean() > 0.999
    np.testing.assert_allclose(big.k1[same[ok]], small.k1[ok] / 3, rtol=1e-6, atol=1e-9)
    assert _angles(big.e1[same[ok]], small.e1[ok]).max() < 1e-4


def test_reversed_normals_flip_the_curvatures_not_the_directions(torus_fields):
    band, c = torus_fields[0.1]
    flipped = principal_curvatures(band, -c.normals)
    np.testing.assert_allclose(flipped.k1, -c.k2, atol=1e-10)
    np.testing.assert_allclose(flipped.k2, -c.k1, atol=1e-10)
    assert _angles(flipped.e1, c.e2).max() < 1e-4


def test_a_triangle_mesh_gives_the_directions_of_the_surface_it_samples():
    torus = Torus(1.0, 0.4)
    vertices, faces, _ = parametric_mesh(torus.point, 64, 24, periodic_u=True, periodic_v=True)
    band = Band.build(TriangleMesh(vertices, faces), 0.05, stencil="anisotropic")
    c = principal_curvatures(band)
    parallel, _ = _torus_truth(torus, band.cp)
    angles = _angles(c.e2, parallel)
    assert np.percentile(angles, 95) < 2.0
    assert np.median(c.k1) == pytest.approx(2.5, rel=0.03)
    smoothed = principal_curvatures(band, smooth=2 * band.h**2)
    assert np.percentile(_angles(smoothed.e2, parallel), 95) < np.percentile(angles, 95)


def test_bad_arguments_are_reported(torus_fields):
    band, _ = torus_fields[0.1]
    with pytest.raises(ValueError, match="consistently oriented normals"):
        principal_curvatures(band, "jacobian")
    with pytest.raises(ValueError, match="smooth must be a non-negative number"):
        principal_curvatures(band, smooth=-1.0)
