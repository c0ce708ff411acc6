"""What the bake-out promises whatever the filter: the input back where nothing changed, colours
within the input's, and a denoiser that beats the noise; and the painterly presets' tone mapping."""

import numpy as np
import pytest
from scipy import ndimage

from cp_stylize import Torus
from cp_stylize.baking import lay_detail
from cp_stylize.cache import RunCache
from cp_stylize.colours import TOLERANCE
from cp_stylize.mesh import parametric_mesh
from cp_stylize.pipeline import ColourInput, Texture, stylize
from cp_stylize.presets import StylizeSettings, load_preset

SIZE = 128
#: Rec. 709 weights of a colour's tone.
LUMA = np.array([0.2126, 0.7152, 0.0722])


@pytest.fixture(scope="module")
def torus():
    return parametric_mesh(Torus(1.0, 0.45).point, 64, 32, periodic_u=True, periodic_v=True)


@pytest.fixture(scope="module")
def cache():
    """One run cache for the module's runs: they share the torus, and most of them its grid, so each band (and
    each picture's colours on it) is built once (a cached run gives a fresh run's image: tests/test_cache.py)."""
    return RunCache()


def _picture(size=SIZE):
    """A picture with detail finer than a coarse band: blobs, sharp-edged discs and fine stripes."""
    rng = np.random.default_rng(3)
    v, u = np.mgrid[0:size, 0:size] / size
    base = ndimage.gaussian_filter(rng.random((size, size, 3)), (4, 4, 0), mode="wrap")
    base = (base - base.min()) / (base.max() - base.min())
    discs = ((np.sin(2 * np.pi * 3 * u) * np.sin(2 * np.pi * 2 * v)) > 0.4)[..., None]
    stripes = 0.15 * (np.sin(2 * np.pi * 24 * u) > 0)[..., None]
    return np.clip(0.2 + 0.5 * base * 0.6 + 0.3 * discs + stripes, 0, 1).astype(np.float32)


def _run(torus, image, settings, cache):
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool))])
    result = stylize(vertices, faces, colours, settings.replace(image_size=SIZE), uvs=uvs, cache=cache)
    covered = result.atlas.coverage.reshape(SIZE, SIZE)
    return result.image, covered


def _psnr(a, b):
    return 10 * np.log10(1.0 / np.mean((np.asarray(a, np.float64) - b) ** 2))


def test_a_run_that_changes_nothing_gives_back_the_texture(torus, cache):
    picture = _picture()
    near_zero = StylizeSettings(mode="eed", T=1e-6, spacing=0.04)
    out, covered = _run(torus, picture, near_zero, cache)
    kept = _psnr(out[covered], picture[covered])
    coarse, _ = _run(torus, picture, near_zero.replace(detail=0.0), cache)
    band_only = _psnr(coarse[covered], picture[covered])
    print(f"\ntime ~0: {kept:.1f} dB with the detail, {band_only:.1f} dB at the band's resolution")
    assert kept >= 45.0 and band_only < 35.0


def test_no_colour_outside_the_inputs_hull(torus, cache):
    # two colours with a sharp edge: tricubic overshoot would leave their segment
    red, teal = np.array([0.85, 0.15, 0.1]), np.array([0.1, 0.55, 0.6])
    v, u = np.mgrid[0:SIZE, 0:SIZE] / SIZE
    half = ((np.sin(2 * np.pi * 3 * u) * np.sin(2 * np.pi * 2 * v)) > 0)[..., None]
    image = np.where(half, red, teal).astype(np.float32)
    for mode in ("eed", "ced"):
        out, covered = _run(torus, image, StylizeSettings(mode=mode, T=5e-4, spacing=0.04), cache)
        colours = out[covered].astype(np.float64)
        s = (colours - red) @ (teal - red) / np.dot(teal - red, teal - red)
        off = np.linalg.norm(colours - (red + np.clip(s, 0, 1)[:, None] * (teal - red)), axis=1)
        assert off.max() <= 2 * TOLERANCE, mode
        assert np.ptp(s) > 0.9                      # both colours are still there


