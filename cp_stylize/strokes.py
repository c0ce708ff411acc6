"""Brush strokes: dabs of paint laid on the surface, coarse to fine, and the relief they leave.

A painter covers the canvas with large strokes first and puts small ones
where the picture has detail (Hertzmann, "Painterly rendering with curved
brush strokes of multiple sizes", SIGGRAPH 1998); strokes follow the forms
and stop at the edges they would cross (Litwinowicz, "Processing images and
video for an impressionist effect", SIGGRAPH 1997).  Here each stroke is one
dab on the surface itself:

- **placed by its 3-D position**: points drawn on the triangles by area,
  thinned to at most one a cube of the layer's width (so they spread evenly),
  so a dab crosses UV seams and islands unbroken;
- **in layers**: the first covers the whole surface with dabs ``width`` wide;
  each next layer's dabs are :data:`LAYER_RATIO` times narrower and go only
  where the paint laid so far differs from the picture's at their size, or
  left it bare (Hertzmann's criterion: an edge or a feature the broad strokes
  could not carry), not over a texture finer than both brushes;
- **oriented** along the stroke field of its layer
  (:class:`~cp_stylize.stroke_field.StrokeField`):
  the picture's structure where it has some, else (with ``swirl``) the level
  lines of its broad light and dark (rings around a bright patch) or swirls;
  or along a given field (the surface's form);
- **a loaded brush**: the filtered colours under the dab, moved a little
  towards a neighbouring palette colour (``jitter``:
  :func:`cp_stylize.palette.loaded`), and a second colour
  moved towards another along one side of it, meeting the first in streaks
  along the bristles; the last dab of a stroke runs dry at its tail;
- **drawn at the texels** of the atlas (:func:`cp_stylize.canvas.paint`): a tapered footprint
  ``length`` long and ``width`` wide with anti-aliased edges, clipped where
  the colours under it differ from its own, composited in order; each dab
  also leaves a ridge profile with bristle furrows, overlapping dabs stack
  into a height map (impasto), and the dabs of one stroke run on into one
  another.

Lengths are those of the object normalised to a diameter of 2, so the
strokes look the same on an object of any size.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .arrays import aligned, ball_pairs
from .canvas import DAB_AREA, HEAD_END, TAIL_END
from .oklab import to_oklab
from .palette import check_palette, loaded
from .stroke_field import StrokeField, Swirls, size_smoothings

__all__ = ["Brush", "Dabs", "place_dabs", "chain_links", "LAYER_RATIO", "LINE_RATIO"]

#: Each layer's dabs are this many times narrower than the layer's before: the finest of three layers is
#: half the broadest's width, a mark of its own rather than a hairline among broad ones.
LAYER_RATIO = 1.45
#: The picture's thin lines and the contours are drawn at the scale of a brush whose layers are this many times
#: narrower each (:meth:`Brush.line_width`): a twig or a mast is drawn as fine as it is, whatever the finest
#: dab's width.
LINE_RATIO = 1.8
#: A layer whose dabs would be narrower than this many texels is left out (it could not be drawn).
MIN_TEXELS = 3.0
#: Dabs of the first layer cover each point of the surface about this many times.
COVER = 2.0
#: A finer layer's dab goes where the colours change by more than :data:`DETAIL` across its width (the
#: picture's structure: its edges and its texture; OKLab distance, certainly at twice) ...
DETAIL = 0.025
#: ... or, with a brush's ``broad`` paint, where the paint the coarser layers laid there differs from the
#: paint's colours at the finer dabs' size by more than :data:`MISSED`, or where they left it bare:
#: Hertzmann's finer brushes go where the canvas so far differs from the picture blurred to their size, so
#: they carry an edge or a feature the broad strokes could not (where those stopped, or crossed it), and
#: leave a texture finer than either brush to the broad paint.
MISSED = 0.04
#: Dabs placed at random leave some of the canvas bare however many there are (with twice the surface's
#: area in dabs, about an eighth of it): a last layer of the finest dabs goes where the layers before it left
#: the canvas more than this share bare, so that no gap shows the unpainted colours between strokes.
FILL = 0.5
#: ... in this many passes, each where the ones before left it bare.
FILLS = 2
#: Each dab's length varies by this share about the brush's.
LENGTH_SPREAD = 0.12
#: Each stroke's size (its dabs' length and width alike, so their shape stays) varies by this share about
#: the brush's, from half to one and a half times it: a flat patch takes strokes of several sizes, not rows
#: of equal scales (a quarter was judged blind against this half on the painterly presets, and lost).
SIZE_SPREAD = 0.5
#: Swirls (:class:`~cp_stylize.stroke_field.Swirls`) are this many dab lengths across.
SWIRL_SIZE = 4.0
#: Swirls begin at this OKLab lightness of the colours under a dab and take full effect 0.2 above it.
SWIRL_LIGHT = 0.45


def swirling(lightness):
    """How far a brush's swirl takes effect (0 to 1) where the picture's OKLab ``lightness`` is this
    (:data:`SWIRL_LIGHT`): in the light parts, as in the painting's sky."""
    return np.clip((np.asarray(lightness) - SWIRL_LIGHT) / 0.2, 0.0, 1.0)


