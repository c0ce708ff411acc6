"""Toon shading: the lightness in flat bands (Winnemöller, Olsen and Gooch, 2006)."""

import numpy as np
import pytest

from cp_stylize.mesh import parametric_mesh
from cp_stylize.oklab import from_oklab, to_oklab
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import StylizeSettings
from cp_stylize.surfaces import Torus
from cp_stylize.toon import Toon, band_middles, band_position, band_values, quantise_lightness


def _ramp(n=2001, hue=(0.8, 0.5, 0.3)):
    """sRGB colours of one hue from black to white."""
    t = np.linspace(0.0, 1.0, n)[:, None]
    return np.clip(t * np.asarray(hue) / max(hue) * 1.0, 0, 1)


def test_hard_steps_leave_the_lightness_in_as_many_bands_as_asked():
    greys = np.repeat(np.linspace(0, 1, 2001)[:, None], 3, axis=1)
    for levels in (2, 3, 5, 8):
        out = to_oklab(quantise_lightness(greys, levels, softness=0.0))[:, 0]
        centres = (np.arange(levels) + 0.5) / levels
        # all but the texels right at a step sit on a band's middle
        off = np.min(np.abs(out[:, None] - centres[None, :]), axis=1)
        assert np.mean(off < 0.01) > 0.9, levels
        assert np.all(np.diff(out) >= -1e-9)          # lighter stays lighter


def test_softness_makes_the_steps_gentler_and_keeps_the_bands_middles():
    lightness = np.linspace(0.02, 0.98, 4001)
    greys = from_oklab(np.column_stack([lightness, np.zeros_like(lightness), np.zeros_like(lightness)]))
    hard = to_oklab(quantise_lightness(greys, 4, 0.0))[:, 0]
    soft = to_oklab(quantise_lightness(greys, 4, 1.0))[:, 0]
    slope = lambda l: np.max(np.diff(l) / np.diff(lightness))
    assert slope(soft) < slope(hard) / 5
    # at a band's middle both give the middle
    for centre in (0.375, 0.625):
        i = np.argmin(np.abs(lightness - centre))
        assert hard[i] == pytest.approx(centre, abs=0.01) and soft[i] == pytest.approx(centre, abs=0.02)


def test_hue_and_chroma_stay_the_colours_own():
    rng = np.random.default_rng(0)
    colours = 0.2 + 0.6 * rng.random((500, 3))          # well inside the gamut
    before, after = to_oklab(colours), to_oklab(quantise_lightness(colours, 6, 0.3))
    inside = np.all((quantise_lightness(colours, 6, 0.3) > 0.001) & (quantise_lightness(colours, 6, 0.3) < 0.999), axis=1)
    np.testing.assert_allclose(after[inside, 1:], before[inside, 1:], atol=2e-3)


def test_bad_levels_and_softness_are_refused():
    with pytest.raises(ValueError, match="levels must be at least 2"):
        quantise_lightness(np.zeros((2, 3)), 1)
    with pytest.raises(ValueError, match="softness must lie in"):
        quantise_lightness(np.zeros((2, 3)), 3, softness=1.5)
    with pytest.raises(ValueError, match=r"Toon Levels \(toon_levels, \[toon\] levels in a preset\) must be 0"):
        StylizeSettings(mode="gaussian", toon_levels=1)
    with pytest.raises(ValueError, match="toon_levels"):
        StylizeSettings(mode="gaussian", toon_levels=9)


def test_a_toon_run_paints_the_surface_in_flat_bands():
    vertices, faces, uvs = parametric_mesh(Torus(10.0, 4.0).point, 48, 24, periodic_u=True, periodic_v=True)
    image = np.repeat(_ramp(64, (1.0, 1.0, 1.0))[None, :, :], 64, axis=0).astype(np.float32)   # greys along u
    colours = ColourInput.constant(len(faces), (0.0, 0.0, 0.0))
    colours.textures.append((image, uvs, np.ones(len(faces), bool)))
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.03, image_size=128, toon_levels=3,
                               toon_softness=0.0)
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    plain = stylize(vertices, faces, colours, settings.replace(toon_levels=0), uvs=uvs)
    covered = plain.image.sum(axis=2) > 0
    lightness = to_oklab(result.image[covered])[:, 0]
    spread = to_oklab(plain.image[covered])[:, 0]
    # the bands centred in thirds of the picture's texels, each at the mean lightness of its texels
    centres = band_values(spread, np.rint(band_position(spread, band_middles(spread, 3))).astype(np.int64), 3)
    on = np.min(np.abs(lightness[:, None] - centres[None, :]), axis=1) < 0.02
    assert np.mean(on) > 0.8
    # without toon shading the same run's lightness spreads over the ramp
    assert np.mean(np.min(np.abs(spread[:, None] - centres[None, :]), axis=1) < 0.02) < 0.4
    assert result.height is None and Toon.columns is None


def test_the_bands_lie_at_the_middles_asked_and_step_halfway_between():
    colours = _ramp()
    middles = np.array([0.2, 0.3, 0.6, 0.7])
    lightness = to_oklab(quantise_lightness(colours, 4, 0.0, middles))[:, 0]
    assert np.mean(np.min(np.abs(lightness[:, None] - middles[None, :]), axis=1) < 0.01) > 0.97
    assert lightness.min() > 0.19 and lightness.max() < 0.71     # no black, no white: a dark picture's own shades
    source = to_oklab(colours)[:, 0]
    assert np.all(lightness[(source > 0.31) & (source < 0.43)] < 0.31)     # the step from 0.3 to 0.6 is at 0.45
    assert np.all(lightness[(source > 0.47) & (source < 0.59)] > 0.59)


