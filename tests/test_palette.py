"""A picture's colours mapped onto a painting's palette by tone and hue, and palette noise."""

import numpy as np
import pytest

from cp_stylize.oklab import hue_difference, to_oklab
from cp_stylize.palette import map_to_palette, palette_distance, palette_noise

NIGHT = ["#0b1a3a", "#1d3b72", "#3c5fc0", "#6d8fd0", "#e6b12f", "#a9c3dd", "#f3d54e"]
SUNFLOWERS = ["#3b2412", "#6a4a18", "#8a3f1c", "#b07a1e", "#5c98a0", "#d8701a", "#d99a2b", "#f0b81c", "#f7d44a",
              "#f9eaa0", "#98c8c8"]


def _rgb(colours):
    return np.array([[int(c[i:i + 2], 16) / 255 for i in (1, 3, 5)] for c in colours])


def _hsv(rgb):
    high, low = rgb.max(axis=1), rgb.min(axis=1)
    saturation = np.where(high > 0, (high - low) / np.maximum(high, 1e-12), 0.0)
    return saturation, high


def test_greys_take_the_palette_by_tone_darkest_to_darkest():
    palette = _rgb(NIGHT)
    greys = np.repeat(np.linspace(0, 1, 200)[:, None], 3, axis=1)
    out = map_to_palette(greys, palette)
    lightness = to_oklab(out)[:, 0]
    assert np.all(np.diff(lightness) >= -1e-6)                          # tones keep their order
    assert lightness[0] < to_oklab(palette)[:, 0].min() + 0.05          # black to the palette's darkest
    assert np.all(lightness <= to_oklab(palette)[:, 0].max() + 1e-6)


def test_hues_keep_to_the_palette_colours_of_their_hue():
    from cp_stylize.presets import load_preset

    starry = load_preset("starry_night")                  # its blues take most of the tones, its yellows the lights
    palette, weights = np.array(starry.palette), starry.palette_weights
    # a picture of mid greys and a yellow of the same lightness: the grey is blue, the yellow yellow
    grey, yellow = np.array([0.55, 0.55, 0.55]), np.array([0.65, 0.55, 0.1])
    picture = np.vstack([np.tile(grey, (500, 1)), np.tile(yellow, (500, 1)), np.linspace(0, 1, 1000)[:, None] * [1, 1, 1]])
    out = map_to_palette(picture, palette, weights)
    hexes = [("#%02x%02x%02x" % tuple(np.round(np.asarray(c[:3]) * 255).astype(int))) for c in palette]
    lab_blue, lab_yellow = to_oklab(palette[hexes.index("#3c5fc0")]), to_oklab(palette[hexes.index("#f3d54e")])
    assert hue_difference(to_oklab(out[0]), lab_blue) < 30
    assert hue_difference(to_oklab(out[500]), lab_yellow) < 30
    # a red takes the palette's warmest colour, not a blue
    red = map_to_palette(np.vstack([[[0.8, 0.15, 0.1]], picture]), palette, weights)[0]
    assert hue_difference(to_oklab(red), lab_yellow) < 45


def test_a_grey_of_the_picture_stays_a_muted_colour_a_coloured_one_a_strong_one():
    from cp_stylize import palette as module

    palette = _rgb(NIGHT)
    # an overcast sky's grey and a strong blue, among a picture's tones
    grey, blue = np.array([0.55, 0.55, 0.55]), np.array([0.1, 0.35, 0.9])
    picture = np.vstack([np.tile(grey, (300, 1)), np.tile(blue, (300, 1)), np.linspace(0, 1, 600)[:, None] * [1, 1, 1]])
    assert np.hypot(*to_oklab(blue)[1:]) > module.VIVID
    muted = to_oklab(map_to_palette(picture, palette))
    full = module.MUTED
    try:
        module.MUTED = 1.0
        unmuted = to_oklab(map_to_palette(picture, palette))
    finally:
        module.MUTED = full
    chroma, unmuted_chroma = np.hypot(muted[:, 1], muted[:, 2]), np.hypot(unmuted[:, 1], unmuted[:, 2])
    assert unmuted_chroma[0] > 0.05                                    # the palette gives the grey a colour ...
    assert abs(chroma[0] / unmuted_chroma[0] - module.MUTED) < 0.01     # ... at MUTED of its chroma
    assert hue_difference(muted[0], unmuted[0]) < 1                    # and of its hue
    assert abs(chroma[300] - unmuted_chroma[300]) < 1e-6               # a strong colour keeps all of it


