import numpy as np
import pytest

from cp_stylize import Ellipsoid, Sphere, Torus


@pytest.mark.parametrize("surface", [Sphere(1.5, (0.1, -0.2, 0.3)), Torus(1.0, 0.4, (0.2, 0.0, -0.1)),
                                     Ellipsoid((1.0, 0.8, 0.6), (0.1, 0.2, -0.3))])
def test_closest_point_is_on_surface_and_nearest(surface):
    rng = np.random.default_rng(0)
    lo, hi = surface.bounds()
    x = rng.uniform(lo - 0.3, hi + 0.3, size=(2000, 3))
    cp, dist = surface.closest_point(x)
    # cp is a fixed point: it lies on the surface
    cp2, d2 = surface.closest_point(cp)
    np.testing.assert_allclose(cp2, cp, atol=1e-12)
    np.testing.assert_allclose(d2, 0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(dist), np.linalg.norm(x - cp, axis=1), atol=1e-12)
    # no sampled surface point is nearer than cp
    s, t = rng.uniform(size=(2, 20000))
    samples = surface.point(s, t)
    nearest = np.min(np.linalg.norm(x[:200, None, :] - samples[None, :, :], axis=2), axis=1)
    assert np.all(np.abs(dist[:200]) <= nearest + 1e-12)


@pytest.mark.parametrize("surface", [Sphere(1.5), Torus(1.0, 0.4), Ellipsoid((0.5, 1.0, 0.7))])
def test_normal_is_unit_and_orthogonal_to_surface_offsets(surface):
    rng = np.random.default_rng(1)
    s, t = rng.uniform(size=(2, 500))
    p = surface.point(s, t)
    n = surface.normal(p)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    # moving along the normal keeps the closest point and changes the distance by the step
    cp, dist = surface.closest_point(p + 0.05 * n)
    np.testing.assert_allclose(cp, p, atol=1e-12)
    np.testing.assert_allclose(dist, 0.05, atol=1e-12)


def test_torus_matches_equation_54():
    p = Torus(1.0, 0.4).point(*np.random.default_rng(2).uniform(size=(2, 100)))
    lhs = (1.0 - np.hypot(p[:, 0], p[:, 1])) ** 2 + p[:, 2] ** 2
    np.testing.assert_allclose(lhs, 0.4**2, atol=1e-12)


@pytest.mark.parametrize("make, message", [
    (lambda: Sphere(-1.0), "radius must be a positive number"),
    (lambda: Torus(0.4, 1.0), "0 < r < R"),
    (lambda: Ellipsoid((1.0, 0.0, 1.0)), "three positive numbers"),
    (lambda: Sphere().closest_point(np.zeros((3, 2))), r"shape \(N, 3\)"),
])
def test_bad_input_is_reported(make, message):
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize("surface", [Sphere(1.5, (0.1, -0.2, 0.3)), Torus(1.0, 0.4, (0.2, 0.0, -0.1)),
                                     Ellipsoid((1.0, 0.8, 0.6), (0.1, 0.2, -0.3))])
def test_parameters_invert_point(surface):
    s, t = np.random.default_rng(3).uniform(0.01, 0.99, size=(2, 1000))
    s2, t2 = surface.parameters(surface.point(s, t))
    np.testing.assert_allclose(s2, s, atol=1e-12)
    np.testing.assert_allclose(t2, t, atol=1e-12)


def test_ellipsoid_distance_is_signed_and_exact_on_its_focal_disc():
    e = Ellipsoid((1.0, 0.8, 0.6))
    cp, dist = e.closest_point(np.array([[0.0, 0.0, 0.0], [0.3, 0.1, 0.0], [0.9, 0.0, 0.0], [2.0, 0.0, 0.0]]))
    # the centre and a point of the focal disc (z = 0, inside): two nearest points, one is returned
    np.testing.assert_allclose(np.sum((cp / e.axes) ** 2, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(dist[0], -0.6, atol=1e-12)
    assert dist[1] < 0 and abs(cp[1, 2]) > 0.1
    # on the x axis beyond the disc's edge (a - c^2 / a = 0.64) the vertex is nearest
    np.testing.assert_allclose(cp[2:], [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]], atol=1e-12)
    np.testing.assert_allclose(dist[2:], [-0.1, 1.0], atol=1e-12)
