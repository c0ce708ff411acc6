"""Normals and tangent space bases at the band's closest points (paper, section 3.2).

Two routes give the orthonormal tangent basis ``Q = [q1 | q2]`` (N, 3, 2):

- from given unit normals, by one Householder reflection (paper, eq. (31));
- from the Jacobian of the closest point function, whose value at a surface
  point is the tangent projector ``I - n n^T`` (eqs. (32)-(33)): its
  eigenvector of the eigenvalue 0 is the normal.

At a band point ``x`` the Jacobian is estimated by central differences of the
closest points of its grid neighbours; its null direction is the normal at
``cp(x)``.  Points without all six neighbours in the band lie far enough from
the surface (more than ``2 h``) that ``(x - cp(x)) / dist`` is the normal at
``cp(x)`` to rounding accuracy, and that is used there.
"""

from __future__ import annotations

import numpy as np

from .band import STENCILS

__all__ = ["householder_basis", "jacobian_normals", "surface_normals", "tangent_basis"]


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


def jacobian_normals(band):
    """Unit normals (N, 3) at the band's closest points from the Jacobian of ``cp`` (eqs. (32)-(33))."""
    nbr = band.neighbors(STENCILS["laplacian"][1:])  # +x, +y, +z, -x, -y, -z
    full = np.all(nbr >= 0, axis=1)
    normals = np.empty((band.size, 3))
    far = band.points[~full] - band.cp[~full]
    dist = np.linalg.norm(far, axis=1)
    if np.any(dist < 1.5 * band.h):
        raise RuntimeError("a band point near the surface lacks grid neighbours; the band is too thin")
    normals[~full] = far / dist[:, None]
    idx = nbr[full]
    # D cp[:, a] = (cp(x + h e_a) - cp(x - h e_a)) / 2h, symmetrised: the projector I - n n^T
    D = (band.cp[idx[:, :3]] - band.cp[idx[:, 3:]]).transpose(0, 2, 1) / (2.0 * band.h)
    D = 0.5 * (D + D.transpose(0, 2, 1))
    _, vectors = np.linalg.eigh(D)
    normals[full] = vectors[:, :, 0]  # eigenvalue closest to 0: eigh sorts ascending
    # orient consistently with (x - cp) where that is well defined, else keep the sign
    offset = band.points - band.cp
    flip = np.einsum("ij,ij->i", normals, offset) < 0
    normals[flip] *= -1.0
    return normals


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
        normal = getattr(band.surface, "normal", None)
        if normal is None:
            return jacobian_normals(band)
        if band.face is not None:
            return np.asarray(normal(band.cp, face=band.face), dtype=np.float64)
        return np.asarray(normal(band.cp), dtype=np.float64)
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
