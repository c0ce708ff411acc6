"""Normals and tangent space bases at the band's closest points (paper, section 3.2).

Two routes give the orthonormal tangent basis ``Q = [q1 | q2]`` (N, 3, 2):

- from given unit normals, by one Householder reflection (paper, eq. (31));
- from the Jacobian of the closest point function, whose value at a surface
  point is the tangent projector ``I - n n^T`` (eqs. (32)-(33)): its
  eigenvector of the eigenvalue 0 is the normal.

At a band point ``x`` the Jacobian is estimated by differences of the closest
points of its grid neighbours; its null direction is the normal at ``cp(x)``
(see :func:`jacobian_normals`).
"""

from __future__ import annotations

import numpy as np

from .arrays import unit_rows
from .stencils import TENSOR_COMPONENTS

__all__ = ["householder_basis", "jacobian_normals", "surface_normals", "tangent_basis", "GridDifferences",
           "symmetric_rows", "symmetric_matrices"]

_CHUNK = 1 << 16


def householder_basis(normals):
    """Tangent bases (N, 3, 2) from unit normals (N, 3) by one Householder reflection (eq. (31)).

    The reflection ``H = I - 2 v v^T / (v^T v)`` with ``v = n + sign(n_1) e_1``
    maps ``e_1`` to ``-sign(n_1) n``; its second and third columns are
    orthonormal and orthogonal to ``n``.
    """
    n = np.asarray(normals, dtype=np.float64)
    if n.ndim != 2 or n.shape[1] != 3:
        raise ValueError(f"normals must have shape (N, 3), got {n.shape}")
    length = np.linalg.norm(n, axis=1)
    if not np.all(np.isfinite(length)) or np.any(length < 1e-12):
        raise ValueError("normals must be finite and non-zero")
    n = n / length[:, None]
    v = n.copy()
    v[:, 0] += np.where(n[:, 0] >= 0, 1.0, -1.0)
    vv = np.einsum("ij,ij->i", v, v)
    # columns 1 and 2 of H = I - 2 v v^T / (v^T v)
    H = np.eye(3)[None, :, 1:] - 2.0 * v[:, :, None] * v[:, None, 1:] / vv[:, None, None]
    return H


def jacobian_normals(band, *, extend=True):
    """Unit normals (N, 3) at the band's closest points from the Jacobian of ``cp`` (eqs. (32)-(33)).

    At a surface point the Jacobian of the closest point function is the
    tangent projector ``D cp = I - n n^T`` (eq. (33)); off the surface it
    still maps the normal to zero.  ``D cp`` at each band point is estimated
    by central differences of ``band.cp`` over the grid neighbours along
    each axis (one-sided where one neighbour is missing), symmetrised, and
    its eigenvector of the eigenvalue nearest zero is the normal there.

    Parameters
    ----------
    band : Band
        Any band (analytic surface or mesh).
    extend : bool
        Replace each estimate by the closest point extension of the field:
        ``E`` applied to the six components of ``n n^T`` (an orientation-free
        line field), then the leading eigenvector.  Every band point then
        carries the normal estimated near its closest point, where the
        estimate is best.

    Returns
    -------
    ndarray, shape (N, 3)
        Unit normals, oriented along ``x - cp(x)`` where ``x`` is off the
        surface.

    Notes
    -----
    Where an axis has neither neighbour in the band the point lies near the
    band's edge, at least ``width - h`` from the surface, and
    ``(x - cp) / |x - cp|`` is used.  On a mesh ``cp`` is only piecewise
    smooth (planar over face regions, linear over edge regions), and
    differences taken far from the surface mix those pieces; on a sphere of
    16k triangles the raw estimate is within about 1 degree of the exact
    normal within ``h`` of the surface but up to 9 degrees at the band's
    edge, and the extended one within 1 degree everywhere.
    """
    differences = GridDifferences(band)
    normals = np.empty((band.size, 3))
    for s in range(0, band.size, _CHUNK):
        e = min(s + _CHUNK, band.size)
        D = differences(band.cp, s, e)
        values, vectors = np.linalg.eigh(0.5 * (D + D.transpose(0, 2, 1)))
        nearest = np.argmin(np.abs(values), axis=1)
        n = np.take_along_axis(vectors, nearest[:, None, None], axis=2)[:, :, 0]
        lost = differences.lost(s, e)
        if lost.any():
            off, length = unit_rows(band.points[s:e][lost] - band.cp[s:e][lost])
            if np.any(length < 0.5 * band.h):
                raise RuntimeError("a band point near the surface lacks grid neighbours; the band is too thin")
            n[lost] = off
        normals[s:e] = n
    if extend:
        lines = band.extend(symmetric_rows(normals[:, :, None] * normals[:, None, :]).astype(np.float32))
        for s in range(0, band.size, _CHUNK):
            e = min(s + _CHUNK, band.size)
            normals[s:e] = np.linalg.eigh(symmetric_matrices(lines[s:e], np.float64))[1][:, :, 2]
    offset = band.points - band.cp
    flip = np.einsum("ij,ij->i", normals, offset) < 0
    normals[flip] *= -1.0
    return normals


