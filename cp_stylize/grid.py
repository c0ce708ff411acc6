"""The uniform grid a band lives on: its stencils, how wide the band must be, and interpolation weights.

Band width
----------
An interpolation stencil of degree ``p`` reaches ``(p + 1) / 2`` grid spacings
from the interpolation point along each axis, and a finite difference stencil
with offsets ``o`` reaches further by ``|o_a|`` along axis ``a``.  Every grid
point that the time step reads therefore lies within

.. math:: w = h \\max_o \\sqrt{\\sum_a ((p + 1)/2 + |o_a|)^2}

of a surface point.  For the 7-point stencil in 3-D this is the
Ruuth-Merriman/Macdonald rule ``sqrt((d-1)((p+1)/2)^2 + (s+(p+1)/2)^2) h``
with ``s = 1``, ``d = 3``, ``p = 3``: ``sqrt(17) h``.  The 19-point stencil of
the anisotropic scheme (paper, eq. (51)) reads diagonal neighbours and needs
``sqrt(22) h``.  The band uses ``w`` times a small safety factor, and
:meth:`cp_stylize.band.Band.build` asserts that every point the stencils read is in the band.
"""

from __future__ import annotations

import itertools

import numpy as np

__all__ = ["STENCILS", "DEGREE", "band_width", "estimate_band_size", "tube_points", "stencil_offsets",
           "lagrange_weights", "flat_index", "candidates"]

_AXES = np.eye(3, dtype=np.int64)

#: Finite difference stencils by name: the grid offsets each one reads.
STENCILS = {
    "laplacian": np.vstack([np.zeros((1, 3), np.int64), _AXES, -_AXES]),
    "anisotropic": np.array(
        [o for o in itertools.product((-1, 0, 1), repeat=3) if sum(map(abs, o)) <= 2], dtype=np.int64
    ),
}

#: The degree of the interpolation that extends band values (tricubic).
DEGREE = 3
#: Grid points a candidate chunk of :func:`candidates` holds, about.
_CHUNK = 1 << 17


def band_width(h, degree=DEGREE, stencil="laplacian"):
    """Distance from the surface within which the band must hold every grid point.

    Parameters
    ----------
    h : float
        Grid spacing.
    degree : int
        Odd degree ``p`` of the interpolation polynomial.
    stencil : str
        A key of :data:`STENCILS`.

    Returns
    -------
    float
        ``h * max_o sqrt(sum_a ((p + 1)/2 + |o_a|)^2)``, without safety factor.
    """
    offsets = stencil_offsets(stencil)
    half = (degree + 1) / 2.0
    return float(h * np.sqrt(((half + np.abs(offsets)) ** 2).sum(axis=1)).max())


def estimate_band_size(area, h, *, stencil="laplacian", degree=DEGREE, safety=1.01):
    """Expected number of band points around a surface of the given area.

    Weyl's tube formula: a band of half-width ``w`` about a closed surface has
    volume ``2 w A + (4 pi / 3) w^3 chi``; the curvature term is small where
    ``w`` is small next to the surface's features and is left out here.
    """
    area, h = float(area), float(h)
    if not np.isfinite(area) or area < 0:
        raise ValueError(f"area must be a non-negative number, got {area!r}")
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"grid spacing h must be a positive number, got {h!r}")
    return int(round(tube_points(area, h, band_width(h, degree, stencil) * safety)))


def tube_points(area, h, width):
    """Grid points of spacing ``h`` within ``width`` of a surface of the given area, about: the leading term of
    Weyl's tube formula (:func:`estimate_band_size`), ``2 width area / h^3``."""
    return 2.0 * width * area / h**3


def stencil_offsets(stencil):
    """The grid offsets (K, 3) the finite difference stencil ``stencil`` reads (a key of :data:`STENCILS`)."""
    try:
        return STENCILS[stencil]
    except KeyError:
        raise ValueError(f"stencil must be one of {sorted(STENCILS)}, got {stencil!r}") from None


def lagrange_weights(t, degree=DEGREE):
    """Lagrange basis weights on the nodes ``0, 1, ..., degree`` at positions ``t``.

    Parameters
    ----------
    t : ndarray, shape (M,)
        Positions in units of the grid spacing, relative to node 0.

    Returns
    -------
    ndarray, shape (M, degree + 1)
    """
    t = np.asarray(t, dtype=np.float64)
    nodes = np.arange(degree + 1)
    w = np.ones(t.shape + (degree + 1,))
    for j in nodes:
        for m in nodes:
            if m != j:
                w[..., j] *= (t - m) / (j - m)
    return w


def flat_index(rel, shape):
    """Flat positions in a C-ordered volume of ``shape`` of integer coordinates ``rel`` (..., 3)."""
    return (rel[..., 0] * shape[1] + rel[..., 1]) * shape[2] + rel[..., 2]


def candidates(surface, h, width):
    """Integer grid coordinates of the surface's grown bounding box, in chunks."""
    lo, hi = (np.asarray(b, dtype=np.float64) for b in surface.bounds())
    imin = np.floor((lo - width) / h).astype(np.int64)
    imax = np.ceil((hi + width) / h).astype(np.int64)
    ii = np.arange(imin[0], imax[0] + 1)
    jj = np.arange(imin[1], imax[1] + 1)
    per_slab = max(1, _CHUNK * 8 // (len(ii) * len(jj)))
    for k0 in range(imin[2], imax[2] + 1, per_slab):
        kk = np.arange(k0, min(k0 + per_slab, imax[2] + 1))
        grid = np.stack(np.meshgrid(ii, jj, kk, indexing="ij"), axis=-1).reshape(-1, 3)
        yield grid
