"""Triangle meshes as closest point surfaces.

A triangle mesh enters the closest point method through its closest point
function (paper, section 4.1, eq. (34)): ``cp(x)`` is the nearest point of the
union of its triangles.  It is computed exactly, not approximated by the
nearest vertex: every query ends with exact point-triangle distances, and the
search drops a triangle only where a bound proves another one nearer.

The search for the nearest triangle is :class:`~cp_stylize.nearest.TriangleSearch`.

Sign convention: ``dist`` is the *unsigned* distance ``|x - cp(x)|``.  Meshes
may be open, non-manifold or inconsistently oriented, and the closest point
method needs only ``cp`` (the band is ``|dist| <= width``).

Which triangles count: faces with a repeated vertex index or with (nearly)
zero area, i.e. height below ``tolerance`` times their longest edge, are
skipped; they add no surface.  Open meshes, disconnected parts, non-manifold
edges and loose vertices need no special treatment.
"""

from __future__ import annotations

import numpy as np

from .arrays import as_points, before, count, unit_rows
from .grid import tube_points
from .nearest import TriangleSearch

__all__ = ["TriangleMesh", "parametric_mesh", "surface_faces", "canonical_faces", "check_mesh"]


#: A face whose height is at most this share of its longest edge is degenerate (see :func:`surface_faces`).
TOLERANCE = 1e-10


def surface_faces(vertices, faces, tolerance=TOLERANCE):
    """Which ``faces`` (F, 3) of ``vertices`` (V, 3) are surface: boolean (F,).

    A face is skipped as degenerate, with no surface, where two of its corners
    are one vertex or where its height (twice its area over its longest edge)
    is at most ``tolerance`` times its longest edge: corners on a line or at
    one point.  The test does not change when the mesh is scaled or turned.
    """
    return _surface_faces(np.asarray(vertices, dtype=np.float64), np.asarray(faces), tolerance)[0]