@dataclasses.dataclass(frozen=True)
class Brush:
    """What the strokes look like (lengths of the object normalised to a diameter of 2).

    ``width``, ``length``: the first layer's dabs; ``layers``: how many
    layers, each :data:`LAYER_RATIO` times finer; ``chain``: how many dabs
    the first layer lays end to end as one stroke (:func:`_chained`), and each finer layer a smaller share
    of them (:func:`chain_links`); ``jitter`` in [0, 1]: how
    far a dab's colour moves towards a neighbouring palette colour;
    ``swirl`` in [0, 1]: how far dabs circle in swirls where the picture has
    no structure and is light (:data:`SWIRL_LIGHT`: as in the painting's sky;
    a dark, flat part keeps calm strokes); ``strength`` in [0, 1]: the dabs'
    opacity; ``seed``: the same seed places the same dabs; ``fidelity`` in
    [0, 1]: how much of the picture's own colours the run keeps (the
    palette's pull on the jitter falls with it); ``broad`` in [0, 1]: where
    the finer layers go, from wherever the picture has structure (0:
    :data:`DETAIL`) to only where the broad paint missed the picture (1:
    :data:`MISSED`).
    """

    width: float
    length: float
    layers: int = 3
    chain: int = 3
    jitter: float = 0.3
    swirl: float = 0.0
    strength: float = 1.0
    seed: int = 0
    fidelity: float = 0.0
    broad: float = 0.0

    def widths(self, texel, ratio=LAYER_RATIO):
        """The dab widths of the layers that can be drawn with texels ``texel`` long (each ``ratio`` times
        narrower than the one before)."""
        widths = [self.width / ratio**k for k in range(self.layers)]
        drawn = [w for w in widths if w >= MIN_TEXELS * texel]
        return drawn or widths[:1]

    def line_width(self, texel):
        """The scale the picture's thin lines and the contours are drawn at (:data:`LINE_RATIO`)."""
        return self.widths(texel, LINE_RATIO)[-1]

    def lengths(self, texel):
        """The dab lengths of the layers of :meth:`widths`."""
        return [self.length * w / self.width for w in self.widths(texel)]


