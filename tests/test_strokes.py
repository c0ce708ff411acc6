"""Brush strokes at the texture's resolution: solid noise, streaks along a line field, and their colours."""

import numpy as np
import pytest

from cp_stylize import Sphere
from cp_stylize.band import Band
from cp_stylize.noise import LUMA
from cp_stylize.strokes import Strokes, line_field, solid_noise, streaks


@pytest.fixture(scope="module")
def sphere_band():
    return Band.build(Sphere(1.0), 0.04, stencil="anisotropic")


def _meridians(band):
    """The line field along the meridians of the unit sphere (the z axis laid onto it)."""
    n = band.cp / np.linalg.norm(band.cp, axis=1)[:, None]
    e = np.array([0.0, 0.0, 1.0]) - n[:, 2:3] * n
    return e / np.maximum(np.linalg.norm(e, axis=1), 1e-12)[:, None]


def _on_sphere(theta, phi):
    return np.column_stack([np.cos(theta) * np.cos(phi), np.cos(theta) * np.sin(phi), np.sin(theta)])


def test_solid_noise_is_a_smooth_function_of_the_point_and_its_seed():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (20000, 3))
    a = solid_noise(x, 0.01, seed=3)
    assert a.min() >= 0 and a.max() <= 1 and abs(a.mean() - 0.5) < 0.01
    np.testing.assert_array_equal(a[::-1], solid_noise(x[::-1], 0.01, seed=3))    # the point's own value
    assert np.corrcoef(a, solid_noise(x, 0.01, seed=4))[0, 1] < 0.05             # another seed, other noise
    near = solid_noise(x + 1e-4, 0.01, seed=3)                                   # continuous across cells
    assert np.max(np.abs(near - a)) < 0.05


def test_streaks_run_along_the_field_and_not_across(sphere_band):
    strokes = Strokes(sphere_band, _meridians(sphere_band), [0.0, 1.0], [(0, 0, 0), (1, 1, 1)], None,
                      strength=1.0, length=0.2, width=0.01, spread=0.2)
    rng = np.random.default_rng(1)
    theta, phi = rng.uniform(-0.6, 0.6, 4000), rng.uniform(0, 2 * np.pi, 4000)
    s = streaks(strokes, _on_sphere(theta, phi))
    assert abs(s.mean()) < 0.1 and 0.8 < s.std() < 1.2                     # scaled on the band's points
    along = streaks(strokes, _on_sphere(theta + 0.03, phi))                 # 0.03 along the meridian
    across = streaks(strokes, _on_sphere(theta, phi + 0.03 / np.cos(theta)))  # 0.03 across it
    c_along, c_across = np.corrcoef(s, along)[0, 1], np.corrcoef(s, across)[0, 1]
    print(f"\ncorrelation 0.03 along the strokes {c_along:.2f}, across {c_across:.2f}")
    assert c_along > 0.8 and c_across < 0.2
    # a point's streak is its own, whichever points are asked with it (seams read the same)
    np.testing.assert_allclose(streaks(strokes, _on_sphere(theta[:7], phi[:7])), s[:7], rtol=0, atol=1e-12)


def test_the_line_field_follows_the_structure(sphere_band):
    # values that change with the longitude only: their structure runs along the meridians
    phi = np.arctan2(sphere_band.cp[:, 1], sphere_band.cp[:, 0])
    values = np.repeat(np.sin(4 * phi)[:, None], 3, axis=1)
    e = line_field(sphere_band, values, 2e-4)
    near = np.abs(sphere_band.cp[:, 2]) < 0.7
    assert np.median(np.abs(np.sum(e * _meridians(sphere_band), axis=1))[near]) > 0.99


def test_strokes_paint_the_palette_in_the_tones_order(sphere_band):
    palette = [(0.05, 0.1, 0.3), (0.2, 0.35, 0.7), (0.95, 0.85, 0.3)]
    rng = np.random.default_rng(2)
    theta, phi = rng.uniform(-1, 1, 5000), rng.uniform(0, 2 * np.pi, 5000)
    colours = np.where((phi < np.pi)[:, None], 0.2, 0.8) * np.ones((1, 3))   # a dark half, a light half
    tones = np.where(np.arange(1000) < 500, 0.2, 0.8)
    strokes = Strokes(sphere_band, _meridians(sphere_band), tones, palette, [1, 1, 1],
                      strength=1.0, length=0.2, width=0.01, spread=0.2)
    out = strokes(_on_sphere(theta, phi), colours)
    nearest = np.min(np.linalg.norm(out[:, None] - np.array(palette)[None], axis=2), axis=1)
    assert np.max(nearest) < 1e-6                                 # strength 1: only the palette's colours
    tone = out @ LUMA
    assert tone[phi < np.pi].mean() < tone[phi >= np.pi].mean() - 0.2   # the dark half stays darker
    assert len(np.unique(out[phi < np.pi], axis=0)) >= 2          # and carries strokes of more than one colour
    half = Strokes(sphere_band, _meridians(sphere_band), tones, palette, None, strength=0.5,
                   length=0.2, width=0.01, spread=0.2)(_on_sphere(theta, phi), colours)
    np.testing.assert_allclose(half, 0.5 * (colours + out), atol=1e-12)


def test_the_streaks_report_their_progress_in_order_and_stop_when_told(sphere_band):
    strokes = Strokes(sphere_band, _meridians(sphere_band), [0.0, 1.0], [(0, 0, 0), (1, 1, 1)], None,
                      strength=1.0, length=0.05, width=0.01, spread=0.2)
    rng = np.random.default_rng(3)
    points = _on_sphere(rng.uniform(-1, 1, 140_000), rng.uniform(0, 2 * np.pi, 140_000))
    colours = np.full((len(points), 3), 0.5)
    seen = []
    strokes(points, colours, progress=seen.append)
    assert len(seen) == 3 and seen == sorted(seen) and seen[-1] == 1.0          # three chunks of texels

    def stop(fraction):
        raise KeyboardInterrupt("stop")

    with pytest.raises(KeyboardInterrupt):
        strokes(points, colours, progress=stop)
