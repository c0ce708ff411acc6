"""UV triangles on a square grid of texels: which texels each covers, and 2-D barycentric coordinates.

Texel ``(row, col)`` of a ``size`` x ``size`` grid has its centre at
``uv = ((col + 0.5) / size, (row + 0.5) / size)``.  :func:`rasterise` finds
the texels whose centres lie in UV triangles, and counts those that lie in
two (overlapping UVs); the atlas (:mod:`cp_stylize.atlas`) and the projected
charts (:mod:`cp_stylize.charts`) lay their layouts out with it, and the
bake-out (:mod:`cp_stylize.baking`) places the margin texels with
:func:`barycentric_2d` and :func:`closest_in_triangle_2d`.
"""

from __future__ import annotations

import threading

import numpy as np

from .arrays import expand_runs, split_counts
from .sparse import map_parallel, workers

__all__ = ["rasterise", "barycentric_2d", "closest_in_triangle_2d", "face_map", "nearest_texels", "nearest_filled",
           "MIN_AREA"]

#: Texel centres rasterised at once.
_TEXELS = 1 << 20
#: Inside test slack, in texels: a centre on an edge belongs to the triangle ...
_EDGE = 1e-6
#: ... but counts towards an overlap only this far inside.
_INSET = 1e-3
#: UV triangles below this area, in square texels, have zero area.
MIN_AREA = 1e-6


def rasterise(uv, size, overlapping=False):
    """Texels covered by UV triangles ``uv`` (K, 3, 2).

    Returns the covered texels (M,), the triangle chosen for each (the one
    whose edges its centre is farthest inside), the barycentric coordinates
    (M, 3), and the number of texels that lie inside two or more triangles
    by more than ``_INSET`` texels; with ``overlapping``, also the triangles
    that hold such a texel (sorted, distinct).
    """
    rows = _Rows(uv, size, overlapping)
    best_score = np.full(size * size, -np.inf, dtype=np.float32)
    best_tri = np.full(size * size, -1, dtype=np.int32)
    best_bary = np.zeros((size * size, 3), dtype=np.float32)
    claims = np.zeros(size * size, dtype=np.uint8)
    # the spans side by side on the cores, a few at a time; merged in order, so ties go as in one pass
    bounds = split_counts(rows.unit_cols, _TEXELS)
    spans = list(zip(bounds[:-1], bounds[1:]))
    holders = []
    for g in range(0, len(spans), 2 * workers()):
        for texel, score, k, bary, (claimed, twice), held in map_parallel(rows.candidates,
                                                                          spans[g:g + 2 * workers()]):
            holders.append(held)
            claims[claimed] = np.minimum(claims[claimed] + 1, 2)
            claims[twice] = 2
            better = score > best_score[texel]
            texel = texel[better]
            best_score[texel] = score[better]
            best_tri[texel] = k[better]
            best_bary[texel] = bary[better]
    texels = np.flatnonzero(best_tri >= 0)
    bary = np.clip(best_bary[texels].astype(np.float64), 0.0, None)
    bary /= bary.sum(axis=1, keepdims=True)
    raster = texels, best_tri[texels].astype(np.int64), bary, int(np.count_nonzero(claims > 1))
    if not overlapping:
        return raster
    held = [k[claims[t] > 1] for t, k in holders]
    return raster + (np.unique(np.concatenate(held)).astype(np.int64) if held else np.zeros(0, np.int64),)


