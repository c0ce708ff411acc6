"""Oil paint: anisotropic Kuwahara filtering on the surface.

Kyprianidis, Kang and Döllner, "Image and video abstraction by anisotropic
Kuwahara filtering" (2009).  Around each point, an ellipse is laid along the
picture's structure (the structure tensor's directions on the surface; the
longer axis along the edges, stretched by how coherent the structure is) and
cut into :data:`SECTORS` overlapping sectors.  Each sector gives its mean
colour and how much the colours in it vary; the output mixes the means,
weighted by ``1 / (1 + variation)^q``, so that the sectors that lie within one
region of colour win: regions flatten, and their edges stay sharp where a
blur would smear them.

On the surface, the ellipse lies in the tangent plane at the point's closest
point and its samples read the band's nearest grid node, on the point's own
sheet.  So neighbourhoods are taken on the surface: they cross UV seams and
islands unbroken, and the poles of a sphere are like any other place.

Two steps, so that the edges are as sharp as the output image's texels and
not the band's grid:

1. :func:`sector_statistics` at the band's nodes: each sector's mean colour
   and variation (smooth functions of space, so interpolating them is fine);
2. :class:`Kuwahara`, at the bake-out (``paint=`` of
   :func:`cp_stylize.baking.bake_to_atlas`): the statistics interpolated at
   each texel's surface point, and the sectors weighed there.

:func:`kuwahara` does both at the band's nodes, for band values in, band
values out.
"""

from __future__ import annotations

import numpy as np

from .smoothing import GridGaussian, taper
from .sparse import map_parallel

__all__ = ["sector_statistics", "Kuwahara", "kuwahara", "sharpness_power", "SECTORS", "MIN_RADIUS"]

#: Sectors of the ellipse (the paper's N).
SECTORS = 8
#: Samples of the ellipse: rings from its centre out, and angles on each ring.
RINGS, ANGLES = 4, 24
#: How much neighbouring sectors overlap: each sector's weight at angle ``phi`` from its middle is
#: ``exp(OVERLAP (cos phi - 1))`` before the sectors' weights are made to sum to 1.
OVERLAP = 6.0
#: The Gaussian fall-off of the samples' weights over the ellipse, as a share of its radius.
FALLOFF = 0.45
#: The smallest radius, in grid spacings: a smaller ellipse would read the same few nodes in every sector.
MIN_RADIUS = 2.0
#: A colour's variation is weighed as if colours ran from 0 to this (the paper's images run to 255).
LEVELS = 255.0
#: Band nodes a block of the sampling takes at once.
_BLOCK = 8192


def sharpness_power(sharpness):
    """The paper's exponent q for a Sharpness in [0, 1], as Blender's Kuwahara node names it: 1 (a plain
    average of the sectors) at 0, the paper's 8 at 0.5, 15 at 1."""
    return 1.0 + 14.0 * float(sharpness)


def _pattern():
    """The ellipse's samples in the unit disc (K, 2) and each sector's weight of each (S, K), summing to 1
    over a sector."""
    rings = np.arange(1, RINGS + 1) / RINGS
    angles = np.arange(ANGLES) * 2.0 * np.pi / ANGLES
    r, a = np.meshgrid(rings, angles, indexing="ij")
    uv = np.vstack([[0.0, 0.0], np.column_stack([(r * np.cos(a)).ravel(), (r * np.sin(a)).ravel()])])
    area = np.r_[0.25 * np.pi / RINGS**2, r.ravel() / RINGS * 2.0 * np.pi / ANGLES]   # polar area of each
    weight = np.exp(-np.sum(uv**2, axis=1) / (2.0 * FALLOFF**2)) * area
    middles = np.arange(SECTORS) * 2.0 * np.pi / SECTORS
    share = np.exp(OVERLAP * (np.cos(np.arctan2(uv[:, 1], uv[:, 0])[None, :] - middles[:, None]) - 1.0))
    share[:, 0] = 1.0                                            # the centre belongs to every sector
    share /= share.sum(axis=0, keepdims=True)
    sectors = share * weight[None, :]
    return uv, (sectors / sectors.sum(axis=1, keepdims=True)).astype(np.float32)


def _axes(band, values, radius, eccentricity):
    """The ellipse's axes at the band's nodes: along the structure (N, 3) and across it (N, 3), each as
    long as its half axis."""
    from .structure import along_structure, grid_gradients, products
    from .tangent import tangent_basis

    J = products(np.ascontiguousarray(values.T), grid_gradients(band, np.float32))
    basis = tangent_basis(band)                                  # (N, 3, 2)
    q0, q1 = np.ascontiguousarray(basis.transpose(2, 1, 0), dtype=np.float32)
    smoothing = GridGaussian(band, 0.5 * (0.5 * radius) ** 2, weights=taper(band.dist, 3.0 * band.h))
    along, _, coherence = along_structure(smoothing(J), q0, q1)
    along = along.astype(np.float64)
    across = np.cross(np.cross(basis[:, :, 0], basis[:, :, 1]), along)
    stretch = 1.0 + eccentricity * coherence                     # the paper's (alpha + A) / alpha, alpha = 1 / e
    return along * (radius * stretch)[:, None], across * (radius / stretch)[:, None]


