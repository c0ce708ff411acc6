"""Dabs drawn at the atlas's texels: their colour, anti-aliased and clipped at the picture's edges, and the
relief their paint leaves.

:func:`paint` draws the :class:`~cp_stylize.strokes.Dabs` that
:func:`cp_stylize.strokes.place_dabs` laid on the surface at the texels of
an atlas (:class:`Texels`): each dab's tapered footprint, ``length`` long and
``width`` wide with edges anti-aliased over a texel, is found in the atlas by
rasterising it in UV (or, where it crosses a seam, by a search in space), is
clipped where the picture under it differs from its own colour, and is
composited in order.  A brush is loaded with two colours (a second one meets
the first in streaks along the bristles); each dab leaves a ridge profile with
a rim and a few broad bristle furrows, a finer brush's thinner than a broad
one's, and overlapping dabs stack into a height map (impasto); the dabs of one
stroke run on into one another, and its last dab runs dry at its tail.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from .arrays import ball_pairs, expand_runs, smooth_step
from .oklab import from_oklab, to_oklab
from .palette import kept_chroma, loaded
from .raster import face_map
from .sparse import map_windows

__all__ = ["Texels", "paint", "clipped", "CLIP", "DAB_AREA", "HEAD_END", "TAIL_END"]

#: A dab's full height (a height of 1), as a share of the widest strokes' width: the relief's depth (the Bump
#: node's distance at Relief 1).  Impasto: the strokes' bodies, rims and furrows read under an ordinary key
#: light, and a raking light casts each stroke's ridge.
THICKNESS = 0.16

#: A dab is clipped where the colour under it differs from its own by more than this (OKLab), and
#: gone at :data:`CLIP_GONE`.
CLIP = 0.2
CLIP_GONE = 0.4
#: A dab's paint stands whole in the relief where at least this share of its footprint shows its colour, and
#: in proportion below it.
SHOWN = 0.5
#: Of the height a later stroke paints over, this share is scraped away (the rest stays under it: paint
#: builds up where strokes overlap); a dab within a stroke lays its paint over the one before it, all of it.
FLATTEN = 0.35
#: A dab's paint ends within this share of its half width (at least a texel) at its sides and its stroke's
#: head, and within three times that at its tail: a stroke's edge stands as a rounded step, not a cliff of
#: one texel.
EDGE = 0.45
#: A stroke's paint is this much thicker at its head, where the loaded brush touched down and the paint piles
#: up in a blob, and a stroke's last dab this much thinner at its tail; each dab's paint is raised by this much
#: in a low rim along its sides (paint the bristles pushed aside).
HEAD = 0.8
TAIL = 0.4
RIM = 0.15
#: The rim's crest, as a share of the dab's half width out from its centre line: where the edge's ramp begins.
RIM_AT = 0.55
#: A dab's paint stands this high in its body (a share of its thickness, without its rim and bristle marks) ...
BODY = 0.5
#: ... this share of it rounded, highest on the dab's centre line and falling to its sides as ``1 - x**2``
#: over its footprint's half width ``x`` (the rest stands flat): a stroke's body is a mound, not a strip
#: between two rims, which under a raking light reads as a groove.
DOME = 0.6
#: How deep the bristle marks in a dab are, as a share of its thickness, and how much lighter and darker they
#: make its colour.
GROOVE_DEPTH = 0.08
STREAK = 0.07
#: A dab's second colour (:attr:`Dabs.second`) meets its first over this share of its width, in streaks along
#: the bristles this much of its half width deep.
LOAD_SOFT = 0.5
LOAD_STREAK = 0.5
#: The last dab of a stroke runs dry from this share of its half length behind its centre to its tail.
DRY_AT = 0.4
#: ... and its paint thins out to this much less at the tail.
DRY_THIN = 0.7
#: A dab's paint is as thick as this power of its width over the widest dabs' (a fine brush carries less
#: paint: a dab half as wide, a quarter as thick), and a finer layer's dabs lie on the paint under them as a
#: stroke's first dab does: the broad strokes carry the relief, in ridges a stroke wide, and the many fine
#: ones do not comb it into a fur of furrows a few texels apart.
FINE_PAINT = 2.0
#: The bristles' streaks in a dab's colour are at least this many texels apart, and a dab has at most
#: about this many of them (with two at least) ...
STREAK_TEXELS = 3.0
STREAKS = 5.0
#: ... and the grooves they leave in its paint at least this many, and at most about this many (a broad
#: brush leaves a few strong marks in the relief, not a comb's fine lines, which under a light read as
#: fur); a dab too narrow for two grooves stands as one rounded crest.
GROOVE_TEXELS = 6.0
GROOVES = 3.0
#: A dab's rims stand fully on dabs at least this many texels wide, and fade on narrower ones (whose
#: two rims would run a texel or two apart, as hairlines).
RIM_TEXELS = 12.0
#: A dab's place in its stroke (:attr:`Dabs.ends`): the first (the brush touched down) or the last (it lifted).
HEAD_END, TAIL_END = 1, 2
#: Dabs drawn at once (a block of pairs of texels and dabs): at most this many, and at most about
#: :data:`_PAIRS` pairs of a dab and a texel it may cover (a block's memory is a few hundred bytes a
#: pair, whatever the atlas's size: a broad dab on a 4096 x 4096 atlas covers ten thousand texels or more).
_CHUNK = 3000
_PAIRS = 1 << 20




@dataclasses.dataclass
class Texels:
    """The atlas texels strokes are painted at.

    ``points`` and ``normals`` (M, 3): their surface points and unit normals;
    ``pieces`` (M,): the connected piece of the mesh each lies on; ``lengths``
    (M,): each texel's length on the surface; ``flat`` (M,): their flat
    indices in the atlas (``row * size + col``), the first ``covered`` inside
    UV triangles and the rest the margin; ``uvs`` (F, 3, 2) and ``corners``
    (F, 3, 3): the UV and 3-D corners of the mesh's input faces.
    """

    points: np.ndarray
    normals: np.ndarray
    pieces: np.ndarray
    lengths: np.ndarray
    flat: np.ndarray
    covered: int
    size: int
    uvs: np.ndarray
    corners: np.ndarray

    def __post_init__(self):
        self.points = np.asarray(self.points, dtype=np.float32)
        self.normals = np.asarray(self.normals, dtype=np.float32)
        self.lengths = np.asarray(self.lengths, dtype=np.float32)
        self.position = np.full(self.size * self.size, -1, dtype=np.int64)   # atlas texel -> index, or -1
        self.position[self.flat[:self.covered]] = np.arange(self.covered)
        self._tree = None

    @property
    def tree(self):
        """A k-d tree of the points (made on first use)."""
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree


#: Share of a dab's area its own UV raster must find (inside UV triangles) before it is taken as
#: whole; a dab that crosses a seam, or a UV map that stretches under it, is drawn from a search in
#: space instead, as is one whose paint reaches its raster's outermost texels (the raster may have cut it
#: off there: a straight step in its relief that a light draws as a crack).
WHOLE = 0.92
#: A dab's paint fades out where the surface turns away from it: none where a texel's normal and the dab's
#: make a cosine of the first or less (the far side of a thin part, or round a sharp bend), all of it from the
#: second.  A cut at one cosine ran along the mesh's edges where a broad dab lies over a sharp bend (a brow),
#: as a step in its relief that a light draws as a crack.
FACING = (0.0, 0.5)
#: The UV raster of a dab is this much larger than its footprint at its centre (the UV map's stretch
#: may change under it), and two texels more.
RASTER_SLACK = 1.1


def paint(dabs, texels, base, reference=None, *, strength=1.0, source=None, pickup=None, progress=None):
    """The texels' colours with the dabs painted over them, and the height the paint leaves.

    Parameters
    ----------
    dabs : Dabs
    texels : Texels
    base : ndarray, shape (M, 3)
        The colours under the paint.
    reference : ndarray, shape (M, 3) or (M, 3k), optional
        The colours a dab is clipped against (:func:`clipped`), sRGB: the picture's own at the texels, or
        k sets side by side (the picture and its paint), when the largest of the k differences clips;
        default ``base``.
    strength : float
        The dabs' opacity.
    source : ndarray, shape (n, 3) or (n, 3k), optional
        Each dab's own colour in ``reference``'s terms (the picture's at its centre); default its colour.
    pickup : tuple, optional
        ``(colours (M, 3) in OKLab, pull, shade, lab_palette)``: each dab takes the mean of ``colours``
        over the texels it covers (the picture under it at the texture's resolution; its chroma kept)
        and its jitter
        (:func:`cp_stylize.palette.jitter`) again; without it, dabs keep the colours they have.
    progress : callable, optional
        ``progress(fraction)``; an exception it raises stops the painting.

    Returns
    -------
    colours : ndarray (M, 3), float32
    height : ndarray (M,), float32
        The paint's height in units of a dab's full thickness (0 where none lies).

    Notes
    -----
    A dab's texels are found in the atlas itself: its footprint at its
    centre, mapped into UV by its face's map, is rasterised row by row.
    Where that finds less than :data:`WHOLE` of the dab's area inside UV
    triangles (the dab crosses a seam or leaves its island), the dab is drawn
    from all texels within its reach in space (a k-d tree), which finds it on
    every island it covers.
    """
    reference = base if reference is None else reference
    lab_reference = _lab_groups(reference)
    lab_dabs = _lab_groups(dabs.colour if source is None else source)
    shapes = _Shapes(dabs)
    widest = dabs.layer_width() if len(dabs) else 1.0
    uv_axes = _uv_axes(dabs, texels)

    def block(span):
        which = np.arange(*span)
        i, j, alpha, along, across = _covering(dabs, shapes, uv_axes, texels, which)
        difference = np.linalg.norm(lab_reference[j] - lab_dabs[i], axis=2).max(axis=1)
        shape = strength * alpha
        alpha = shape * clipped(difference)
        drawn = shape > 1e-3
        i, j, alpha, shape, along, across = (x[drawn] for x in (i, j, alpha, shape, along, across))
        # a dab's paint keeps its whole shape in the relief, as far as its colour shows: one clipped away
        # all but a sliver leaves no ridge where no stroke is seen
        own = i - which[0]
        shows = (np.bincount(own, alpha, len(which)) / np.maximum(np.bincount(own, shape, len(which)), 1e-12))
        shape = shape * np.clip(shows / SHOWN, 0.0, 1.0)[own]
        colour = dabs.colour[which]
        second = colour if dabs.second is None else dabs.second[which]
        if pickup is not None and len(i):
            colour, second = _under((colour, second), which, i, j, alpha, dabs.draws[which], *pickup)
        return _composite(dabs, texels, (colour, second), which[0], i, j, alpha, shape, along, across, widest)

    colours = np.array(base, dtype=np.float64)
    height = np.zeros(len(texels.points))
    for found in map_windows(block, _blocks(uv_axes[0]), progress):
        if found is not None:
            touched, through, added, height_through, height_added = found
            colours[touched] = colours[touched] * through[:, None] + added
            height[touched] = height[touched] * height_through + height_added
    return colours.astype(np.float32), height.astype(np.float32)


def _lab_groups(colours):
    """sRGB colours (M, 3k), k of them side by side, in OKLab (M, k, 3)."""
    colours = np.asarray(colours, dtype=np.float64)
    return to_oklab(colours.reshape(len(colours), -1, 3)).astype(np.float32)


def clipped(difference):
    """How much of a dab paints where the picture differs from its own colour by ``difference`` (OKLab):
    all of it up to :data:`CLIP`, none from :data:`CLIP_GONE` on."""
    return np.clip((CLIP_GONE - difference) / (CLIP_GONE - CLIP), 0.0, 1.0)


def _blocks(axes):
    """Spans ``(start, stop)`` of the dabs, in order, of at most :data:`_CHUNK` dabs and about :data:`_PAIRS`
    texels their UV rasters (:func:`_raster_pairs`) may cover: ``axes`` (n, 2, 2), their half length and half
    width in texels of the atlas."""
    sides = 2.0 * np.linalg.norm(_grown(axes), axis=2)
    pairs = np.where(np.all(np.isfinite(sides), axis=1), sides[:, 0] * sides[:, 1], 0.0)
    ends = np.cumsum(pairs)
    spans, start = [], 0
    while start < len(pairs):
        stop = int(np.searchsorted(ends, ends[start] - pairs[start] + _PAIRS, side="right"))
        stop = min(max(stop, start + 1), start + _CHUNK)
        spans.append((start, stop))
        start = stop
    return spans


def _under(colours, which, i, j, alpha, draws, lab, pull, shade, lab_palette):
    """The two colours (n, 3 each) the brushes of the dabs ``which`` are loaded with: the mean of the OKLab
    colours ``lab`` over the texels each covers (weighted by coverage, its chroma kept:
    :func:`cp_stylize.palette.kept_chroma`), jittered by its own draws and by those of its second colour
    (:func:`cp_stylize.palette.loaded`); a dab that covers no texel keeps ``colours``."""
    place = i - which[0]
    weight = np.bincount(place, weights=alpha, minlength=len(which))

    def mean(values):
        return np.bincount(place, weights=alpha * values, minlength=len(which)) / np.maximum(weight, 1e-12)

    found = weight > 1e-6
    under = lab[j]
    ab = kept_chroma(np.column_stack([mean(under[:, 1]), mean(under[:, 2])]), mean(np.hypot(under[:, 1], under[:, 2])))
    picked = np.column_stack([mean(under[:, 0]), ab])
    out = [np.array(c, dtype=np.float64) for c in colours]
    for o, c in zip(out, loaded(from_oklab(picked[found]), draws[found], pull, shade, lab_palette)):
        o[found] = c
    return out


def _uv_axes(dabs, texels):
    """The dabs' half length and half width vectors (n, 2, 2) in texel units of the atlas, by the map
    of each centre's face, and their centres (n, 2) with texel centres at integers."""
    uv = texels.uvs[dabs.face] * texels.size - 0.5                   # (n, 3, 2)
    corners = texels.corners[dabs.face]
    sides = np.cross(dabs.normal, dabs.direction)
    axes = [face_map(uv, corners, w) for w in (dabs.direction * (0.5 * dabs.length)[:, None],
                                                 sides * (0.5 * dabs.width + dabs.depth)[:, None])]
    centre = np.einsum("nk,nkj->nj", dabs.bary, uv)
    return np.stack(axes, axis=1), centre


def _covering(dabs, shapes, uv_axes, texels, which):
    """The texels each dab of ``which`` (sorted indices) covers: pairs of dabs ``i`` and texels ``j`` with the coverage
    ``alpha`` (anti-aliased over a texel) and the texel's place in the dab (``along`` its length and
    ``across`` its width, each in [-1, 1])."""
    i, j, leaves = _raster_pairs(uv_axes, texels, which)
    found = _geometry(shapes, texels, i, j)
    place = np.searchsorted(which, found[0])                         # ``which`` is sorted
    inside = found[1] < texels.covered
    area = np.bincount(place, weights=found[2] * texels.lengths[found[1]] ** 2 * inside, minlength=len(which))
    whole = area >= WHOLE * DAB_AREA * dabs.length[which] * dabs.width[which]
    whole[place[_at_rim(uv_axes, texels, found[0], found[1])]] = False
    whole &= ~leaves
    if whole.all():
        return found
    keep = whole[place]
    searched = _geometry(shapes, texels, *_ball_pairs(dabs, texels, which[~whole]))
    return tuple(np.concatenate([a[keep], b]) for a, b in zip(found, searched))


def _raster_pairs(uv_axes, texels, which):
    """Pairs (dab, texel index) of the texels inside each dab's UV parallelogram (with slack), and whether
    each dab of ``which`` runs on past its chart's edge: its footprint's parallelogram (without the slack)
    holds atlas texels outside the charts.  Its paint there lies on another chart, which the raster does
    not see: drawn from the raster alone, it would stop along the chart's edge, as a step in its relief
    that a light draws as a crack."""
    axes, centre = uv_axes[0][which], uv_axes[1][which]
    size = texels.size
    axes = _grown(axes)
    corners = centre[:, None, :] + np.stack([axes[:, 0] + axes[:, 1], axes[:, 0] - axes[:, 1],
                                             -axes[:, 0] - axes[:, 1], -axes[:, 0] + axes[:, 1]], axis=1)
    finite = np.all(np.isfinite(corners.reshape(len(which), -1)), axis=1)
    low = np.clip(np.ceil(np.where(finite, corners[:, :, 1].min(axis=1), 0)), 0, size).astype(np.int64)
    high = np.clip(np.floor(np.where(finite, corners[:, :, 1].max(axis=1), -1)), -1, size - 1).astype(np.int64)
    rows = np.maximum(high - low + 1, 0) * finite
    unit, offset = expand_runs(rows)
    y = (low[unit] + offset).astype(np.float64)
    # the row's span: |alpha| <= 1 and |beta| <= 1 for (alpha, beta) = A^-1 (q - centre)
    a, b = axes[unit, 0], axes[unit, 1]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    det = np.where(np.abs(det) > 1e-12, det, 1e-12)
    dy = y - centre[unit, 1]
    lo, hi = np.full(len(unit), -np.inf), np.full(len(unit), np.inf)
    for px, py in ((b[:, 1] / det, -b[:, 0] / det), (-a[:, 1] / det, a[:, 0] / det)):   # rows of A^-1
        # px (x - cx) + py dy in [-1, 1]
        with np.errstate(divide="ignore", invalid="ignore"):
            x1, x2 = (-1.0 - py * dy) / px, (1.0 - py * dy) / px
        flat = np.abs(px) < 1e-12
        inside = np.abs(py * dy) <= 1.0
        lo = np.maximum(lo, np.where(flat, np.where(inside, -np.inf, np.inf), np.minimum(x1, x2)))
        hi = np.minimum(hi, np.where(flat, np.where(inside, np.inf, -np.inf), np.maximum(x1, x2)))
    lo = np.clip(np.ceil(lo + centre[unit, 0]), 0, size).astype(np.int64)
    hi = np.clip(np.floor(hi + centre[unit, 0]), -1, size - 1).astype(np.int64)
    span = np.maximum(hi - lo + 1, 0)
    run, col = expand_runs(span)
    position = texels.position[y[run].astype(np.int64) * size + lo[run] + col]
    found = position >= 0
    outside = np.flatnonzero(~found)
    dab = unit[run[outside]]
    footprint = uv_axes[0][which]                                    # not grown
    offset = np.column_stack([lo[run[outside]] + col[outside], y[run[outside]]]) - centre[dab]
    alpha, beta = _in_axes(offset, footprint[dab])
    within = (np.abs(alpha) < 1.0) & (np.abs(beta) < 1.0)
    leaves = np.bincount(dab[within], minlength=len(which)) > 0
    reach = np.abs(footprint[:, 0]) + np.abs(footprint[:, 1])      # and where it runs off the atlas
    leaves |= np.any((centre - reach < -0.5) | (centre + reach > size - 0.5), axis=1)
    return which[unit[run[found]]], position[found], leaves


def _at_rim(uv_axes, texels, i, j):
    """Whether the texels ``j`` lie on the rim (the outermost texel) of dab ``i``'s UV raster
    (:func:`_raster_pairs`): a dab that covers one may reach beyond its raster, which cuts it off along a
    straight line."""
    axes, centre = _grown(uv_axes[0][i]), uv_axes[1][i]
    y, x = np.divmod(texels.flat[j], texels.size)
    alpha, beta = _in_axes(np.column_stack([x, y]) - centre, axes)
    reach = 1.0 - 1.0 / np.maximum(np.linalg.norm(axes, axis=2), 1.0)   # a texel in from the rim
    return (np.abs(alpha) > reach[:, 0]) | (np.abs(beta) > reach[:, 1])


def _in_axes(offset, axes):
    """The coordinates ``(alpha, beta)`` of UV offsets (M, 2) in dabs' half axes (M, 2, 2):
    ``offset = alpha a + beta b`` for ``a, b = axes[:, 0], axes[:, 1]``."""
    a, b = axes[:, 0], axes[:, 1]
    det = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    det = np.where(np.abs(det) > 1e-12, det, 1e-12)
    return ((offset[:, 0] * b[:, 1] - offset[:, 1] * b[:, 0]) / det,
            (a[:, 0] * offset[:, 1] - a[:, 1] * offset[:, 0]) / det)


def _grown(axes):
    """The half axes (n, 2, 2) of the dabs' UV rasters: their footprints' ``axes`` made :data:`RASTER_SLACK`
    times longer, and a texel and a half more each way."""
    grow = RASTER_SLACK + 1.5 / np.maximum(np.linalg.norm(axes, axis=2), 1e-9)     # (n, 2)
    return axes * grow[:, :, None]


def _ball_pairs(dabs, texels, which):
    """Pairs (dab, texel index) of all texels within each dab's reach in space."""
    if not len(which):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    margin = 2.0 * float(np.median(texels.lengths))
    i, j = ball_pairs(texels.tree, dabs.centre[which], np.maximum(0.5 * dabs.length[which], dabs.width[which])
                      + dabs.depth[which] + margin)
    return which[i], j


def _half_width(along):
    """A dab's half width at ``along`` in [-1, 1], as a share of half its width: a flat body with a
    rounded head (-1) and a tail that tapers (+1)."""
    return (1.0 - np.abs(along) ** 3) ** (1 / 3) * (1.0 - 0.45 * np.maximum(along, 0.0) ** 3)


#: A dab's area over its length times its width.
DAB_AREA = float(np.mean(_half_width(np.linspace(-1, 1, 20001))))


class _Shapes:
    """The dabs' geometry in single precision, made once for :func:`_geometry`."""

    def __init__(self, dabs):
        self.centre = dabs.centre.astype(np.float32)
        self.direction = dabs.direction.astype(np.float32)
        self.side = np.cross(dabs.normal, dabs.direction).astype(np.float32)
        self.normal = dabs.normal.astype(np.float32)
        self.half_length = (0.5 * dabs.length).astype(np.float32)
        self.width = dabs.width.astype(np.float32)
        self.bend = (np.zeros(len(dabs), np.float32) if dabs.bend is None else dabs.bend.astype(np.float32))
        self.piece = dabs.piece


def _geometry(shapes, texels, i, j):
    """Of pairs of dabs ``i`` and texels ``j``: those the dab covers, with the coverage and the
    texel's place in the dab (see :func:`_covering`)."""
    half_length = shapes.half_length[i]
    delta = texels.points[j] - shapes.centre[i]
    a = np.einsum("ij,ij->i", delta, shapes.direction[i]) / half_length
    lengths = texels.lengths[j]
    near = np.abs(a) <= 1.0 + 2.0 * lengths / half_length
    i, j, delta, a, half_length, lengths = i[near], j[near], delta[near], a[near], half_length[near], lengths[near]
    v = np.einsum("ij,ij->i", delta, shapes.side[i])
    v -= 0.5 * shapes.bend[i] * (a * half_length) ** 2              # across the dab's arc, not its chord
    width = shapes.width[i]
    near = np.abs(v) <= 0.5 * width + lengths
    i, j, delta, a, v, half_length, width, lengths = (x[near] for x in (i, j, delta, a, v, half_length, width, lengths))
    normal = shapes.normal[i]
    facing = np.einsum("ij,ij->i", texels.normals[j], normal)
    own = ((facing > FACING[0]) & (texels.pieces[j] == shapes.piece[i])
           & (np.abs(np.einsum("ij,ij->i", delta, normal)) < half_length))
    i, j, a, v, half_length, width, lengths, facing = (x[own] for x in (i, j, a, v, half_length, width, lengths,
                                                                       facing))
    along = np.clip(a, -1.0, 1.0)
    half_width = 0.5 * width * _half_width(along)
    outside = np.maximum(np.abs(v) - half_width, (np.abs(a) - 1.0) * half_length)
    alpha = (np.clip(0.5 - outside / lengths, 0.0, 1.0)
             * smooth_step((facing - FACING[0]) / (FACING[1] - FACING[0])))
    covered = alpha > 0
    across = np.clip(v / np.maximum(half_width, 1e-9), -1.0, 1.0)
    return i[covered], j[covered], alpha[covered], along[covered], across[covered]


def _composite(dabs, texels, colours, first, i, j, alpha, shape, along, across, widest):
    """Pairs of dabs ``i`` and texels ``j`` composited in order, the dabs' two colours ``colours`` (from dab
    ``first`` on): per texel touched, how much of what lies under the block shows through, and what
    the block adds (colour and height).  Paint is thinner on narrower dabs than ``widest``
    (:data:`FINE_PAINT`).  ``alpha``: each pair's coverage by the dab's colour (clipped at the picture's
    edges); ``shape``: by its paint.  A dab's paint keeps its whole shape where its
    colour is clipped: the relief shows each stroke's body, rims and rounded ends, and no cliff where
    the picture's colours change (a step there, lit, reads as a cut stencil)."""
    if not len(i):
        return None
    width = dabs.width[i]
    phase = dabs.phase[i]
    opens, closes = dabs.stroke_ends(i)                    # whether each pair's dab begins, ends its stroke
    footprint = across                                     # across the dab's own tapered footprint
    # a dab within a stroke runs on from the one before it: its marks and rims go straight on into its head,
    # where a stroke's first dab bends them round its rounded head
    across = np.where(opens, across, across * _half_width(along))
    # bristle marks along the stroke, irregular: two waves across it, their number a dab's own (a stroke's
    # dabs share it, so its marks run on through them); fine streaks in its colour, fewer and broader
    # grooves in its paint
    texels_wide = width / texels.lengths[j]
    fading = np.where(closes, 1.0 - 0.3 * (along + 1.0), 1.0)           # where the brush runs dry
    broad, bristle = _bristles(texels_wide / STREAK_TEXELS, 2.0, STREAKS, phase, across)
    groove = bristle * fading
    ridge = _bristles(texels_wide / GROOVE_TEXELS, 1.0, GROOVES, phase, across)[1] * fading
    # a loaded brush: the second colour along one side of the stroke, meeting the first in streaks
    side_of = (5.7 * phase) % 1.0 - 0.5
    load = smooth_step(0.5 + (across - side_of + LOAD_STREAK * bristle) / LOAD_SOFT)
    # the tail runs dry: the paint breaks up along the bristles (the broadest of them) and lets what lies
    # under it show
    dry = np.where(closes, np.clip((along - DRY_AT) / (1.0 - DRY_AT), 0.0, 1.0), 0.0)
    dried = smooth_step(0.5 + (broad + 1.4 - 2.8 * dry) / 0.8)
    alpha = alpha * dried
    # its paint thins out evenly: the bristles' broken streaks of colour, raised, would stand as thin
    # fingers that a light draws as dark ticks
    shape = shape * (1.0 - DRY_THIN * smooth_step(dry))
    # raised paint, as a loaded brush leaves it: each dab its own thickness, thickest where the brush
    # touched down (the head of its stroke) and thinning towards the tail where it ran dry; a rim along
    # both sides where the bristles pushed the paint aside; bristle furrows along the stroke
    thickness = ((width / widest) ** FINE_PAINT * (0.7 + 0.6 * ((3.1 * phase) % 1.0))
                 * (1.0 + opens * HEAD * np.exp(-(((along + 0.7) / 0.25) ** 2)) - closes * TAIL * 0.5 * (along + 1.0)))
    rim = RIM * np.clip(texels_wide / RIM_TEXELS, 0.0, 1.0) * np.exp(-(((np.abs(across) - RIM_AT) / 0.15) ** 2))
    # the paint ends at the dab's sides and at its stroke's ends within a short share of its half width: a
    # stroke's edge stands as a rounded step, anti-aliased over a texel; a dab within a stroke runs on into
    # the one before it (it lays its paint over that one's, not on top of it)
    edge = np.maximum(EDGE * width / 2, texels.lengths[j])              # on the surface
    edge_across, edge_along = edge / (width / 2), edge / (dabs.length[i] / 2)
    side = (smooth_step((1.0 - np.abs(footprint)) / edge_across) * smooth_step((along + 1.0) / edge_along)
            * smooth_step((1.0 - along) / (3.0 * edge_along)))
    body = BODY * (1.0 - DOME * footprint**2)
    profile = thickness * side * (body + rim + GROOVE_DEPTH * ridge)
    scrape = np.where(opens | (dabs.layer[i] > dabs.layer.min()), FLATTEN, 1.0)   # fine strokes lie on the paint
    shade = 1.0 + STREAK * groove
    order = np.lexsort((-i, j))                # per texel, the last dab painted first
    i, j, alpha, shape, profile, shade, load, side, scrape = (x[order] for x in (i, j, alpha, shape, profile, shade,
                                                                                 load, side, scrape))
    heads = np.flatnonzero(np.r_[True, j[1:] != j[:-1]])
    through, shown = _over(alpha, heads)
    weight = alpha * shown * shade
    paint = (1.0 - load)[:, None] * np.asarray(colours[0])[i - first] + load[:, None] * np.asarray(colours[1])[i - first]
    added = np.column_stack([np.add.reduceat(weight * paint[:, c], heads) for c in range(3)])
    height_through, height_shown = _over(scrape * shape * side, heads)
    height_added = np.add.reduceat(shape * height_shown * profile, heads)
    return j[heads], through, added, height_through, height_added


def _bristles(count, fewest, most, phase, across):
    """A dab's bristle marks at ``across`` (in [-1, 1]): about ``count`` across its width (at least
    ``fewest``, at most about ``most``, by its ``phase``): its broadest bristles' wave and the marks (both in
    [-1, 1])."""
    grooves = np.clip(count, fewest, most * (0.7 + 0.6 * ((7.3 * phase) % 1.0)))
    wave = 0.5 * np.pi * grooves * (across + 1.0)
    broad = np.sin(wave + phase)
    return broad, 0.65 * broad + 0.35 * np.sin(1.7 * wave + 2.0 * phase)


def _over(alpha, heads):
    """Front-to-back compositing of runs (from ``heads``) of opacities: the share of what lies under a
    run that shows through it (per run), and the share of each item that shows (per item)."""
    log = np.log(np.maximum(1.0 - alpha, 1e-7)).astype(np.float64)
    total = np.cumsum(log)
    before = np.repeat(total[heads] - log[heads], np.diff(np.r_[heads, len(alpha)]))
    return np.exp(np.add.reduceat(log, heads)), np.exp(total - log - before)
