"""OKLab: the perceptual colour space colours are mapped and compared in."""

import numpy as np
import pytest

from cp_stylize.oklab import from_oklab, hue_difference, to_oklab, within_gamut


def test_round_trip_gives_the_colours_back():
    rng = np.random.default_rng(0)
    colours = rng.random((10000, 3))
    np.testing.assert_allclose(from_oklab(to_oklab(colours)), colours, atol=2e-6)


def test_reference_values():
    # Ottosson's published values: white, and the sRGB primaries
    np.testing.assert_allclose(to_oklab([1.0, 1.0, 1.0]), [1.0, 0.0, 0.0], atol=2e-4)
    np.testing.assert_allclose(to_oklab([0.0, 0.0, 0.0]), [0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(to_oklab([1.0, 0.0, 0.0]), [0.6280, 0.2249, 0.1258], atol=2e-4)
    np.testing.assert_allclose(to_oklab([0.0, 0.0, 1.0]), [0.4520, -0.0325, -0.3115], atol=2e-4)


def test_hue_difference_is_an_angle_between_0_and_180():
    red, yellow, blue = to_oklab([[1, 0, 0], [1, 1, 0], [0, 0, 1]])
    assert 0 < hue_difference(red, yellow) < 90
    assert hue_difference(yellow, blue) > 150
    assert hue_difference(red, red) == 0


def test_within_gamut_lowers_only_the_chroma_and_only_as_far_as_sRGB_needs():
    rng = np.random.default_rng(4)
    inside = to_oklab(rng.random((200, 3)))
    assert np.allclose(within_gamut(inside), inside, atol=1e-12)          # colours of sRGB stay as they are
    dark_green = np.array([0.15, -0.12, 0.09])                             # far beyond sRGB at that lightness
    kept = within_gamut(dark_green)
    assert kept[0] == dark_green[0] and hue_difference(kept, dark_green) < 1e-9
    assert 0.2 * np.hypot(*dark_green[1:]) < np.hypot(*kept[1:]) < np.hypot(*dark_green[1:])
    assert np.allclose(to_oklab(from_oklab(kept)), kept, atol=1e-3)      # it round-trips: it is inside
    more = within_gamut(np.array([0.15, -0.12 * 1.05, 0.09 * 1.05]))        # the boundary: as far as it can go
    assert np.hypot(*more[1:]) == pytest.approx(np.hypot(*kept[1:]), rel=1e-3)
