"""The paint a run lays over its atlas: brush strokes, contour lines and the relief they leave.

:func:`painting` makes a :class:`Painting` from the run's filtered colours on
the band; :func:`cp_stylize.baking.bake_to_atlas` calls it on the atlas's
texels, after it has interpolated the filtered colours there.  At the texels
the strokes (laid by :mod:`cp_stylize.strokes`, drawn by
:mod:`cp_stylize.canvas`) are painted over the filtered colours, the contour
lines (:mod:`cp_stylize.contours`) are inked over the strokes, and the
strokes' heights come back as a height map.
"""

from __future__ import annotations

import numpy as np

from .arrays import smooth_step
from .baking import texel_lengths
from .contours import contour_field, ink_colour, line_strength, line_width, thin_lines
from .oklab import from_oklab, to_oklab, within_gamut
from .canvas import FINE_PAINT, THICKNESS, Texels, paint
from .rigger import HELD, line_dabs
from .lines import inked
from .stroke_field import StrokeField, agreement
from .strokes import place_dabs
from .watercolour import solid_noise

__all__ = ["Painting", "painting", "GRAIN_REACH", "LINE_EDGE"]

#: The picture's lightness detail under the paint (:class:`Painting`'s ``detail``) is kept within this
#: OKLab lightness of the paint's own: windows, lettering and fence posts read through a dab without
#: its edge turning into texel-sized speckle.
GRAIN_REACH = 0.12
#: With the picture at hand, a contour line is inked where the picture is darker than the band's smooth
#: colours, fully at this OKLab lightness below them: the line keeps to the dark side of an edge, as a
#: painter outlines a form, and is sharp at the edge itself instead of a soft band across it.
LINE_EDGE = 0.04
#: The picture's thin dark lines (:func:`cp_stylize.contours.thin_lines`: a crane's jib, a mast, a fence
#: post, too thin for the finest dab) are inked this many times the Detail setting (at most fully), with a
#: closing disc of this share of the finest dabs' width, and at least 1.5 texels (the disc fills in lines up to
#: about its diameter wide: a forest's bare branches against the sky, three to five texels wide where the
#: finest dabs are about five, are lines the finest dab does not hold; they come out as smudges if left to
#: it); each is drawn as a
#: rigger's line this share of the finest dabs' width wide (and at least its own) where it is inked fully,
#: and narrower as it is inked less (a faint line stays fine rather than spread as a grey smear).
THIN = 2.5
#: A thin line inked less than fully (Detail below 0.4) is laid only where it runs on for at least this many
#: of the finest dabs' widths times the share it falls short by (a mast, a jib, a cable): a short faint line,
#: thinner than the finest dab and barely darker than the paint, reads as a crack in it, not as a twig.
LONG_RUN = 8.0
THIN_RADIUS = 0.6
THIN_WIDTH = 0.7
#: Lines are laid with a brush, not drawn with a pen: a brush's pressure swells and eases along a line, by a
#: smooth random function of the surface (:func:`cp_stylize.watercolour.solid_noise`, its features this many
#: of the finest dabs' widths across).  The picture's thin lines run from this share of their width to all of
#: it; the contours, as wide everywhere, from this share of their strength to all of it.
PRESSURE = 3.0
THIN_PRESS, CONTOUR_PRESS = 0.35, 0.55
#: A line is painted in a dark paint that keeps this share of the chroma of the paint under it (the rest
#: the ink's): a twig over green leaves is a deep green, a crane over a yellow sky a dark umber.
LINE_HUE = 0.4
#: The picture's thin lines are laid in the paint under them made this much darker (OKLab lightness, not
#: below the ink's), keeping this share of its chroma (the rest the ink's): a twig in a pale sky is a
#: stroke of a deeper blue, one in the wheat an umber-ochre, as a painter lays them, not a black scratch.
RIGGER_DARKER = 0.32
RIGGER_HUE = 0.75
#: The paint's relief is nowhere steeper than this (the tangent of its angle at Relief 1: 35 degrees), however
#: a narrower dab ends over thicker paint (:func:`slope_limited`) ...
MAX_SLOPE = 0.7
#: ... found in at most this many passes of a texel each (a step of a full height ramps over about 20 texels at
#: the 2048 atlas).
SLOPE_PASSES = 64
#: Sheen (:func:`_sheen`) lights the paint's relief as if a dab's full height were this share of the widest
#: strokes' width: the flanks of a stroke shade softly and its colour reads through them.
SHEEN_HEIGHT = 0.1
#: At Sheen 1, a flank turned fully to the light goes this share of the way to white, one turned fully away
#: this share of the way to black.
SHEEN_LIGHT, SHEEN_SHADE = 0.5, 0.4
#: The height's slope is taken over this share of the first layer's dab width (at least a texel) each way:
#: the light shows the dabs' bodies, rims and edges, not each bristle groove (which, lit texel by texel,
#: reads as an engraved comb of even lines).
SHEEN_REACH = 0.05
#: Sheen lights this many texels at a time (its memory is a few hundred bytes a texel of them).
SHEEN_CHUNK = 1 << 18