class GridDifferences:
    """Derivatives of band functions along the grid axes, by differences of grid neighbours.

    Central differences where both neighbours along an axis are in the band,
    one-sided where one is, zero where neither is (:meth:`lost` says where).
    """

    def __init__(self, band):
        axes = np.eye(3, dtype=np.int64)
        self.plus, self.minus, self.h = band.neighbors(axes), band.neighbors(-axes), band.h

    def __call__(self, values, s, e):
        """``d values_k / d x_a`` (e - s, k, 3) at band points ``s:e`` of ``values`` (N, k)."""
        rows = np.arange(s, e)
        p, m = self.plus[s:e], self.minus[s:e]
        D = np.empty((e - s, values.shape[1], 3))
        for a in range(3):
            hi = np.where(p[:, a] >= 0, p[:, a], rows)
            lo = np.where(m[:, a] >= 0, m[:, a], rows)
            span = self.h * ((p[:, a] >= 0).astype(np.float64) + (m[:, a] >= 0))
            D[:, :, a] = (values[hi] - values[lo]) / np.where(span > 0, span, 1.0)[:, None]
        return D

    def lost(self, s, e):
        """Band points ``s:e`` with an axis along which neither neighbour is in the band."""
        return ~np.all((self.plus[s:e] >= 0) | (self.minus[s:e] >= 0), axis=1)


def symmetric_rows(M):
    """The six components (N, 6) of symmetric matrices (N, 3, 3), in ``TENSOR_COMPONENTS`` order."""
    return np.column_stack([M[:, a, b] for a, b in TENSOR_COMPONENTS])


def symmetric_matrices(rows, dtype=None):
    """Symmetric matrices (N, 3, 3) from their six components (N, 6); see :func:`symmetric_rows`."""
    M = np.empty((len(rows), 3, 3), dtype=rows.dtype if dtype is None else dtype)
    for k, (a, b) in enumerate(TENSOR_COMPONENTS):
        M[:, a, b] = M[:, b, a] = rows[:, k]
    return M


def surface_normals(band, normals=None):
    """Unit normals (N, 3) at the band's closest points.

    Parameters
    ----------
    band : Band
    normals : None, "jacobian" or ndarray (N, 3)
        None uses the surface's own ``normal`` (analytic for Sphere and Torus,
        interpolated for meshes that provide it) and falls back to the
        Jacobian of the closest point function; "jacobian" forces the latter;
        an array is taken as given.
    """
    if normals is None:
        # the surface's own normals, which the band keeps (read-only) to tell its sheets apart
        return jacobian_normals(band) if band.normals is None else band.normals
    if isinstance(normals, str):
        if normals != "jacobian":
            raise ValueError(f"normals must be None, 'jacobian' or an (N, 3) array, got {normals!r}")
        return jacobian_normals(band)
    normals = np.asarray(normals, dtype=np.float64)
    if normals.shape != (band.size, 3):
        raise ValueError(f"normals must have shape ({band.size}, 3), got {normals.shape}")
    return normals


def tangent_basis(band, normals=None):
    """Orthonormal tangent bases Q (N, 3, 2) at the band's closest points; see :func:`surface_normals`."""
    return householder_basis(surface_normals(band, normals))