class _Rows:
    """The texel rows of UV triangles ``uv`` (K, 3, 2) in a ``size`` square grid, as units (one texel row
    of one triangle's bounding box), and their candidate texels (:meth:`candidates`)."""

    def __init__(self, uv, size, overlapping):
        p = uv * size - 0.5                                  # texel centres at integers
        self.size, self.overlapping = size, overlapping
        self.x = (p[:, 0, 0], p[:, 1, 0], p[:, 2, 0])
        self.y = (p[:, 0, 1], p[:, 1, 1], p[:, 2, 1])
        (x0, x1, x2), (y0, y1, y2) = self.x, self.y
        self.det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)  # twice the signed area
        self.edge = np.stack([np.hypot(x2 - x1, y2 - y1), np.hypot(x0 - x2, y0 - y2), np.hypot(x1 - x0, y1 - y0)], 1)
        usable = (np.abs(self.det) > 2 * MIN_AREA) & np.all(np.isfinite(p.reshape(len(p), -1)), axis=1)
        self.tri = np.flatnonzero(usable)
        self.lo = np.clip(np.ceil(p[self.tri].min(axis=1) - _EDGE), 0, size).astype(np.int64)
        hi = np.clip(np.floor(p[self.tri].max(axis=1) + _EDGE), -1, size - 1).astype(np.int64)
        rows = np.maximum(hi[:, 1] - self.lo[:, 1] + 1, 0)
        cols = np.maximum(hi[:, 0] - self.lo[:, 0] + 1, 0)
        rows[cols == 0] = 0
        self.unit_tri, self.unit_row = expand_runs(rows)
        self.unit_row += self.lo[self.unit_tri, 1]
        self.unit_cols = cols[self.unit_tri]
        self.scratch = threading.local()                                # one stamp array a worker thread

    def candidates(self, span):
        """The best triangle of each texel among the units ``span``, and the texels they claim."""
        (x0, x1, x2), (y0, y1, y2), det, edge, size = self.x, self.y, self.det, self.edge, self.size
        s, e = span
        unit, col = expand_runs(self.unit_cols[s:e])
        unit += s
        t = self.unit_tri[unit]
        k = self.tri[t]
        qx = (col + self.lo[t, 0]).astype(np.float64)
        qy = self.unit_row[unit].astype(np.float64)
        l0 = ((x1[k] - qx) * (y2[k] - qy) - (x2[k] - qx) * (y1[k] - qy)) / det[k]
        l1 = ((x2[k] - qx) * (y0[k] - qy) - (x0[k] - qx) * (y2[k] - qy)) / det[k]
        l2 = 1.0 - l0 - l1
        area = np.abs(det[k])
        score = np.minimum(np.minimum(l0 * area / edge[k, 0], l1 * area / edge[k, 1]), l2 * area / edge[k, 2])
        texel = self.unit_row[unit] * size + col + self.lo[t, 0]
        inside = np.flatnonzero(score >= -_EDGE)
        texel, score, k = texel[inside], score[inside], k[inside]
        l0, l1, l2 = l0[inside], l1[inside], l2[inside]
        # a texel centre deep inside a triangle (by more than _INSET) lies in no other unless two overlap,
        # so only the centres near edges, and the overlaps, need a sort to find their best triangle
        deep = np.flatnonzero(score > _INSET)
        deep_texel = texel[deep]
        order = np.arange(len(deep), dtype=np.int32)
        stamp = getattr(self.scratch, "stamp", None)                    # the last deep candidate of a texel
        if stamp is None:
            stamp = self.scratch.stamp = np.empty(size * size, dtype=np.int32)
        stamp[deep_texel] = order
        twice = deep_texel[stamp[deep_texel] != order]                   # held deeply by two triangles
        if len(twice):
            keep = _best_of(texel, score)
        else:
            near_edge = np.flatnonzero(score <= _INSET)
            at = stamp[texel[near_edge]]
            beaten = (at >= 0) & (at < len(deep))                       # stamp is not cleared: check it
            beaten[beaten] = deep_texel[at[beaten]] == texel[near_edge[beaten]]   # a deep candidate wins
            near_edge = near_edge[~beaten]
            keep = np.concatenate([deep, near_edge[_best_of(texel[near_edge], score[near_edge])]])
        held = (deep_texel, k[deep]) if self.overlapping else None
        bary = np.column_stack([l0[keep], l1[keep], l2[keep]])
        return texel[keep], score[keep].astype(np.float32), k[keep], bary, (deep_texel, twice), held


def _best_of(texel, score):
    """Positions of the best candidate of each distinct texel: the highest score, the last of equal ones."""
    order = np.lexsort((score, texel))
    return order[np.r_[texel[order][1:] != texel[order][:-1], True]] if len(order) else order


def barycentric_2d(q, a, b, c):
    """Barycentric coordinates (M, 3) of points ``q`` (M, 2) in triangles ``abc`` (unclamped)."""
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    v = ((q[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1])) / det
    w = ((b[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1]) - (q[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
    return np.column_stack([1.0 - v - w, v, w])


def closest_in_triangle_2d(q, a, b, c):
    """Points (M, 2) of triangles ``abc`` nearest to ``q`` (M, 2): inside, or on the nearest edge."""
    def on_segment(p, r):
        d = r - p
        t = np.clip(np.einsum("ij,ij->i", q - p, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        return p + t[:, None] * d

    candidates = np.stack([on_segment(a, b), on_segment(b, c), on_segment(c, a)])
    gap = ((candidates - q[None]) ** 2).sum(axis=2)
    nearest = candidates[np.argmin(gap, axis=0), np.arange(len(q))]
    bary = barycentric_2d(q, a, b, c)
    inside = np.all(bary >= 0, axis=1)
    return np.where(inside[:, None], q, nearest)


def face_map(uv, corners, vectors):
    """Vectors (n, 3) in the planes of triangles ``corners`` (n, 3, 3) as they map into the UV triangles
    ``uv`` (n, 3, 2) by each face's linear map: (n, 2), in ``uv``'s units.  A face with no area maps
    every vector to 0."""
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    g11, g12, g22 = (np.einsum("ij,ij->i", a, b) for a, b in ((e1, e1), (e1, e2), (e2, e2)))
    det = g11 * g22 - g12 * g12
    det = np.where(np.abs(det) > 1e-30, det, np.inf)
    r1, r2 = np.einsum("ij,ij->i", vectors, e1), np.einsum("ij,ij->i", vectors, e2)
    x, y = (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det
    return x[:, None] * d1 + y[:, None] * d2


def nearest_texels(flat, size):
    """For every texel of a ``size`` x ``size`` grid, the flat index (size * size,) of the nearest of the
    texels ``flat`` (a Euclidean distance transform; each of ``flat`` is its own)."""
    from scipy import ndimage

    known = np.zeros(size * size, dtype=bool)
    known[flat] = True
    if known.all():
        return np.arange(size * size)
    _, nearest = ndimage.distance_transform_edt(~known.reshape(size, size), return_indices=True)
    return (nearest[0] * size + nearest[1]).ravel()


def nearest_filled(values, flat, size, nearest=None):
    """An image (size, size) of ``values`` (M,) at the texels ``flat`` (M,), every other texel taking its
    nearest one's value, so no edge shows where the texels end.  ``nearest``: :func:`nearest_texels` of
    ``flat``, if made before."""
    image = np.zeros(size * size, dtype=np.result_type(values, np.float64))
    image[flat] = values
    return image[nearest_texels(flat, size) if nearest is None else nearest].reshape(size, size)
