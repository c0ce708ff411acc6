"""Oil paint: the anisotropic Kuwahara filter on the surface (Kyprianidis, Kang and Döllner, 2009)."""

import numpy as np
import pytest

from cp_stylize import Sphere, Torus
from cp_stylize.band import Band
from cp_stylize.baking import layered
from cp_stylize.kuwahara import MIN_RADIUS, SECTORS, kuwahara, sector_statistics, sharpness_power
from cp_stylize.mesh import parametric_mesh
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import StylizeSettings
from cp_stylize.smoothing import GridGaussian, taper

RADIUS = 0.1


@pytest.fixture(scope="module")
def sphere_band():
    return Band.build(Sphere(), 0.025)


def _step(band, normal, noise=0.0, seed=0):
    """Band values 0 on one side of the plane through the centre with ``normal``, 1 on the other, with
    Gaussian ``noise`` of the closest point (so a closest point extension)."""
    side = (band.cp @ np.asarray(normal, dtype=float) > 0).astype(np.float32)
    if noise:
        # noise as a function of the closest point, rounded to a fine grid: the same point, the same noise
        _, cell = np.unique(np.round(band.cp / 0.01).astype(np.int64), axis=0, return_inverse=True)
        cell = cell.ravel()
        side = side + noise * np.random.default_rng(seed).standard_normal(cell.max() + 1)[cell].astype(np.float32)
    return side


def test_a_constant_stays_what_it_is(sphere_band):
    values = np.full((sphere_band.size, 3), (0.2, 0.5, 0.9), np.float32)
    out = kuwahara(sphere_band, values, RADIUS)
    assert out.shape == values.shape and out.dtype == np.float32
    np.testing.assert_allclose(out, values, atol=1e-6)


def test_statistics_hold_each_sectors_mean_and_variation(sphere_band):
    values = np.random.default_rng(1).random((sphere_band.size, 2)).astype(np.float32)
    stats = sector_statistics(sphere_band, values, RADIUS).reshape(sphere_band.size, SECTORS, 3)
    assert np.all(stats[..., :2] >= 0) and np.all(stats[..., :2] <= 1)
    assert np.all(stats[..., 2] >= 0) and np.all(stats[..., 2] <= 2 * 0.25 + 1e-6)   # two channels in [0, 1]
    # a random field varies in every sector: the statistics see it
    assert np.median(stats[..., 2]) > 0.05
    # the nodes not asked for are left at 0
    rows = np.zeros(sphere_band.size, bool)
    rows[::7] = True
    some = sector_statistics(sphere_band, values, RADIUS, rows=rows)
    np.testing.assert_array_equal(some[~rows], 0.0)
    np.testing.assert_allclose(some[rows], stats.reshape(sphere_band.size, -1)[rows], atol=1e-6)


def test_regions_flatten_and_their_edge_stays_sharp_where_a_blur_smears_it(sphere_band):
    band = sphere_band
    clean = _step(band, (1.0, 0.0, 0.0))
    noisy = _step(band, (1.0, 0.0, 0.0), noise=0.15)
    oil = kuwahara(band, noisy, RADIUS, sharpness=0.75)
    blur = GridGaussian(band, 0.5 * RADIUS**2, weights=taper(band.dist, 3 * band.h))(noisy[None])[0]
    near = np.abs(band.dist) < band.h
    x = band.cp[:, 0]
    inside = near & (np.abs(x) > 2.5 * RADIUS)
    # the noise within each region falls to under a third
    for region in (x > 0, x < 0):
        part = inside & region
        assert np.std(oil[part]) < np.std(noisy[part]) / 3
    # across the edge, the oil paint steps within a few grid spacings; the blur of the same reach ramps
    def transition(values):
        ramp = near & (np.abs(x) < 3 * RADIUS) & (values > 0.15) & (values < 0.85)
        return np.percentile(np.abs(x[ramp]), 90) if ramp.any() else 0.0
    assert transition(oil) < 0.5 * transition(blur)
    # and the edge stays where it was
    assert np.mean((oil[near] > 0.5) == (clean[near] > 0.5)) > 0.97


def test_values_stay_within_the_inputs_range(sphere_band):
    values = np.random.default_rng(2).random((sphere_band.size, 3)).astype(np.float32)
    out = kuwahara(sphere_band, values, RADIUS, sharpness=1.0, eccentricity=2.0)
    assert out.min() >= values.min() - 1e-6 and out.max() <= values.max() + 1e-6


@pytest.mark.parametrize("degrees", [0.0, 30.0, 71.0])
def test_an_edge_at_any_angle_to_the_grid_comes_out_alike(sphere_band, degrees):
    # the filter works on the surface, not on the grid's axes: an edge turned about the sphere's axis
    # keeps its sharpness
    a = np.radians(degrees)
    normal = np.array([np.cos(a), np.sin(a), 0.0])
    band = sphere_band
    oil = kuwahara(band, _step(band, normal, noise=0.1, seed=3), RADIUS, sharpness=0.75)
    near = np.abs(band.dist) < band.h
    along = band.cp @ normal
    ramp = near & (np.abs(along) < 3 * RADIUS) & (oil > 0.15) & (oil < 0.85)
    width = np.percentile(np.abs(along[ramp]), 90) if ramp.any() else 0.0     # none between: a clean step
    assert width < 0.6 * RADIUS
    assert np.mean((oil[near] > 0.5) == (along[near] > 0)) > 0.97