@dataclasses.dataclass
class Dabs:
    """Dabs in painting order: centres, unit normals and directions (n, 3), lengths and widths (n,),
    sRGB colours (n, 3), connected pieces of the mesh (n,), bristle phases (n,), layers (n,), and the
    input face (n,) and barycentric coordinates (n, 3) of each centre, and the draws of each dab's
    colour jitter (n, 3), which :func:`cp_stylize.canvas.paint` applies to the colour it picks up under the dab, and each
    dab's bend (n,): the curvature of its centre line on the surface (per unit length; positive turns
    towards ``normal x direction``), so that a dab arcs with the field it follows."""

    centre: np.ndarray
    normal: np.ndarray
    direction: np.ndarray
    length: np.ndarray
    width: np.ndarray
    colour: np.ndarray
    piece: np.ndarray
    phase: np.ndarray
    layer: np.ndarray
    face: np.ndarray
    bary: np.ndarray
    draws: np.ndarray = None       # (n, 3) uniform draws of each dab's jitter (see :func:`cp_stylize.palette.jitter`), or None
    bend: np.ndarray = None        # (n,) curvature of each dab's centre line, or None (straight)
    ends: np.ndarray = None        # (n,) HEAD_END | TAIL_END: which ends of its stroke a dab is; None: both
    second: np.ndarray = None      # (n, 3) the second colour the brush is loaded with; None: ``colour``

    def __len__(self):
        return len(self.centre)

    @classmethod
    def concatenate(cls, parts):
        def joined(name):
            found = [getattr(p, name) for p in parts]
            return None if any(f is None for f in found) else np.concatenate(found)

        return cls(*[joined(f.name) for f in dataclasses.fields(cls)])

    @property
    def heads(self):
        """Whether each dab begins its stroke (n,)."""
        return self.stroke_ends(slice(None))[0]

    @property
    def tails(self):
        """Whether each dab ends its stroke (n,)."""
        return self.stroke_ends(slice(None))[1]

    def stroke_ends(self, which):
        """Whether each of the dabs ``which`` (an index) begins and ends its stroke: two boolean arrays."""
        ends = np.full(len(self), HEAD_END | TAIL_END, np.int8)[which] if self.ends is None else self.ends[which]
        return (ends & HEAD_END) > 0, (ends & TAIL_END) > 0

    @property
    def depth(self):
        """How deep each dab's arc is (n,): 0 for a straight dab."""
        return np.zeros(len(self)) if self.bend is None else 0.125 * np.abs(self.bend) * self.length**2

    @property
    def aspect(self):
        """Each dab's length over its width (n,)."""
        return self.length / self.width

    def layer_width(self, finest=False):
        """The median width of the first (broadest) layer's dabs, or with ``finest`` of the finest layer's."""
        layer = self.layer.max() if finest else self.layer.min()
        return float(np.median(self.width[self.layer == layer]))


def _spread(points, cell, rng):
    """Indices of ``points`` with at most one in each cube of side ``cell``, chosen at random."""
    order = rng.permutation(len(points))
    key = np.floor(points[order] / cell).astype(np.int64)
    _, first = np.unique(key, axis=0, return_index=True)
    return np.sort(order[first])


