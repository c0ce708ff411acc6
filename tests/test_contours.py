"""Contour lines along the picture's strong edges, on the surface."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.contours import contour_field, ink_colour, line_strength, line_width, thin_lines
from cp_stylize.oklab import from_oklab, hue_difference, to_oklab


@pytest.fixture(scope="module")
def band():
    return Band.build(Sphere(1.0), 0.03)


def test_lines_lie_along_edges_and_nowhere_on_flat_colour(band):
    z = band.cp[:, 2]
    colours = np.where((z > 0.3)[:, None], [0.9, 0.85, 0.7], [0.15, 0.2, 0.35]).astype(np.float32)  # a light cap
    lines = line_strength(contour_field(band, colours, line_width(0.04, band.h)))
    on_edge = (z > 0.28) & (z < 0.32)                                # both sides of it: the edge stays put
    near, far = (z > 0.35) & (z < 0.4), (z > 0.2) & (z < 0.24)
    flat = np.abs(z) < 0.2
    assert np.median(lines[on_edge]) > 0.9
    assert np.median(lines[near]) < 0.05 and np.median(lines[far]) < 0.05
    assert lines[flat].max() == 0
    assert ((lines > 0.05) & (lines < 0.95)).any()                  # ink ramps in: lines are anti-aliased


def test_lines_follow_the_edges_direction_and_a_faint_picture_draws_none(band):
    z = band.cp[:, 2]
    colours = np.where((z > 0.3)[:, None], 0.9, 0.15).astype(np.float32) * np.ones((1, 3), np.float32)
    along = np.cross(band.cp, [0.0, 0.0, 1.0])                       # the parallels: along the edge
    along /= np.maximum(np.linalg.norm(along, axis=1, keepdims=True), 1e-12)
    smooth = line_strength(contour_field(band, colours, line_width(0.04, band.h), along))
    assert np.median(smooth[(z > 0.28) & (z < 0.32)]) > 0.9           # the line stays where it was
    faint = 0.5 + 0.002 * (colours - 0.5)                            # an edge far below the floor
    assert line_strength(contour_field(band, faint, line_width(0.04, band.h))).max() == 0


def test_lines_are_as_wide_as_the_band_can_hold_and_drawn_in_the_palettes_darkest():
    assert line_width(0.04, 0.008) == pytest.approx(0.01)
    assert line_width(0.004, 0.008) == pytest.approx(0.006)         # no finer than 0.75 spacings
    ink = ink_colour([[0.9, 0.9, 0.2], [0.05, 0.1, 0.3], [0.5, 0.5, 0.5]])       # the darkest, darker still
    assert to_oklab(ink)[0] == pytest.approx(0.6 * to_oklab([0.05, 0.1, 0.3])[0], rel=1e-3)
    assert hue_difference(to_oklab(ink), to_oklab([0.05, 0.1, 0.3])) < 5
    assert ink_colour([]) is None


def _thin(image, radius=2.0):
    size = image.shape[0]
    flat = np.arange(size * size)
    return thin_lines(image.ravel(), flat, size, radius).reshape(size, size)


@pytest.mark.parametrize("angle", [0.0, 30.0, 45.0, 75.0])
def test_thin_lines_ink_a_thin_dark_line_in_any_direction_but_not_a_broad_dark_form(angle):
    size = 96
    y, x = np.mgrid[:size, :size] - size / 2 + 0.5
    t = np.radians(angle)
    across = np.abs(-np.sin(t) * x + np.cos(t) * y)
    image = np.full((size, size), 0.8, dtype=np.float32)
    image[across < 1.0] = 0.35                                  # a crane's jib: two texels wide, across the picture
    image[(np.abs(x + 25) < 12) & (np.abs(y - 25) < 12) & (across > 6)] = 0.3     # a broad dark block
    ink = _thin(image)
    middle = (np.hypot(x, y) < 30) & (np.hypot(x + 25, y - 25) > 20)
    assert ink[(across < 0.6) & middle].min() > 0.8            # the line is inked along its whole length
    assert ink[(across > 5) & middle].max() < 0.05             # and nowhere beside it
    block = (np.abs(x + 25) < 8) & (np.abs(y - 25) < 8) & (across > 10)
    assert ink[block].max() < 0.05                             # a broad form is the dabs', not a line's


def test_thin_lines_leave_dots_and_faint_lines_to_the_dabs():
    size = 96
    rng = np.random.default_rng(3)
    image = np.full((size, size), 0.8, dtype=np.float32)
    for cy in range(8, size - 8, 12):                           # the gaps between a tree's leaves, 12 texels apart
        for cx in range(8, size - 8, 12):
            y, x = (cy, cx) + rng.integers(-2, 3, 2)
            image[y - 1:y + 2, x - 1:x + 2] = 0.3
    assert _thin(image).max() < 0.2
    faint = np.full((size, size), 0.8, dtype=np.float32)
    faint[:, 47:49] = 0.8 - 0.02                                 # a line fainter than FINE_START
    assert _thin(faint).max() == 0.0


def test_thin_lines_in_a_busy_canopy_are_left_to_the_dabs_but_not_the_twig_against_the_sky(monkeypatch):
    from scipy import ndimage

    from cp_stylize import contours

    size = 128
    rng = np.random.default_rng(5)
    y, x = np.mgrid[:size, :size]
    canopy = x < size // 2
    # leaves: lightness varying by about 0.12 over a few texels, the gaps between them darker by 0.2
    leaves = 0.55 + 0.12 * ndimage.gaussian_filter(rng.standard_normal((size, size)), 2.0) / 0.14
    image = np.where(canopy, leaves, 0.8).astype(np.float32)
    for _ in range(60):
        cy, cx = rng.integers(6, size - 6), rng.integers(6, size // 2 - 10)
        angle = rng.uniform(0, np.pi)
        for t in np.linspace(-5, 5, 21):
            image[int(round(cy + t * np.sin(angle))), int(round(cx + t * np.cos(angle)))] -= 0.2
    image[size // 2 - 1:size // 2 + 1, size // 2 + 12:size - 8] = 0.45          # a twig in the sky
    ink = _thin(image)
    assert ink[:, 8:size // 2 - 8].mean() < 0.06                    # the canopy's gaps: hardly a trace
    assert ink[size // 2 - 1:size // 2 + 1, size // 2 + 20:size - 16].min() > 0.8     # the twig: drawn whole
    sky = (x > size // 2 + 8) & (np.abs(y - size // 2) > 5)
    assert ink[sky].max() < 0.05
    monkeypatch.setattr(contours, "FINE_STANDOUT", (-2.0, -1.0))   # by depth alone, the gaps are lines
    assert _thin(image)[:, 8:size // 2 - 8].mean() > 0.2


def test_a_thin_line_is_drawn_as_wide_as_the_brush_asked_for():
    size = 96
    y, x = np.mgrid[:size, :size] - size / 2 + 0.5
    image = np.full((size, size), 0.8, dtype=np.float32)
    image[np.abs(y - 0.5) < 0.1] = 0.35                         # a hairline, one texel wide, along the rows
    flat = np.arange(size * size)
    middle = np.abs(x) < 30

    def inked_rows(width):
        ink = thin_lines(image.ravel(), flat, size, 2.0, width).reshape(size, size)
        return int(np.sum(ink[:, size // 2] > 0.5)), ink

    hairline, _ = inked_rows(1.0)
    brushed, ink = inked_rows(7.0)
    assert hairline <= 3                                        # the picture's own line, anti-aliased
    assert 7 <= brushed <= 9                                    # a brush's line, seven texels wide
    assert ink[(np.abs(y) < 3) & middle].min() > 0.5            # whole along its length
    assert ink[(np.abs(y) > 6) & middle].max() < 0.05           # and no wider
    # several widths at once, as a brush's pressure swells and eases along a line: each as drawn alone
    both = thin_lines(image.ravel(), flat, size, 2.0, [3.0, 7.0])
    assert both.shape == (2, size * size)
    assert np.array_equal(both[1].reshape(size, size), ink)
    assert np.all(both[0] <= both[1]) and int(np.sum(both[0].reshape(size, size)[:, size // 2] > 0.5)) <= 5


def test_a_line_is_painted_in_a_dark_paint_of_the_colour_under_it():
    from cp_stylize.painting import LINE_HUE, Painting

    ink = ink_colour([[0.05, 0.1, 0.3], [0.9, 0.8, 0.3]])
    lines = Painting(None, None, ink=ink)
    under = np.array([[0.2, 0.6, 0.2], [0.95, 0.8, 0.2], [0.5, 0.5, 0.5]])      # leaves, a yellow sky, a grey
    full = to_oklab(lines._inked(under, np.ones(3)))
    assert np.allclose(full[:, 0], to_oklab(ink)[0], atol=1e-6)             # as dark as the ink
    assert hue_difference(full[0], full[1]) > 60                           # a deep green, a dark umber
    # the ink's chroma and LINE_HUE of the colour's under it, lowered where a dark colour leaves sRGB's gamut
    expected = to_oklab(ink)[1:] + LINE_HUE * (to_oklab(under)[:, 1:] - to_oklab(ink)[1:])
    assert np.all(hue_difference(full, np.column_stack([full[:, 0], expected])) < 1.0)
    assert np.all(np.hypot(*full[:, 1:].T) <= np.hypot(*expected.T) + 1e-6)
    assert np.array_equal(lines._inked(under, np.zeros(3)), under)           # no line, no change
    half = lines._inked(under, np.full(3, 0.5))
    assert np.allclose(half, 0.5 * (under + from_oklab(full)), atol=1e-6)
    plain = Painting(None, None)._inked(under, np.ones(3))                    # without a palette, darkened
    assert np.allclose(plain, 0.25 * under)