def _surface_faces(vertices, faces, tolerance):
    """The mask of :func:`surface_faces`, and each face's twice area (F,)."""
    a = vertices[faces[:, 0]]
    ab, ac = vertices[faces[:, 1]] - a, vertices[faces[:, 2]] - a
    cross = np.cross(ab, ac)
    twice_area = np.sqrt(np.einsum("ij,ij->i", cross, cross))
    longest2 = np.maximum(np.einsum("ij,ij->i", ab, ab), np.einsum("ij,ij->i", ac, ac))
    ac -= ab                                                           # the third edge, b to c
    np.maximum(longest2, np.einsum("ij,ij->i", ac, ac), out=longest2)
    repeated = (faces[:, 0] == faces[:, 1]) | (faces[:, 1] == faces[:, 2]) | (faces[:, 2] == faces[:, 0])
    return ~repeated & (twice_area > tolerance * longest2) & (longest2 > 0), twice_area


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

    def __init__(self, vertices, faces, *, tolerance=TOLERANCE):
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

        keep, twice_area = _surface_faces(vertices, faces, tolerance)
        if not keep.any():
            raise ValueError(f"faces must include a non-degenerate triangle, "
                             f"got {len(faces)} degenerate face(s)")

        self.vertices = vertices
        self.input_faces = faces
        self.faces = faces[keep]
        self.face_index = np.flatnonzero(keep).astype(np.int64)

        # The search, the normals and the samples see the faces in a canonical order (their positions
        # alone decide it), so nothing depends on how the faces were numbered or where each starts.
        self._order, self._turn = canonical_faces(vertices, self.faces)
        self._rank = np.empty_like(self._order)
        self._rank[self._order] = np.arange(len(self._order))
        self._turned = turned = self.faces[self._order[:, None], _turned_corners(self._turn)]
        a, b, c = (vertices[turned[:, k]] for k in range(3))
        self._search = TriangleSearch(a, b, c)
        self._twice_areas = np.linalg.norm(np.cross(b - a, c - a), axis=1)     # in the canonical order
        self.area = 0.5 * float(self._twice_areas.sum())
        self.face_normals = self._search.normals[self._rank]
        self.vertex_normals = self._angle_weighted_normals(turned, a, b, c)
        self._kept = None
        self._piece = None
        self._welded_faces = None

    @property
    def welded_faces(self):
        """The input faces (F, 3) as indices of the distinct vertex positions: corners split at a seam (one
        vertex a side) share their index here."""
        if self._welded_faces is None:
            _, welded = np.unique(self.vertices, axis=0, return_inverse=True)
            self._welded_faces = welded.reshape(-1)[self.input_faces]
        return self._welded_faces

    @property
    def piece(self):
        """A label (F,) of the connected piece of each input face: faces sharing a vertex position
        are in one piece, so vertices split at seams do not cut a surface apart."""
        if self._piece is None:
            from scipy.sparse import csr_matrix
            from scipy.sparse.csgraph import connected_components

            corners = self.welded_faces
            n = len(self.input_faces)
            # a graph of faces and vertex positions: face f links to its three corners
            links = csr_matrix((np.ones(3 * n), (np.repeat(np.arange(n), 3), n + corners.ravel())),
                               shape=(n + len(self.vertices),) * 2)
            self._piece = connected_components(links, directed=False)[1][:n].astype(np.int32)
        return self._piece

    @property
    def n_input_faces(self):
        """``F``, the number of faces given."""
        return len(self.input_faces)

    @property
    def skipped_faces(self):
        """Faces skipped as degenerate (repeated index or zero area)."""
        return self.n_input_faces - len(self.face_index)

    def __repr__(self):
        skipped = f", skipped_faces={self.skipped_faces}" if self.skipped_faces else ""
        return f"TriangleMesh(vertices={len(self.vertices)}, faces={len(self.faces)}{skipped})"

    def bounds(self):
        """Axis-aligned box ``(lo, hi)`` of the kept faces' vertices (loose vertices left out)."""
        used = self.vertices[np.unique(self.faces)]
        return used.min(axis=0), used.max(axis=0)

    def kept_index(self, face):
        """The index among the kept faces of input faces ``face`` (any shape); -1 for skipped ones."""
        if self._kept is None:
            self._kept = np.full(self.n_input_faces, -1, dtype=np.int64)
            self._kept[self.face_index] = np.arange(len(self.face_index))
        return self._kept[face]

    # -- normals --------------------------------------------------------------

    def _angle_weighted_normals(self, faces, a, b, c):
        """Vertex normals: face normals summed with the face's angle at the vertex as weight (``faces``
        and their corners ``a``, ``b``, ``c`` in the search's order)."""
        corners = (a, b, c)
        normals = np.zeros_like(self.vertices)
        for k in range(3):
            e1 = corners[(k + 1) % 3] - corners[k]
            e2 = corners[(k + 2) % 3] - corners[k]
            angle = np.arctan2(np.linalg.norm(np.cross(e1, e2), axis=1), np.einsum("ij,ij->i", e1, e2))
            for axis in range(3):
                normals[:, axis] += np.bincount(faces[:, k], weights=angle * self._search.normals[:, axis],
                                                minlength=len(self.vertices))
        return unit_rows(normals)[0]

    def _kept_faces(self, face, n):
        face = np.asarray(face)
        if not np.issubdtype(face.dtype, np.integer) or face.shape != (n,):
            raise ValueError(f"face must be {n} integer face numbers, got shape {face.shape} of {face.dtype}")
        if np.any((face < 0) | (face >= self.n_input_faces)):
            raise ValueError(f"face numbers must lie in [0, {self.n_input_faces}), "
                             f"got {face.min()}..{face.max()}")
        kept = self.kept_index(face)
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
        cp = as_points(cp, "cp")
        if face is None:
            _, _, face, bary = self.closest_point_on_faces(cp)
        kept = self._kept_faces(face, len(cp))
        at = self._rank[kept]                                   # the search's triangles
        if bary is None:
            bary = self._input_bary(at, *self._search.on(cp, at))
        bary = np.asarray(bary, dtype=np.float64)
        if bary.shape != (len(cp), 3):
            raise ValueError(f"bary must have shape ({len(cp)}, 3), got {bary.shape}")
        fn = self.face_normals[kept]
        # summed in the search's order of corners
        n = np.einsum("ij,ijk->ik", bary[np.arange(len(at))[:, None], self._corners(at)],
                      self.vertex_normals[self._turned[at]])
        n, length = unit_rows(n)
        bad = (length < 1e-6) | (np.einsum("ij,ij->i", n, fn) <= 0.0)
        n[bad] = fn[bad]
        return n

    # -- closest points -----------------------------------------------------

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
        x = as_points(x)
        if len(x) == 0:
            return np.empty((0, 3)), np.empty(0), np.empty(0, dtype=np.int64), np.empty((0, 3))
        return self._result(*self._search.nearest(x))

    def _input_bary(self, at, v, w):
        """Barycentric coordinates (N, 3), by the input face's corners, of the points ``(v, w)`` of the
        search's triangles ``at`` (N,), whose corners start at the input's corner ``self._turn[at]``."""
        turned = np.column_stack([np.maximum(1.0 - v - w, 0.0), v, w])
        bary = np.empty_like(turned)
        bary[np.arange(len(at))[:, None], self._corners(at)] = turned
        return bary

    def _corners(self, at):
        """The input corners (N, 3) of the search's triangles ``at`` (N,), in the search's order."""
        return _turned_corners(self._turn[at])

    def _result(self, at, v, w, d2):
        """``(cp, dist, input face, bary)`` of the search's ``(triangle, v, w, d2)``."""
        return (self._search.point(at, v, w), np.sqrt(d2), self.face_index[self._order[at]],
                self._input_bary(at, v, w))

    def sample(self, n, rng):
        """``n`` random points on the mesh, uniform by area: points (n, 3), input faces (n,) and
        barycentric coordinates (n, 3).  The same ``rng`` gives the same points however the faces are
        numbered or where each starts."""
        at = rng.choice(len(self._order), size=n, p=self._twice_areas / self._twice_areas.sum())
        r = np.sqrt(rng.random(n))
        t = rng.random(n)
        v, w = r * (1.0 - t), r * t
        return self._search.point(at, v, w), self.face_index[self._order[at]], self._input_bary(at, v, w)

    def closest_point(self, x):
        """Closest points (N, 3) on the mesh and unsigned distances (N,) of points ``x`` (N, 3)."""
        cp, dist, _, _ = self.closest_point_on_faces(x)
        return cp, dist

    # -- the band ---------------------------------------------------------------

    def band_points(self, h, width):
        """The grid points within ``width`` of the mesh with their closest points, in chunks.

        Yields ``(ijk, cp, dist, face, bary)`` for grid points ``h * ijk`` (int64
        ``ijk``, shape (K, 3)): over all chunks, every grid point within
        ``width`` exactly once, with its closest point as
        :meth:`closest_point_on_faces` gives it.  The chunks come from
        :meth:`cp_stylize.nearest.TriangleSearch.band`, or on meshes with many
        triangles a band point, where libigl can be imported, from its AABB
        tree (:func:`cp_stylize.band_search.use_aabb`,
        :func:`cp_stylize.band_search.aabb_band_points`): the same points,
        and the same closest points up to ties.
        """
        from .band_search import aabb_band_points, use_aabb

        h, width = float(h), float(width)
        if not np.isfinite(h) or h <= 0:
            raise ValueError(f"grid spacing h must be a positive number, got {h!r}")
        if not np.isfinite(width) or width < 0:
            raise ValueError(f"width must be a non-negative number, got {width!r}")
        if use_aabb(len(self.faces), tube_points(self.area, h, width)):
            chunks = aabb_band_points(self._search, self.vertices, self._turned, h, width)
        else:
            chunks = self._search.band(h, width)
        for ijk, kept, v, w, d2 in chunks:
            result = self._result(kept, v, w, d2)
            inside = result[1] <= width
            yield (ijk[inside],) + tuple(a[inside] for a in result)


