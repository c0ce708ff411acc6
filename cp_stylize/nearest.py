"""Exact closest points on a set of triangles: the spatial search.

:class:`TriangleSearch` finds, for query points, the nearest point of the
union of its triangles.  It is exact: every query ends with exact
point-triangle distances, and the search drops a triangle only where a bound
proves another one nearer.

Query points are grouped into a hierarchy of cells: for the band
(:meth:`TriangleSearch.band`, :mod:`cp_stylize.band_search`), blocks of ``4^3``
grid points, their ``2^3`` sub-blocks, then the points; for any other query (:meth:`TriangleSearch.nearest`),
an octree over the points.  One routine, :meth:`TriangleSearch._descend`,
narrows the cells' candidate triangles from level to level with two bounds:

- a triangle farther than ``dmin + 2 delta`` from a cell's centre ``c``
  (``dmin`` the least distance from ``c`` to the cell's candidates,
  ``delta`` the cell's radius) is nearer to none of the cell's points;
- the distance to a triangle is a convex function with a unit gradient
  ``g``, so ``d(c + o) >= d(c) + g.o``: a child cell at offset ``o`` drops
  the triangles whose bound exceeds a distance already known there.

In full: a child cell at ``c + o`` bounds its parent's faces from below by
``d(c) + g.o - delta_child`` throughout the child (and ``d(c) - |o| -
delta_child`` in any case; where ``d(c)`` is near zero, rounding makes ``g``
unreliable and this bound takes over).  Faces whose bound exceeds the
distance from the child's centre to the parent's nearest face, plus
``delta_child``, are dropped before the exact distances of the rest are
taken.

The coarsest lists come from the triangles' bounding boxes grown by the band
width (for the band: Ruuth's ``tri2cp`` boxes, per block of grid points) or
from a k-d tree of sample points that cover every triangle within a radius
``r`` (for any other query).  Exact distances follow Ericson's regions
(*Real-Time Collision Detection*, section 5.1.5), vectorised over (point,
triangle) pairs.  Nothing scans the mesh's bounding box.

Triangles are numbered as given; the results name them by that number.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

from .arrays import expand_runs, unit_rows

__all__ = ["TriangleSearch"]

#: Points handled at once, about (band chunks, query chunks).
_CHUNK = 1 << 17


class TriangleSearch:
    """The closest points on triangles ``(a, b, c)``, each array (K, 3) with non-degenerate rows.

    The triangles are kept once, as contiguous columns: ``a`` and the edges
    ``ab = b - a``, ``ac = c - a`` by component, and ``ab.ab``, ``ab.ac``,
    ``ac.ac`` and the Gram determinant ``ab.ab ac.ac - ab.ac^2``.
    """

    def __init__(self, a, b, c):
        ab, ac = b - a, c - a
        abab = np.einsum("ij,ij->i", ab, ab)
        acac = np.einsum("ij,ij->i", ac, ac)
        abac = np.einsum("ij,ij->i", ab, ac)
        columns = np.column_stack([a, ab, ac, abab, abac, acac, abab * acac - abac**2])
        self._pack = [np.ascontiguousarray(col) for col in columns.T]
        longest = np.sqrt(np.max([abab, acac, ((c - b) ** 2).sum(1)], axis=0)) if len(a) else np.zeros(1)
        #: a length that bounds every coordinate: the scale of the search's rounding tolerances
        self._scale = float(np.abs(np.concatenate([a, b, c])).max() + longest.max())
        #: unit normals (K, 3) by the right-hand rule
        self.normals = unit_rows(np.cross(ab, ac))[0]
        self._tree = None

    def __len__(self):
        return len(self._pack[0])

    def edges(self, tri=slice(None)):
        """``a``, ``b - a`` and ``c - a`` (each (K, 3)) of the triangles ``tri``."""
        pk = self._pack
        return tuple(np.column_stack([pk[i][tri], pk[i + 1][tri], pk[i + 2][tri]]) for i in (0, 3, 6))

    def on(self, x, tri):
        """``(v, w)`` of the closest points of ``x`` (N, 3) on the given triangles ``tri`` (N,)."""
        v, w, _, _ = self._closest(np.ascontiguousarray(np.asarray(x, dtype=np.float64).T), tri)
        return v, w

    def point(self, tri, v, w):
        """The points ``a + v (b - a) + w (c - a)`` (N, 3) of the triangles ``tri``."""
        pk = self._pack
        return np.column_stack([pk[i][tri] + v * pk[3 + i][tri] + w * pk[6 + i][tri] for i in range(3)])

    def _closest(self, p, tri):
        """Closest points of ``p`` (3, P) on the kept triangles ``tri`` (P,): :func:`closest_on`."""
        return closest_on(self._pack, p, tri)

    def _build_index(self):
        """Sample points covering every kept triangle within ``self._radius``, and their k-d tree."""
        a, ab, ac = self.edges()
        centroid = a + (ab + ac) / 3.0
        corners = np.stack([a, a + ab, a + ac], axis=1)
        reach = np.linalg.norm(corners - centroid[:, None, :], axis=2).max(axis=1)
        # subdivide triangles much larger than the typical one, within a sample budget
        self._typical = float(np.median(reach))
        target = 2.0 * self._typical
        budget = max(4 * len(reach), 100_000)
        while True:
            m = np.maximum(1, np.ceil(reach / target * (1 - 1e-12))).astype(np.int64)
            if (m**2).sum() <= budget:
                break
            target *= 1.5
        points, owner = [], []
        for level in np.unique(m):
            tris = np.flatnonzero(m == level)
            bary = _subdivision_centroids(int(level))
            p = (a[tris, None, :] + bary[None, :, 1:2] * ab[tris, None, :]
                 + bary[None, :, 2:3] * ac[tris, None, :])
            points.append(p.reshape(-1, 3))
            owner.append(np.repeat(tris, len(bary)))
        self._samples = np.concatenate(points)
        self._owner = np.concatenate(owner)
        self._radius = float((reach / m).max()) * (1 + 1e-9)
        self._tree = cKDTree(self._samples)

    def _descend(self, centres, deltas, parents, cells, tris, width=None, regular=None):
        """Closest triangles of the points at the bottom of a hierarchy of cells.

        Parameters
        ----------
        centres, deltas, parents : lists over levels
            Level ``l`` has cells with centres (3, n_l), radii (n_l,) such
            that every point of a cell lies within its radius of its centre,
            and (for ``l > 0``) the index of each cell's parent in level
            ``l - 1``.  The last level is the query points (radius 0).
        cells, tris : ndarray of int64
            Pairs (level-0 cell, triangle), sorted by cell, that include the
            face holding the closest point of every point of the cell (with
            ``width``: every face within ``width`` of one of them).
        width : float, optional
            Drop the points farther than this from the mesh.
        regular : list over levels, optional
            For a level ``l > 0`` whose cells are the eight children of each
            cell of level ``l - 1`` (child ``8 p + j`` of parent ``p``), all at
            the same offsets from their parents' centres and of one radius:
            those offsets (8, 3); None for other levels.  Their bounds are then
            one small matrix product instead of gathers.

        Returns
        -------
        face : ndarray of int64
            Triangle of the closest point of every query point, -1 if dropped.
        d2 : ndarray
            Squared distances.

        Notes
        -----
        The two bounds are the module's (see its notes).
        """
        eps = 1e-9 * self._scale
        last = len(centres) - 1
        _, _, r, d2 = self._closest(centres[0][:, cells], tris)
        level = 0
        while True:
            n = len(deltas[level])
            delta = deltas[level]
            d = np.sqrt(d2)
            start = np.flatnonzero(np.r_[True, cells[1:] != cells[:-1]]) if len(cells) else cells[:0]
            least = np.full(n, np.inf)
            if len(start):
                least[cells[start]] = np.minimum.reduceat(d, start)
            if level == last:
                return _closest_of(cells, tris, d, d2, least, n, width)
            keep = d <= least[cells] + 2.0 * delta[cells] + eps
            if width is not None:
                keep &= least[cells] - delta[cells] <= width + eps
            cells, tris, d = cells[keep], tris[keep], d[keep]
            inv = 1.0 / np.where(d > 0, d, np.inf)
            g = [c[keep] * inv for c in r]
            # |g - gradient| is at most twice the rounding error of r over d
            slack = np.minimum(2e-12 * self._scale * inv, 2.0)
            best = np.flatnonzero(d <= least[cells])
            best = best[np.r_[True, cells[best][1:] != cells[best][:-1]]] if len(best) else best
            nearest = np.zeros(n, dtype=np.int64)
            nearest[cells[best]] = tris[best]
            count = np.bincount(cells, minlength=n)
            nxt = level + 1
            parent, centre, radius = parents[nxt], centres[nxt], deltas[nxt]
            kids = np.flatnonzero(count[parent] > 0)
            _, _, _, up2 = self._closest(centre[:, kids], nearest[parent[kids]])
            upper = np.full(len(parent), np.inf)
            upper[kids] = np.sqrt(up2) + radius[kids]
            if regular is not None and regular[nxt] is not None:
                cells, tris = self._children(regular[nxt], radius[0], cells, tris, d, g, slack, upper, width)
            else:
                cells, tris = self._any_children(centre - centres[level][:, parent], parent, radius, count,
                                                 tris, d, g, slack, upper, width)
            level = nxt
            _, _, r, d2 = self._closest(centre[:, cells], tris)

    def _any_children(self, offset, parent, radius, count, tris, d, g, slack, upper, width):
        """The pairs (child, triangle) that the bounds of :meth:`_descend` keep, for children at any
        ``offset`` (3, m) from the centres of their ``parent`` (m,) cells, of any ``radius`` (m,); the
        parents' pairs ``tris`` (sorted by parent, ``count`` (n,) a parent) with their distances ``d``,
        gradients ``g`` and the gradients' ``slack``."""
        eps = 1e-9 * self._scale
        first = np.cumsum(count) - count
        step = np.sqrt((offset * offset).sum(axis=0))
        run, pos = expand_runs(count[parent])
        src = first[parent[run]] + pos
        ahead = g[0][src] * offset[0][run] + g[1][src] * offset[1][run] + g[2][src] * offset[2][run]
        bound = d[src] + np.maximum(ahead - slack[src] * step[run], -step[run]) - radius[run]
        keep = bound <= upper[run] + eps
        if width is not None:
            keep &= bound <= width + eps
        return run[keep], tris[src[keep]]

    def _children(self, offsets, radius, cells, tris, d, g, slack, upper, width):
        """The pairs (child, triangle) that the bounds of :meth:`_descend` keep, for children ``8 p + j``
        of every parent ``p`` at the same ``offsets`` (8, 3) and of one ``radius``; sorted by child, and
        within a child in their parent's order."""
        eps = 1e-9 * self._scale
        step = np.sqrt((offsets * offsets).sum(axis=1))
        bound = np.multiply.outer(g[0], offsets[:, 0])                     # (pairs, 8): g . o, then the bound
        bound += np.multiply.outer(g[1], offsets[:, 1])
        bound += np.multiply.outer(g[2], offsets[:, 2])
        bound -= np.multiply.outer(slack, step)
        np.maximum(bound, -step, out=bound)
        bound += (d - radius)[:, None]
        limit = upper.reshape(-1, 8)[cells]                                # the children's upper bounds
        if width is not None:
            np.minimum(limit, width, out=limit)
        slot, pair = np.nonzero((bound <= limit + eps).T)                  # slot major: 8 sorted runs
        kept = 8 * cells[pair] + slot
        order = np.argsort(kept, kind="stable")                            # merges the eight runs
        return kept[order], tris[pair[order]]

    def _levels(self, x):
        """Finest cell side and number of coarser levels for the query points ``x``."""
        sub = np.unique(x[:: max(1, len(x) // 20000), 0])
        gaps = np.diff(sub)
        spacing = float(np.median(gaps)) if len(gaps) else 0.0
        typical = self._typical
        fine = 2.0 * spacing if spacing > 0 else typical
        fine = min(max(fine, typical / 8.0), 8.0 * typical)
        top = max(4.0 * fine, 2.0 * typical)
        return fine, int(np.clip(np.round(np.log2(top / fine)), 0, 6))

    def nearest(self, x):
        """Triangle, ``v``, ``w`` and squared distance of the closest point of every row of ``x`` (N, 3).

        The closest point of ``x[i]`` is :meth:`point` ``(tri[i], v[i], w[i])``.

        The query points are grouped into an octree of cells (level 0, the
        coarsest, to ``L``, then the points themselves) and
        :meth:`_descend` narrows each cell's faces down the levels.  A
        level-0 cell starts from the faces with a sample within
        ``d + 2 delta + r`` of its centre ``c`` (``d`` the distance from ``c``
        to its nearest sample, ``delta`` the cell's radius): every point of
        the cell lies within ``d + delta`` of the mesh, and every point of a
        face within ``r`` of one of its samples.
        """
        if self._tree is None:
            self._build_index()
        n = len(x)
        fine, L = self._levels(x)
        origin = x.min(axis=0) - 0.25 * fine
        g = np.floor((x - origin) / fine).astype(np.int64)
        keys = []
        for level in range(L + 1):
            c = g >> (L - level)
            dims = c.max(axis=0) + 1
            keys.append((c[:, 0] * dims[1] + c[:, 1]) * dims[2] + c[:, 2])
        order = np.lexsort(keys[::-1])
        keys = [k[order] for k in keys]
        xs = x[order]
        top = np.flatnonzero(np.r_[True, keys[0][1:] != keys[0][:-1]])
        at = np.searchsorted(top, np.arange(0, n, _CHUNK // 4))
        cuts = np.unique(np.r_[top[at[at < len(top)]], n])
        face = np.empty(n, dtype=np.int64)
        for s, e in zip(cuts[:-1], cuts[1:]):
            face[order[s:e]] = self._nearest_sorted(xs[s:e], [k[s:e] for k in keys])
        if np.any(face < 0):
            raise RuntimeError("the closest point search lost a point; this is a bug")
        v, w, _, d2 = self._closest(np.ascontiguousarray(x.T), face)
        return face, v, w, d2

    def _nearest_sorted(self, xs, keys):
        """Closest triangles of points ``xs`` sorted by their cell keys at every level."""
        centres, deltas, parents, point_cell = [], [], [], None
        for key in keys:
            change = np.r_[True, key[1:] != key[:-1]]
            start = np.flatnonzero(change)
            lo = np.minimum.reduceat(xs, start, axis=0)
            hi = np.maximum.reduceat(xs, start, axis=0)
            centres.append(np.ascontiguousarray((0.5 * (lo + hi)).T))
            deltas.append(0.5 * np.linalg.norm(hi - lo, axis=1) * (1 + 1e-12))
            parents.append(None if point_cell is None else point_cell[start])
            point_cell = np.cumsum(change) - 1
        centres.append(np.ascontiguousarray(xs.T))
        deltas.append(np.zeros(len(xs)))
        parents.append(point_cell)
        eps = 1e-9 * self._scale
        d, _ = self._tree.query(centres[0].T, k=1)
        found = self._tree.query_ball_point(centres[0].T, d + 2.0 * deltas[0] + self._radius + eps,
                                            return_sorted=False)
        counts = np.fromiter(map(len, found), dtype=np.int64, count=len(found))
        samples = np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64, count=int(counts.sum()))
        n_faces = len(self)
        pair = np.unique(np.repeat(np.arange(len(found)), counts) * n_faces + self._owner[samples])
        face, _ = self._descend(centres, deltas, parents, pair // n_faces, pair % n_faces)
        return face

    def band(self, h, width):
        """The grid points within ``width`` of the triangles with their closest points, in chunks
        (:func:`cp_stylize.band_search.band_points`)."""
        from .band_search import band_points

        return band_points(self, h, width)


def _subdivision_centroids(m):
    """Barycentric centroids (m^2, 3) of the regular subdivision of a triangle into m^2 triangles."""
    i, j = np.meshgrid(np.arange(m), np.arange(m), indexing="ij")
    up = (i + j) <= m - 1
    iu, ju = i[up], j[up]
    upward = np.column_stack([iu + 1 / 3, ju + 1 / 3, m - 1 - iu - ju + 1 / 3]) / m
    down = (i + j) <= m - 2
    idn, jdn = i[down], j[down]
    downward = np.column_stack([idn + 2 / 3, jdn + 2 / 3, m - 2 - idn - jdn + 2 / 3]) / m
    return np.vstack([upward, downward])




def _closest_of(cells, tris, d, d2, least, n, width):
    """Of pairs (query point ``cells``, triangle ``tris``) sorted by point, with distances ``d`` and
    their squares ``d2``: each of the ``n`` points' closest triangle (the first at its least distance
    ``least``) and squared distance; -1 and infinity where none is, or none within ``width``."""
    keep = d <= least[cells]
    if width is not None:
        keep &= d <= width
    hit = np.flatnonzero(keep)
    hit = hit[np.r_[True, cells[hit][1:] != cells[hit][:-1]]] if len(hit) else hit
    face = np.full(n, -1, dtype=np.int64)
    face[cells[hit]] = tris[hit]
    dist2 = np.full(n, np.inf)
    dist2[cells[hit]] = d2[hit]
    return face, dist2


def closest_on(pack, p, tri):
    """Closest points of ``p`` (3, P) on the triangles ``tri`` (P,) of the columns ``pack`` (13 arrays: ``a``,
    ``ab``, ``ac`` by component, ``ab.ab``, ``ab.ac``, ``ac.ac`` and the Gram determinant).

    Returns
    -------
    v, w : ndarray, shape (P,)
        The closest point is ``a + v (b - a) + w (c - a)``.
    r : tuple of 3 ndarrays (P,)
        The offset ``p - cp``.
    d2 : ndarray, shape (P,)
        Its squared length.

    Notes
    -----
    The closest point is the projection on the triangle's plane where
    that falls inside the triangle (non-negative barycentric
    coordinates), and otherwise the nearest of the clamped projections on
    the three edges (the regions of Ericson, *Real-Time Collision
    Detection*, section 5.1.5).  Every dot product follows from
    ``ap = p - a`` and the triangle's ``ab.ab``, ``ab.ac``, ``ac.ac``;
    arrays are gathered component by component so that every operation
    runs on contiguous memory.
    """
    pk = pack
    ax, ay, az = (p[i] - pk[i][tri] for i in range(3))
    abx, aby, abz, acx, acy, acz = (pk[i][tri] for i in range(3, 9))
    abab, abac, acac, denom = (pk[i][tri] for i in range(9, 13))
    d1 = abx * ax + aby * ay + abz * az
    d2 = acx * ax + acy * ay + acz * az
    ap2 = ax * ax + ay * ay + az * az
    # edges AB (v = t), AC (w = t) and BC (v = 1 - t, w = t)
    t1 = np.clip(d1 / abab, 0.0, 1.0)
    e1 = ap2 - t1 * (2.0 * d1 - t1 * abab)
    t2 = np.clip(d2 / acac, 0.0, 1.0)
    e2 = ap2 - t2 * (2.0 * d2 - t2 * acac)
    bc2 = abab + acac - 2.0 * abac
    s = d2 - d1 - abac + abab                      # bc.bp
    t3 = np.clip(s / bc2, 0.0, 1.0)
    e3 = ap2 - 2.0 * d1 + abab - t3 * (2.0 * s - t3 * bc2)
    first = e1 <= e2
    v = np.where(first, t1, 0.0)
    w = np.where(first, 0.0, t2)
    third = e3 < np.minimum(e1, e2)
    v = np.where(third, 1.0 - t3, v)
    w = np.where(third, t3, w)
    # the plane, where the projection is inside
    vn = acac * d1 - abac * d2
    wn = abab * d2 - abac * d1
    inside = (vn >= 0) & (wn >= 0) & (vn + wn <= denom)
    v = np.where(inside, vn / denom, v)
    w = np.where(inside, wn / denom, w)
    rx = ax - v * abx - w * acx
    ry = ay - v * aby - w * acy
    rz = az - v * abz - w * acz
    return v, w, (rx, ry, rz), rx * rx + ry * ry + rz * rz