def place_dabs(mesh, band, values, brush, *, structure=None, texel, palette=None, weights=None, field=None,
               fields=None, level=None):
    """The dabs of a brush on a mesh, in painting order (a :class:`Dabs`).

    Parameters
    ----------
    mesh : TriangleMesh
        The surface, as the band was built on it.
    band : Band
    values : ndarray, shape (N, 3)
        The band's sRGB colours the dabs take theirs from (the filtered result).
    brush : Brush
    structure : ndarray, shape (N, 3), optional
        The picture's colours on the band in OKLab, whose structure the dabs follow and by which they are
        clipped (default ``values``'s).
    texel : float
        The atlas's texel length on the surface (layers too fine for it are left out).
    palette, weights : optional
        Colours a dab's colour is jittered towards (see :class:`Brush`).
    field : ndarray, shape (N, 3), optional
        A direction field the dabs follow where its length (the confidence in it) is 1.
    level : ndarray, shape (N, 3), optional
        Where the dabs run where the picture has no structure and ``field`` no direction
        (:func:`cp_stylize.stroke_field.level_field`).
    fields : list of StrokeField, optional
        The layers' fields, made before (:meth:`StrokeField.layers` of ``structure`` and the layers'
        dab lengths, :meth:`Brush.lengths`).
    """
    rng = np.random.default_rng([int(brush.seed), 6])
    values = np.ascontiguousarray(np.asarray(values, dtype=np.float32).reshape(band.size, -1)[:, :3])
    structure = to_oklab(values) if structure is None else structure
    lab_palette = None if palette is None else to_oklab(check_palette(palette, weights)[0])
    swirls = Swirls(SWIRL_SIZE * brush.length, brush.seed) if brush.swirl > 0 else None
    broad = StrokeField.layers(band, structure, [SWIRL_SIZE * brush.length])[0] if brush.swirl > 0 else None
    widths, lengths = brush.widths(texel), brush.lengths(texel)
    fields = StrokeField.layers(band, structure, lengths) if fields is None else fields
    at_size = clip_by = None
    if len(widths) > 1 and brush.broad > 0:
        paint = to_oklab(values).astype(np.float32)
        at_size = _at_sizes(band, paint, widths)                    # the paint's colours at each layer's size
        clip_by = np.stack([structure[:, :3], paint], axis=1)      # what a dab is clipped by: the picture, its paint
    parts, laid = [], []
    # the layers, broad to fine, then the finest dabs again where the canvas is still bare (FILL)
    for layer, (width, length, lines) in enumerate(zip(widths + widths[-1:] * FILLS, lengths + lengths[-1:] * FILLS,
                                                       fields + fields[-1:] * FILLS)):
        filling = layer >= len(widths)
        links = chain_links(brush.chain, layer) if band.face is not None and not filling else 1
        n = int(4 * COVER * mesh.area / (DAB_AREA * length * width))
        # a filling pass draws from its own stream, each place's draws made before the bare ones are chosen:
        # where the strokes before left no gap (or the same gaps), it lays the same dabs
        stream = np.random.default_rng([int(brush.seed), 6, layer]) if filling else rng
        points, faces, bary = mesh.sample(n, stream)
        keep = _spread(points, width * np.sqrt(2.5 * links / COVER), stream)
        points, faces, bary = points[keep], faces[keep], bary[keep]
        draw = rng
        if filling:
            chosen = _bare(parts, points) > FILL
            if not chosen.any():
                break
            draw = _Drawn(stream.random((len(points), 7))[chosen])
            points, faces, bary = points[chosen], faces[chosen], bary[chosen]
        elif layer > 0:
            # finer dabs where the colours change by more than DETAIL across a dab's width ...
            chance = np.clip(lines.strength_at(points) * width / DETAIL - 1.0, 0.0, 1.0)
            if at_size is not None:
                # ... or where the paint laid so far differs from the paint's colours at their size (MISSED)
                near = lines._nearest(points)
                painted, bare = _painted(parts, laid, points, clip_by[near], at_size[layer][near])
                missed = np.linalg.norm(painted - at_size[layer][near], axis=1) + 2.0 * MISSED * bare
                chance = (1.0 - brush.broad) * chance + brush.broad * np.clip(missed / MISSED - 1.0, 0.0, 1.0)
            chosen = rng.random(len(points)) < chance
            points, faces, bary = points[chosen], faces[chosen], bary[chosen]
        normals = mesh.normal(points, faces, bary)
        pieces = mesh.piece[faces]
        near = lines._nearest(points)
        light = swirling(structure[near, 0])
        direction = lines.at(points, normals, brush.swirl * light, swirls, field, broad, level)
        # where the picture has little structure, each dab turns a little its own way: a flat patch gets a
        # painter's varied strokes, not rings of parallel ones
        turn = WANDER * (1.0 - lines.confidence[near]) * (2.0 * draw.random(len(points)) - 1.0)
        direction = np.cos(turn)[:, None] * direction + np.sin(turn)[:, None] * np.cross(normals, direction)
        length = length * (1.0 + LENGTH_SPREAD * (2.0 * draw.random(len(points)) - 1.0))
        draws, phase = draw.random((len(points), 3)), 2 * np.pi * draw.random(len(points))
        size = 1.0 + SIZE_SPREAD * (2.0 * draw.random(len(points)) - 1.0)
        length, width = length * size, width * size

        def along(at, normals, which):
            return lines.at(at, normals, brush.swirl * light[which], swirls, field, broad, level)

        ends = None
        if links > 1:
            seed, points, faces, bary, normals, direction, ends = _chained(
                mesh, band, structure, structure[near], along, points, faces, bary, normals, direction, length, links)
            length, width, light, draws, phase = length[seed], width[seed], light[seed], draws[seed], phase[seed]
            pieces = mesh.piece[faces]
        count = len(points)
        colour = _picked_up(band, values, points, normals, pieces, direction, length)
        bend = _bends(band, points, normals, direction, length, width, lambda at: along(at, normals, slice(None)))
        first, second = loaded(colour, draws, brush.jitter * (1.0 - brush.fidelity), brush.jitter, lab_palette)
        if at_size is not None and layer + 1 < len(widths):
            # the picture and its paint at its centre (what it is clipped by), and the paint at its size
            # (the mean it picks up)
            near = lines._nearest(points)
            laid.append((clip_by[near], at_size[layer][near]))
        parts.append(Dabs(points, normals, direction, length, width, first,
                          pieces.astype(np.int64), phase, np.full(count, layer), faces, bary, draws, bend,
                          np.full(count, HEAD_END | TAIL_END, np.int8) if ends is None else ends, second))
    return Dabs.concatenate(parts)


class _Drawn:
    """Uniform draws made before, one row (k,) for each place, handed out column by column as a NumPy
    generator's ``random`` would hand out new ones."""

    def __init__(self, values):
        self.values, self.used = values, 0

    def random(self, shape):
        columns = int(np.prod(shape[1:])) if isinstance(shape, tuple) else 1
        out = self.values[:, self.used:self.used + columns]
        self.used += columns
        return out.reshape(shape)