def test_denoising_beats_the_noise(torus, cache):
    picture = _picture()
    noisy = np.clip(picture + np.random.default_rng(7).normal(0, 0.1, picture.shape), 0, 1).astype(np.float32)
    out, covered = _run(torus, noisy, load_preset("denoise_eed").replace(spacing=0.02), cache)
    before, after = _psnr(noisy[covered], picture[covered]), _psnr(out[covered], picture[covered])
    print(f"\nnoisy {before:.2f} dB, Denoise (EED) {after:.2f} dB")
    assert after >= before + 3.0


def test_lay_detail_keeps_the_original_where_nothing_changed_and_drops_noise_where_it_did():
    rng = np.random.default_rng(0)
    sampled = rng.random((1000, 3)).astype(np.float32)
    original = sampled + rng.normal(0, 0.05, sampled.shape).astype(np.float32)
    np.testing.assert_allclose(lay_detail(sampled, sampled, original), original, atol=1e-6)
    changed = sampled + 0.2
    out = lay_detail(changed, sampled, original)
    # small detail (the noise) is shrunk towards the changed result
    assert np.mean(np.abs(out - changed)) < 0.5 * np.mean(np.abs(original - sampled))
    np.testing.assert_array_equal(lay_detail(changed, sampled, original, 0.0), changed)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["starry_night", "van_gogh_form", "sunflower_vase"])
def test_the_painterly_presets_keep_the_subject_in_their_palette_without_speckle(torus, cache, name):
    from cp_stylize_dev.looks import edge_survival, hue_difference, speckle

    size = 384
    picture = _picture(size)
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])
    settings = load_preset(name).replace(spacing=0.016, image_size=size)
    result = stylize(vertices, faces, colours, settings, uvs=uvs, cache=cache)
    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.016, image_size=size),
                     uvs=uvs, cache=cache)
    mask = result.atlas.coverage.reshape(size, size)
    texel = np.sqrt(0.5 * np.linalg.norm(np.cross(*np.diff(np.asarray(vertices)[faces], axis=1).transpose(1, 0, 2)),
                                         axis=1).sum() / mask.sum())
    texel *= 2.0 / 2.9                                        # the torus' diameter, 2 (1 + 0.45), is normalised to 2
    edges = edge_survival(result.image, source.image, 0.5 * settings.stroke_width / texel, mask)
    dots = speckle(result.image, mask)
    # Fidelity 0.5 brings back the picture's hues (Palette Hues, at 0, leaves them the picture's own)
    half = stylize(vertices, faces, colours, settings.replace(fidelity=0.5, hue_snap=0.0), uvs=uvs, cache=cache)
    hue, counted = hue_difference(half.image, source.image, mask)
    from cp_stylize.oklab import from_oklab, to_oklab
    from cp_stylize.palette import MUTED

    palette = np.array(settings.palette)
    palette = np.vstack([palette, from_oklab(to_oklab(palette) * [1.0, MUTED, MUTED])])   # a grey takes muted ones
    alone = stylize(vertices, faces, colours, settings.replace(fidelity=0.0), uvs=uvs, cache=cache).image[mask]
    nearest = np.min(np.linalg.norm(alone[:, None] - palette[None], axis=2), axis=1)
    print(f"\n{name}: edges {edges:.2f}, speckle {100 * dots:.3f} %, hue at fidelity 0.5 {hue:.1f} degrees "
          f"({counted} texels), distance to the palette {np.median(nearest):.3f}")
    assert edges >= 0.8 and dots <= 0.001 and hue <= 25 and counted > 1000
    assert np.median(nearest) < 0.16             # at fidelity 0: the palette's colours (muted for greys), mixed and jittered
    assert result.height is not None and result.height[mask].max() > 0.3