class Painting:
    """Strokes and lines for :func:`cp_stylize.baking.bake_to_atlas` to lay over its texels.

    ``dabs``: the :class:`~cp_stylize.strokes.Dabs` (or None), drawn with
    opacity ``strength``; ``lines`` (N,): the band's contour field (or None),
    inked ``contours`` strong in ``ink`` (sRGB; None darkens the colour under
    the line instead).  ``source(faces, barys)`` gives the picture's own
    colours (M, 3) at points of the mesh, at the texture's resolution; with
    it, strokes stop where the picture's colours change (not where the
    palette's do), and each stroke takes the colour under it from
    ``recolour(colours)`` of those colours (the palette mapping) rather than
    the band's, jittered by ``jitter = (pull, shade, palette in OKLab)``.
    ``detail`` in [0, 1]: how much of that picture's lightness detail,
    finer than the band, shows in the paint (as a brush that picks up the
    wet paint under it): the difference between the recoloured picture's
    OKLab lightness and the band's colours', kept within
    :data:`GRAIN_REACH`, is added to the painted lightness, and the
    picture's thin dark lines, too thin for a dab, are inked over the strokes
    (:data:`THIN`), under the contours, at the scale ``fine`` (a length on the
    surface: :meth:`cp_stylize.strokes.Brush.line_width`; None: the finest
    dabs' width).  ``sheen`` in [0, 1]: how much of the light and shade of
    the paint's own relief is painted into its colour (:func:`_sheen`).
    ``keep_darks`` in [0, 1] (with the picture): how far the paint's lightness, at the scale of a broad
    dab, is keyed to the picture's as mapped, and to its own darks (:func:`_keyed`).
    """

    def __init__(self, mesh, atlas, dabs=None, *, strength=1.0, lines=None, contours=0.0, ink=None, source=None,
                 recolour=None, jitter=None, detail=0.0, sheen=0.0, fine=None, keep_darks=0.0):
        self.mesh, self.atlas, self.dabs, self.strength = mesh, atlas, dabs, float(strength)
        self.keep_darks = float(keep_darks)
        self.fine = fine
        self.detail, self.sheen = float(detail), float(sheen)
        self.contours = float(contours)
        self.ink = None if ink is None else np.asarray(ink, dtype=np.float64)
        self.columns = None if lines is None or self.contours <= 0 else np.asarray(lines, dtype=np.float32)
        self.source, self.recolour, self.jitter = source, recolour, jitter

    def __call__(self, texels, colours, columns, progress=None):
        """The texels' colours (M, C) painted, and the height (M,) the strokes leave (None without strokes)."""
        flat, points, faces, barys = texels
        colours = np.asarray(colours)
        out = colours[:, :3].astype(np.float64)
        height = fine = wavelength = None
        if self.dabs is not None and len(self.dabs):
            mesh, dabs = self.mesh, self.dabs
            where = Texels(points, mesh.normal(points, faces, barys), mesh.piece[faces],
                           texel_lengths(mesh, self.atlas, faces), flat, len(self.atlas.texels), self.atlas.size,
                           self.atlas.uvs, mesh.vertices[mesh.input_faces])
            reference = source = pickup = None
            if self.source is not None:
                picture = np.asarray(self.source(faces, barys), dtype=np.float64)[:, :3]
                reference, source = picture, np.asarray(self.source(dabs.face, dabs.bary))[:, :3]
                if self.recolour is not None:
                    # a dab stops where the picture or its paint changes: a road's marking a little lighter
                    # than the road, painted in the palette's yellow, is not painted over in its umber.  The
                    # paint is the band's, smooth (the picture's texel noise mapped onto the palette would
                    # flicker the clip into speckle), at the texels and at the texel nearest each dab's centre
                    _, nearest = where.tree.query(dabs.centre)
                    reference, source = np.hstack([picture, out]), np.hstack([source, out[nearest]])
                under = to_oklab(picture if self.recolour is None else self.recolour(picture))
                pickup = (under, *self.jitter) if self.jitter is not None else None
            out, height = paint(dabs, where, out, reference, strength=self.strength, source=source, pickup=pickup,
                                progress=progress)
            texel, widest = float(np.median(where.lengths)), dabs.layer_width()     # lengths on the surface
            if source is not None:
                # the picture's lightness at the texture's resolution over the band's: its detail
                fine = under[:, 0] - to_oklab(colours[:, :3].astype(np.float64))[:, 0]
                if self.detail > 0 or self.keep_darks > 0:          # the picture's own lightness
                    own = under[:, 0] if self.recolour is None else to_oklab(picture)[:, 0]
                if self.detail > 0:
                    out = _with_grain(out, fine, self.detail)
                    # the thin lines no broad dab can carry, laid with a rigger
                    scale = self.fine if self.fine is not None else dabs.layer_width(finest=True)
                    finest = scale / texel
                    wavelength = PRESSURE * scale
                    ink = min(1.0, THIN * self.detail)
                    lined = thin_lines(own, flat, self.atlas.size, max(1.5, THIN_RADIUS * finest))
                    out, height = self._rigged(out, height, lined, where, faces, barys, wavelength,
                                               max(1.5, ink * THIN_WIDTH * finest), ink, THIN_PRESS, dabs,
                                               LONG_RUN * (1.0 - ink) * scale)
                if self.keep_darks > 0:
                    out = _keyed(out, under[:, 0], own, flat, self.atlas.size,
                                 KEY_REACH * widest / texel, self.keep_darks)
            # no cliff steeper than paint stands: no black hairline under a light
            height = slope_limited(height, flat, self.atlas.size, MAX_SLOPE * texel / (THICKNESS * widest))
            if self.sheen > 0:
                reach = max(1, int(round(SHEEN_REACH * widest / texel)))
                out = _sheen(out, height, where, SHEEN_HEIGHT * widest, self.sheen, reach)
        if self.columns is not None:
            strength = line_strength(columns[:, 0])
            if fine is not None:          # the line keeps to the dark side of the edge, sharp at the edge itself
                strength = strength * _box(smooth_step(-fine / LINE_EDGE), flat, self.atlas.size)
            if wavelength is not None:
                drawn = strength > 0
                strength[drawn] *= CONTOUR_PRESS + (1.0 - CONTOUR_PRESS) * _pressure(points[drawn], wavelength)
            out = self._inked(out, self.contours * strength)
        painted = colours.copy()
        painted[:, :3] = out
        return painted, height

    def _rigged(self, out, height, lined, where, faces, barys, wavelength, texels_wide, ink, press, dabs, run):
        """``out`` and ``height`` with the lines ``lined`` (M,) laid over them as a rigger's dabs
        (:func:`cp_stylize.rigger.line_dabs`) ``texels_wide`` texels wide at full pressure (at least ``press``
        of it), ``ink`` strong, where they run on at least ``run`` (a length on the surface)."""
        on = lined >= HELD
        width = np.zeros(len(lined))
        width[on] = (texels_wide * where.lengths[on]
                     * (press + (1.0 - press) * _pressure(where.points[on], wavelength)))
        line, at, strength = line_dabs(lined, where.points, where.normals, faces, barys, where.pieces, width,
                                       seed=int(dabs.phase.size), layer=int(dabs.layer.max()) + 1, run=run)
        if line is None:
            return out, height
        under = out[at].astype(np.float64)
        dark = self._line_paint(under, RIGGER_HUE, RIGGER_DARKER)
        line.colour = under + (np.sqrt(ink) * np.clip(2.0 * strength, 0.0, 1.0))[:, None] * (dark - under)
        out, raised = paint(line, where, out, np.zeros((len(out), 3)), source=np.zeros((len(line), 3)))
        # a rigger's paint is thin: as thick as a dab of its width (canvas.FINE_PAINT)
        height = height + raised * (line.layer_width() / dabs.layer_width()) ** FINE_PAINT
        return out, height

    def _line_paint(self, colours, hue=LINE_HUE, darker=None):
        """The dark paint lines are laid in over sRGB ``colours`` (M, 3), keeping ``hue`` of their own chroma
        (the rest the ink's, as a dark paint mixed on the canvas): as dark as the ink, or with ``darker``,
        their own lightness that much lower (OKLab, not below the ink's).  Without an ink, a contour's paint
        is their own darkened, and the ink a dark grey."""
        if self.ink is None and darker is None:
            return inked(colours, np.ones(len(colours)), None)
        ink = to_oklab(self.ink) if self.ink is not None else np.array([0.2, 0.0, 0.0])
        paint = to_oklab(colours)
        paint[:, 0] = ink[0] if darker is None else np.maximum(paint[:, 0] - darker, np.minimum(ink[0], paint[:, 0]))
        paint[:, 1:] = ink[1:] + hue * (paint[:, 1:] - ink[1:])
        return from_oklab(within_gamut(paint))

    def _inked(self, colours, amount):
        """sRGB ``colours`` (M, 3) inked ``amount`` (M,) in [0, 1]: towards the ink (keeping :data:`LINE_HUE` of
        their own chroma, as a dark paint mixed on the canvas), or darkened without one."""
        if self.ink is None:
            return inked(colours, amount, None)
        out = np.array(colours, dtype=np.float64)
        drawn = amount > 0                              # lines cover few of the texels
        out[drawn] = inked(out[drawn], amount[drawn], self._line_paint(out[drawn]))
        return out


