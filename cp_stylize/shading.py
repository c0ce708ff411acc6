"""Hand-painted shading: the form's light and its edges painted into the colour.

A hand-painted game texture carries its light in the paint, so that it reads
without a lamp (an unlit material, a mobile game): the side that faces the
light is lighter, the side turned from it darker, convex edges catch a
highlight and creases keep a shadow.  Painters shift hue as they shade:
lights go warmer and shadows cooler, rather than only lighter and darker.

Both come from the surface itself, at the band's closest points:

- the **form light** from the normals: a light from above the object, a
  little to its left and front (:data:`LIGHT`; fixed to the object, so that it
  turns with it), as a game's hand-painted textures are lit from the sky: tops
  lighter, undersides darker, seen from any side.  The lightness moves by
  ``n . l`` less its mean over the surface, so the light casts nothing over
  the whole (a plane, which faces one way, keeps its colour; a sphere's
  terminator keeps its own);
- the **edges** from the mean curvature ``H = (k1 + k2) / 2``
  (:func:`cp_stylize.curvature.principal_curvatures`) of the outward normals
  smoothed on the surface over :data:`EDGE_WIDTH` (a heat flow of that width
  squared; a mesh's face normals, so a sharp edge counts as a bevel of that
  width), taken from the surface's median, so a sphere or a plane has no
  edges and a ridge (``H`` above it) is lit, a crease (below) shaded.  ``H``
  saturates :data:`EDGE_CURVATURE` above the median: a rounded edge of radius
  1/24 of the object's radius (``H = 1 / (2 r)``) is a full edge.

Each moves OKLab lightness; the warmth moves hue and chroma with it, towards
:data:`WARM` in the lights and :data:`COOL` in the shadows.  Colours stay in
gamut.  :class:`FormShading` lays it over everything a run paints (the
filtered colours, strokes, lines), at the texels, as a light would fall on it.
"""

from __future__ import annotations

import numpy as np

from .curvature import principal_curvatures
from .heat_flow import heat_rows
from .oklab import from_oklab, to_oklab
from .tangent import surface_normals

__all__ = ["LIGHT", "FormShading", "shade_field", "shaded", "edge_strength", "LIGHT_DEPTH", "EDGE_DEPTH"]

#: Where the form light comes from, in the object's own space (z up, -y its front): above, a little to the
#: left and front.
LIGHT = np.array([-0.3, -0.25, 0.92]) / np.linalg.norm([-0.3, -0.25, 0.92])
#: Lightness (OKLab) that the form light adds on the side facing it, and takes on the side turned away.
LIGHT_DEPTH = 0.25
#: Lightness that a full convex edge adds, and a full crease takes.
EDGE_DEPTH = 0.2
#: The mean curvature above (below) the surface's median at which an edge (a crease) is full, for an object
#: of diameter 2.
EDGE_CURVATURE = 12.0
#: The width (for an object of diameter 2) over which the mean curvature is smoothed: a mesh's facets and
#: the tessellation's noise go, the edges' roundings stay.
EDGE_WIDTH = 0.02
#: OKLab (a, b) that a full step of light moves a colour by (a warm yellow-orange), and a full step of shadow
#: (a cool blue-violet).
WARM = np.array([0.02, 0.06])
COOL = np.array([-0.015, -0.07])


def edge_strength(band, normals=None):
    """Each band point's edge (N,) in [-1, 1]: 1 on a convex edge, -1 in a crease, 0 where the surface bends
    as it does at its median (a sphere and a plane have none).  See the module notes.  ``normals`` (N, 3):
    outward unit normals at the closest points; by default a mesh's face normals (an analytic surface's
    own)."""
    surface = band.surface
    if normals is None and band.face is not None and hasattr(surface, "face_normals"):
        # a mesh's own faces' normals: a sharp edge turns them at the edge itself, where interpolated vertex
        # normals would spread its turn over the faces on either side
        normals = surface.face_normals[surface.kept_index(band.face)]
    # the normals smoothed over the edges' width on the surface, as a bevel of that width would turn them
    rows = np.array(surface_normals(band, normals), dtype=np.float64).T.copy()
    heat_rows(band, rows, EDGE_WIDTH**2)
    smooth = rows.T / np.maximum(np.linalg.norm(rows.T, axis=1, keepdims=True), 1e-12)
    curvature = principal_curvatures(band, smooth)
    mean = 0.5 * (curvature.k1 + curvature.k2)
    return np.clip((mean - np.median(mean)) / EDGE_CURVATURE, -1.0, 1.0)


def shade_field(band, *, light=0.0, edges=0.0, normals=None):
    """The lightness (OKLab) each band point's colour moves by (N,): ``light`` times the form light's and
    ``edges`` times the edges' share (see the module), each strength in [0, 1].  ``normals`` (N, 3):
    outward unit normals at the closest points (by default the surface's own)."""
    for name, value in (("light", light), ("edges", edges)):
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"{name} must lie in [0, 1], got {value!r}")
    n = np.asarray(surface_normals(band, normals), dtype=np.float64)
    shift = np.zeros(band.size)
    if light > 0:
        facing = np.clip(n @ LIGHT, -1.0, 1.0)
        shift += light * LIGHT_DEPTH * (facing - facing.mean())     # no cast over the whole: a plane keeps its colour
    if edges > 0:
        shift += edges * EDGE_DEPTH * edge_strength(band, None if normals is None else n)
    return shift


def shaded(colours, shift, warmth=0.0):
    """sRGB ``colours`` (M, C), C >= 3, with their OKLab lightness moved by ``shift`` (M,) and, ``warmth``
    (in [0, 1]) times, their hue with it: towards :data:`WARM` where lighter, :data:`COOL` where darker.
    Channels past the third are kept; the colours stay in gamut."""
    if not 0.0 <= warmth <= 1.0:
        raise ValueError(f"warmth must lie in [0, 1], got {warmth!r}")
    colours = np.asarray(colours)
    lab = to_oklab(colours[:, :3].astype(np.float64))
    lab[:, 0] += shift
    if warmth > 0:
        step = np.clip(np.asarray(shift) / LIGHT_DEPTH, -1.0, 1.0)[:, None]
        lab[:, 1:] += warmth * np.where(step > 0, step * WARM, -step * COOL)
    out = np.array(colours, copy=True)
    out[:, :3] = np.clip(from_oklab(lab), 0.0, 1.0)
    return out


class FormShading:
    """The form's light and edges laid over everything painted before, at the bake-out (``paint=`` of
    :func:`cp_stylize.baking.bake_to_atlas`): :func:`shade_field` on the band, read at each texel, moves
    its colour by :func:`shaded`.  Leaves no height."""

    def __init__(self, band, *, light=0.0, edges=0.0, warmth=0.0, normals=None):
        self.columns = shade_field(band, light=light, edges=edges, normals=normals).astype(np.float32)[:, None]
        self.warmth = float(warmth)

    def __call__(self, texels, colours, read, progress=None):
        out = shaded(colours, np.asarray(read, dtype=np.float64)[:, 0], self.warmth)
        if progress is not None:
            progress(1.0)
        return out, None