def test_fidelity_leads_back_to_the_picture():
    rng = np.random.default_rng(1)
    picture = rng.random((5000, 3))
    palette = _rgb(NIGHT)
    np.testing.assert_allclose(map_to_palette(picture, palette, fidelity=1.0), picture, atol=1e-5)
    saturation, value = _hsv(picture)
    saturated = (saturation > 0.3) & (value > 0.15)
    half = map_to_palette(picture, palette, fidelity=0.5)
    difference = hue_difference(to_oklab(half[saturated]), to_oklab(picture[saturated]))
    print(f"\nfidelity 0.5: median hue difference {np.median(difference):.1f} degrees")
    assert np.median(difference) <= 25
    none = map_to_palette(picture, palette, fidelity=0.0)
    assert np.median(hue_difference(to_oklab(none[saturated]), to_oklab(picture[saturated]))) > 40


def test_palette_hues_turn_the_pictures_hues_to_the_palettes_nearest():
    """With Palette Hues at 1, the hues Fidelity brings back are the palette's: a grey-blue sky, between a warm
    palette's blue-green and its yellows, takes the blue-green (at no more than the palette's chroma for it)
    rather than its own hue, a lilac the palette lacks; a yellow stays yellow; at 0 the picture's hues return."""
    palette = _rgb(["#3b2412", "#3f5a26", "#5f9c8e", "#d99a2b", "#f0b81c", "#f9eaa0", "#9cc9b8"])
    lab_palette = to_oklab(palette)
    sky = np.tile([[0.55, 0.6, 0.75]], (400, 1)) + np.random.default_rng(2).normal(0, 0.01, (400, 3))
    picture = np.clip(np.concatenate([sky, np.tile([[0.8, 0.7, 0.2]], (400, 1)), np.linspace(0, 1, 400)[:, None]
                                      * np.ones((1, 3))]), 0, 1)
    own = map_to_palette(picture, palette, fidelity=0.55)
    snapped = map_to_palette(picture, palette, fidelity=0.55, hue_snap=1.0)
    to_sky = hue_difference(to_oklab(snapped[:400]), np.tile(lab_palette[2], (400, 1)))
    assert np.median(to_sky) < 10                                                 # the palette's blue-green
    assert np.median(hue_difference(to_oklab(own[:400]), to_oklab(picture[:400]))) < 10   # unsnapped: its own
    assert np.median(hue_difference(to_oklab(own[:400]), np.tile(lab_palette[2], (400, 1)))) > 45
    chroma = np.hypot(*to_oklab(snapped[:400])[:, 1:].T)
    assert np.max(chroma) <= np.hypot(*lab_palette[[2, 6], 1:].T).max() + 1e-3   # no brighter than the palette's
    yellow = to_oklab(snapped[400:800])
    assert np.median(hue_difference(yellow, np.tile(lab_palette[4], (400, 1)))) < 15
    np.testing.assert_allclose(map_to_palette(picture, palette, fidelity=0.55, hue_snap=0.0), own)
    with pytest.raises(ValueError, match=r"hue_snap must lie in \[0, 1\], got 3"):
        map_to_palette(picture, palette, hue_snap=3)


def test_palette_hues_light_a_green_with_the_palettes_yellows_and_shade_it_with_its_olive():
    """Of the palette's hues near a colour's, those of its tone count more: an even green, dark to light, takes the
    palette's olive in its darks and turns towards the yellows beside its yellow-green in its lights."""
    palette = _rgb(["#3b2412", "#3f5a26", "#9aa83a", "#5c98a0", "#d99a2b", "#f0b81c", "#f7d44a", "#98c8c8"])
    olive = np.degrees(np.arctan2(*to_oklab(palette)[1, [2, 1]]))
    lightness = np.linspace(0.3, 0.85, 600)
    green = np.column_stack([lightness, 0.06 * np.cos(np.radians(125)) * np.ones(600),
                             0.06 * np.sin(np.radians(125)) * np.ones(600)])
    from cp_stylize.oklab import from_oklab

    mapped = to_oklab(map_to_palette(np.clip(from_oklab(green), 0, 1), palette, fidelity=0.55, hue_snap=1.0))
    hue = np.degrees(np.arctan2(mapped[:, 2], mapped[:, 1]))
    darks, lights = np.median(hue[:200]), np.median(hue[400:])
    print(f"\ndarks {darks:.1f} degrees (olive {olive:.1f}), lights {lights:.1f} degrees")
    assert abs(darks - olive) < 10
    assert lights < darks - 15                       # towards the yellows (95 degrees and less)