def canonical_faces(vertices, faces):
    """A numbering of ``faces`` (K, 3) of ``vertices`` that their positions alone decide.

    Returns ``order`` (K,) and ``turn`` (K,): the faces ``faces[order]``, each
    started at its corner ``turn`` (the one whose position comes first by
    x, then y, then z; turning keeps the orientation), come sorted by their
    corners' positions.  Faces at the same positions keep their given order.
    """
    corners = vertices[faces]                                                 # (K, 3, 3)
    rows = np.arange(len(faces))
    turn = np.zeros(len(faces), dtype=np.int64)
    for k in (1, 2):
        turn[before(corners[:, k], corners[rows, turn])] = k
    turned = corners[rows[:, None], _turned_corners(turn)].reshape(len(faces), 9)
    order = np.lexsort(turned.T[::-1])
    return order.astype(np.int64), turn[order]


def _turned_corners(turn):
    """The corners (N, 3) of faces started at their corners ``turn`` (N,), in order: ``turn``, then on."""
    return (np.asarray(turn)[:, None] + np.arange(3)) % 3


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
    n_u, n_v = count(n_u, "n_u"), count(n_v, "n_v")
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


def check_mesh(mesh):
    """``mesh`` if it is a :class:`~cp_stylize.mesh.TriangleMesh` (or alike); TypeError otherwise."""
    for name in ("faces", "face_index", "n_input_faces", "vertices"):
        if not hasattr(mesh, name):
            raise TypeError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
    return mesh
