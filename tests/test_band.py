import numpy as np
import pytest

from cp_stylize import Band, Sphere, Torus, band_width
from cp_stylize.band import STENCILS


def test_band_width_follows_the_ruuth_merriman_rule():
    # sqrt((d-1)((p+1)/2)^2 + (s+(p+1)/2)^2) h with d = 3, p = 3, s = 1
    assert band_width(0.1) == pytest.approx(np.sqrt(2 * 2**2 + 3**2) * 0.1)
    assert band_width(0.1, stencil="anisotropic") == pytest.approx(np.sqrt(22) * 0.1)


@pytest.mark.parametrize("stencil", sorted(STENCILS))
def test_every_stencil_point_of_every_closest_point_is_in_the_band(stencil):
    band = Band.build(Torus(1.0, 0.4), 0.05, stencil=stencil)
    E = band.extension_matrix()
    assert np.all(np.diff(E.indptr) == 64)
    # every interpolation stencil point is a band point, and so is every grid
    # point its finite difference stencil reads
    read = np.unique(E.indices)
    nbr = band.neighbors(STENCILS[stencil])[read]
    assert np.all(nbr >= 0)
    # and the band holds exactly the grid points within its width
    assert np.all(np.abs(band.dist) <= band.width)


def test_torus_band_size_matches_area_times_width():
    # Weyl's tube formula: a tube of half-width w about a torus has volume 2 w A exactly
    torus = Torus(1.0, 0.4)
    for h in (0.05, 0.025):
        band = Band.build(torus, h)
        expected = torus.area * 2 * band.width / h**3
        assert abs(band.size / expected - 1) < 0.03, (h, band.size, expected)


def test_points_are_grid_points_aligned_with_the_origin():
    band = Band.build(Sphere(1.0, (0.013, 0.0, 0.0)), 0.1)
    np.testing.assert_allclose(band.points / band.h, np.round(band.points / band.h), atol=1e-12)
    cp, dist = band.surface.closest_point(band.points)
    np.testing.assert_array_equal(cp, band.cp)


def test_extension_reproduces_tricubic_polynomials_exactly():
    band = Band.build(Sphere(), 0.1)
    f = lambda p: (1 + p[:, 0] - 2 * p[:, 1] ** 2 + p[:, 2] ** 3 * p[:, 0] ** 3
                   - 0.5 * p[:, 0] ** 2 * p[:, 1] ** 3 * p[:, 2] ** 2)
    np.testing.assert_allclose(band.extend(f(band.points).astype(np.float64)), f(band.cp), atol=1e-12)


def test_extension_error_is_fourth_order():
    f = lambda p: np.sin(3 * p[:, 0]) * np.cos(2 * p[:, 1] + p[:, 2])
    errors = []
    for h in (0.1, 0.05, 0.025):
        band = Band.build(Sphere(), h)
        errors.append(np.abs(band.extend(f(band.points).astype(np.float64)) - f(band.cp)).max())
    orders = np.log2(np.array(errors[:-1]) / errors[1:])
    print("\nextension error", errors, "orders", orders)
    assert np.all(orders > 3.5)


def test_extend_works_on_several_columns_and_keeps_float32():
    band = Band.build(Sphere(), 0.1)
    v = np.random.default_rng(0).uniform(size=(band.size, 3)).astype(np.float32)
    out = band.extend(v)
    assert out.shape == (band.size, 3) and out.dtype == np.float32
    np.testing.assert_allclose(out[:, 1], band.extend(v[:, 1]), rtol=1e-6)


def test_laplacian_is_exact_on_quadratics_at_inner_points():
    band = Band.build(Sphere(), 0.1)
    p = band.points
    v = p[:, 0] ** 2 + 3 * p[:, 1] * p[:, 2] - p[:, 2] ** 2 + 2 * p[:, 1] ** 2
    lap = band.laplacian(v.astype(np.float64))
    np.testing.assert_allclose(lap[band.inner], 2 - 2 + 4, atol=1e-9)


def test_interpolation_off_the_surface_is_refused():
    band = Band.build(Sphere(), 0.1)
    with pytest.raises(ValueError, match="outside the band"):
        band.interpolate(np.zeros(band.size), np.array([[0.0, 0.0, 0.0]]))


@pytest.mark.parametrize("h, message", [(0.0, "positive"), (np.nan, "positive"), (-1, "positive")])
def test_bad_grid_spacing_is_reported(h, message):
    with pytest.raises(ValueError, match=message):
        Band.build(Sphere(), h)


def test_values_of_the_wrong_length_are_reported():
    band = Band.build(Sphere(), 0.2)
    with pytest.raises(ValueError, match=r"band values must have shape"):
        band.extend(np.zeros(band.size + 1))


def test_neighbour_tables_agree_with_lookups():
    band = Band.build(Sphere(), 0.05, stencil="anisotropic")
    offsets = np.array([[0, 0, 0], [1, 0, -1], [0, 0, 5], [-7, 0, 0], [2, -3, 1]])
    np.testing.assert_array_equal(band.neighbors(offsets), band.lookup(band.ijk[:, None, :] + offsets))
