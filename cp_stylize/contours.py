"""Contour lines along the picture's strong edges, drawn on the surface.

A painter outlines the forms that carry the subject: a silhouette, a
window, a road marking.  The lines here follow the size of the colours'
lightness gradient after a Gaussian on the surface, as edge-based
abstraction does (Winnemöller, Olsen and Gooch, "Real-time video
abstraction", SIGGRAPH 2006), smoothed along the edges' own direction so that
broken edges join into lines (Kang, Lee and Chui, "Coherent line drawing",
NPAR 2007):

- ``D = |grad (G_s * L)|`` on the band, ``L`` the OKLab lightness and
  ``G_s`` the band's 3-D Gaussian of deviation ``s`` (a surface Gaussian to
  second order), by central differences: largest on the edge itself and zero
  on flat colour, so that the line straddles the edge (half of it shows on
  the light side of a dark form, where a line on the dark side would not,
  and the edge does not move);
- ``D`` averaged along the stroke field (the edges' tangent) over a few
  deviations, which keeps lines and drops speckle;
- a line where ``D`` is large against the picture's own edges (its 99th
  percentile, so that a faint picture still has its strongest edges drawn),
  with a smooth ramp: lines are anti-aliased by construction.

Lines are as wide as about two and a half deviations ``s``; :func:`line_width`
ties ``s`` to the finest strokes and the band's spacing.
"""

from __future__ import annotations

import numpy as np

from .arrays import aligned, smooth_step
from .oklab import from_oklab, to_oklab
from .smoothing import GaussianSmoother, taper
from .structure import grid_gradients

__all__ = ["contour_field", "line_strength", "line_width", "ink_colour", "thin_lines"]

#: A line starts where D reaches this share of its 99th percentile, and is full at three times it.
LINE_START = 0.25
#: The smallest 99th percentile of D taken (OKLab lightness across a deviation): flatter pictures draw
#: no lines.
LINE_FLOOR = 0.01
#: Steps of the averaging along the edges, each way, each half a deviation long.
FLOW_STEPS = 4


def line_width(stroke_width, spacing):
    """The Gaussian deviation ``s`` of contour lines for strokes ``stroke_width`` wide on a band of
    ``spacing``: a quarter of the stroke width, and no less than 0.75 spacings (finer, the band
    cannot hold the Gaussian)."""
    return max(0.25 * stroke_width, 0.75 * spacing)


def contour_field(band, colours, deviation, directions=None):
    """The line field ``D`` (N,) of band colours (N, 3): the gradient of their OKLab lightness smoothed
    at ``deviation`` (object units), averaged along ``directions`` (N, 3) where given, divided by
    its 99th percentile over the band points the interpolation reads (see the module's notes)."""
    lightness = np.ascontiguousarray(to_oklab(np.asarray(colours).reshape(band.size, -1)[:, :3])[:, 0],
                                     dtype=np.float32)
    smooth = GaussianSmoother(band, 0.5 * deviation**2, weights=taper(band.dist, band.width))(lightness[None, :])[0]
    # lightness across a deviation
    field = np.sqrt(sum((D @ smooth) ** 2 for D in grid_gradients(band, np.float32))) * deviation
    if directions is not None:
        field = _along(band, field, directions, 0.5 * deviation)
    scale = max(float(np.quantile(field[band.inner] if band.inner is not None else field, 0.99)), LINE_FLOOR)
    return (field / scale).astype(np.float32)


def _along(band, field, directions, step):
    """``field`` (N,) averaged over :data:`FLOW_STEPS` steps of ``step`` each way along ``directions``
    (N, 3) from the closest point of every band point the interpolation reads (``band.inner``),
    reading the nearest band point at each step and keeping to the tangent plane of its closest
    point."""
    from .tangent import surface_normals

    normals = surface_normals(band)
    read = np.flatnonzero(band.inner) if band.inner is not None else np.arange(band.size)  # what is interpolated
    total = field[read].astype(np.float64)
    count = np.ones(len(read))
    for sign in (1.0, -1.0):
        x = band.cp[read].copy()
        heading = sign * np.asarray(directions[read], dtype=np.float64)
        for _ in range(FLOW_STEPS):
            x += step * heading
            g = band.nearest(x)
            inside = g >= 0
            g = np.where(inside, g, 0)
            total += np.where(inside, field[g], 0.0)
            count += inside
            ahead = np.asarray(directions[g], dtype=np.float64)
            heading = aligned(ahead, heading)
            x -= np.einsum("ij,ij->i", x - band.cp[g], normals[g])[:, None] * normals[g]
    out = field.astype(np.float64, copy=True)
    out[read] = total / count
    return out


def line_strength(field):
    """How much ink (M,) in [0, 1] lies where the line field (see :func:`contour_field`) is ``field``."""
    return np.clip((np.asarray(field) - LINE_START) / (2.0 * LINE_START), 0.0, 1.0)


#: Lines are drawn in the palette's darkest colour made darker still: this share of its lightness.
INK_LIGHTNESS = 0.6


def ink_colour(palette):
    """The colour lines are drawn in: the palette's darkest, darker still (sRGB), or None without a palette
    (then lines darken the colour under them)."""
    if palette is None or len(palette) == 0:
        return None
    lab = to_oklab(np.asarray(palette, dtype=np.float64)[:, :3])
    darkest = lab[int(np.argmin(lab[:, 0]))] * [INK_LIGHTNESS, 1.0, 1.0]
    return from_oklab(darkest)