@pytest.mark.slow
def test_strokes_show_the_pictures_detail_finer_than_the_band_with_detail_and_not_without(torus, cache):
    size = 256
    v, u = np.mgrid[0:size, 0:size] / size
    smooth = ndimage.gaussian_filter(np.random.default_rng(5).random((size, size, 3)), (12, 12, 0), mode="wrap")
    fine = 0.12 * ((np.sin(2 * np.pi * 48 * u) * np.sin(2 * np.pi * 48 * v)) > 0)[..., None]   # 2.7 texels a square
    picture = np.clip(0.25 + 0.5 * (smooth - smooth.min()) / np.ptp(smooth) + fine, 0, 1).astype(np.float32)
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])

    def high_pass(image):
        lum = np.asarray(image, np.float64)[..., :3] @ LUMA
        return lum - ndimage.gaussian_filter(lum, 3.0, mode="wrap")

    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.04, image_size=size),
                     uvs=uvs, cache=cache)
    mask = ndimage.binary_erosion(source.atlas.coverage.reshape(size, size), iterations=4)
    settings = load_preset("starry_night").replace(spacing=0.04, image_size=size, contours=0.0)   # the strokes only
    kept, dropped = (np.corrcoef(high_pass(stylize(vertices, faces, colours, settings.replace(detail=d), uvs=uvs,
                                                   cache=cache).image)[mask], high_pass(source.image)[mask])[0, 1]
                     for d in (0.8, 0.0))
    print(f"\nthe picture's fine detail in the strokes: correlation {kept:.2f} with detail 0.8, {dropped:.2f} with 0")
    assert kept > 0.5 and dropped < 0.2


@pytest.mark.slow
def test_oil_paint_keeps_the_subject_and_paints_across_the_uv_seam(torus, cache):
    from cp_stylize_dev.looks import edge_survival, seam_step

    size = 256
    picture = _picture(size)                      # periodic in u and v: no edge where the UV map is cut
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])
    settings = load_preset("oil_paint").replace(spacing=0.016, image_size=size)
    result = stylize(vertices, faces, colours, settings, uvs=uvs, cache=cache)
    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.016, image_size=size),
                     uvs=uvs, cache=cache)
    mask = result.atlas.coverage.reshape(size, size)
    texel = 2.0 / 2.9 * 2 * np.pi * 1.0 / size        # along u at the torus's middle, normalised to a diameter of 2
    assert edge_survival(result.image, source.image, 0.5 * settings.oil_size / texel, mask) >= 0.8
    # the first and last columns meet on the surface: the paint runs on across them as it does inside
    across, inside = seam_step(result.image, np.arange(size))
    assert across <= 1.5 * inside


@pytest.mark.slow
def test_toon_keeps_the_subject_in_its_levels_with_outlines_along_its_edges(torus, cache):
    from cp_stylize.oklab import to_oklab
    from cp_stylize_dev.looks import away, edge_survival, lightness_levels, outline_coverage, seam_step

    size = 256
    # periodic in u and v, and rolled so that no stripe's edge lies on the UV seam: the seam's step is then
    # measured where the picture has none
    picture = np.roll(_picture(size), 3, axis=1)
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])
    settings = load_preset("toon").replace(spacing=0.016, image_size=size)
    result = stylize(vertices, faces, colours, settings, uvs=uvs, cache=cache)
    bare = stylize(vertices, faces, colours, settings.replace(line_width=0.0, toon_outlines=0.0), uvs=uvs, cache=cache)
    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.016, image_size=size),
                     uvs=uvs, cache=cache)
    mask = result.atlas.coverage.reshape(size, size)
    darker = to_oklab(bare.image.astype(np.float64))[..., 0] - to_oklab(result.image.astype(np.float64))[..., 0]
    assert lightness_levels(bare.image, mask & ~away(bare.image, darker), settings.toon_levels) >= 0.9
    assert outline_coverage(mask & (darker > 0.05), source.image, mask) >= 0.6
    assert edge_survival(result.image, source.image, 1.5, mask) >= 0.8
    across, inside = seam_step(result.image, np.arange(size))
    assert across <= 1.5 * inside