def test_a_radius_below_two_grid_spacings_is_taken_as_two(sphere_band):
    values = np.random.default_rng(4).random(sphere_band.size).astype(np.float32)
    tiny = sector_statistics(sphere_band, values, 1e-6)
    least = sector_statistics(sphere_band, values, MIN_RADIUS * sphere_band.h)
    np.testing.assert_array_equal(tiny, least)


def test_sharpness_is_the_papers_power():
    assert sharpness_power(0.0) == 1.0 and sharpness_power(0.5) == 8.0 and sharpness_power(1.0) == 15.0


@pytest.fixture(scope="module")
def torus():
    return parametric_mesh(Torus(10.0, 4.0).point, 48, 24, periodic_u=True, periodic_v=True)


def _halves(size=64):
    img = np.zeros((size, size, 3), np.float32)
    img[:, : size // 2] = (0.9, 0.2, 0.1)
    img[:, size // 2:] = (0.1, 0.3, 0.8)
    noise = np.random.default_rng(5).normal(0.0, 0.06, img.shape).astype(np.float32)
    return np.clip(img + noise, 0, 1)


def test_stylize_with_oil_paint_flattens_the_texture_and_keeps_its_colours(torus):
    vertices, faces, uvs = torus
    colours = ColourInput.constant(len(faces), (0.0, 0.0, 0.0))
    colours.textures.append((_halves(), uvs, np.ones(len(faces), bool)))
    plain = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.03, image_size=128)
    oil = plain.replace(oil_size=0.12, oil_sharpness=0.75)
    a = stylize(vertices, faces, colours, plain, uvs=uvs)
    b = stylize(vertices, faces, colours, oil, uvs=uvs)
    assert b.image.shape == a.image.shape and b.height is None
    assert np.isfinite(b.image).all() and b.image.min() >= 0 and b.image.max() <= 1
    # the texels well inside each half: the noise flattens, the half's colour stays
    s = np.linspace(0, 1, 128)[None, :] * np.ones((128, 1))
    for lo, hi, colour in ((0.08, 0.42, (0.9, 0.2, 0.1)), (0.58, 0.92, (0.1, 0.3, 0.8))):
        part = (s > lo) & (s < hi) & (a.image.sum(axis=2) > 0)
        assert np.std(b.image[part], axis=0).max() < 0.7 * np.std(a.image[part], axis=0).max()
        np.testing.assert_allclose(b.image[part].mean(axis=0), colour, atol=0.08)


def test_oil_paint_under_contours_keeps_the_contours_height_and_lines(torus):
    vertices, faces, uvs = torus
    colours = ColourInput.constant(len(faces), (0.0, 0.0, 0.0))
    colours.textures.append((_halves(), uvs, np.ones(len(faces), bool)))
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.03, image_size=128, contours=1.0)
    lines = stylize(vertices, faces, colours, settings, uvs=uvs)
    both = stylize(vertices, faces, colours, settings.replace(oil_size=0.08), uvs=uvs)
    # the lines are drawn over the oil paint: the darkest texels are as dark as the lines alone make them
    dark = lines.image.sum(axis=2) < np.percentile(lines.image.sum(axis=2)[lines.image.sum(axis=2) > 0], 2)
    assert np.mean(both.image[dark]) < np.mean(lines.image[lines.image.sum(axis=2) > 0]) * 0.8


class _Paint:
    def __init__(self, columns, add, height):
        self.columns, self.add, self.height = columns, add, height

    def __call__(self, texels, colours, read, progress=None):
        assert (read is None) == (self.columns is None)
        extra = 0 if read is None else read.sum(axis=1, keepdims=True)
        h = None if self.height is None else np.full(len(colours), self.height, np.float32)
        return colours + self.add + extra, h


def test_layered_paints_read_their_own_columns_in_order():
    n, m = 5, 4
    under = _Paint(np.ones((n, 2)), 1.0, None)
    over = _Paint(None, 10.0, 0.5)
    both = layered(under, over)
    assert both.columns.shape == (n, 2)
    colours, height = both(None, np.zeros((m, 3)), np.full((m, 2), 3.0))
    np.testing.assert_allclose(colours, 1.0 + 6.0 + 10.0)
    np.testing.assert_allclose(height, 0.5)
    assert layered(None, over) is over and layered(under, None) is under
    two = layered(_Paint(np.ones((n, 1)), 0.0, 0.25), _Paint(np.ones((n, 3)), 0.0, 0.5))
    colours, height = two(None, np.zeros((m, 1)), np.arange(4 * m, dtype=float).reshape(m, 4))
    np.testing.assert_allclose(colours[:, 0], np.arange(0, 4 * m, 4) + np.arange(4 * m).reshape(m, 4)[:, 1:].sum(axis=1))
    np.testing.assert_allclose(height, 0.75)