def test_values_keep_the_pictures_own_light_and_dark():
    """With Keep Values at 1, a dark picture stays dark and a pale one pale, whatever share of the tones the
    weights give the palette's colours; at 0 the tones are spread over the palette by rank."""
    palette = _rgb(NIGHT)
    palette_lightness = to_oklab(palette)[:, 0]
    # a dark picture: most of it near-black ground, a few mid tones
    rng = np.random.default_rng(3)
    grey = np.concatenate([rng.uniform(0.05, 0.15, 900), rng.uniform(0.3, 0.6, 100)])
    picture = np.repeat(grey[:, None], 3, axis=1)
    own = to_oklab(picture)[:, 0]
    kept = to_oklab(map_to_palette(picture, palette, keep_values=1.0))[:, 0]
    spread = to_oklab(map_to_palette(picture, palette, keep_values=0.0))[:, 0]
    inside = (own > palette_lightness.min() + 0.02) & (own < palette_lightness.max() - 0.02)
    assert inside.sum() > 50
    assert np.max(np.abs(kept[inside] - own[inside])) < 0.03      # the picture's lightness where the palette has it
    assert np.all(kept >= palette_lightness.min() - 0.03)              # and the palette's range elsewhere
    assert np.median(spread) > np.median(kept) + 0.1                   # equalised, the dark ground would be lifted
    assert np.corrcoef(own, kept)[0, 1] > 0.97                          # (the ground below the palette is clamped)
    with pytest.raises(ValueError, match=r"keep_values must lie in \[0, 1\], got -1"):
        map_to_palette(picture, palette, keep_values=-1)


def test_keep_darks_keeps_the_pictures_darks_and_leaves_its_lights_to_the_palette():
    """Keep Darks keeps more of the picture's own lightness the darker a tone ranks: a mostly dark picture's
    darks, lifted by a partial Keep Values, come back down towards their own lightness, while its lightest tones
    map as they did."""
    palette = _rgb(SUNFLOWERS)
    rng = np.random.default_rng(5)
    grey = np.concatenate([rng.uniform(0.08, 0.2, 600), rng.uniform(0.25, 0.5, 300), rng.uniform(0.7, 0.9, 100)])
    picture = np.repeat(grey[:, None], 3, axis=1)
    own = to_oklab(picture)[:, 0]
    even = to_oklab(map_to_palette(picture, palette, keep_values=0.4))[:, 0]
    darks = to_oklab(map_to_palette(picture, palette, keep_values=0.4, keep_darks=1.0))[:, 0]
    dark, light = own < np.quantile(own, 0.6), own > np.quantile(own, 0.95)
    floor = np.maximum(own, to_oklab(palette)[:, 0].min())      # no darker than the palette's darkest
    # in the darks, a quarter or more of the lift Keep Values left is gone (a third, 0.10 against 0.15) ...
    lift, lift_even = np.median(darks[dark] - floor[dark]), np.median(even[dark] - floor[dark])
    assert lift < 0.75 * lift_even, (lift, lift_even)
    # ... and the lightest tones keep the palette's light colours: within 0.02 of where they went without it
    assert np.max(np.abs(darks[light] - even[light])) < 0.02
    assert np.corrcoef(own, darks)[0, 1] > np.corrcoef(own, even)[0, 1]
    np.testing.assert_array_equal(map_to_palette(picture, palette, keep_values=0.4, keep_darks=0.0),
                                  map_to_palette(picture, palette, keep_values=0.4))
    with pytest.raises(ValueError, match=r"keep_darks must lie in \[0, 1\], got 2"):
        map_to_palette(picture, palette, keep_darks=2)


