"""The computational band: grid points near a surface, their closest points, E and L.

The closest point method (paper, section 4) works on the points of a uniform
grid ``x = h * (i, j, k)`` that lie within a distance ``width`` of the surface.
Each band point knows its closest point on the surface.  Two sparse matrices
act on arrays of band values:

- ``E``, the extension: row ``i`` interpolates band values (tensor-product
  Lagrange interpolation of degree 3, 64 weights a row) at the closest point
  of band point ``i`` (paper, eq. (47)-(48b));
- ``L``, the 7-point Laplacian ``sum_axes (v[x+e] - 2 v[x] + v[x-e]) / h^2``.

The grid is aligned with the origin, so scaling a surface and ``h`` by the same
factor scales the band exactly.  How wide the band must be, and the stencils'
and the interpolation's weights on the grid, are :mod:`cp_stylize.grid`'s.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp

from .grid import (DEGREE, STENCILS, band_width, candidates, estimate_band_size, flat_index, lagrange_weights,
                   stencil_offsets)
from .sheets import Sheets
from .sparse import SplitMatrix, map_parallel

__all__ = ["Band", "band_width", "estimate_band_size", "flat_index", "STENCILS", "lagrange_weights"]

_CHUNK = 1 << 17


def apply(matrix, v):
    """``matrix @ v`` for v of shape (N,) or (N, k), one column at a time.

    SciPy's sparse product with several columns at once is slower than the
    same product column by column on contiguous arrays.
    """
    if v.ndim == 1:
        return matrix @ v
    out = np.empty((matrix.shape[0], v.shape[1]), dtype=np.result_type(matrix.dtype, v.dtype))
    for j in range(v.shape[1]):
        out[:, j] = matrix @ np.ascontiguousarray(v[:, j])
    return out


def _float_type(dtype):
    """float64 stays float64; everything else computes in float32."""
    return np.dtype(np.float64) if np.dtype(dtype) == np.float64 else np.dtype(np.float32)


class Band:
    """Grid points near a surface with their closest points, and the E and L matrices.

    Build one with :meth:`Band.build`.

    Attributes
    ----------
    h : float
        Grid spacing.
    ijk : ndarray of int64, shape (N, 3)
        Integer grid coordinates; ``points == h * ijk``.
    points : ndarray, shape (N, 3)
        Band points.
    cp : ndarray, shape (N, 3)
        Their closest points on the surface.
    dist : ndarray, shape (N,)
        Distance from the surface: signed for analytic surfaces (negative
        inside), unsigned for triangle meshes.
    width : float
        Distance from the surface within which grid points were taken.
    size : int
        Number of band points ``N``.
    surface : object
        The surface the band was built from.
    face, bary : ndarray or None
        For triangle meshes: the index of the face that holds each closest
        point (N,) and its barycentric coordinates there (N, 3); None otherwise.
    """

    def __init__(self, surface, h, ijk, cp, dist, *, width, stencil="laplacian", degree=DEGREE,
                 face=None, bary=None):
        self.surface = surface
        self.h = float(h)
        ijk = np.asarray(ijk, dtype=np.int64)
        order = np.lexsort(ijk.T[::-1])  # i major, k minor: neighbours in memory stay near
        self.ijk = np.ascontiguousarray(ijk[order])
        self.cp = np.ascontiguousarray(np.asarray(cp, dtype=np.float64)[order])
        self.dist = np.ascontiguousarray(np.asarray(dist, dtype=np.float64)[order])
        self.face = None if face is None else np.ascontiguousarray(np.asarray(face, dtype=np.int64)[order])
        self.bary = None if bary is None else np.ascontiguousarray(np.asarray(bary, dtype=np.float64)[order])
        self.width = float(width)
        self.stencil = stencil
        self.degree = int(degree)
        self._lo = self.ijk.min(axis=0) - 1
        self._shape = tuple(self.ijk.max(axis=0) - self._lo + 2)
        self._index = np.full(self._shape, -1, dtype=np.int32 if self.size < 2**31 else np.int64)
        self._index[tuple((self.ijk - self._lo).T)] = np.arange(self.size)
        self._matrices = {}
        self._stencil_table = None
        #: the memo of the structures runs build from the band (:meth:`structure`): a
        #: :class:`~cp_stylize.cache.RunCache` set where the band is kept for further runs; None: none kept
        self.memo = None
        #: what tells the surface's sheets apart at the band's points (None for surfaces without normals)
        self.sheets = Sheets.of(surface, self.h, self.degree, self.cp, self.face, self.bary)
        self.normals = None if self.sheets is None else self.sheets.normals
        self.pieces = None if self.sheets is None else self.sheets.pieces
        moved = []
        self.E = _interpolation_matrix(self, self.cp, np.float32, self.normals, self.pieces, moved)
        #: band points whose extension keeps to their own sheet with trilinear weights
        #: (:meth:`cp_stylize.sheets.Sheets.keep_to_own`)
        self.separated = int(sum(moved))
        self.inner = np.zeros(self.size, dtype=bool)
        self.inner[self.E.indices] = True
        self._check_stencils()

    @classmethod
    def build(cls, surface, h, *, stencil="laplacian", degree=DEGREE, safety=1.01):
        """Build the band of the grid of spacing ``h`` around ``surface``.

        Parameters
        ----------
        surface : object
            Anything with ``closest_point(x) -> (cp, dist)`` and ``bounds()``,
            such as :class:`~cp_stylize.Sphere` or :class:`~cp_stylize.Torus`:
            the grid points of its bounding box grown by the band width are
            tested.  A surface may instead offer ``band_points(h, width)``
            yielding chunks ``(ijk, cp, dist, face, bary)`` of exactly the grid
            points within ``width`` (triangle meshes do), and
            ``closest_point_on_faces(x) -> (cp, dist, face, bary)``, whose
            faces and barycentric coordinates the band then keeps.
        h : float
            Grid spacing, in the surface's units.
        stencil : {"laplacian", "anisotropic"}
            The finite difference stencil the band must support: the 7-point
            Laplacian, or the 19-point stencil of the anisotropic scheme.
        degree : int
            Odd degree of the interpolation (3: tricubic).
        safety : float
            Factor (>= 1) on the band width of :func:`band_width`.

        Returns
        -------
        Band
        """
        h = float(h)
        if not np.isfinite(h) or h <= 0:
            raise ValueError(f"grid spacing h must be a positive number, got {h!r}")
        if degree < 1 or degree % 2 == 0:
            raise ValueError(f"interpolation degree must be odd and positive, got {degree!r}")
        if safety < 1:
            raise ValueError(f"safety factor must be >= 1, got {safety!r}")
        width = band_width(h, degree, stencil) * safety
        on_faces = getattr(surface, "closest_point_on_faces", None)
        own = getattr(surface, "band_points", None)
        parts = []
        if own is not None:
            parts = list(own(h, width))
        else:
            for ijk in candidates(surface, h, width):
                found = on_faces(h * ijk) if on_faces is not None else surface.closest_point(h * ijk)
                keep = np.abs(found[1]) <= width
                parts.append((ijk[keep],) + tuple(a[keep] for a in found))
        if not parts or sum(len(p[0]) for p in parts) == 0:
            raise ValueError(f"the band of {surface!r} at h={h!r} holds no grid point")
        ijk, cp, dist, *faces = (np.concatenate(a) for a in zip(*parts))
        face, bary = faces if faces else (None, None)
        return cls(surface, h, ijk, cp, dist, width=width, stencil=stencil, degree=degree, face=face, bary=bary)

    def structure(self, name, key, build):
        """``build()``: a structure made from the band and the parameters ``key``.

        Where the band is kept for further runs (it has a :attr:`memo`), the
        structure is kept in it, one per ``name``, for the next call with the same key.
        """
        return build() if self.memo is None else self.memo.get(name, key, build)

    def __repr__(self):
        return f"Band(size={self.size}, h={self.h!r}, width={self.width:.4g}, stencil={self.stencil!r})"

    @property
    def size(self):
        return len(self.ijk)

    @property
    def points(self):
        return self.h * self.ijk

    # -- lookup -------------------------------------------------------------

    def lookup(self, ijk):
        """Band indices of integer grid coordinates ``ijk`` (..., 3); -1 where not in the band."""
        rel = np.asarray(ijk, dtype=np.int64) - self._lo
        shape = self._shape
        inside = np.all((rel >= 0) & (rel < shape), axis=-1)
        flat = self._flat(np.where(inside[..., None], rel, 0))
        return np.where(inside, self._index.ravel()[flat], -1)

    def nearest(self, points):
        """Band indices (...,) of the grid nodes nearest to ``points`` (..., 3); -1 where not in the band."""
        return self.lookup(np.rint(np.asarray(points) / self.h).astype(np.int64))

    def neighbors(self, offsets):
        """Band indices of the grid points at ``offsets`` (K, 3) from each band point: (N, K), -1 if absent."""
        offsets = np.asarray(offsets, dtype=np.int64).reshape(-1, 3)
        known = self._stencil_table
        if known is not None:
            # the stencil's neighbours are looked up once, when the band is built
            where = {tuple(o): k for k, o in enumerate(known[0].tolist())}
            cols = [where.get(tuple(o)) for o in offsets.tolist()]
            if None not in cols:
                return known[1][:, cols]
        reach = int(np.abs(offsets).max()) if len(offsets) else 0
        index, shape, lo = self._index, self._shape, self._lo
        if reach > 1:  # the index volume keeps a margin of one point: widen it for longer offsets
            index = np.pad(index, reach - 1, constant_values=-1)
            shape, lo = index.shape, lo - (reach - 1)
        base = flat_index(self.ijk - lo, shape)
        steps = flat_index(offsets, shape)
        out = np.empty((len(base), len(offsets)), dtype=index.dtype)
        flat = index.ravel()
        for k, step in enumerate(steps):
            np.take(flat, base + step, out=out[:, k])
        return out

    # -- interpolation ------------------------------------------------------

    def _flat(self, rel):
        """Flat positions in the index volume of coordinates relative to its corner."""
        return flat_index(rel, self._shape)

    def cut_links(self, nodes, rows=slice(None)):
        """Which finite difference links cross between sheets (:meth:`cp_stylize.sheets.Sheets.cut_links`):
        (M, K) bool for the band points ``rows`` and their neighbours ``nodes`` (M, K), or None for
        surfaces without normals."""
        return None if self.sheets is None else self.sheets.cut_links(nodes, rows)

    def interpolation_matrix(self, x, dtype=np.float32, normals=None, pieces=None):
        """Sparse (M, N) matrix that interpolates band values at surface points ``x`` (M, 3).

        Each row holds the (degree + 1)^3 tensor-product Lagrange weights of the
        grid points around ``x``.  Given the surface's unit ``normals`` at ``x``
        (M, 3), and for meshes the ``pieces`` (M,) of their faces
        (``surface.piece[face]``), each row keeps to the sheet of the surface
        ``x`` lies on, as the extension E does (see :meth:`cp_stylize.sheets.Sheets.keep_to_own`).
        Raises ValueError where a stencil leaves the band.
        """
        if normals is not None:
            normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
            if len(normals) != len(x):
                raise ValueError(f"normals must have shape ({len(x)}, 3), got {normals.shape}")
        if pieces is not None and self.pieces is None:
            raise ValueError("pieces apply to bands of triangle meshes only")
        return _interpolation_matrix(self, x, _float_type(dtype), normals, pieces)

    def interpolate(self, values, x, normals=None, pieces=None):
        """Values at surface points ``x`` (M, 3) interpolated from band ``values`` (N,) or (N, k);
        ``normals`` and ``pieces`` as for :meth:`interpolation_matrix`."""
        values = self.check_values(values)
        return apply(self.interpolation_matrix(x, values.dtype, normals, pieces), values)

    def extension_matrix(self, dtype=np.float32):
        """The extension matrix E (N, N) in ``dtype`` (float32 or float64)."""
        return self._matrix("E", dtype)

    def extend(self, w):
        """Closest point extension ``E w``: interpolate ``w`` at every band point's closest point.

        ``w`` has shape (N,) or (N, k); float64 stays float64, other types become float32.
        """
        w = self.check_values(w)
        return apply(self.split_matrix("E", w.dtype), w)

    def split_matrix(self, name, dtype=np.float32):
        """E (``"E"``) or L (``"L"``) as a :class:`~cp_stylize.sparse.SplitMatrix`, whose products use all cores."""
        key = ("split", name, _float_type(dtype))
        if key not in self._matrices:
            self._matrices[key] = SplitMatrix(self._matrix(name, dtype))
        return self._matrices[key]

    # -- finite differences -------------------------------------------------

    def laplacian_matrix(self, dtype=np.float32):
        """The 7-point Laplacian L (N, N) in ``dtype``.

        Rows of points whose stencil leaves the band are zero; ``E`` never reads
        those points (asserted when the band is built).
        """
        return self._matrix("L", dtype)

    def laplacian(self, v):
        """``L v`` for band values ``v`` (N,) or (N, k)."""
        v = self.check_values(v)
        return apply(self.laplacian_matrix(v.dtype), v)

    def _matrix(self, name, dtype):
        dtype = _float_type(dtype)
        key = (name, dtype)
        if key not in self._matrices:
            if name == "E":
                m = (self.E if dtype == self.E.dtype
                     else _interpolation_matrix(self, self.cp, dtype, self.normals, self.pieces))
            else:
                m = self._build_laplacian(dtype)
            self._matrices[key] = m
        return self._matrices[key]

    def _build_laplacian(self, dtype):
        offsets = STENCILS["laplacian"]
        nbr = self.neighbors(offsets)
        full = np.all(nbr >= 0, axis=1)
        k = len(offsets)
        counts = np.where(full, k, 0)
        indptr = np.concatenate([[0], np.cumsum(counts)])
        coef = np.full((int(full.sum()), k), 1.0 / self.h**2)
        coef[:, 0] = -(k - 1) / self.h**2
        cut = self.cut_links(nbr[full, 1:], full)
        if cut is not None and cut.any():
            coef[:, 1:][cut] = 0.0
            coef[:, 0] = -coef[:, 1:].sum(axis=1)
        data = coef.astype(dtype).ravel()
        L = sp.csr_matrix((data, nbr[full].ravel().astype(self.E.indices.dtype), indptr), shape=(self.size, self.size))
        L.sort_indices()  # canonical: products sum each row in column order, whatever touched L before
        return L

    def _check_stencils(self):
        """Every point E reads must have its whole finite difference stencil in the band."""
        offsets = stencil_offsets(self.stencil)
        nbr = self.neighbors(offsets)
        self._stencil_table = (offsets, nbr)
        bad = self.inner & np.any(nbr < 0, axis=1)
        if bad.any():
            raise RuntimeError(
                f"{int(bad.sum())} interpolation stencil point(s) lack {self.stencil} neighbours "
                f"in the band of width {self.width:.4g}; increase the safety factor"
            )

    def check_values(self, v):
        """Band values ``v`` (N,) or (N, k) as an array of float32, or float64 if given so; ValueError otherwise."""
        v = np.asarray(v)
        if v.ndim not in (1, 2) or v.shape[0] != self.size:
            raise ValueError(f"band values must have shape ({self.size},) or ({self.size}, k), got {v.shape}")
        return v.astype(_float_type(v.dtype), copy=False)


def _interpolation_matrix(band, x, dtype, normals=None, pieces=None, moved=None):
    """The (M, N) matrix of :meth:`Band.interpolation_matrix` at points ``x`` (M, 3) in ``dtype``;
    ``moved`` (a list) gets the number of rows each block kept to their own sheet."""
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"interpolation points must have shape (M, 3), got {x.shape}")
    p = band.degree
    n_w = (p + 1) ** 3
    g = x / band.h
    base = np.floor(g).astype(np.int64) - (p - 1) // 2
    nodes = np.array(list(itertools.product(range(p + 1), repeat=3)), dtype=np.int64)
    node_flat = band._flat(nodes).astype(band._index.dtype)
    index = band._index.ravel()
    indices = np.empty((len(x), n_w), dtype=index.dtype)
    data = np.empty((len(x), n_w), dtype=dtype)

    def chunk(s):
        e = min(s + _CHUNK, len(x))
        w = [lagrange_weights(g[s:e, a] - base[s:e, a], p) for a in range(3)]
        # tensor product, last axis fastest: the order of ``nodes``
        data[s:e] = (w[0][:, :, None, None] * w[1][:, None, :, None] * w[2][:, None, None, :]).reshape(e - s, n_w)
        rel = base[s:e] - band._lo
        inside = np.all((rel >= 0) & (rel + p < band._shape), axis=1)
        corner = np.where(inside, band._flat(rel), 0).astype(index.dtype)
        np.take(index, corner[:, None] + node_flat[None, :], out=indices[s:e])
        indices[s:e][~inside] = -1
        if normals is not None and band.sheets is not None:
            n = band.sheets.keep_to_own(data[s:e], indices[s:e], x[s:e], g[s:e] - np.floor(g[s:e]), nodes,
                                        normals[s:e], None if pieces is None else pieces[s:e], corner)
            if moved is not None:
                moved.append(n)     # list.append is atomic: the chunks run on several threads

    map_parallel(chunk, range(0, len(x), _CHUNK))
    if len(x) and indices.min() < 0:
        rows = np.flatnonzero((indices < 0).any(axis=1))
        raise ValueError(
            f"{len(rows)} interpolation point(s) have stencil points outside the band "
            f"(first at {x[rows[0]].tolist()}): interpolate only at points on the surface"
        )
    indptr = np.arange(0, n_w * len(x) + 1, n_w, dtype=np.int64)
    return sp.csr_matrix((data.ravel(), indices.ravel(), indptr), shape=(len(x), band.size))