#: Thin lines (:func:`thin_lines`) start where the picture is this much darker (OKLab lightness) than
#: its surroundings, and are full at FINE_FULL.
FINE_START = 0.03
FINE_FULL = 0.06
#: A thin feature is drawn only where it runs on as a line at least this many ``radius`` long (the
#: largest opening of its depth by segments in :data:`FINE_ANGLES` directions): the gaps between a
#: tree's leaves, dots too, are left to the dabs.
FINE_LENGTH = 4.0
FINE_ANGLES = 8
#: The depth is smoothed by a Gaussian of this many texels first: the dots of a lattice or of a line
#: sampled across texels join into one line.
FINE_JOIN = 0.8
#: A line is drawn only where it stands out from the picture's own variation about it, as a painter
#: draws a twig against the sky or a crane's jib with a rigger and masses the gaps in a canopy or the
#: cracks in gravel with the brush: its depth over the local spread of the picture with its thin features
#: filled in (the closing, less its Gaussian of FINE_TREND ``radius`` so that a smooth glow is calm, in a
#: Gaussian window of FINE_CALM ``radius``, the calmest within FINE_BESIDE ``radius``; FINE_QUIET is the
#: spread of a calm sky's grain) must reach FINE_STANDOUT[0], and the line is whole from
#: FINE_STANDOUT[1].  The calmest near by: a mast standing up from a roof is measured against the sky
#: beside it, not against the roof's edge.  Inside a canopy every window is busy.
FINE_STANDOUT = (1.5, 2.5)
FINE_TREND = 2.0
FINE_CALM = 4.0
FINE_BESIDE = 2.0
FINE_QUIET = 0.005


def thin_lines(lightness, flat, size, radius, width=1.0):
    """How much ink (M,) in [0, 1] the picture's thin dark features take at the atlas texels ``flat``
    (M,) of a ``size`` square atlas, from the picture's OKLab ``lightness`` (M,) there: a crane's jib,
    a fence post, a mast, a window's bars, too thin for the finest dab to carry.  Each is drawn at least
    ``width`` texels wide, as a fine brush draws a line, not at the picture's own hairline.

    A feature is thin where a morphological closing by a disc of ``radius`` texels fills it in (a
    black top-hat): the depth it fills, from :data:`FINE_START` to :data:`FINE_FULL`, is the ink, where
    the feature stands out from the picture's variation about it (:data:`FINE_STANDOUT`).  A disc is the
    same in every direction, so the lines do not depend on how a chart lies in the atlas; the atlas's
    margin texels continue the surface past each chart's edge, so the few texels the disc reads across
    an edge come from the surface on the other side.  With several ``width`` (K,), the ink (K, M) at
    each of them.
    """
    from scipy import ndimage

    disc = _disc(radius)
    image = np.ones(size * size, dtype=np.float32)
    image[flat] = lightness
    image = image.reshape(size, size)
    closed = ndimage.grey_closing(image, footprint=disc)
    spread = _spread(closed, radius) + FINE_QUIET
    depth = ndimage.gaussian_filter(closed - image, FINE_JOIN)
    depth = np.maximum.reduce([ndimage.grey_opening(depth, footprint=segment)
                             for segment in _segments(FINE_LENGTH * radius)])
    low, high = FINE_STANDOUT
    ink = (np.clip((depth - FINE_START) / (FINE_FULL - FINE_START), 0.0, 1.0)
           * smooth_step((depth / spread - low) / (high - low)))
    out = []
    for w in np.atleast_1d(width):
        # the brush's own width, round, about the line's middle
        wide = ndimage.grey_dilation(ink, footprint=_disc((w - 1.0) / 2.0)) if w > 1.5 else ink
        out.append(ndimage.uniform_filter(wide, 3, mode="constant").ravel()[flat])   # anti-aliased
    return out[0] if np.ndim(width) == 0 else np.stack(out)


def _spread(closed, radius):
    """The spread of the picture ``closed`` (its thin features filled in) about each texel, less its smooth
    trend, the calmest within :data:`FINE_BESIDE` ``radius`` (:data:`FINE_STANDOUT`).  It changes over
    several ``radius``, so it is taken on every second texel each way and laid back bilinearly."""
    from scipy import ndimage

    coarse = closed[::2, ::2]
    grain = coarse - ndimage.gaussian_filter(coarse, FINE_TREND * radius / 2)
    spread = ndimage.grey_erosion(np.sqrt(ndimage.gaussian_filter(grain * grain, FINE_CALM * radius / 2)),
                                  footprint=_disc(FINE_BESIDE * radius / 2))
    return ndimage.zoom(spread, 2, order=1, grid_mode=True, mode="nearest")[:closed.shape[0], :closed.shape[1]]


def _disc(radius):
    """A disc of ``radius`` texels as a footprint."""
    r = max(1, int(round(radius)))
    y, x = np.mgrid[-r:r + 1, -r:r + 1]
    return x**2 + y**2 <= radius**2 + 0.25


def _segments(length):
    """Footprints of line segments ``length`` texels long through the centre, in :data:`FINE_ANGLES`
    directions evenly over a half turn."""
    r = max(1, int(np.ceil(length / 2)))
    t = np.linspace(-length / 2, length / 2, 4 * r + 1)
    out = []
    for angle in np.arange(FINE_ANGLES) * np.pi / FINE_ANGLES:
        footprint = np.zeros((2 * r + 1, 2 * r + 1), dtype=bool)
        footprint[np.rint(r + t * np.sin(angle)).astype(int), np.rint(r + t * np.cos(angle)).astype(int)] = True
        out.append(footprint)
    return out