def test_a_palette_needs_colours_and_weights_not_all_zero():
    with pytest.raises(ValueError, match=r"palette weights must be 2 non-negative numbers, not all zero"):
        map_to_palette(np.zeros((3, 3)), [[0, 0, 0], [1, 1, 1]], [0, 0])
    with pytest.raises(ValueError, match=r"fidelity must lie in \[0, 1\], got 2"):
        map_to_palette(np.zeros((3, 3)), [[0, 0, 0]], fidelity=2)


def test_palette_noise_replaces_the_share_asked_by_colours_near_their_own():
    rng = np.random.default_rng(2)
    picture = rng.random((20000, 3)).astype(np.float32)
    palette = _rgb(NIGHT)
    out = palette_noise(picture, 0.4, palette, spread=0.0, seed=3)
    changed = np.any(out != picture, axis=1)
    assert abs(changed.mean() - 0.4) < 0.02
    # spread 0: the nearest palette colour (OKLab, hue first) of each changed colour
    distance = palette_distance(to_oklab(picture[changed])[:, None], to_oklab(palette)[None])
    np.testing.assert_allclose(out[changed], palette[np.argmin(distance, axis=1)], atol=1e-6)
    np.testing.assert_array_equal(out, palette_noise(picture, 0.4, palette, spread=0.0, seed=3))   # seeded


def test_tone_ranks_spread_the_tones_but_keep_a_flat_region_one_tone():
    from cp_stylize.palette import tone_ranks

    rng = np.random.default_rng(4)
    spread = rng.random(100000) ** 3                       # a dark picture: ranks spread it over [0, 1]
    ranks = tone_ranks(spread)
    assert np.all(np.diff(ranks[np.argsort(spread)]) >= 0)
    assert 0.25 < np.median(ranks) < 0.5                  # towards even, its slope limited (median: 0.125)
    flat = 0.4 + 1e-6 * rng.standard_normal(100000)        # one colour, up to rounding
    assert np.ptp(tone_ranks(flat)) < 1e-3
    # half the picture in one flat tone: it takes no more than its share's limit of the ranks
    mixed = np.concatenate([np.full(50000, 0.3), rng.random(50000)])
    r = tone_ranks(mixed)
    assert np.ptp(r[:50000]) == 0 and np.all(np.diff(np.sort(r)) <= 4.0 / 256 + 1e-9)


def test_fidelity_above_a_half_brings_back_a_muted_pictures_lightness_not_its_dull_chroma_when_hues_snap():
    from cp_stylize.oklab import from_oklab

    palette = _rgb(["#3b2412", "#5c98a0", "#d99a2b", "#f0b81c", "#f9eaa0"])
    khaki = from_oklab(np.array([[0.55, 0.0, 0.03], [0.75, 0.004, 0.04], [0.85, 0.0, 0.035]]))  # dull yellows
    chroma = {}
    for fidelity in (0.5, 0.6, 0.8):
        lab = to_oklab(map_to_palette(khaki, palette, fidelity=fidelity, hue_snap=1.0))
        chroma[fidelity] = np.hypot(lab[:, 1], lab[:, 2])
        assert np.all(hue_difference(lab, to_oklab(_rgb(["#f0b81c"]))) < 25)         # the palette's yellow hue
    # the lighter two keep their chroma; the dark one loses only what the gamut takes as its own lightness
    # comes back (about 0.13 of chroma at a yellow's lightness 0.55), far from khaki's 0.03
    assert np.all(chroma[0.6][1:] > chroma[0.5][1:] - 2e-3) and np.all(chroma[0.8][1:] > chroma[0.5][1:] - 2e-3)
    assert chroma[0.6][0] > 0.12 and chroma[0.8][0] > 0.12
    assert np.all(chroma[0.5] > 0.08)                                                # a yellow, not khaki
    lab = to_oklab(map_to_palette(khaki, palette, fidelity=1.0, hue_snap=1.0))
    assert np.allclose(lab[:, 0], to_oklab(khaki)[:, 0], atol=5e-3)     # its own lightness at 1 (in the gamut)
    plain = to_oklab(map_to_palette(khaki, palette, fidelity=1.0))                     # without snapping, its own
    assert np.allclose(plain, to_oklab(khaki), atol=1e-3)                            # colours at 1
