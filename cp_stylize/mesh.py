"""Triangle meshes as closest point surfaces.

A triangle mesh enters the closest point method through its closest point
function (paper, section 4.1, eq. (34)): ``cp(x)`` is the nearest point of the
union of its triangles.  It is computed exactly, not approximated by the
nearest vertex: every query ends with exact point-triangle distances, and the
search drops a triangle only where a bound proves another one nearer.

Search
------
Query points are grouped into a hierarchy of cells: for the band, blocks of
``4^3`` grid points, their ``2^3`` sub-blocks, then the points; for any other
query, an octree over the points.  Each cell carries a list of candidate
triangles that narrows from level to level with two bounds:

- a triangle farther than ``dmin + 2 delta`` from a cell's centre ``c``
  (``dmin`` the least distance from ``c`` to the cell's candidates,
  ``delta`` the cell's radius) is nearer to none of the cell's points;
- the distance to a triangle is a convex function with a unit gradient
  ``g``, so ``d(c + o) >= d(c) + g.o``: a child cell at offset ``o`` drops
  the triangles whose bound exceeds a distance already known there.

The coarsest lists come from the triangles' bounding boxes grown by the band
width (for the band: Ruuth's ``tri2cp`` boxes, per block of grid points) or
from a k-d tree of sample points that cover every triangle within a radius
``r`` (for any other query).  Exact distances follow Ericson's regions
(*Real-Time Collision Detection*, section 5.1.5), vectorised over (point,
triangle) pairs.  Nothing scans the mesh's bounding box.

Sign convention: ``dist`` is the *unsigned* distance ``|x - cp(x)|``.  Meshes
may be open, non-manifold or inconsistently oriented, and the closest point
method needs only ``cp`` (the band is ``|dist| <= width``).

Which triangles count: faces with a repeated vertex index or with (nearly)
zero area, i.e. height below ``tolerance`` times their longest edge, are
skipped; they add no surface.  Open meshes, disconnected parts, non-manifold
edges and loose vertices need no special treatment.
"""

from __future__ import annotations

import itertools

import numpy as np
from scipy.spatial import cKDTree

from .sparse import map_parallel, workers

__all__ = ["TriangleMesh", "parametric_mesh"]

#: Points handled at once, about (band chunks, query chunks, normals).
_CHUNK = 1 << 17
#: Side, in grid points, of the blocks that start the band search.
_BLOCK = 4