def test_the_bands_lie_at_the_pictures_own_quantiles_and_each_holds_a_share_of_it():
    lightness = np.random.default_rng(1).beta(2, 6, 100_000)        # a dark picture
    middles = band_middles(lightness, 4)
    assert np.allclose(middles, np.quantile(lightness, [0.125, 0.375, 0.625, 0.875]), atol=1e-9)
    nearest = np.argmin(np.abs(lightness[:, None] - middles[None, :]), axis=1)
    assert np.all(np.bincount(nearest, minlength=4) / len(lightness) > 0.1)
    # a flat picture's bands stay apart
    assert np.all(np.diff(band_middles(np.full(100, 0.5), 4)) >= 0.02 - 1e-12)


def test_each_band_takes_the_mean_lightness_of_its_texels_so_the_picture_keeps_its_values():
    lightness = np.random.default_rng(2).beta(2, 6, 100_000)        # a dark picture
    band = np.rint(band_position(lightness, band_middles(lightness, 4))).astype(np.int64)
    values = band_values(lightness, band, 4)
    assert np.allclose(values, [lightness[band == k].mean() for k in range(4)])
    assert values[band].mean() == pytest.approx(lightness.mean())  # the mean is kept
    # a band no texel is in lies between its neighbours, and the values keep rising
    assert np.all(np.diff(band_values(np.array([0.2, 0.2, 0.8]), np.array([0, 0, 3]), 4)) >= 0.02 - 1e-12)


def test_specks_go_to_the_band_around_them_and_a_step_is_anti_aliased_over_a_texel():
    from cp_stylize.toon import ISLAND

    size = 1024                                            # ISLAND counts texels of a 1024 x 1024 atlas
    grey = np.repeat(np.linspace(0.3, 0.7, size)[None, :], size, axis=0)     # a shallow ramp across
    for r, c in ((10, 10), (200, 150), (400, 50)):         # specks of light in the dark
        grey[r:r + 2, c:c + 2] = 0.75
    colours = from_oklab(np.column_stack([grey.ravel(), np.zeros((size * size, 2))]))
    flat = np.arange(size * size)
    out, height = Toon(2, 0.0, size)((flat, None, None, None), colours, None)
    lightness = to_oklab(out)[:, 0].reshape(size, size)
    low, high = lightness.min(), lightness.max()
    assert height is None and ISLAND > 4
    assert np.ptp(lightness[:, :500]) < 1e-6               # the specks are gone: the dark side is one band
    # the step is crisp and anti-aliased: one to three columns between the bands' values, not zero, not many
    between = (lightness[0] > low + 0.005) & (lightness[0] < high - 0.005)
    assert 1 <= between.sum() <= 3
    assert np.all(np.diff(lightness[0]) >= -1e-9)
    # without the atlas's size, no clean-up: the specks stay
    bare = to_oklab(Toon(2, 0.0)((flat, None, None, None), colours, None)[0])[:, 0].reshape(size, size)
    assert bare[10, 10] > bare[20, 20] + 0.1


def test_outlines_ink_the_dark_side_of_each_step_a_texel_wide_however_shallow_the_gradient():
    size = 1024
    grey = np.repeat(np.linspace(0.2, 0.8, size)[None, :], size, axis=0)      # a shallow ramp across
    grey[:, 700:] = 0.95                                   # and a sharp step
    colours = from_oklab(np.column_stack([grey.ravel(), np.zeros((size * size, 2))]))
    flat = np.arange(size * size)
    plain = to_oklab(Toon(3, 0.0, size)((flat, None, None, None), colours, None)[0])[:, 0].reshape(size, size)[0]
    inked = to_oklab(Toon(3, 0.0, size, outlines=1.0)((flat, None, None, None), colours, None)[0])[:, 0]
    darker = plain - inked.reshape(size, size)[0]
    lines = np.flatnonzero(darker > 0.05)
    # one line a step, one to two texels wide, on the dark side (before the lighter band begins)
    pieces = np.split(lines, np.flatnonzero(np.diff(lines) > 1) + 1)
    assert len(pieces) == 2 and all(1 <= len(p) <= 2 for p in pieces)
    for p in pieces:
        assert plain[p.max() + 1] > plain[p.min() - 1] + 0.05
    assert np.abs(darker[:pieces[0].min() - 2]).max() < 1e-9               # flat: no ink


def test_a_toon_runs_outlines_are_black_without_ink_lines():
    # the run's colour hull takes black in for the outlines alone (Line Width 0), so they are not clamped
    # to the picture's darkest grey
    vertices, faces, uvs = parametric_mesh(Torus(10.0, 4.0).point, 48, 24, periodic_u=True, periodic_v=True)
    image = np.repeat(np.linspace(0.35, 0.9, 64)[None, :, None].repeat(3, axis=2), 64, axis=0).astype(np.float32)
    colours = ColourInput(textures=[(image, uvs, np.ones(len(faces), bool))])
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.03, image_size=512, toon_levels=3,
                               toon_softness=0.0, toon_outlines=1.0, line_width=0.0)
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    covered = result.image.sum(axis=2) > 0
    assert result.image[covered][:, :3].max(axis=1).min() < 0.15     # outlines in near-black ink, not 0.35
    assert image.min() > 0.3
