"""The picture's thin lines laid as a rigger's dabs (cp_stylize.rigger)."""

import numpy as np
import pytest

from cp_stylize.rigger import HELD, LENGTH, line_dabs

SIZE = 120
TEXEL = 0.01


def _plane(ink, run=0.0):
    """Texels of a flat square (SIZE x SIZE, TEXEL apart) with ``ink`` (SIZE, SIZE), and the dabs laid on it
    by a brush two texels wide, on lines that run on at least ``run``."""
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    points = np.column_stack([cols.ravel() * TEXEL, rows.ravel() * TEXEL, np.zeros(SIZE * SIZE)])
    normals = np.tile([0.0, 0.0, 1.0], (SIZE * SIZE, 1))
    m = SIZE * SIZE
    return points, line_dabs(ink.ravel(), points, normals, np.zeros(m, np.int64), np.tile([1.0, 0, 0], (m, 1)),
                             np.zeros(m, np.int64), np.full(m, 2 * TEXEL), seed=3, layer=4, run=run)


@pytest.mark.parametrize("angle", [0.0, 0.4, 1.1, np.pi / 2])
def test_dabs_lie_along_a_thin_line_and_cover_it_end_to_end(angle):
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    centre = np.array([SIZE / 2, SIZE / 2])
    along = np.array([np.cos(angle), np.sin(angle)])
    offset = np.stack([cols - centre[0], rows - centre[1]], -1)
    t = offset @ along
    off = np.abs(offset @ np.array([-along[1], along[0]]))
    ink = ((off <= 1.0) & (np.abs(t) <= 45)).astype(float)            # a line 3 texels wide, 90 long
    points, (dabs, at, strength) = _plane(ink)
    assert dabs is not None and len(dabs) >= 4
    direction = np.array([along[0], along[1], 0.0])
    assert np.all(np.abs(dabs.direction @ direction) > 0.98)             # along the line
    assert np.all(ink.ravel()[at] >= HELD) and np.allclose(strength, 1.0)  # centred on it, fully inked
    assert np.all(dabs.length <= LENGTH * 2 * TEXEL + 1e-9) and np.all(dabs.layer == 4)
    # every texel of the line lies within some dab's length and width
    line = points[ink.ravel() > 0]
    delta = line[:, None, :] - dabs.centre[None]
    a = np.abs(np.einsum("mnk,nk->mn", delta, dabs.direction)) <= 0.5 * dabs.length + TEXEL
    b = np.abs(np.einsum("mnk,nk->mn", delta, np.cross(dabs.normal, dabs.direction))) <= 1.5 * TEXEL
    assert np.all(np.any(a & b, axis=1))


def test_dabs_turn_with_a_curved_line():
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    x, y = cols - SIZE / 2, rows - SIZE / 2
    ink = (np.abs(np.hypot(x, y) - 45) <= 1.0).astype(float)        # a ring 45 texels in radius
    points, (dabs, at, _) = _plane(ink)
    radial = dabs.centre[:, :2] - (SIZE / 2) * TEXEL
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    assert len(dabs) >= 12 and np.all(np.abs(np.einsum("ij,ij->i", dabs.direction[:, :2], radial)) < 0.2)


def test_a_blot_and_faint_ink_lay_no_dabs():
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    blot = (np.hypot(cols - 60, rows - 60) <= 8).astype(float)        # a round blot 17 texels across
    assert _plane(blot)[1][0] is None
    faint = np.where(np.abs(rows - 60) <= 1, 0.4, 0.0)                 # a line too faint to hold
    assert _plane(faint)[1][0] is None


def test_a_fleck_too_short_to_be_a_line_lays_no_dabs():
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    fleck = ((np.abs(rows - 60) <= 1) & (np.abs(cols - 60) <= 4)).astype(float)   # 9 texels: under 6 widths
    assert _plane(fleck)[1][0] is None
    dash = ((np.abs(rows - 60) <= 1) & (np.abs(cols - 60) <= 8)).astype(float)    # 17 texels: a line
    assert _plane(dash)[1][0] is not None


def test_a_line_is_laid_only_where_it_runs_on_as_far_as_asked():
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    mast = (np.abs(cols - 30) <= 1) & (np.abs(rows - 60) <= 45)             # 91 texels long
    twig = (np.abs(rows - 60) <= 1) & (np.abs(cols - 90) <= 10)             # 21 texels long
    _, (dabs, _, _) = _plane((mast | twig).astype(float), run=50 * TEXEL)
    assert dabs is not None and np.all(np.abs(dabs.centre[:, 0] - 0.30) < 3 * TEXEL)    # the mast alone
    _, (dabs, _, _) = _plane((mast | twig).astype(float))
    assert np.any(np.abs(dabs.centre[:, 0] - 0.90) < 12 * TEXEL)                        # both, by default


def test_the_short_dashes_of_a_busy_texture_lay_no_line_however_many():
    rows, cols = np.mgrid[0:SIZE, 0:SIZE]
    rng = np.random.default_rng(4)
    ink = np.zeros((SIZE, SIZE))
    for _ in range(60):                     # dashes 13 texels long, every which way, close together
        y, x, angle = rng.uniform(15, SIZE - 15), rng.uniform(15, SIZE - 15), rng.uniform(0, np.pi)
        t = np.clip(np.arange(-6, 7), -6, 6)
        ink[np.round(y + t * np.sin(angle)).astype(int), np.round(x + t * np.cos(angle)).astype(int)] = 1.0
    assert _plane(ink, run=40 * TEXEL)[1][0] is None