def _bare(parts, points):
    """How much of the canvas the dabs of ``parts`` (:class:`Dabs`, in painting order) leave bare at surface
    ``points`` (M, 3), by their footprints alone (1: none covers the point; 0: one does)."""
    zeros = [(np.zeros((len(p), 1, 3)), np.zeros((len(p), 3))) for p in parts]
    return _painted(parts, zeros, points, np.zeros((len(points), 1, 3)), np.zeros((len(points), 3)))[1]


def _at_sizes(band, values, widths):
    """The band's ``values`` (N, C) at the size of dabs ``widths`` wide, broad to fine: smoothed by a
    Gaussian of half the width on the surface (:func:`~cp_stylize.stroke_field.size_smoothings`)."""
    rows = np.ascontiguousarray(np.asarray(values, dtype=np.float32).reshape(band.size, -1).T)
    return [smoothing(rows).T for smoothing in size_smoothings(band, widths)]


def _painted(parts, laid, points, under, base):
    """What the dabs laid so far leave at surface ``points`` (M, 3), as :func:`cp_stylize.canvas.paint` lays
    them, and how much of the canvas they leave bare there (M,).

    ``parts``: the layers' :class:`Dabs`, in painting order; ``laid``: for each, the colours each dab is
    clipped by (n, k, 3: the picture and its paint at its centre) and the colour it paints (n, 3: the
    paint's colours at its size, as it picks up their mean).  A dab covers the points inside its footprint,
    less where their colours ``under`` (M, k, 3) differ from its own (:func:`cp_stylize.canvas.clipped`),
    the last on top, over ``base`` (M, 3)."""
    from scipy.spatial import cKDTree

    from .canvas import _half_width, _over, clipped

    dabs = Dabs.concatenate(parts)
    centre, colour = (np.concatenate(c) for c in zip(*laid))
    half = 0.5 * dabs.length
    i, j = ball_pairs(cKDTree(points), dabs.centre, half)
    delta = points[j] - dabs.centre[i]
    a = np.einsum("ij,ij->i", delta, dabs.direction[i]) / half[i]
    v = np.einsum("ij,ij->i", delta, np.cross(dabs.normal[i], dabs.direction[i]))
    if dabs.bend is not None:
        v -= 0.5 * dabs.bend[i] * (a * half[i]) ** 2
    inside = (np.abs(a) <= 1.0) & (np.abs(v) <= 0.5 * dabs.width[i] * _half_width(np.clip(a, -1.0, 1.0)))
    i, j = i[inside], j[inside]
    alpha = clipped(np.linalg.norm(under[j] - centre[i], axis=2).max(axis=1))
    order = np.lexsort((-i, j))                       # per point, the last dab first
    i, j, alpha = i[order], j[order], alpha[order]
    out, bare = np.array(base, dtype=np.float64), np.ones(len(points))
    if not len(i):
        return out, bare
    heads = np.flatnonzero(np.r_[True, j[1:] != j[:-1]])
    through, shown = _over(alpha, heads)
    weight = alpha * shown
    added = np.column_stack([np.add.reduceat(weight * colour[i, c], heads) for c in range(3)])
    out[j[heads]] = out[j[heads]] * through[:, None] + added
    bare[j[heads]] = through
    return out, bare


#: Where the picture has no structure, a dab turns by up to this angle (radians) from the field, at random.
WANDER = 0.35