def slope_limited(height, flat, size, step):
    """The ``height`` (M,) at the atlas texels ``flat`` (M,) of a ``size`` square atlas, lowered where it stands
    more than ``step`` above a neighbouring texel (``step`` times the distance, diagonals included): the
    greatest height within that slope of every texel's, its lower Lipschitz envelope.  Each pass lowers a
    texel to its eight neighbours' heights plus their distance's ``step``, the first over every texel and
    the next only about those the last one lowered, :data:`SLOPE_PASSES` at most, until nothing changes.  A
    dab's edge over thick paint, a texel-wide cliff, becomes a ramp a few texels wide: the Bump node would
    turn the cliff into a dark hairline on its side away from the light, which reads as a crack.  Texels off
    the atlas's charts bind nothing, and one chart's paint binds no other's across them."""
    wide = size + 2                                  # a border of texels off the charts all round
    rows, cols = np.divmod(np.asarray(flat, dtype=np.int64), size)
    at = (rows + 1) * wide + cols + 1
    image = np.full(wide * wide, np.inf, dtype=np.float32)
    image[at] = height
    offsets = np.array([-wide - 1, -wide, -wide + 1, -1, 1, wide - 1, wide, wide + 1])
    cost = (np.float32(step) * np.array([np.sqrt(2.0), 1.0, np.sqrt(2.0), 1.0, 1.0, np.sqrt(2.0), 1.0,
                                         np.sqrt(2.0)])).astype(np.float32)
    near = at
    for _ in range(SLOPE_PASSES):
        bound = (image[near[:, None] + offsets] + cost).min(axis=1)
        lower = bound < image[near]
        if not lower.any():
            break
        lowered = near[lower]
        image[lowered] = bound[lower]
        near = np.unique((lowered[:, None] + offsets).ravel())       # whose neighbours were lowered
        near = near[np.isfinite(image[near])]                         # on the charts
    return image[at]


