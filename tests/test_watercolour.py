"""Watercolour: washes of transparent pigment on grained paper (Curtis et al., 1997; Bousseau et al., 2006)."""

import numpy as np
import pytest

from cp_stylize.mesh import parametric_mesh
from cp_stylize.oklab import from_oklab, to_oklab
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import StylizeSettings, load_preset
from cp_stylize.surfaces import Torus
from cp_stylize.watercolour import BLEED_TEXELS, GRAIN_WAVELENGTH, PAPER, RIM_TEXELS, Watercolour, solid_noise

SIZE = 256


def _plane(lightness, size=SIZE, extent=1.0):
    """Texels of a flat ``size`` x ``size`` atlas on the square ``extent`` across, with OKLab ``lightness``
    (size, size) of a blue-grey: ``(texels, colours)``."""
    rows, cols = np.mgrid[0:size, 0:size]
    points = np.column_stack([cols.ravel(), rows.ravel(), np.zeros(size * size)]) * (extent / size)
    lab = np.column_stack([lightness.ravel(), np.full(size * size, -0.01), np.full(size * size, -0.04)])
    return (np.arange(size * size), points, None, None), from_oklab(lab)


def _lightness(out, size=SIZE):
    return to_oklab(out)[:, 0].reshape(size, size)


def _luma(out, size=SIZE):
    return (np.asarray(out)[:, :3] @ [0.2126, 0.7152, 0.0722]).reshape(size, size)