def chain_links(chain, layer):
    """How many dabs a stroke of layer ``layer`` (0: the first, the broadest) takes at most, for a brush's
    ``chain``: all of them in the first layer, half of them in the second, a third in the third and so on,
    at least one.  A long stroke that follows the form carries on, narrower, where the picture has detail,
    and a brush of short strokes (a chain of 2 or 3) lays the finer layers in single dabs."""
    return max(1, int(chain) // (int(layer) + 1))


#: A layer's dabs are laid in strokes of up to :func:`chain_links`: from each dab the next goes on
#: along the field by :data:`CHAIN_STEP` of its length, with the same paint (its jitter and bristles),
#: until the picture's colour under it changes by more than :data:`CHAIN_COLOUR` (OKLab) from where the
#: stroke began.  Each dab keeps its own shape; together they read as one long, bending stroke of the brush.
CHAIN_STEP = 0.6
CHAIN_COLOUR = 0.1


def _chained(mesh, band, lab, start, along, points, faces, bary, normals, direction, length, links):
    """Strokes of up to ``links`` dabs begun at ``points`` (see :data:`CHAIN_STEP`): each stroke's seed index
    (m,) and its dabs' centres (m, 3), input faces (m,), barycentrics (m, 3), normals (m, 3) and
    directions (m, 3), a stroke's dabs one after another, and which ends of its stroke each is (m,:
    :attr:`Dabs.ends`).  ``lab`` (N, 3) are the band's colours a stroke
    keeps to, ``start`` (n, 3) theirs where each stroke begins; ``along(points, normals, seeds)`` gives
    the field's directions."""
    piece = mesh.piece[faces]
    found = [(np.arange(len(points)), points, faces, bary, normals, direction)]
    alive, x, d = found[0][0], points, direction
    for _ in range(1, links):
        g = band.nearest(x + (CHAIN_STEP * length[alive])[:, None] * d)
        ok = g >= 0
        g = np.maximum(g, 0)
        ok &= (mesh.piece[band.face[g]] == piece[alive]) & (np.linalg.norm(lab[g] - start[alive], axis=1)
                                                             < CHAIN_COLOUR)
        alive, g, d = alive[ok], g[ok], d[ok]
        if not len(alive):
            break
        x, f, b = band.cp[g].astype(np.float64), band.face[g], band.bary[g]
        n = mesh.normal(x, f, b)
        d = aligned(along(x, n, alive), d)
        found.append((alive, x, f, b, n, d))
    seed, *rest = (np.concatenate(parts) for parts in zip(*found))
    order = np.argsort(seed, kind="stable")                  # a stroke's dabs together, in the order laid
    seed = seed[order]
    new = np.r_[True, seed[1:] != seed[:-1]]
    ends = HEAD_END * new + TAIL_END * np.r_[new[1:], True]
    return (seed, *(a[order] for a in rest), ends.astype(np.int8))


#: A dab bends by at most this share of its width (the depth of its arc), however fast the field turns.
BEND_MAX = 0.5


def _bends(band, points, normals, direction, length, width, directions):
    """The curvature (n,) of each dab's centre line: how far the field turns between its two ends (read by
    ``directions(points)`` at the closest points of the band points nearest to them) over its length,
    kept to an arc at most :data:`BEND_MAX` of ``width`` deep; 0 where an end leaves the band."""
    ends, inside = [], np.ones(len(points), dtype=bool)
    for sign in (-1.0, 1.0):
        end = points + (sign * 0.5 * length)[:, None] * direction
        onto, found = _onto(band, end, points)
        inside &= found
        ends.append(aligned(directions(onto), direction))
    turn = np.arctan2(np.einsum("ij,ij->i", np.cross(ends[0], ends[1]), normals), np.einsum("ij,ij->i", *ends))
    depth = np.clip(0.125 * turn * length, -BEND_MAX * width, BEND_MAX * width)     # the arc's depth, kept
    return np.where(inside, depth / (0.125 * length**2), 0.0)


#: Where along its length (a share of half the length) a dab reads the colours it takes the mean of.
PICKUP = np.linspace(-0.7, 0.7, 5)


def _onto(band, x, fallback):
    """Points ``x`` (M, 3) moved onto the surface: the closest points of their nearest band points, and
    ``fallback`` (M, 3) where they have left the band; and whether each was in it (M,)."""
    nearest = band.nearest(x)
    inside = nearest >= 0
    return np.where(inside[:, None], band.cp[np.maximum(nearest, 0)], fallback), inside


def _picked_up(band, values, points, normals, pieces, direction, length):
    """The colour a dab takes (n, 3): the mean of the band's colours at :data:`PICKUP` points along it,
    each moved onto the surface (the closest point of its nearest band point; the centre where it
    has left the band)."""
    k = len(PICKUP)
    along = points[:, None, :] + (PICKUP[None, :, None] * 0.5 * length[:, None, None]) * direction[:, None, :]
    along = along.reshape(-1, 3)
    onto, _ = _onto(band, along, np.repeat(points, k, axis=0))
    read = band.interpolate(values, onto, np.repeat(normals, k, axis=0), np.repeat(pieces, k))
    return read.reshape(len(points), k, read.shape[-1]).mean(axis=1)      # (no dabs: none, not an error)
