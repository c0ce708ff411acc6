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
  where the colours at their scale differ from the layer before (detail and
  edges);
- **oriented** along the stroke field of its layer (:class:`StrokeField`):
  the picture's structure where it has some, else (with ``swirl``) the level
  lines of its broad light and dark (rings around a bright patch) or swirls;
  or along a given field (the surface's form);
- **a loaded brush**: the filtered colours under the dab, moved a little
  towards a neighbouring palette colour (``jitter``), and a second colour
  moved towards another along one side of it, meeting the first in streaks
  along the bristles; the last dab of a stroke runs dry at its tail;
- **drawn at the texels** of the atlas (:func:`paint`): a tapered footprint
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
from scipy.spatial import cKDTree

from .oklab import from_oklab, to_oklab
from .arrays import aligned, expand_runs, smooth_step
from .palette import check_palette, kept_chroma, palette_distance
from .smoothing import GridGaussian, taper
from .sparse import map_parallel

__all__ = ["Brush", "Dabs", "Texels", "StrokeField", "Swirls", "form_field", "level_field", "place_dabs", "paint", "jitter",
           "LAYER_RATIO"]

#: Each layer's dabs are this many times narrower than the layer's before.
LAYER_RATIO = 1.8
#: A layer whose dabs would be narrower than this many texels is left out (it could not be drawn).
MIN_TEXELS = 3.0
#: Dabs of the first layer cover each point of the surface about this many times.
COVER = 2.0
#: A finer layer's dab goes where its colour differs from the coarser layer's by more than this
#: (OKLab distance; certainly at twice).
DETAIL = 0.025
#: A dab is clipped where the colour under it differs from its own by more than this (OKLab), and
#: gone at twice.
CLIP = 0.2
#: Each dab's length varies by this share about the brush's.
LENGTH_SPREAD = 0.12
#: Each stroke's size (its dabs' length and width alike, so their shape stays) varies by this share about
#: the brush's: a flat patch takes strokes of several sizes, not rows of equal scales.
SIZE_SPREAD = 0.25
#: Swirls (:class:`Swirls`) are this many dab lengths across.
SWIRL_SIZE = 4.0
#: Swirls begin at this OKLab lightness of the colours under a dab and take full effect 0.2 above it.
SWIRL_LIGHT = 0.45
#: Of the height a later stroke paints over, this share is scraped away (the rest stays under it: paint
#: builds up where strokes overlap); a dab within a stroke lays its paint over the one before it, all of it.
FLATTEN = 0.35
#: A dab's paint ends within this share of its half width (at least a texel) at its sides and its stroke's
#: head, and within three times that at its tail: a stroke's edge stands as a rounded step, not a cliff of
#: one texel.
EDGE = 0.45
#: A stroke's paint is this much thicker at its head (where the brush touched down) and a stroke's last dab this
#: much thinner at its tail; each dab's paint is raised by this much in a rim along its sides (paint the
#: bristles pushed aside).
HEAD = 0.2
TAIL = 0.4
RIM = 0.3
#: The rim's crest, as a share of the dab's half width out from its centre line: where the edge's ramp begins.
RIM_AT = 0.55
#: A dab's paint stands this high in its body (a share of its thickness, without its rim and bristle marks).
BODY = 0.5
#: How deep the bristle marks in a dab are, as a share of its thickness, and how much lighter and darker they
#: make its colour.
GROOVE_DEPTH = 0.12
STREAK = 0.07
#: A dab's second colour (:attr:`Dabs.second`) meets its first over this share of its width, in streaks along
#: the bristles this much of its half width deep.
LOAD_SOFT = 0.5
LOAD_STREAK = 0.5
#: The last dab of a stroke runs dry from this share of its half length behind its centre to its tail.
DRY_AT = 0.4
#: Bristle grooves are at least this many texels apart, and a dab has at most about this many of them
#: (a broad brush leaves a few strong marks, not a comb's fine lines).
GROOVE_TEXELS = 3.0
GROOVES = 5.0
#: A dab's place in its stroke (:attr:`Dabs.ends`): the first (the brush touched down) or the last (it lifted).
HEAD_END, TAIL_END = 1, 2
#: Dabs drawn at once (a block of pairs of texels and dabs).
_CHUNK = 3000


@dataclasses.dataclass(frozen=True)
class Brush:
    """What the strokes look like (lengths of the object normalised to a diameter of 2).

    ``width``, ``length``: the first layer's dabs; ``layers``: how many
    layers, each :data:`LAYER_RATIO` times finer; ``chain``: how many dabs
    the first layer lays end to end as one stroke (:func:`_chained`); ``jitter`` in [0, 1]: how
    far a dab's colour moves towards a neighbouring palette colour;
    ``swirl`` in [0, 1]: how far dabs circle in swirls where the picture has
    no structure and is light (:data:`SWIRL_LIGHT`: as in the painting's sky;
    a dark, flat part keeps calm strokes); ``strength`` in [0, 1]: the dabs'
    opacity; ``seed``: the same seed places the same dabs; ``fidelity`` in
    [0, 1]: how much of the picture's own colours the run keeps (the
    palette's pull on the jitter falls with it).
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

    def widths(self, texel):
        """The dab widths of the layers that can be drawn with texels ``texel`` long."""
        widths = [self.width / LAYER_RATIO**k for k in range(self.layers)]
        drawn = [w for w in widths if w >= MIN_TEXELS * texel]
        return drawn or widths[:1]

    def lengths(self, texel):
        """The dab lengths of the layers of :meth:`widths`."""
        return [self.length * w / self.width for w in self.widths(texel)]


@dataclasses.dataclass
class Dabs:
    """Dabs in painting order: centres, unit normals and directions (n, 3), lengths and widths (n,),
    sRGB colours (n, 3), connected pieces of the mesh (n,), bristle phases (n,), layers (n,), and the
    input face (n,) and barycentric coordinates (n, 3) of each centre, and the draws of each dab's
    colour jitter (n, 3), which :func:`paint` applies to the colour it picks up under the dab, and each
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
    draws: np.ndarray = None       # (n, 3) uniform draws of each dab's jitter (see :func:`jitter`), or None
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


class Swirls:
    """Swirling directions on any surface: the rotated surface gradient ``n x grad phi`` of a smooth
    random function ``phi`` of space (a sum of plane waves of about one ``wavelength``), which runs
    along the level lines of ``phi`` and so circles its maxima and minima."""

    WAVES = 24

    def __init__(self, wavelength, seed=0):
        rng = np.random.default_rng([int(seed), 5])
        direction = rng.standard_normal((self.WAVES, 3))
        direction /= np.linalg.norm(direction, axis=1, keepdims=True)
        k = 2 * np.pi / wavelength * (0.7 + 0.6 * rng.random(self.WAVES))
        self.omega = direction * k[:, None]
        self.phase = 2 * np.pi * rng.random(self.WAVES)
        self.amplitude = 1.0 / (np.sqrt(self.WAVES) * k)

    def __call__(self, points, normals):
        """Unit tangent directions (M, 3) at surface points (M, 3) with unit normals (M, 3)."""
        gradient = (np.cos(points @ self.omega.T + self.phase) * self.amplitude) @ self.omega
        gradient -= np.einsum("ij,ij->i", gradient, normals)[:, None] * normals
        return _unit(np.cross(normals, gradient))


class StrokeField:
    """Where strokes run at one scale: along the structure of band values (the smaller eigenvector of
    their tangent structure tensor, integrated over a deviation of half a dab length), with a
    confidence in it, so that :meth:`at` can blend in swirls or a given field where the picture has
    little structure.  Made by :meth:`layers` for all the scales of a brush at once."""

    def __init__(self, band, direction, confidence, strength):
        self.band, self.direction, self.confidence, self.strength = band, direction, confidence, strength

    def _nearest(self, points):
        return np.maximum(self.band.nearest(points), 0)

    def strength_at(self, points):
        """The structure's strength (M,) at surface points (M, 3): the root of the tensor's larger
        eigenvalue, a colour change per unit length."""
        return self.strength[self._nearest(points)]

    @classmethod
    def layers(cls, band, values, lengths):
        """A field for each dab length of ``lengths``, of the structure of band ``values`` (N, C)."""
        from .diffusion import GridSmoothing
        from .structure import eigen_2x2, products, reduce_to_tangent
        from .tangent import tangent_basis

        gradients = GridSmoothing(band, np.float32, {"sigma": 0.0})
        gradients._build_gradients()
        rows = np.ascontiguousarray(np.asarray(values, dtype=np.float32).reshape(band.size, -1).T)
        J = products(rows, gradients.gradients)
        q0, q1 = np.ascontiguousarray(tangent_basis(band).transpose(2, 1, 0), dtype=np.float32)
        fields, smoothing = [], None
        for length in lengths:
            rho = 0.5 * (0.5 * length) ** 2
            smoothing = (GridGaussian(band, rho, weights=taper(band.dist, 3.0 * band.h)) if smoothing is None
                         else smoothing.at_time(rho))
            mu1, mu2, c, s = eigen_2x2(*reduce_to_tangent(smoothing(J), q0, q1))
            strength = np.sqrt(np.maximum(mu1, 0.0))
            coherence = (mu1 - mu2) / np.maximum(mu1 + mu2, 1e-12)
            # a structure counts where it is coherent and among the stronger of the surface's
            confidence = (np.clip(coherence / 0.5, 0.0, 1.0)
                          * np.clip(strength / max(float(np.quantile(strength, 0.75)), 1e-12), 0.0, 1.0))
            fields.append(cls(band, np.ascontiguousarray((q1 * c - q0 * s).T), confidence, strength))
        return fields

    def at(self, points, normals, swirl=0.0, swirls=None, field=None, broad=None, level=None):
        """Unit directions (M, 3) at surface points (M, 3) with normals (M, 3): the structure's, blended
        by doubled angles with a given ``field`` (N, 3) of the band, whose length is the confidence in
        it (a field trusted at :data:`FALLBACK_TRUST` or less yields where the structure is sure), and,
        by ``swirl`` where the structure is weak, with the ``broad`` field (the same structure over a
        wide neighbourhood: its level lines ring a bright or dark patch, as van Gogh's strokes ring
        his stars) and, where that is weak too, with ``swirls``.  ``swirl`` is a number or one
        for each point (M,).  Before the swirls, a ``level`` field (N, 3: unit, or 0 where it has no
        direction; see :func:`level_field`) takes over where the structure is weak
        (:data:`LEVEL_YIELD`)."""
        nearest = self._nearest(points)
        direction = _tangent(self.direction[nearest].astype(np.float64), normals)
        none = np.linalg.norm(direction, axis=1) < 0.5
        if none.any():                                   # the structure lies along the normal there: any tangent
            direction[none] = _tangent(np.cross(normals[none], [0.577, 0.577, 0.577]) + [1e-3, 0.0, 0.0],
                                       normals[none])
        confidence = self.confidence[nearest].astype(np.float64)
        if field is not None:
            raw = np.asarray(field[nearest], dtype=np.float64)
            given = _tangent(raw, normals)
            trust = np.clip(np.linalg.norm(raw, axis=1), 0.0, 1.0)
            trust[np.linalg.norm(given, axis=1) < 0.5] = 0.0          # no direction there (a flat part)
            given[trust == 0] = direction[trust == 0]
            # a fallback (trusted at FALLBACK_TRUST or less) yields to the picture's structure as far as
            # that is sure; a field trusted fully does not
            fallback = np.clip((1.0 - trust) / (1.0 - FALLBACK_TRUST), 0.0, 1.0)
            trust = np.where(trust > 0, 1.0 - fallback * np.sqrt(confidence), 0.0)
            direction = _blend(given, direction, trust, normals)
        if level is not None:
            flat = _tangent(np.asarray(level[nearest], dtype=np.float64), normals)
            has = np.linalg.norm(flat, axis=1) > 0.5
            flat[~has] = direction[~has]
            direction = _blend(direction, flat, np.where(has, confidence**LEVEL_YIELD, 1.0), normals)
        swirl = np.broadcast_to(np.asarray(swirl, dtype=np.float64), (len(points),))
        if swirl.any() and (broad is not None or swirls is not None):
            if broad is not None:
                wide = broad._nearest(points)
                around = _tangent(broad.direction[wide].astype(np.float64), normals)
                none = np.linalg.norm(around, axis=1) < 0.5
                around[none] = direction[none]
                reach = np.where(none, 0.0, broad.confidence[wide].astype(np.float64))
                if swirls is not None:
                    around = _blend(around, swirls(points, normals), reach, normals)
            else:
                around = swirls(points, normals)
            direction = _blend(direction, around, 1.0 - swirl * (1.0 - confidence), normals)
        return direction


#: The confidence :func:`form_field` gives its meridians or parallels where the form has no direction:
#: a strong structure of the picture turns strokes away from them (see :meth:`StrokeField.at`).
FALLBACK_TRUST = 0.5
#: Where the picture's structure is weak, strokes turn to a ``level`` field (:meth:`StrokeField.at`) by 1 less the
#: confidence in the structure to this power: a faint grain of asphalt does not keep its whorls.
LEVEL_YIELD = 1.0


def form_field(band, field, around=False, axis=(0.0, 0.0, 1.0)):
    """A direction field (N, 3) along the form, whose length is the confidence in it, completed where the
    form has no direction of its own (a sphere, a flat part): there strokes run along the object's
    ``axis`` projected onto the surface (its meridians), or around it (``around``: its parallels), as
    far as the surface is not square to the axis.  ``field`` is a principal curvature direction times
    its confidence (:func:`cp_stylize.pipeline.stroke_field`)."""
    from .tangent import surface_normals

    normals = np.asarray(surface_normals(band), dtype=np.float64)
    given = np.asarray(field, dtype=np.float64)
    trust = np.clip(np.linalg.norm(given, axis=1), 0.0, 1.0)
    meridian = np.asarray(axis, dtype=np.float64) - (normals @ np.asarray(axis, dtype=np.float64))[:, None] * normals
    reach = np.clip(np.linalg.norm(meridian, axis=1), 0.0, 1.0)            # 0 where the surface faces the axis
    fallback = _unit(np.cross(normals, meridian) if around else meridian)
    unit = _tangent(given, normals)
    unsure = np.linalg.norm(unit, axis=1) < 0.5
    unit[unsure] = fallback[unsure]
    blended = _blend(unit, fallback, np.where(unsure, 0.0, trust), normals)
    return blended * np.maximum(trust, FALLBACK_TRUST * reach)[:, None]


def level_field(band, field, level):
    """The picture's horizontal (N, 3) at the band's points where ``field`` (N, 3, or None; see
    :func:`form_field`) has no direction, 0 elsewhere: ``level`` (F, 3) is the direction of each input
    face along its picture's u axis (0 where no picture colours the face).

    A painter lays flat ground in level strokes.  Where the picture has no structure of its own
    (asphalt, a lawn, a wall), strokes turn to this field (:meth:`StrokeField.at`) instead of ringing
    the nearest edges in whorls.  Each face's own picture gives it, so the field turns where the
    picture does (across its UV seams) and nowhere else."""
    from .tangent import surface_normals

    normals = np.asarray(surface_normals(band), dtype=np.float64)
    out = np.asarray(level, dtype=np.float64)[band.face]
    has = np.linalg.norm(out, axis=1) > 0
    if field is not None:
        has &= np.linalg.norm(np.asarray(field, dtype=np.float64), axis=1) < 1e-3
    return np.where(has[:, None], _tangent(out, normals), 0.0).astype(np.float32)


def _unit(v):
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-12)


