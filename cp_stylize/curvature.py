"""Principal curvatures and directions from the closest point representation.

The normal field ``n(x) = n(cp(x))`` is constant along the normals, so its
derivative at a band point ``x`` a signed distance ``d`` off the surface is
``W (I + d W)^{-1}``, with ``W`` the shape operator (Weingarten map) at
``cp(x)``: symmetric, tangent, with the principal curvatures ``k`` as
eigenvalues at ``d = 0`` and ``k / (1 + d k)`` off it.  Differences of the
band's normals over the grid give it at every band point; the closest point
extension then reads it at the closest point, where ``d = 0``, to the order
of the interpolation.

The derivative is taken of ``n n^T`` (which does not care how ``n`` is
oriented) and contracted with the point's own normal,
``D n = D(n n^T) n``, so that a neighbour's orientation cannot spoil the
difference; the curvatures then have the sign of the normals given
(outward normals: ``1 / R`` on a sphere of radius ``R``).

Principal directions are line fields: ``e`` and ``-e`` are the same
direction, and a use of them must not depend on the sign.  At umbilics
(spheres, flat parts) every tangent direction is principal; the
``confidence`` ``|k1 - k2| / (|k1| + |k2|)`` says how well a direction is
defined (0 at umbilics, 1 where one curvature vanishes or they have
opposite signs).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .heat_flow import heat_rows
from .stencils import TENSOR_COMPONENTS
from .structure import eigen_2x2, reduce_to_tangent
from .tangent import GridDifferences, householder_basis, surface_normals, symmetric_rows

__all__ = ["Curvature", "principal_curvatures"]

_CHUNK = 1 << 16


@dataclasses.dataclass(frozen=True)
class Curvature:
    """Principal curvatures and directions at the band's closest points."""

    k1: np.ndarray           # (N,) the larger principal curvature
    k2: np.ndarray           # (N,) the smaller one
    e1: np.ndarray           # (N, 3) unit tangent direction of k1 (a line field: the sign is arbitrary)
    e2: np.ndarray           # (N, 3) unit tangent direction of k2, e2 = n x e1
    normals: np.ndarray      # (N, 3) the unit normals used
    confidence: np.ndarray   # (N,) |k1 - k2| / (|k1| + |k2|) in [0, 1]; 0 where k1 = k2

    def direction(self, which):
        """``"max"`` (e1) or ``"min"`` (e2)."""
        if which not in ("max", "min"):
            raise ValueError(f"which must be 'max' or 'min', got {which!r}")
        return self.e1 if which == "max" else self.e2


def principal_curvatures(band, normals=None, *, smooth=0.0):
    """Principal curvatures and directions (:class:`Curvature`) at every band point's closest point.

    Parameters
    ----------
    band : Band
        Any band: analytic surface or triangle mesh.
    normals : None or ndarray (N, 3)
        Consistently oriented unit normals at the closest points; by default
        the surface's own (:func:`cp_stylize.tangent.surface_normals`).  The
        curvatures take their sign from them.
    smooth : float
        Surface heat flow time applied to the shape operator's components
        before its eigen-decomposition (0: none).  On triangle meshes, whose
        interpolated normals bend face by face, a time of a few ``h^2``
        evens the field out.

    Notes
    -----
    Second order in ``h`` on smooth surfaces: central differences of the
    normals, read at the closest point by the band's interpolation.
    """
    if isinstance(normals, str):
        raise ValueError("principal_curvatures needs consistently oriented normals: None or an (N, 3) array")
    n = surface_normals(band, normals)
    smooth = float(smooth)
    if not np.isfinite(smooth) or smooth < 0:
        raise ValueError(f"smooth must be a non-negative number, got {smooth!r}")
    lines = symmetric_rows(n[:, :, None] * n[:, None, :])
    differences = GridDifferences(band)
    shape = np.empty((band.size, 6))
    for s in range(0, band.size, _CHUNK):
        e = min(s + _CHUNK, band.size)
        D = differences(lines, s, e)                        # (k, 6, 3): d (n n^T)_c / d x_a
        full = np.empty((e - s, 3, 3, 3))
        for c, (i, j) in enumerate(TENSOR_COMPONENTS):
            full[:, i, j] = full[:, j, i] = D[:, c]
        W = np.einsum("nika,nk->nia", full, n[s:e])          # D n = D(n n^T) n
        shape[s:e] = symmetric_rows(0.5 * (W + W.transpose(0, 2, 1)))
    shape = band.extend(shape)
    if smooth > 0:
        rows = np.ascontiguousarray(shape.T)
        heat_rows(band, rows, smooth)
        shape = rows.T
    Q = householder_basis(n)
    q0, q1 = Q[:, :, 0].T, Q[:, :, 1].T
    a, b, d = reduce_to_tangent(np.ascontiguousarray(shape.T), q0, q1)
    k1, k2, c, s = eigen_2x2(a, b, d)
    e1 = c[:, None] * Q[:, :, 0] + s[:, None] * Q[:, :, 1]
    e2 = np.cross(n, e1)
    total = np.abs(k1) + np.abs(k2)
    confidence = np.where(total > 0, (k1 - k2) / np.where(total > 0, total, 1.0), 0.0)
    return Curvature(k1, k2, e1, e2, n, np.clip(confidence, 0.0, 1.0))