def sector_statistics(band, values, radius, eccentricity=1.0, *, rows=None):
    """Each sector's mean colour and variation in an ellipse along the structure of band ``values``.

    Parameters
    ----------
    band : Band
    values : ndarray (N, C) or (N,)
        Band values (a closest point extension).
    radius : float
        The ellipse's radius where the structure has no direction (at least :data:`MIN_RADIUS` grid
        spacings are taken).
    eccentricity : float in [0, 2]
        How far the ellipse stretches along a coherent structure (0: a circle everywhere).
    rows : ndarray of bool (N,), optional
        The nodes to compute (the others get 0); all by default.

    Returns
    -------
    ndarray (N, S * (C + 1)), float32
        For each of the :data:`SECTORS` sectors, its mean (C) then the sum of its channels' variances.
    """
    values = np.asarray(band.check_values(values), dtype=np.float32).reshape(band.size, -1)
    channels = values.shape[1]
    radius = max(float(radius), MIN_RADIUS * band.h)
    along, across = _axes(band, values, radius, float(eccentricity))
    uv, sectors = _pattern()
    out = np.zeros((band.size, SECTORS, channels + 1), dtype=np.float32)
    todo = np.arange(band.size) if rows is None else np.flatnonzero(rows)
    pieces = band.pieces

    def block(start):
        nodes = todo[start:start + _BLOCK]
        where = (band.cp[nodes][:, None, :] + uv[None, :, 0, None] * along[nodes][:, None, :]
                 + uv[None, :, 1, None] * across[nodes][:, None, :])
        found = band.nearest(where)                             # (M, K)
        ok = found >= 0
        if pieces is not None:                                  # on the node's own sheet only
            ok &= pieces[np.maximum(found, 0)] == pieces[nodes][:, None]
        found = np.where(ok, found, 0)
        x = values[found] * ok[:, :, None]                      # (M, K, C)
        weight = sectors[None, :, :] * ok[:, None, :]           # (M, S, K)
        total = np.maximum(weight.sum(axis=2), 1e-12)[:, :, None]
        mean = np.einsum("msk,mkc->msc", weight, x) / total
        square = np.einsum("msk,mkc->msc", weight, x * x) / total
        out[nodes, :, :channels] = mean
        out[nodes, :, channels] = np.maximum(square - mean * mean, 0.0).sum(axis=2)

    map_parallel(block, range(0, len(todo), _BLOCK))
    return out.reshape(band.size, -1)


def _mixed(statistics, channels, power):
    """The sectors' means (M, C) weighed by their variation, from :func:`sector_statistics` rows."""
    s = np.asarray(statistics, dtype=np.float32).reshape(len(statistics), SECTORS, channels + 1)
    deviation = np.sqrt(np.maximum(s[:, :, channels], 0.0))
    weight = (1.0 + LEVELS * deviation) ** -float(power)
    weight /= weight.sum(axis=1, keepdims=True)
    return np.einsum("ms,msc->mc", weight, s[:, :, :channels])


class Kuwahara:
    """The oil paint laid at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): the
    sector statistics (``columns``, band columns the bake-out interpolates at each texel) weighed at
    each texel, so that region edges are as sharp as the texels.  Leaves no height."""

    def __init__(self, band, values, radius, sharpness=0.5, eccentricity=1.0):
        values = np.asarray(values).reshape(band.size, -1)
        self.channels = values.shape[1]
        self.power = sharpness_power(sharpness)
        # the texels read the nodes the closest point extension reads: those are enough
        self.columns = sector_statistics(band, values, radius, eccentricity, rows=band.inner)

    def __call__(self, texels, colours, read, progress=None):
        mixed = _mixed(read, self.channels, self.power).astype(np.asarray(colours).dtype)
        if progress is not None:
            progress(1.0)
        return mixed, None


def kuwahara(band, values, radius, sharpness=0.5, eccentricity=1.0):
    """Band ``values`` (N, C) or (N,) after anisotropic Kuwahara filtering at the band's nodes (see the
    module's notes): regions of like colour flattened, their edges kept."""
    values = np.asarray(values)
    flat = values.reshape(band.size, -1)
    stats = sector_statistics(band, flat, radius, eccentricity)
    return _mixed(stats, flat.shape[1], sharpness_power(sharpness)).astype(np.float32).reshape(values.shape)