def _as_points(x, name="points"):
    x = np.asarray(x)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {x.shape}")
    if not (np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.integer)):
        raise TypeError(f"{name} must hold real numbers, got dtype {x.dtype}")
    x = x.astype(np.float64, copy=False)
    if not np.all(np.isfinite(x)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
        raise ValueError(f"{name} must be finite, got {x[bad].tolist()} at row {bad}")
    return x


def _unit(v):
    """Rows of ``v`` divided by their lengths (rows of length 0 stay 0) and the lengths."""
    n = np.linalg.norm(v, axis=-1)
    return v / np.where(n > 0, n, 1.0)[..., None], n


def _split_counts(counts, budget):
    """Boundaries ``[0, ..., len(counts)]`` of consecutive runs whose counts sum to about ``budget``."""
    total = np.cumsum(counts)
    cuts = np.searchsorted(total, np.arange(budget, total[-1] if len(total) else 0, budget), side="right")
    bounds = np.unique(np.concatenate([[0], cuts, [len(counts)]]))
    return bounds


def _expand(counts):
    """For runs of lengths ``counts``: the run of every element and its position in the run."""
    run = np.repeat(np.arange(len(counts)), counts)
    start = np.cumsum(counts) - counts
    return run, np.arange(len(run)) - start[run]


class TriangleMesh:
    """A triangle mesh with an exact closest point function.

    Parameters
    ----------
    vertices : array_like, shape (V, 3)
        Vertex positions (finite real numbers).
    faces : array_like of int, shape (F, 3)
        Vertex indices of each triangle, in ``[0, V)``.
    tolerance : float, keyword-only
        A face whose height (twice its area over its longest edge) is at
        most ``tolerance`` times its longest edge is skipped as degenerate.

    Attributes
    ----------
    vertices : ndarray, shape (V, 3)
        All vertices, loose ones included.
    input_faces : ndarray of int64, shape (F, 3)
        The faces as given.
    faces : ndarray of int64, shape (K, 3)
        The faces kept, ``K <= F``.
    face_index : ndarray of int64, shape (K,)
        The index in the input ``faces`` of each kept face.
    n_input_faces : int
        ``F``, the number of faces given.
    skipped_faces : int
        ``F - K``: faces skipped as degenerate (repeated index or zero area).
    face_normals : ndarray, shape (K, 3)
        Unit normals of the kept faces, by the right-hand rule.
    vertex_normals : ndarray, shape (V, 3)
        Angle-weighted vertex normals (zero at loose vertices).
    area : float
        Total area of the kept faces.

    Notes
    -----
    Face numbers in the results of :meth:`closest_point_on_faces` are input
    face numbers, so per-corner data given for the input faces (UVs) line up.
    """

    def __init__(self, vertices, faces, *, tolerance=1e-10):
        vertices = np.asarray(vertices)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
            raise ValueError(f"vertices must have shape (V, 3) with V > 0, got {vertices.shape}")
        if not (np.issubdtype(vertices.dtype, np.floating) or np.issubdtype(vertices.dtype, np.integer)):
            raise TypeError(f"vertices must hold real numbers, got dtype {vertices.dtype}")
        vertices = np.array(vertices, dtype=np.float64)
        finite = np.all(np.isfinite(vertices), axis=1)
        if not finite.all():
            bad = int(np.flatnonzero(~finite)[0])
            raise ValueError(f"vertices must be finite, got {vertices[bad].tolist()} at vertex {bad}")
        faces = np.asarray(faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
            raise ValueError(f"faces must have shape (F, 3) with F > 0, got {faces.shape}")
        if not np.issubdtype(faces.dtype, np.integer):
            raise TypeError(f"faces must hold integer vertex indices, got dtype {faces.dtype}")
        faces = faces.astype(np.int64)
        out = (faces < 0) | (faces >= len(vertices))
        if out.any():
            f = int(np.flatnonzero(out.any(axis=1))[0])
            raise ValueError(
                f"face vertex indices must lie in [0, {len(vertices)}), got {faces[f].tolist()} at face {f}")
        tolerance = float(tolerance)
        if not np.isfinite(tolerance) or tolerance < 0:
            raise ValueError(f"tolerance must be a non-negative number, got {tolerance!r}")

        a, b, c = (vertices[faces[:, k]] for k in range(3))
        twice_area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
        longest = np.sqrt(np.max([((b - a) ** 2).sum(1), ((c - b) ** 2).sum(1), ((a - c) ** 2).sum(1)],
                                 axis=0))
        repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
        keep = ~repeated & (twice_area > tolerance * longest**2) & (longest > 0)
        if not keep.any():
            raise ValueError(f"faces must include a non-degenerate triangle, "
                             f"got {len(faces)} degenerate face(s)")

        self.vertices = vertices
        self.input_faces = faces
        self.faces = faces[keep]
        self.face_index = np.flatnonzero(keep).astype(np.int64)
        self.n_input_faces = len(faces)
        self.skipped_faces = int(len(faces) - keep.sum())
        self._kept = np.full(len(faces), -1, dtype=np.int64)
        self._kept[self.face_index] = np.arange(len(self.face_index))
        self.area = 0.5 * float(twice_area[keep].sum())

        a, b, c = (vertices[self.faces[:, k]] for k in range(3))
        self._a, self._ab, self._ac = a, b - a, c - a
        self._abab = np.einsum("ij,ij->i", self._ab, self._ab)
        self._acac = np.einsum("ij,ij->i", self._ac, self._ac)
        self._abac = np.einsum("ij,ij->i", self._ab, self._ac)
        self.face_normals = _unit(np.cross(self._ab, self._ac))[0]
        self.vertex_normals = self._angle_weighted_normals(a, b, c)
        columns = np.column_stack([self._a, self._ab, self._ac, self._abab, self._abac, self._acac,
                                   self._abab * self._acac - self._abac**2])
        self._pack = [np.ascontiguousarray(c) for c in columns.T]
        self._scale = float(np.abs(vertices[self.faces]).max() + longest[keep].max())
        self._tree = None

    def __repr__(self):
        skipped = f", skipped_faces={self.skipped_faces}" if self.skipped_faces else ""
        return f"TriangleMesh(vertices={len(self.vertices)}, faces={len(self.faces)}{skipped})"

    def bounds(self):
        """Axis-aligned box ``(lo, hi)`` of the kept faces' vertices (loose vertices left out)."""
        used = self.vertices[np.unique(self.faces)]
        return used.min(axis=0), used.max(axis=0)

    # -- normals --------------------------------------------------------------

    def _angle_weighted_normals(self, a, b, c):
        """Vertex normals: face normals summed with the face's angle at the vertex as weight."""
        corners = (a, b, c)
        normals = np.zeros_like(self.vertices)
        for k in range(3):
            e1 = corners[(k + 1) % 3] - corners[k]
            e2 = corners[(k + 2) % 3] - corners[k]
            angle = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), np.einsum("ij,ij->i", e1, e2))
            for axis in range(3):
                normals[:, axis] += np.bincount(self.faces[:, k], weights=angle * self.face_normals[:, axis],
                                                minlength=len(self.vertices))
        return _unit(normals)[0]

    def _kept_faces(self, face, n):
        face = np.asarray(face)
        if not np.issubdtype(face.dtype, np.integer) or face.shape != (n,):
            raise ValueError(f"face must be {n} integer face numbers, got shape {face.shape} of {face.dtype}")
        if np.any((face < 0) | (face >= self.n_input_faces)):
            raise ValueError(f"face numbers must lie in [0, {self.n_input_faces}), "
                             f"got {face.min()}..{face.max()}")
        kept = self._kept[face]
        if np.any(kept < 0):
            bad = int(face[np.flatnonzero(kept < 0)[0]])
            raise ValueError(f"face {bad} was skipped as degenerate and holds no surface point")
        return kept

    def normal(self, cp, face=None, bary=None):
        """Unit normals (N, 3) at surface points ``cp`` from interpolated vertex normals.

        Parameters
        ----------
        cp : ndarray, shape (N, 3)
            Points on the mesh.
        face : ndarray of int, shape (N,), optional
            Input face number holding each point (``Band.face``); found with
            :meth:`closest_point_on_faces` when not given.
        bary : ndarray, shape (N, 3), optional
            Barycentric coordinates of ``cp`` in ``face`` (``Band.bary``);
            computed from ``cp`` when not given.

        Returns
        -------
        ndarray, shape (N, 3)
            ``sum_i bary_i n_i / |...|`` with ``n_i`` the angle-weighted normals
            of the face's vertices, oriented like the face normal.

        Notes
        -----
        The normals feed the tangent basis of the paper's eq. (31) and so the
        diffusion tensor.  Face normals jump by the dihedral angle at every
        edge, and would print the tessellation into anisotropic diffusion;
        interpolated vertex normals vary continuously over the surface
        (Phong's normal field).  The angle weights (Thuermer and Wuethrich)
        make a vertex normal independent of how the polygons around it were
        split into triangles, which area or uniform weights are not.  Vertex
        normals assume consistently oriented faces: where the interpolated
        normal nearly vanishes or points away from the face normal (an
        inconsistently oriented or non-orientable part), the face normal is
        used instead.
        """
        cp = _as_points(cp, "cp")
        if face is None:
            _, _, face, bary = self.closest_point_on_faces(cp)
        kept = self._kept_faces(face, len(cp))
        if bary is None:
            v, w, _, _ = self._closest(np.ascontiguousarray(cp.T), kept)
            bary = np.column_stack([1.0 - v - w, v, w])
        bary = np.asarray(bary, dtype=np.float64)
        if bary.shape != (len(cp), 3):
            raise ValueError(f"bary must have shape ({len(cp)}, 3), got {bary.shape}")
        fn = self.face_normals[kept]
        n = np.einsum("ij,ijk->ik", bary, self.vertex_normals[self.faces[kept]])
        n, length = _unit(n)
        bad = (length < 1e-6) | (np.einsum("ij,ij->i", n, fn) <= 0.0)
        n[bad] = fn[bad]
        return n

    # -- closest points -----------------------------------------------------

    def _closest(self, p, tri):
        """Closest points of ``p`` (3, P) on the kept triangles ``tri`` (P,).

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
        pk = self._pack
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

    def _build_index(self):
        """Sample points covering every kept triangle within ``self._radius``, and their k-d tree."""
        centroid = self._a + (self._ab + self._ac) / 3.0
        corners = np.stack([self._a, self._a + self._ab, self._a + self._ac], axis=1)
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
            p = (self._a[tris, None, :] + bary[None, :, 1:2] * self._ab[tris, None, :]
                 + bary[None, :, 2:3] * self._ac[tris, None, :])
            points.append(p.reshape(-1, 3))
            owner.append(np.repeat(tris, len(bary)))
        self._samples = np.concatenate(points)
        self._owner = np.concatenate(owner)
        self._radius = float((reach / m).max()) * (1 + 1e-9)
        self._tree = cKDTree(self._samples)

    def _descend(self, centres, deltas, parents, cells, tris, width=None):
        """Closest kept faces of the points at the bottom of a hierarchy of cells.

        Parameters
        ----------
        centres, deltas, parents : lists over levels
            Level ``l`` has cells with centres (3, n_l), radii (n_l,) such
            that every point of a cell lies within its radius of its centre,
            and (for ``l > 0``) the index of each cell's parent in level
            ``l - 1``.  The last level is the query points (radius 0).
        cells, tris : ndarray of int64
            Pairs (level-0 cell, kept face), sorted by cell, that include the
            face holding the closest point of every point of the cell (with
            ``width``: every face within ``width`` of one of them).
        width : float, optional
            Drop the points farther than this from the mesh.

        Returns
        -------
        face : ndarray of int64
            Kept face of the closest point of every query point, -1 if dropped.
        d2 : ndarray
            Squared distances.

        Notes
        -----
        With ``dmin`` the least distance from a cell's centre ``c`` to its
        faces and ``delta`` its radius, a face farther than ``dmin + 2 delta``
        from ``c`` is nearer to none of the cell's points.  A child cell at
        ``c + o`` first bounds its parent's faces from below: the distance to
        a triangle is a convex function with gradient ``g`` of unit length,
        so it exceeds ``d(c) + g.o - delta_child`` throughout the child (and
        ``d(c) - |o| - delta_child`` in any case; where ``d(c)`` is near
        zero, rounding makes ``g`` unreliable and this bound takes over).  Faces
        whose bound exceeds the distance from the child's centre to the
        parent's nearest face, plus ``delta_child``, are dropped before the
        exact distances of the rest are taken.
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
            first = np.cumsum(count) - count
            nxt = level + 1
            parent, centre, radius = parents[nxt], centres[nxt], deltas[nxt]
            offset = centre - centres[level][:, parent]
            step = np.sqrt((offset * offset).sum(axis=0))
            run, pos = _expand(count[parent])
            src = first[parent[run]] + pos
            ahead = g[0][src] * offset[0][run] + g[1][src] * offset[1][run] + g[2][src] * offset[2][run]
            bound = d[src] + np.maximum(ahead - slack[src] * step[run], -step[run]) - radius[run]
            kids = np.flatnonzero(count[parent] > 0)
            _, _, _, up2 = self._closest(centre[:, kids], nearest[parent[kids]])
            upper = np.full(len(parent), np.inf)
            upper[kids] = np.sqrt(up2) + radius[kids]
            keep = bound <= upper[run] + eps
            if width is not None:
                keep &= bound <= width + eps
            cells, tris = run[keep], tris[src[keep]]
            level = nxt
            _, _, r, d2 = self._closest(centre[:, cells], tris)

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

    def _nearest(self, x):
        """Kept face, ``v``, ``w`` and squared distance of the closest point of every row of ``x``.

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
        """Closest kept faces of points ``xs`` sorted by their cell keys at every level."""
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
        n_faces = len(self.faces)
        pair = np.unique(np.repeat(np.arange(len(found)), counts) * n_faces + self._owner[samples])
        face, _ = self._descend(centres, deltas, parents, pair // n_faces, pair % n_faces)
        return face

    def closest_point_on_faces(self, x):
        """Exact closest points on the mesh, with the face and barycentric coordinates.

        Parameters
        ----------
        x : ndarray, shape (N, 3)
            Query points.

        Returns
        -------
        cp : ndarray, shape (N, 3)
            The nearest point of the union of the kept triangles (eq. (34)).
        dist : ndarray, shape (N,)
            The unsigned distance ``|x - cp|``.
        face : ndarray of int64, shape (N,)
            The *input* face number of the triangle holding ``cp``.
        bary : ndarray, shape (N, 3)
            Barycentric coordinates of ``cp`` in that face (non-negative, sum 1).

        Notes
        -----
        Where several points are equally near (the medial axis), one of them
        is returned.
        """
        x = _as_points(x)
        if len(x) == 0:
            return np.empty((0, 3)), np.empty(0), np.empty(0, dtype=np.int64), np.empty((0, 3))
        kept, v, w, d2 = self._nearest(x)
        return self._result(kept, v, w, d2)

    def _result(self, kept, v, w, d2):
        cp = self._a[kept] + v[:, None] * self._ab[kept] + w[:, None] * self._ac[kept]
        bary = np.column_stack([np.maximum(1.0 - v - w, 0.0), v, w])
        return cp, np.sqrt(d2), self.face_index[kept], bary

    def closest_point(self, x):
        """Closest points (N, 3) on the mesh and unsigned distances (N,) of points ``x`` (N, 3)."""
        cp, dist, _, _ = self.closest_point_on_faces(x)
        return cp, dist

    # -- the band ---------------------------------------------------------------

    def band_points(self, h, width):
        """The grid points within ``width`` of the mesh with their closest points, in chunks.

        Parameters
        ----------
        h : float
            Grid spacing; grid points are ``h * ijk``.
        width : float
            Band half-width.

        Yields
        ------
        ijk : ndarray of int64, shape (K, 3)
            Distinct integer grid coordinates with ``dist <= width``; over
            all chunks, every such grid point exactly once.
        cp, dist, face, bary
            As :meth:`closest_point_on_faces` returns them for ``h * ijk``.

        Notes
        -----
        The grid is cut into blocks of ``4^3`` points.  A triangle is a
        candidate of a block when the block meets the triangle's bounding
        box grown by ``width`` and the block's centre lies within ``width``
        plus the block's radius of the triangle's plane.  The candidate
        lists then narrow through the blocks' ``2^3`` sub-blocks down to the
        points (see the module notes).  Nothing scans the mesh's bounding
        box.
        """
        h, width = float(h), float(width)
        if not np.isfinite(h) or h <= 0:
            raise ValueError(f"grid spacing h must be a positive number, got {h!r}")
        if not np.isfinite(width) or width < 0:
            raise ValueError(f"width must be a non-negative number, got {width!r}")
        blocks, pair_block, pair_tri = self._block_pairs(h, width)
        local = np.stack(np.meshgrid(*[np.arange(_BLOCK)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        half = _BLOCK // 2
        corner = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
        sub_of_point = ((local // half) * [4, 2, 1]).sum(axis=1)
        sub_offset = half * corner + 0.5 * (half - 1)
        # chunks of blocks with a bounded number of points and (sub-block, triangle) pairs
        per_block = np.bincount(pair_block, minlength=len(blocks))
        pair_start = np.r_[0, np.cumsum(per_block)]
        chunks = _split_counts(np.maximum(8 * per_block, len(local)), 4 * _CHUNK)

        def search(bounds):
            s, e = bounds
            b = blocks[s:e]
            nb = len(b)
            p0, p1 = pair_start[s], pair_start[e]
            cells, tris = pair_block[p0:p1] - s, pair_tri[p0:p1]
            base = _BLOCK * b
            ijk = (base[:, None, :] + local[None, :, :]).reshape(-1, 3)
            centres = [
                np.ascontiguousarray((h * (base + 0.5 * (_BLOCK - 1))).T),
                np.ascontiguousarray((h * (base[:, None, :] + sub_offset[None, :, :])).reshape(-1, 3).T),
                np.ascontiguousarray((h * ijk).T),
            ]
            deltas = [np.full(nb, 0.5 * (_BLOCK - 1) * np.sqrt(3.0) * h * (1 + 1e-12)),
                      np.full(nb * 8, 0.5 * (half - 1) * np.sqrt(3.0) * h * (1 + 1e-12)),
                      np.zeros(len(ijk))]
            parents = [None, np.repeat(np.arange(nb), 8),
                       (np.arange(nb)[:, None] * 8 + sub_of_point[None, :]).ravel()]
            face, _ = self._descend(centres, deltas, parents, cells, tris, width=width)
            keep = np.flatnonzero(face >= 0)
            if len(keep) == 0:
                return None
            v, w, _, d2 = self._closest(centres[2][:, keep], face[keep])
            result = self._result(face[keep], v, w, d2)
            inside = result[1] <= width
            return (ijk[keep][inside],) + tuple(a[inside] for a in result)

        # the chunks are independent: a few at a time, side by side on the worker threads
        spans = list(zip(chunks[:-1], chunks[1:]))
        step = 2 * workers()
        for k in range(0, len(spans), step):
            for found in map_parallel(search, spans[k:k + step]):
                if found is not None:
                    yield found

    def _block_pairs(self, h, width):
        """Blocks near the mesh and their candidate triangles.

        Returns the distinct block coordinates (B, 3) and the pairs (block
        index, kept face) sorted by block.
        """
        side = _BLOCK * h
        corners = np.stack([self._a, self._a + self._ab, self._a + self._ac], axis=1)
        pad = 1e-9 * (1.0 + np.abs(corners).max() / side)
        lo = np.floor((corners.min(axis=1) - width) / side - pad).astype(np.int64)
        hi = np.floor((corners.max(axis=1) + width) / side + pad).astype(np.int64)
        extent = hi - lo + 1
        counts = extent.prod(axis=1)
        slack = (width + 0.5 * np.sqrt(3.0) * (_BLOCK - 1) * h) * (1 + 1e-9)
        origin = np.min(lo, axis=0)
        dims = np.max(hi, axis=0) - origin + 1
        keys, owners = [], []
        bounds = _split_counts(counts, _CHUNK * 8)
        for s, e in zip(bounds[:-1], bounds[1:]):
            tri, pos = _expand(counts[s:e])
            ext = extent[s:e][tri]
            iz = pos % ext[:, 2]
            iy = (pos // ext[:, 2]) % ext[:, 1]
            ix = pos // (ext[:, 2] * ext[:, 1])
            block = lo[s:e][tri] + np.column_stack([ix, iy, iz])
            tri += s
            centre = h * (_BLOCK * block + 0.5 * (_BLOCK - 1))
            near = np.abs(np.einsum("ij,ij->i", centre - self._a[tri], self.face_normals[tri])) <= slack
            rel = block[near] - origin
            keys.append((rel[:, 0] * dims[1] + rel[:, 1]) * dims[2] + rel[:, 2])
            owners.append(tri[near])
        keys, owners = np.concatenate(keys), np.concatenate(owners)
        order = np.argsort(keys, kind="stable")
        keys, owners = keys[order], owners[order]
        unique, pair_block = np.unique(keys, return_inverse=True)
        rel = np.column_stack([unique // (dims[1] * dims[2]), (unique // dims[2]) % dims[1], unique % dims[2]])
        return rel + origin, pair_block.astype(np.int64), owners


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


def parametric_mesh(point, n_u, n_v, *, periodic_u=False, periodic_v=False):
    """Triangulate a parametrised surface on a regular grid of parameters, with per-corner UVs.

    Parameters
    ----------
    point : callable
        ``point(s, t) -> (..., 3)`` for ``s, t`` in [0, 1], such as
        :meth:`Sphere.point <cp_stylize.surfaces.Sphere.point>` or
        :meth:`Torus.point <cp_stylize.surfaces.Torus.point>`.
    n_u, n_v : int
        Grid cells along ``s`` and ``t`` (each cell is split into two triangles).
    periodic_u, periodic_v : bool
        The surface closes along ``s`` (``t``): the last grid column (row)
        shares the vertices of the first one, while its UVs end at 1, so the
        UV map has a seam there.

    Returns
    -------
    vertices : ndarray, shape (V, 3)
    faces : ndarray of int64, shape (2 n_u n_v, 3)
        Counter-clockwise about ``d point/ds x d point/dt``.
    uvs : ndarray, shape (2 n_u n_v, 3, 2)
        ``(s, t)`` at each face corner, the layout of Blender's UV sphere for
        the sphere's parametrisation.

    Notes
    -----
    A grid row or column that the parametrisation collapses to one point
    (the sphere's poles) becomes one vertex, unused vertices stay in the
    list, and the triangles with a repeated vertex there are skipped by
    :class:`TriangleMesh`.
    """
    for name, n in (("n_u", n_u), ("n_v", n_v)):
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ValueError(f"{name} must be a positive integer, got {n!r}")
    cols = n_u if periodic_u else n_u + 1
    rows = n_v if periodic_v else n_v + 1
    s, t = np.meshgrid(np.arange(cols) / n_u, np.arange(rows) / n_v, indexing="ij")
    vertices = np.asarray(point(s.ravel(), t.ravel()), dtype=np.float64).reshape(-1, 3)
    # one vertex for a grid row or column that the parametrisation collapses to a point
    grid = vertices.reshape(cols, rows, 3)
    tiny = 1e-12 * (1.0 + np.abs(vertices).max())
    index = np.arange(cols * rows).reshape(cols, rows)
    row_point = np.all(np.abs(grid - grid[:1]) <= tiny, axis=(0, 2))
    index[:, row_point] = index[0, row_point]
    column_point = np.all(np.abs(grid - grid[:, :1]) <= tiny, axis=(1, 2))
    index[column_point, :] = index[column_point, :1]
    i, j = (a.ravel() for a in np.meshgrid(np.arange(n_u), np.arange(n_v), indexing="ij"))
    corner = {}
    for di in (0, 1):
        for dj in (0, 1):
            vi, vj = (i + di) % cols, (j + dj) % rows
            corner[di, dj] = (index[vi, vj], np.column_stack([(i + di) / n_u, (j + dj) / n_v]))
    tri = [((0, 0), (1, 0), (1, 1)), ((0, 0), (1, 1), (0, 1))]
    faces = np.stack([np.column_stack([corner[c][0] for c in t3]) for t3 in tri], axis=1).reshape(-1, 3)
    uvs = np.stack([np.stack([corner[c][1] for c in t3], axis=1) for t3 in tri], axis=1).reshape(-1, 3, 2)
    return vertices, faces.astype(np.int64), uvs