def _tangent(v, normals):
    return _unit(v - np.einsum("ij,ij->i", v, normals)[:, None] * normals)


def _blend(first, second, weight, normals):
    """Line fields (M, 3) blended by doubled angles in each tangent plane: ``weight`` of ``first``."""
    side = np.cross(normals, first)
    angle = np.arctan2(np.einsum("ij,ij->i", second, side), np.einsum("ij,ij->i", second, first))
    doubled = (1.0 - weight) * np.exp(2j * angle) + weight        # first at angle 0
    half = 0.5 * np.angle(doubled)
    return _unit(np.cos(half)[:, None] * first + np.sin(half)[:, None] * side)


def _surface_samples(mesh, n, rng):
    """``n`` random points on the mesh, by area: points (n, 3), input faces (n,), barycentrics (n, 3)."""
    corners = mesh.vertices[mesh.faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    kept = rng.choice(len(corners), size=n, p=area / area.sum())
    r = np.sqrt(rng.random(n))
    t = rng.random(n)
    bary = np.column_stack([1.0 - r, r * (1.0 - t), r * t])
    return np.einsum("nk,nkj->nj", bary, corners[kept]), mesh.face_index[kept], bary


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
    structure : ndarray, shape (N, C), optional
        Band values whose structure the dabs follow (default ``values``).
    texel : float
        The atlas's texel length on the surface (layers too fine for it are left out).
    palette, weights : optional
        Colours a dab's colour is jittered towards (see :class:`Brush`).
    field : ndarray, shape (N, 3), optional
        A direction field the dabs follow where its length (the confidence in it) is 1.
    level : ndarray, shape (N, 3), optional
        Where the dabs run where the picture has no structure and ``field`` no direction
        (:func:`level_field`).
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
    parts = []
    for layer, (width, length, lines) in enumerate(zip(widths, lengths, fields)):
        links = brush.chain if layer == 0 and band.face is not None else 1      # the first layer's dabs in strokes
        n = int(4 * COVER * mesh.area / (_AREA * length * width))
        points, faces, bary = _surface_samples(mesh, n, rng)
        keep = _spread(points, width * np.sqrt(2.5 * links / COVER), rng)
        points, faces, bary = points[keep], faces[keep], bary[keep]
        if layer > 0:
            # finer dabs where the colours change by more than DETAIL across a dab's width
            change = lines.strength_at(points) * width
            chosen = rng.random(len(points)) < np.clip(change / DETAIL - 1.0, 0.0, 1.0)
            points, faces, bary = points[chosen], faces[chosen], bary[chosen]
        normals = mesh.normal(points, faces, bary)
        pieces = mesh.piece[faces]
        near = lines._nearest(points)
        light = np.clip((structure[near, 0] - SWIRL_LIGHT) / 0.2, 0.0, 1.0)
        direction = lines.at(points, normals, brush.swirl * light, swirls, field, broad, level)
        # where the picture has little structure, each dab turns a little its own way: a flat patch gets a
        # painter's varied strokes, not rings of parallel ones
        turn = WANDER * (1.0 - lines.confidence[near]) * (2.0 * rng.random(len(points)) - 1.0)
        direction = np.cos(turn)[:, None] * direction + np.sin(turn)[:, None] * np.cross(normals, direction)
        length = length * (1.0 + LENGTH_SPREAD * (2.0 * rng.random(len(points)) - 1.0))
        draws, phase = rng.random((len(points), 3)), 2 * np.pi * rng.random(len(points))
        size = 1.0 + SIZE_SPREAD * (2.0 * rng.random(len(points)) - 1.0)
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
        parts.append(Dabs(points, normals, direction, length, width, first,
                          pieces.astype(np.int64), phase, np.full(count, layer), faces, bary, draws, bend,
                          np.full(count, HEAD_END | TAIL_END, np.int8) if ends is None else ends, second))
    return Dabs.concatenate(parts)


#: Where the picture has no structure, a dab turns by up to this angle (radians) from the field, at random.
WANDER = 0.35
#: The first layer's dabs are laid in strokes of up to :attr:`Brush.chain`: from each dab the next goes on
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
    return read.reshape(len(points), k, -1).mean(axis=1)


#: The most a dab's jitter moves its lightness (OKLab), at a jitter of 1.
SHADE = 0.2


def jitter(colours, draws, pull, shade, lab_palette):
    """sRGB colours (n, 3), each moved towards one of the three palette colours nearest to it
    (:func:`cp_stylize.palette.palette_distance`: its neighbours in hue first) by up to ``pull``, and
    its lightness by up to ``shade`` times :data:`SHADE`: broken colour.  ``draws`` (n, 3) in [0, 1) pick the
    neighbour, the share of ``pull`` and the lightness, so that a dab keeps its jitter whatever
    colour it picks up."""
    return _jittered(to_oklab(colours), draws, pull, shade, lab_palette)


def loaded(colours, draws, pull, shade, lab_palette):
    """The two sRGB colours (n, 3 each) a brush is loaded with from the colours (n, 3) it picks up: each
    jittered (:func:`jitter`) by its own ``draws`` and by those of its second colour (:func:`_loaded`),
    the palette's neighbours of each colour found once for both."""
    lab = to_oklab(colours)
    near = _palette_neighbours(lab, pull, lab_palette)
    return tuple(_jittered(lab.copy(), d, pull, shade, lab_palette, near) for d in (draws, _loaded(draws)))


def _palette_neighbours(lab, pull, lab_palette):
    """The three palette colours nearest to each OKLab colour (n, 3) (indices, (n, 3)), or None without a pull."""
    if pull > 0 and lab_palette is not None:
        return np.argsort(palette_distance(lab[:, None, :], lab_palette[None]), axis=1)[:, :3]
    return None


def _jittered(lab, draws, pull, shade, lab_palette, near=None):
    """:func:`jitter` of OKLab colours ``lab`` (n, 3, changed in place), given their palette neighbours ``near``
    (found here when None)."""
    near = _palette_neighbours(lab, pull, lab_palette) if near is None else near
    if near is not None:
        pick = near[np.arange(len(lab)), np.minimum((draws[:, 0] * near.shape[1]).astype(np.int64), near.shape[1] - 1)]
        lab += (pull * draws[:, 1])[:, None] * (lab_palette[pick] - lab)
    lab[:, 0] += SHADE * shade * (2.0 * draws[:, 2] - 1.0)
    return from_oklab(lab)


def _loaded(draws):
    """The jitter draws (n, 3) of the second colour a brush is loaded with, from those of its first: another of
    the neighbouring palette colours, and a lightness on the other side of the picked-up colour's."""
    return (draws + 0.5) % 1.0


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
#: space instead.
WHOLE = 0.92
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
    reference : ndarray, shape (M, 3), optional
        The colours a dab is clipped against (:data:`CLIP`), sRGB: the picture's own at the texels;
        default ``base``.
    strength : float
        The dabs' opacity.
    source : ndarray, shape (n, 3), optional
        Each dab's own colour in ``reference``'s terms (the picture's at its centre); default its colour.
    pickup : tuple, optional
        ``(colours (M, 3) in OKLab, pull, shade, lab_palette)``: each dab takes the mean of ``colours``
        over the texels it covers (the picture under it at the texture's resolution; its chroma kept)
        and its jitter
        (:func:`jitter`) again; without it, dabs keep the colours they have.
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
    lab_reference = to_oklab(reference).astype(np.float32)
    lab_dabs = to_oklab(dabs.colour if source is None else source).astype(np.float32)
    shapes = _Shapes(dabs)
    uv_axes = _uv_axes(dabs, texels)

    def block(s):
        which = np.arange(s, min(s + _CHUNK, len(dabs)))
        i, j, alpha, along, across = _covering(dabs, shapes, uv_axes, texels, which)
        difference = np.linalg.norm(lab_reference[j] - lab_dabs[i], axis=1)
        alpha *= strength * np.clip(2.0 - difference / CLIP, 0.0, 1.0)
        drawn = alpha > 1e-3
        i, j, alpha, along, across = (x[drawn] for x in (i, j, alpha, along, across))
        colour = dabs.colour[which]
        second = colour if dabs.second is None else dabs.second[which]
        if pickup is not None and len(i):
            colour, second = _under((colour, second), which, i, j, alpha, dabs.draws[which], *pickup)
        return _composite(dabs, texels, (colour, second), which[0], i, j, alpha, along, across)

    colours = np.array(base, dtype=np.float64)
    height = np.zeros(len(texels.points))
    for found in map_parallel(block, range(0, len(dabs), _CHUNK), progress):
        if found is not None:
            touched, through, added, height_through, height_added = found
            colours[touched] = colours[touched] * through[:, None] + added
            height[touched] = height[touched] * height_through + height_added
    return colours.astype(np.float32), height.astype(np.float32)


def _under(colours, which, i, j, alpha, draws, lab, pull, shade, lab_palette):
    """The two colours (n, 3 each) the brushes of the dabs ``which`` are loaded with: the mean of the OKLab
    colours ``lab`` over the texels each covers (weighted by coverage, its chroma kept:
    :func:`cp_stylize.palette.kept_chroma`), jittered by its own draws and by those of its second colour
    (:func:`_loaded`); a dab that covers no texel keeps ``colours``."""
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
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    g11, g12, g22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    det = g11 * g22 - g12 * g12
    det = np.where(np.abs(det) > 1e-30, det, np.inf)
    sides = np.cross(dabs.normal, dabs.direction)
    axes = []
    for w in (dabs.direction * (0.5 * dabs.length)[:, None], sides * (0.5 * dabs.width + dabs.depth)[:, None]):
        r1, r2 = np.einsum("ij,ij->i", w, e1), np.einsum("ij,ij->i", w, e2)
        x, y = (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det
        axes.append(x[:, None] * d1 + y[:, None] * d2)
    centre = np.einsum("nk,nkj->nj", dabs.bary, uv)
    return np.stack(axes, axis=1), centre


def _covering(dabs, shapes, uv_axes, texels, which):
    """The texels each dab of ``which`` (sorted indices) covers: pairs of dabs ``i`` and texels ``j`` with the coverage
    ``alpha`` (anti-aliased over a texel) and the texel's place in the dab (``along`` its length and
    ``across`` its width, each in [-1, 1])."""
    i, j = _raster_pairs(uv_axes, texels, which)
    found = _geometry(shapes, texels, i, j)
    place = np.searchsorted(which, found[0])                         # ``which`` is sorted
    inside = found[1] < texels.covered
    area = np.bincount(place, weights=found[2] * texels.lengths[found[1]] ** 2 * inside, minlength=len(which))
    whole = area >= WHOLE * _AREA * dabs.length[which] * dabs.width[which]
    if whole.all():
        return found
    keep = whole[place]
    searched = _geometry(shapes, texels, *_ball_pairs(dabs, texels, which[~whole]))
    return tuple(np.concatenate([a[keep], b]) for a, b in zip(found, searched))


def _raster_pairs(uv_axes, texels, which):
    """Pairs (dab, texel index) of the texels inside each dab's UV parallelogram (with slack)."""
    axes, centre = uv_axes[0][which], uv_axes[1][which]
    size = texels.size
    grow = RASTER_SLACK + 1.5 / np.maximum(np.linalg.norm(axes, axis=2), 1e-9)     # (n, 2)
    axes = axes * grow[:, :, None]
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
    return which[unit[run[found]]], position[found]


def _ball_pairs(dabs, texels, which):
    """Pairs (dab, texel index) of all texels within each dab's reach in space."""
    if not len(which):
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    margin = 2.0 * float(np.median(texels.lengths))
    found = texels.tree.query_ball_point(dabs.centre[which], np.maximum(0.5 * dabs.length[which], dabs.width[which])
                                         + dabs.depth[which] + margin, return_sorted=False)
    counts = np.fromiter((len(f) for f in found), np.int64, len(found))
    if not counts.sum():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.repeat(which, counts), np.concatenate([np.asarray(f, dtype=np.int64) for f in found if len(f)])


def _half_width(along):
    """A dab's half width at ``along`` in [-1, 1], as a share of half its width: a flat body with a
    rounded head (-1) and a tail that tapers (+1)."""
    return (1.0 - np.abs(along) ** 3) ** (1 / 3) * (1.0 - 0.45 * np.maximum(along, 0.0) ** 3)


#: A dab's area over its length times its width.
_AREA = float(np.mean(_half_width(np.linspace(-1, 1, 20001))))


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
    own = ((np.einsum("ij,ij->i", texels.normals[j], normal) > 0.3) & (texels.pieces[j] == shapes.piece[i])
           & (np.abs(np.einsum("ij,ij->i", delta, normal)) < half_length))
    i, j, a, v, half_length, width, lengths = (x[own] for x in (i, j, a, v, half_length, width, lengths))
    along = np.clip(a, -1.0, 1.0)
    half_width = 0.5 * width * _half_width(along)
    outside = np.maximum(np.abs(v) - half_width, (np.abs(a) - 1.0) * half_length)
    alpha = np.clip(0.5 - outside / lengths, 0.0, 1.0)
    covered = alpha > 0
    across = np.clip(v / np.maximum(half_width, 1e-9), -1.0, 1.0)
    return i[covered], j[covered], alpha[covered], along[covered], across[covered]


def _composite(dabs, texels, colours, first, i, j, alpha, along, across):
    """Pairs of dabs ``i`` and texels ``j`` composited in order, the dabs' two colours ``colours`` (from dab
    ``first`` on): per texel touched, how much of what lies under the block shows through, and what
    the block adds (colour and height)."""
    if not len(i):
        return None
    width = dabs.width[i]
    phase = dabs.phase[i]
    opens, closes = dabs.stroke_ends(i)                    # whether each pair's dab begins, ends its stroke
    # a dab within a stroke runs on from the one before it: its marks and rims go straight on into its head,
    # where a stroke's first dab bends them round its rounded head
    across = np.where(opens, across, across * _half_width(along))
    # bristle marks along the stroke, irregular: two waves across it, their number a dab's own (a stroke's
    # dabs share it, so its marks run on through them)
    grooves = np.clip(width / (GROOVE_TEXELS * texels.lengths[j]), 2.0, GROOVES * (0.7 + 0.6 * ((7.3 * phase) % 1.0)))
    wave = 0.5 * np.pi * grooves * (across + 1.0)
    broad = np.sin(wave + phase)                                         # the broadest bristles
    bristle = 0.65 * broad + 0.35 * np.sin(1.7 * wave + 2.0 * phase)
    groove = bristle * np.where(closes, 1.0 - 0.3 * (along + 1.0), 1.0)      # fading where the brush runs dry
    # a loaded brush: the second colour along one side of the stroke, meeting the first in streaks
    side_of = (5.7 * phase) % 1.0 - 0.5
    load = smooth_step(0.5 + (across - side_of + LOAD_STREAK * bristle) / LOAD_SOFT)
    # the tail runs dry: the paint breaks up along the bristles (the broadest of them) and lets what lies
    # under it show
    dry = np.where(closes, np.clip((along - DRY_AT) / (1.0 - DRY_AT), 0.0, 1.0), 0.0)
    alpha = alpha * smooth_step(0.5 + (broad + 1.4 - 2.8 * dry) / 0.8)
    # raised paint, as a loaded brush leaves it: each dab its own thickness, thickest where the brush
    # touched down (the head of its stroke) and thinning towards the tail where it ran dry; a rim along
    # both sides where the bristles pushed the paint aside; bristle furrows along the stroke
    thickness = (0.7 + 0.6 * ((3.1 * phase) % 1.0)) * (1.0 + opens * HEAD * np.exp(-(((along + 0.7) / 0.25) ** 2))
                                                       - closes * TAIL * 0.5 * (along + 1.0))
    rim = RIM * np.exp(-(((np.abs(across) - RIM_AT) / 0.15) ** 2))
    # the paint ends at the dab's sides and at its stroke's ends within a short share of its half width: a
    # stroke's edge stands as a rounded step, anti-aliased over a texel; a dab within a stroke runs on into
    # the one before it (it lays its paint over that one's, not on top of it)
    edge = np.maximum(EDGE * width / 2, texels.lengths[j])              # on the surface
    edge_across, edge_along = edge / (width / 2), edge / (dabs.length[i] / 2)
    side = (smooth_step((1.0 - np.abs(across)) / edge_across)
            * np.where(opens, smooth_step((along + 1.0) / edge_along), 1.0)
            * smooth_step((1.0 - along) / (3.0 * edge_along)))
    profile = thickness * side * (BODY + rim + GROOVE_DEPTH * groove)
    scrape = np.where(opens, FLATTEN, 1.0)
    shade = 1.0 + STREAK * groove
    order = np.lexsort((-i, j))                # per texel, the last dab painted first
    i, j, alpha, profile, shade, load, side, scrape = (x[order] for x in (i, j, alpha, profile, shade, load, side,
                                                                          scrape))
    heads = np.flatnonzero(np.r_[True, j[1:] != j[:-1]])
    through, shown = _over(alpha, heads)
    weight = alpha * shown * shade
    paint = (1.0 - load)[:, None] * np.asarray(colours[0])[i - first] + load[:, None] * np.asarray(colours[1])[i - first]
    added = np.column_stack([np.add.reduceat(weight * paint[:, c], heads) for c in range(3)])
    height_through, height_shown = _over(scrape * alpha * side, heads)
    height_added = np.add.reduceat(alpha * height_shown * profile, heads)
    return j[heads], through, added, height_through, height_added


def _over(alpha, heads):
    """Front-to-back compositing of runs (from ``heads``) of opacities: the share of what lies under a
    run that shows through it (per run), and the share of each item that shows (per item)."""
    log = np.log(np.maximum(1.0 - alpha, 1e-7)).astype(np.float64)
    total = np.cumsum(log)
    before = np.repeat(total[heads] - log[heads], np.diff(np.r_[heads, len(alpha)]))
    return np.exp(np.add.reduceat(log, heads)), np.exp(total - log - before)
