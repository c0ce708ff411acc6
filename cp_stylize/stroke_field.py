"""The directions brush strokes follow on the surface, layer by layer.

:class:`StrokeField` holds, for one layer of strokes, the picture's own
structure at that layer's scale (the structure tensor's dominant direction and
how sure it is); where the picture has no structure, strokes follow a field
given (the surface's form: :func:`form_field`), the level lines of the
picture's broad light and dark, swirls (:class:`Swirls`), or the picture's
horizontal (:func:`level_field`).
"""

from __future__ import annotations

import numpy as np

from .smoothing import GridGaussian, taper

__all__ = ["StrokeField", "Swirls", "agreement", "form_field", "level_field", "level_share", "sample_directions",
           "size_smoothings", "FALLBACK_TRUST"]


def size_smoothings(band, sizes):
    """Gaussians on the band (:class:`~cp_stylize.smoothing.GridGaussian`, tapered off the surface), one for
    each dab size of ``sizes`` (broad to fine), of deviation half the size; each shares the grids of the one
    before it."""
    smoothing = None
    for size in sizes:
        rho = 0.5 * (0.5 * size) ** 2
        smoothing = (GridGaussian(band, rho, weights=taper(band.dist, 3.0 * band.h)) if smoothing is None
                     else smoothing.at_time(rho))
        yield smoothing


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
        from .structure import along_structure, grid_gradients, products
        from .tangent import tangent_basis

        rows = np.ascontiguousarray(np.asarray(values, dtype=np.float32).reshape(band.size, -1).T)
        J = products(rows, grid_gradients(band, np.float32))
        q0, q1 = np.ascontiguousarray(tangent_basis(band).transpose(2, 1, 0), dtype=np.float32)
        fields = []
        for smoothing in size_smoothings(band, lengths):
            direction, mu1, coherence = along_structure(smoothing(J), q0, q1)
            strength = np.sqrt(np.maximum(mu1, 0.0))
            # a structure counts where it is coherent and among the stronger of the surface's
            confidence = (np.clip(coherence / 0.5, 0.0, 1.0)
                          * np.clip(strength / max(float(np.quantile(strength, 0.75)), 1e-12), 0.0, 1.0))
            fields.append(cls(band, direction, confidence, strength))
        return fields

    def at(self, points, normals, swirl=0.0, swirls=None, field=None, broad=None, level=None):
        """Unit directions (M, 3) at surface points (M, 3) with normals (M, 3): the structure's, blended
        by doubled angles with a given ``field`` (N, 3) of the band, whose length is the confidence in
        it (a field trusted at :data:`FALLBACK_TRUST` or less yields where the structure is sure), and,
        by ``swirl`` where the structure is weak, with the ``broad`` field (the same structure over a
        wide neighbourhood: its level lines ring a bright or dark patch, as van Gogh's strokes ring
        his stars) and, where that is weak too, with ``swirls``.  ``swirl`` is a number or one
        for each point (M,).  Before the swirls, a ``level`` field (N, 3: 0 where it has no direction;
        see :func:`level_field`) takes over where the structure is weak (:data:`LEVEL_YIELD`), as far as
        its length (at most 1) says."""
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
            # that is sure, and fades out as its trust falls below FALLBACK_TRUST (where meridians meet at a
            # pole); a field trusted fully does not
            fallback = np.clip((1.0 - trust) / (1.0 - FALLBACK_TRUST), 0.0, 1.0)
            trust = (1.0 - fallback * np.sqrt(confidence)) * np.clip(trust / FALLBACK_TRUST, 0.0, 1.0)
            direction = _blend(given, direction, trust, normals)
        if level is not None:
            raw = np.asarray(level[nearest], dtype=np.float64)
            share = np.clip(np.linalg.norm(raw, axis=1), 0.0, 1.0)          # how far it may take over
            flat = _tangent(raw, normals)
            has = (share > 1e-3) & (np.linalg.norm(flat, axis=1) > 0.5)
            flat[~has] = direction[~has]
            yielded = 1.0 - share * (1.0 - confidence**LEVEL_YIELD)
            direction = _blend(direction, flat, np.where(has, yielded, 1.0), normals)
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
#: A brush that swirls lays no level strokes: where the picture has no structure of its own, its strokes
#: circle in swirls (where the picture is light) or turn each its own way (where it is dark), as van Gogh's
#: do, instead of combing the ground flat.  The level field's share (:func:`level_share`) falls from all of
#: it at Swirl 0 to none at this Swirl.
LEVEL_SWIRL = 0.5