def _halves(dark=0.45, light=0.8):
    lightness = np.full((SIZE, SIZE), light)
    lightness[:, :SIZE // 2] = dark
    return lightness


def test_the_solid_noise_is_a_smooth_function_of_the_point_alone():
    rng = np.random.default_rng(0)
    points = rng.random((20_000, 3))
    noise = solid_noise(points, 0.05, seed=3)
    assert noise.min() >= 0.0 and noise.max() <= 1.0 and noise.mean() == pytest.approx(0.5, abs=0.03)
    assert noise.std() > 0.12                                          # it spans its range
    np.testing.assert_allclose(solid_noise(points[::-1], 0.05, seed=3), noise[::-1], atol=1e-12)   # the point alone
    assert np.corrcoef(noise, solid_noise(points, 0.05, seed=4))[0, 1] < 0.1             # the seed's own
    # smooth at a tenth of its wavelength, unrelated at several
    near = solid_noise(points + [0.005, 0.0, 0.0], 0.05, seed=3)
    far = solid_noise(points + [0.4, 0.0, 0.0], 0.05, seed=3)
    assert np.corrcoef(noise, near)[0, 1] > 0.8 and abs(np.corrcoef(noise, far)[0, 1]) < 0.1


def test_the_darker_wash_darkens_towards_its_border_where_it_dried_hard_and_the_lighter_does_not():
    texels, colours = _plane(_halves(light=0.7))
    plain = _luma(Watercolour(2, SIZE, edges=0.0, granulation=0.0, bleed=0.0, wobble=0.0)(texels, colours,
                                                                                          None)[0])
    rimmed = _luma(Watercolour(2, SIZE, edges=1.0, granulation=0.0, bleed=0.0, wobble=0.0)(texels, colours,
                                                                                           None)[0])
    border = SIZE // 2
    dark, light = slice(border - 2, border), slice(border, border + 2)
    # the darker wash (laid over the lighter) pooled its pigment at its border: at least 15 % darker there
    rim, middle = np.mean(rimmed[:, dark]), np.mean(rimmed[:, border - 40:border - 20])
    assert rim < 0.85 * middle
    assert middle == pytest.approx(np.mean(plain[:, border - 40:border - 20]), abs=0.01)   # inside, as without
    # the lighter wash keeps its colour up to the border: no outline around the darker
    np.testing.assert_allclose(rimmed[:, light], plain[:, light], atol=1e-6)
    # the rim fades inward within a few texels: flat beyond
    assert np.ptp(rimmed[:, :border - 8 * int(RIM_TEXELS)]) < 0.01
    assert np.ptp(plain[:, :border - 2]) < 1e-6


def test_a_border_that_bled_is_soft_and_has_no_dark_rim():
    size = 512                                               # a bled border spreads over BLEED_TEXELS at 1024
    lightness = np.full((size, size), 0.8)
    lightness[:, :size // 2] = 0.45
    texels, colours = _plane(lightness, size)
    row = lambda **kw: _lightness(Watercolour(2, size, granulation=0.0, wobble=0.0, **kw)(texels, colours, None)[0],
                                  size)[size // 2]
    wet, hard, rimmed = row(edges=1.0, bleed=1.0), row(edges=0.0, bleed=0.0), row(edges=1.0, bleed=0.0)
    low, high = wet.min(), wet.max()
    between = lambda values: np.sum((values > low + 0.01) & (values < high - 0.01))
    assert between(wet) >= BLEED_TEXELS * size / 1024 and between(hard) <= 2    # spread wide, against a texel or two
    assert np.all(np.diff(wet) >= -1e-6)                         # a soft ramp, no darker rim before it
    assert rimmed.min() < low - 0.05                             # where it dried hard, it has one


def test_granulation_grains_the_washes_most_in_the_darks_and_leaves_white_paper_white():
    lightness = np.full((SIZE, SIZE), 0.97)
    lightness[:, :SIZE // 3] = 0.35
    lightness[:, SIZE // 3:2 * SIZE // 3] = 0.65
    texels, colours = _plane(lightness, extent=SIZE * GRAIN_WAVELENGTH / 4)      # four texels a grain
    smooth = _lightness(Watercolour(3, SIZE, granulation=0.0, bleed=0.0, wobble=0.0)(texels, colours, None)[0])
    grained = _lightness(Watercolour(3, SIZE, granulation=1.0, bleed=0.0, wobble=0.0)(texels, colours, None)[0])

    def grain(image, part):
        block = image[:, part][:, 10:-10]
        return np.std(block - np.median(block))

    dark, mid, paper = slice(0, SIZE // 3), slice(SIZE // 3, 2 * SIZE // 3), slice(2 * SIZE // 3, SIZE)
    assert grain(smooth, dark) < 0.01
    assert grain(grained, dark) > 0.03 and grain(grained, dark) > grain(grained, mid) > grain(grained, paper)
    # the paper: its own colour, faintly grained
    paper_colour = to_oklab(np.asarray(PAPER))[0]
    assert np.median(grained[:, paper][:, 10:-10]) == pytest.approx(paper_colour, abs=0.02)
    assert grain(grained, paper) < 0.015


def test_the_paint_is_the_same_at_the_same_point_of_the_surface_however_the_atlas_lays_it_out():
    # one even wash over two charts that hold the same points of the surface, the second turned and mirrored
    size = 128
    rows, cols = np.mgrid[0:size, 0:size // 2]
    points = np.column_stack([cols.ravel(), rows.ravel(), np.zeros(cols.size)]) * 0.004
    turned = points.reshape(size, size // 2, 3)[::-1, ::-1].reshape(-1, 3)
    flat = np.concatenate([(rows * size + cols).ravel(), (rows * size + cols + size // 2).ravel()])
    colours = np.tile(np.array([[0.3, 0.45, 0.7]]), (len(flat), 1))
    out, _ = Watercolour(3, size, seed=5)((flat, np.vstack([points, turned]), None, None), colours, None)
    first, second = out[:len(points)], out[len(points):].reshape(size, size // 2, 3)[::-1, ::-1].reshape(-1, 3)
    np.testing.assert_allclose(first, second, atol=1e-6)
    assert np.ptp(first[:, 2]) > 0.05                                  # and it is grained, not flat


def test_washes_must_be_none_or_two_or_more():
    with pytest.raises(ValueError, match=r"Washes \(wash_levels, \[watercolour\] washes in a preset\) must be 0"):
        StylizeSettings(mode="gaussian", wash_levels=1)
    with pytest.raises(ValueError, match="wash_edges"):
        StylizeSettings(mode="gaussian", wash_levels=4, wash_edges=1.5)


def test_a_watercolour_run_paints_washes_on_paper_within_the_run_colours():
    vertices, faces, uvs = parametric_mesh(Torus(10.0, 4.0).point, 48, 24, periodic_u=True, periodic_v=True)
    ramp = np.linspace(0.1, 0.6, 64)
    image = np.repeat(np.column_stack([ramp, ramp * 0.8, ramp * 0.4])[None], 64, axis=0).astype(np.float32)
    colours = ColourInput.constant(len(faces), (0.0, 0.0, 0.0))
    colours.textures.append((image, uvs, np.ones(len(faces), bool)))
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.03, image_size=128, wash_levels=3)
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    plain = stylize(vertices, faces, colours, settings.replace(wash_levels=0), uvs=uvs)
    covered = plain.image.sum(axis=2) > 0
    assert result.height is None and Watercolour.columns is None
    # the washes are thinner than the picture: lighter on the whole, and no darker than black
    assert to_oklab(result.image[covered])[:, 0].mean() > to_oklab(plain.image[covered])[:, 0].mean()


def test_the_watercolour_preset_paints_washes_over_oil_flattened_regions():
    s = load_preset("watercolour")
    assert s.wash_levels >= 3 and s.oil_size > 0 and 0 < s.wash_bleed < 1
    assert s.wash_edges > 0 and s.wash_granulation > 0 and s.strokes == 0
