import numpy as np
import pytest
from scipy.spatial import ConvexHull

from cp_stylize.colours import TOLERANCE, ColourHull, distinct_colours


def _excess(points, colours):
    hull = ConvexHull(colours)
    return np.max(points @ hull.equations[:, :3].T + hull.equations[:, 3], axis=1)


def test_colours_inside_pass_bit_identical_and_outside_land_on_the_hull():
    rng = np.random.default_rng(0)
    source = rng.random((500, 3)) * [0.6, 0.5, 0.4] + [0.2, 0.1, 0.3]
    hull = ColourHull(source)
    values = rng.random((20000, 3)).astype(np.float32)
    out = hull.limit(values)
    assert out.dtype == np.float32 and out.shape == values.shape
    inside = _excess(values.astype(np.float64), source) <= 0
    assert inside.sum() > 100 and (~inside).sum() > 1000
    np.testing.assert_array_equal(out[inside], values[inside])
    assert _excess(out.astype(np.float64), source).max() <= 2 * TOLERANCE   # the tolerance, and 8 bits' rounding
    # a colour just outside moves towards the centre, by no more than it was outside (plus the rounding)
    moved = np.linalg.norm(out - values, axis=1)
    beyond = np.maximum(_excess(values.astype(np.float64), source), 0)
    assert np.all(moved[~inside] >= beyond[~inside] - 2 * TOLERANCE)


def test_two_colours_give_their_segment_not_a_box():
    red, green = np.array([0.9, 0.1, 0.1]), np.array([0.1, 0.8, 0.2])
    t = np.linspace(0, 1, 50)[:, None]
    hull = ColourHull(red + t * (green - red))
    overshoot = np.array([[1.0, 0.0, 0.0], [0.5, 0.5, 0.15], [1.0, 1.0, 0.0], [0.0, 1.0, 0.3]])
    out = hull.limit(overshoot)
    # every result lies on the segment between the two colours
    s = (out - red) @ (green - red) / np.dot(green - red, green - red)
    assert np.all((s >= -TOLERANCE) & (s <= 1 + TOLERANCE))
    np.testing.assert_allclose(out, red + s[:, None] * (green - red), atol=TOLERANCE)
    np.testing.assert_array_equal(hull.limit(red[None]), red[None])


def test_a_few_colours_off_a_photographs_plane_keep_their_own_direction():
    # a photograph's many colours lie near one plane (greys, a blue sky, a yellow road marking), a
    # palette's few lie off it: the hull holds them as they are, and the colours they mix to
    rng = np.random.default_rng(4)
    grey = rng.random((40000, 1))
    tint = (rng.random((40000, 1)) - 0.5) * 0.3
    photo = np.clip(grey + tint * np.array([[-0.5, -0.2, 0.7]]) + rng.normal(0, 0.002, (40000, 3)), 0, 1)
    palette = np.array([[0.06, 0.19, 0.12], [0.11, 0.35, 0.24], [0.31, 0.49, 0.17], [0.54, 0.66, 0.23]])
    hull = ColourHull(np.vstack([photo, palette]))
    np.testing.assert_allclose(hull.limit(palette), palette, atol=TOLERANCE)
    green = 0.5 * (palette[1] + palette[2])
    np.testing.assert_allclose(hull.limit(green[None]), green[None], atol=TOLERANCE)


def test_one_colour_and_bad_input():
    assert np.allclose(ColourHull([[0.2, 0.4, 0.6]] * 3).limit(np.random.default_rng(1).random((5, 3))),
                       [0.2, 0.4, 0.6], atol=TOLERANCE)
    with pytest.raises(ValueError, match="colours must have shape"):
        ColourHull(np.zeros(3))
    with pytest.raises(ValueError, match="no finite colour"):
        ColourHull([[np.nan, 0, 0]])


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_an_images_distinct_colours_have_the_hull_of_its_pixels(channels, monkeypatch):
    from cp_stylize import colours

    rng = np.random.default_rng(3)
    image = rng.random((300, 200, channels)).astype(np.float32) * 0.8 + 0.1
    image[5, 7] = np.nan                                     # not a colour: left out, as the hull leaves it out
    pixels = image.reshape(-1, channels)
    expected = np.unique(np.clip(np.round(pixels[np.isfinite(pixels).all(axis=1)] * 255), 0, 255), axis=0)
    monkeypatch.setattr(colours, "_PIXELS", 7919)              # rounded in many chunks, as a large image is
    distinct = distinct_colours(image)
    np.testing.assert_array_equal(np.unique(distinct * 255, axis=0), expected)
    values = rng.random((5000, channels)).astype(np.float32)
    np.testing.assert_array_equal(ColourHull(distinct).limit(values), ColourHull(pixels).limit(values))