def _pressure(points, wavelength):
    """A brush's pressure (M,) in [0, 1] at surface ``points`` (M, 3), swelling and easing over about
    ``wavelength`` (:data:`PRESSURE`)."""
    return solid_noise(points, wavelength, seed=5, octaves=2)


def _sheen(painted, height, texels, thickness, strength, reach=1):
    """``painted`` (M, 3, sRGB) at the :class:`~cp_stylize.canvas.Texels` ``texels``, lit by its own
    ``height`` (M,; ``thickness`` long at 1, in the texels' lengths): the light and shade the paint's relief
    takes under the form light (:data:`cp_stylize.hatching.LIGHT`, fixed to the object, so it turns with
    it), over what the surface takes without it, so the renderer's own light still shades the form.

    The height's gradient on the surface comes from its differences between the texels ``reach`` texels
    ahead of and behind each along the atlas's axes (those of the margin continue the surface), and tilts
    the normal.  The light comes at each texel from the surface's side (mirrored
    where the surface turns away from it), so the relief reads on every side of the object, as under a
    raking light, and a flank turned to it lightens towards white (``strength`` times
    :data:`SHEEN_LIGHT` at most) where one turned away darkens (:data:`SHEEN_SHADE`)."""
    from .hatching import LIGHT

    flat, size = texels.flat, texels.size
    position = np.full(size * size, -1, dtype=np.int32)      # atlas texel -> its index among them, or -1
    position[flat] = np.arange(len(flat), dtype=np.int32)
    out = np.array(painted, dtype=np.float64)
    for start in range(0, len(flat), SHEEN_CHUNK):
        part = slice(start, start + SHEEN_CHUNK)
        here = flat[part]
        column, row = here % size, here // size
        own = np.arange(start, start + len(here))
        ends = []
        for step, after, before in ((1, column < size - reach, column >= reach),
                                    (size, row < size - reach, row >= reach)):
            ends.append([_neighbour(position, here, reach * step * sign, inside, own)
                         for sign, inside in ((1, after), (-1, before))])
        lit = _relief_light(texels.points, texels.normals[part], height, ends, thickness, LIGHT)
        shine = np.where(lit > 0, (1.0 - out[part]) * (SHEEN_LIGHT * lit), out[part] * (SHEEN_SHADE * lit))
        out[part] += strength * shine
    return out