def level_share(swirl):
    """How far the :func:`level_field` takes over (0 to 1) for a brush of ``swirl`` (:data:`LEVEL_SWIRL`)."""
    return float(np.clip(1.0 - swirl / LEVEL_SWIRL, 0.0, 1.0))


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


#: How far a guide field must agree with itself over a stroke's length (the coherence of its directions'
#: averaged outer products, 0 to 1; see :func:`agreement`) before strokes follow it at all, and where they
#: follow it fully.
AGREE = (0.7, 0.95)


def agreement(band, field, length):
    """How far (N,; 0 to 1) strokes of ``length`` may follow a guide ``field`` (N, 3; 0 where it has no
    direction): as far as its directions agree with one another over a stroke's length about each point.

    A guide that turns within a stroke's length cannot be followed: strokes laid along it comb a herringbone
    or ring a bullseye.  A picture's horizontal (:func:`level_field`) folds into a chevron where its UV map is
    mirrored (Suzanne's two halves) and rings a sphere's pole in ever smaller circles; the meridians of
    :func:`form_field` meet there as spokes, and the surface's principal directions whirl about its umbilics.
    The outer products of the field's unit directions, averaged over a Gaussian of deviation half a stroke's
    ``length``, have a coherence ``lambda_1 - lambda_2`` (over their trace) of 1 where the field is one
    direction, falling towards 0 where it folds, rings or meets; it maps to 0..1 between the two of
    :data:`AGREE`."""
    field = np.asarray(field, dtype=np.float64)
    norm = np.linalg.norm(field, axis=1)
    has = norm > 1e-3
    if not has.any():
        return np.zeros(len(field))
    unit = np.divide(field, norm[:, None], out=np.zeros_like(field), where=has[:, None])
    i, j = np.triu_indices(3)
    weights = taper(band.dist, 3.0 * band.h) * has
    mean = GridGaussian(band, 0.5 * (0.5 * length) ** 2, weights=weights)((unit[:, i] * unit[:, j]).T)
    tensor = np.empty((len(field), 3, 3))
    tensor[:, i, j] = mean.T
    tensor[:, j, i] = mean.T
    eigen = np.linalg.eigvalsh(tensor)                   # ascending
    coherence = (eigen[:, 2] - eigen[:, 1]) / np.maximum(eigen.sum(axis=1), 1e-12)
    low, high = AGREE
    return np.where(has, np.clip((coherence - low) / (high - low), 0.0, 1.0), 0.0)


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


def sample_directions(band, corners):
    """A line field (N, 3) at the band's closest points from per-corner vectors (F, 3, 3).

    Each corner's vector is normalised (zero stays zero) and flipped to agree
    with the face's first corner, so that ``v`` and ``-v`` give the same
    field; the barycentric mix's length, at most 1, says how well the
    corners agree.
    """
    if band.face is None:
        raise ValueError("the band was not built on a triangle mesh: it has no faces to read directions from")
    corners = np.asarray(corners, dtype=np.float64)
    if corners.ndim != 3 or corners.shape[1:] != (3, 3) or corners.shape[0] <= int(band.face.max()):
        raise ValueError(f"directions must have shape (F, 3, 3) for the mesh's faces, got {corners.shape}")
    if not np.all(np.isfinite(corners)):
        raise ValueError("directions hold NaN or infinite values")
    length = np.linalg.norm(corners, axis=2, keepdims=True)
    unit = np.divide(corners, length, out=np.zeros_like(corners), where=length > 0)
    sign = np.where(np.sum(unit * unit[:, :1], axis=2) < 0, -1.0, 1.0)
    unit *= sign[:, :, None]
    return np.einsum("nk,nkc->nc", band.bary, unit[band.face])