@pytest.mark.slow
def test_ink_hatching_keeps_the_subject_in_paper_and_ink_with_even_lines(torus, cache):
    """The Ink Hatching preset on a picture: texels on paper or ink, ink where the picture is dark, the lines'
    spacing even on the surface, the subject's edges kept at the lines' spacing, and the lines on across the
    UV seam."""
    from cp_stylize.oklab import to_oklab
    from cp_stylize.pipeline import hatch_colours
    from cp_stylize_dev.looks import (edge_survival, hatch_spacings, ink_share, kept_hatchings, paper_or_ink,
                                      seam_step, tone_correlation)

    size = 512
    picture = np.roll(_picture(size), 3, axis=1)
    vertices, faces, uvs = torus
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])
    settings = load_preset("hatching").replace(spacing=0.016, image_size=size)
    with kept_hatchings() as made:
        result = stylize(vertices, faces, colours, settings, uvs=uvs, cache=cache)
    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.016, image_size=size),
                     uvs=uvs, cache=cache)
    mask = result.atlas.coverage.reshape(size, size)
    ink, paper = hatch_colours(settings)
    assert paper_or_ink(result.image, mask, ink, paper) >= 0.8
    lightness = to_oklab(source.image[..., :3].astype(np.float64))[..., 0]
    assert tone_correlation(ink_share(result.image, ink, paper), lightness, mask) <= -0.6
    spacings = hatch_spacings(made[0], probes=200)
    assert len(spacings) > 100 and np.std(spacings) / np.mean(spacings) <= 0.3
    from cp_stylize.baking import texel_lengths

    texel = float(np.median(texel_lengths(made[0].mesh, result.atlas, result.atlas.face)))
    assert edge_survival(result.image, source.image, made[0].spacing / texel, mask) >= 0.8
    across, inside = seam_step(result.image, np.arange(size))
    assert across <= 1.5 * inside


@pytest.mark.slow
def test_watercolour_darkens_its_washes_at_their_borders_grains_them_and_keeps_the_subject(torus, cache):
    """The Watercolour preset on a picture: washes at least 15 % darker at the borders that dried hard than
    inside, granulation that shows against the same washes without it, the subject's edges kept at the
    oil paint's scale, and no step across the UV seam."""
    from cp_stylize_dev.looks import edge_survival, grain_contrast, seam_step, wash_rims

    size = 512
    vertices, faces, uvs = torus
    rng = np.random.default_rng(4)
    v, u = np.mgrid[0:size, 0:size] / size
    broad = ndimage.gaussian_filter(rng.random((size, size, 3)), (24, 24, 0), mode="wrap")   # a painting's areas
    broad = (broad - broad.min()) / (broad.max() - broad.min())
    discs = ((np.sin(2 * np.pi * 3 * u) * np.sin(2 * np.pi * 2 * v)) > 0.4)[..., None]
    picture = np.clip(0.15 + 0.6 * broad + 0.3 * discs, 0, 1).astype(np.float32)
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool))])
    settings = load_preset("watercolour").replace(spacing=0.016, image_size=size)

    def run(**changes):
        return stylize(vertices, faces, colours, settings.replace(**changes), uvs=uvs, cache=cache)

    result = run()
    hard = dict(line_width=0.0, wash_bleed=0.0, wash_granulation=0.0)
    source = stylize(vertices, faces, colours, StylizeSettings(mode="eed", T=1e-6, spacing=0.016, image_size=size),
                     uvs=uvs, cache=cache)
    mask = result.atlas.coverage.reshape(size, size)
    darker, share = wash_rims(run(**hard).image, run(**hard, wash_edges=0.0).image, mask)
    assert darker >= 0.15 and share >= 0.5
    smooth = run(wash_granulation=0.0).image
    assert grain_contrast(result.image, smooth, mask) > 3 * grain_contrast(smooth, smooth, mask)
    texel = 2.0 / 2.9 * 2 * np.pi * 1.0 / size        # along u at the torus's middle, normalised to a diameter of 2
    assert edge_survival(result.image, source.image, 0.5 * settings.oil_size / texel, mask) >= 0.8
    across, inside = seam_step(result.image, np.arange(size))
    assert across <= 1.5 * inside