def _neighbour(position, flat, step, inside, own):
    """The index (``position``: by atlas texel) of each atlas texel ``flat`` ``step`` texels on in the atlas,
    where that lies ``inside`` the atlas and is one of the texels, else its ``own``."""
    found = np.where(inside, position[np.where(inside, flat + step, 0)], -1)
    return np.where(found >= 0, found, own)


def _relief_light(points, normals, height, ends, thickness, light):
    """How much lighter (> 0) or darker (< 0), in [-1, 1], the relief ``height`` (``thickness`` long at 1)
    makes texels with unit ``normals`` (K, 3) under ``light`` (see :func:`_sheen`): the Lambert term of the
    normal tilted by the height's gradient, less the untilted one's.  ``ends``: for the atlas's two axes,
    the indices (K,) of each texel's neighbours ahead and behind along it among ``points`` and ``height``."""
    (du, hu), (dv, hv) = [(points[ahead].astype(np.float64) - points[behind],
                           height[ahead].astype(np.float64) - height[behind]) for ahead, behind in ends]
    a, b, c = (du * du).sum(1), (du * dv).sum(1), (dv * dv).sum(1)
    det = a * c - b * b
    ok = det > 1e-12 * np.maximum(a * c, 1e-300)
    det = np.where(ok, det, 1.0)
    gradient = ((c * hu - b * hv) / det)[:, None] * du + ((a * hv - b * hu) / det)[:, None] * dv
    gradient[~ok] = 0.0
    normals = normals.astype(np.float64)
    facing = normals @ light
    towards = light[None, :] - facing[:, None] * normals + np.abs(facing)[:, None] * normals   # from its side
    tilted = normals - thickness * gradient
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    lit = np.clip(np.einsum("ij,ij->i", tilted, towards) - np.abs(facing), -1.0, 1.0)
    return np.where(np.any(gradient != 0.0, axis=1), lit, 0.0)[:, None]      # flat paint exactly as it was


