"""OKLab: the perceptual colour space colours are mapped and compared in."""

import numpy as np

from cp_stylize.oklab import from_oklab, hue_difference, to_oklab


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