def _with_grain(painted, fine, strength):
    """``painted`` (M, 3, sRGB) with ``strength`` times the lightness detail ``fine`` (M,, OKLab) kept
    within :data:`GRAIN_REACH`."""
    lab = to_oklab(painted)
    lab[:, 0] += strength * np.clip(fine, -GRAIN_REACH, GRAIN_REACH)
    return from_oklab(lab)


#: Keep Darks keys the paint's lightness, over this share of the broadest dabs' width (a Gaussian's
#: deviation), to the mapped picture's, lowered towards the picture's own where that is dark: fully at an
#: OKLab lightness of KEY_DARK[0] and below, not at all from KEY_DARK[1] (not below KEY_FLOOR, a palette's
#: deepest umber or blue).  Smoothing and strokes spread a light's paint over the darks beside it; a
#: painter keys the darks to the subject and keeps each stroke's own light and shade over it.
KEY_REACH = 0.6
KEY_FLOOR = 0.2
KEY_DARK = (0.3, 0.6)
#: A Gaussian blur of the atlas wider than this many texels is taken on a coarser grid (:func:`_blurred`).
BLUR_CELLS = 3.0


def _blurred(values, flat, size, sigma):
    """``values`` (M,) at the atlas texels ``flat`` of a ``size`` square atlas, blurred by a Gaussian ``sigma``
    texels wide over the texels on the atlas's charts only.  A broad Gaussian is taken on a grid coarser by a
    whole factor, :data:`BLUR_CELLS` cells to its deviation (each cell the sum of its texels), and read back
    bilinearly: its cost does not grow with its width, at 4096 texels as at 1024."""
    from scipy import ndimage

    flat = np.asarray(flat, dtype=np.int64)
    factor = max(1, int(sigma / BLUR_CELLS))
    cells = -(-size // factor)
    rows, cols = np.divmod(flat, size)
    cell = (rows // factor) * cells + cols // factor
    sums = np.bincount(cell, weights=values, minlength=cells * cells).reshape(cells, cells)
    counts = np.bincount(cell, minlength=cells * cells).reshape(cells, cells).astype(np.float64)
    sums = ndimage.gaussian_filter(sums, sigma / factor, mode="constant")
    counts = ndimage.gaussian_filter(counts, sigma / factor, mode="constant")
    coarse = sums / np.maximum(counts, 1e-12)
    if factor == 1:
        return coarse.ravel()[flat]
    at = [(rows + 0.5) / factor - 0.5, (cols + 0.5) / factor - 0.5]
    return ndimage.map_coordinates(coarse, at, order=1, mode="nearest")


def _keyed(painted, mapped, own, flat, size, sigma, strength):
    """``painted`` (M, 3 sRGB) at the atlas texels ``flat`` with ``strength`` of its lightness at the scale
    ``sigma`` (texels) moved to the key's: the ``mapped`` picture's lightness (M,, OKLab), lowered towards the
    picture's ``own`` where that is dark (:data:`KEY_DARK`).  Each dab keeps its light and shade about it."""
    lo, hi = KEY_DARK
    dark = np.clip((hi - own) / (hi - lo), 0.0, 1.0)
    key = mapped + dark * np.minimum(0.0, np.maximum(own, KEY_FLOOR) - mapped)
    lab = to_oklab(painted)
    lab[:, 0] += strength * _blurred(key - lab[:, 0], flat, size, sigma)
    return from_oklab(within_gamut(lab))


def _box(values, flat, size):
    """``values`` (M,) at the atlas texels ``flat`` (M,) averaged over each texel's 3 x 3 neighbours in
    the atlas (texels outside ``flat`` count as 0): a line's edge is anti-aliased over a texel.  The
    margin texels around each chart continue the surface, so a chart's edge reads its neighbours on the
    surface."""
    from scipy import ndimage

    image = np.zeros(size * size)
    image[flat] = values
    return ndimage.uniform_filter(image.reshape(size, size), 3, mode="constant").ravel()[flat]


def painting(mesh, band, values, atlas, *, brush=None, contours=0.0, structure=None, palette=None,
             weights=None, field=None, source=None, recolour=None, detail=0.0, level=None, sheen=0.0,
             keep_darks=0.0):
    """A :class:`Painting` of the band's filtered colours ``values`` (N, 3) on a mesh's atlas.

    Parameters
    ----------
    mesh : TriangleMesh
    band : Band
    values : ndarray, shape (N, 3)
        The filtered colours (sRGB) the strokes take theirs from.
    atlas : Atlas
    brush : Brush, optional
        The strokes (none without).
    contours : float
        How strongly lines are inked along the strong edges of ``structure`` (0: none).
    structure : ndarray, shape (N, 3), optional
        The colours whose structure strokes follow and lines outline (default ``values``).
    palette, weights : optional
        The palette: strokes are jittered towards its colours, lines drawn in its darkest.
    field : ndarray, shape (N, 3), optional
        A direction field the strokes follow where its length is 1 (see
        :func:`cp_stylize.pipeline.stroke_field`).
    level : ndarray, shape (N, 3), optional
        Where strokes run where the picture has no structure (:func:`cp_stylize.stroke_field.level_field`).
    source : callable, optional
        ``source(faces, barys)``: the picture's colours at points of the mesh, at the texture's
        resolution (see :class:`Painting`).
    recolour : callable, optional
        ``recolour(colours)``: the mapping that made ``values`` from the picture's colours (the
        palette's), for the colours strokes pick up at the texture's resolution.
    detail : float in [0, 1]
        How much of the picture's lightness detail, finer than the band, shows in the strokes (with
        ``source``; see :class:`Painting`).
    sheen : float in [0, 1]
        How much of the paint's relief is lit into its colour (see :class:`Painting`).
    keep_darks : float in [0, 1]
        How far the paint is keyed to the picture's lightness and its darks (with ``source``; see
        :class:`Painting`).
    """
    values = np.asarray(values).reshape(band.size, -1)[:, :3]
    structure = values if structure is None else np.asarray(structure).reshape(band.size, -1)[:, :3]
    lab = to_oklab(structure).astype(np.float32)
    texel = float(np.median(texel_lengths(mesh, atlas, atlas.face))) if len(atlas.face) else band.h
    lengths = brush.lengths(texel) if brush is not None else [16 * texel]
    fields = StrokeField.layers(band, lab, lengths) if brush is not None or contours > 0 else None
    if brush is not None:       # guides that turn within a broad stroke's length are not followed there
        field, level = (None if guide is None else
                        np.asarray(guide) * agreement(band, guide, lengths[0])[:, None].astype(np.float32)
                        for guide in (field, level))
    dabs = jitter = None
    if brush is not None and brush.strength > 0:
        dabs = place_dabs(mesh, band, values, brush, structure=lab, texel=texel, palette=palette,
                          weights=weights, field=field, fields=fields, level=level)
        lab_palette = None if palette is None else to_oklab(np.asarray(palette, dtype=np.float64)[:, :3])
        jitter = (brush.jitter * (1.0 - brush.fidelity), brush.jitter, lab_palette)
    lines = None
    fine = brush.line_width(texel) if brush is not None else 4 * texel
    if contours > 0:
        lines = contour_field(band, structure, line_width(fine, band.h), fields[-1].direction)
    return Painting(mesh, atlas, dabs, strength=1.0 if brush is None else brush.strength, lines=lines,
                    contours=contours, ink=ink_colour(palette), source=source, recolour=recolour, jitter=jitter,
                    detail=detail if dabs is not None else 0.0, sheen=sheen, fine=fine,
                    keep_darks=keep_darks if dabs is not None else 0.0)
