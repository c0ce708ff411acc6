"""Fast surface smoothing on the band: normalised 3-D Gaussians.

Heat flow to time ``t`` on a surface blurs with a Gaussian of standard
deviation ``sqrt(2 t)``.  For a closest point extension ``v(x) = u(cp(x))``,
which is constant along the surface's normals, a 3-D Gaussian of that width
restricted to the surface is the surface Gaussian up to terms of relative size
``(sqrt(2 t) kappa)^2`` (kappa a principal curvature).  The band is a thin
shell, so the Gaussian is taken as a normalised convolution,

.. math:: S[v] = \frac{G * (m v)}{G * m},

with ``m`` the weights of the points that carry data: the points outside the
band (or without data) are left out, constants stay constant and no value
leaves the range of the data.  Weights that fall smoothly to zero away from
the surface (:func:`taper`) weigh every direction along the surface alike; a
cut-off mask follows the grid's staircase and pulls the averages sideways.

Two implementations:

- :class:`GaussianSmoother`: three sparse passes along the grid axes inside
  the band, ``2 ceil(3 sqrt(2 t) / h) + 1`` products a point and pass.  Cheap
  for narrow kernels; a pass only sees the band points on its line, which
  skews wide kernels.
- :class:`GridGaussian`: the data summed into a box grid up to four times
  coarser, blurred there, read back by trilinear interpolation.  Every path of
  the 3-D kernel is there, and the coarse grid makes wide kernels cheap.

The fast scheme of :func:`cp_stylize.diffuse` smooths the image (``sigma``)
with the first and the structure tensor (``rho``) with the second, instead of
``t / (0.15 h^2)`` closest point heat steps each.
"""

from __future__ import annotations

import copy
import itertools
import math

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from .grid import flat_index
from .sparse import SplitMatrix, map_parallel

__all__ = ["GaussianSmoother", "GridGaussian", "gaussian_taps", "taper"]

#: Kernels are cut at this many standard deviations.
TRUNCATE = 3.0


def gaussian_taps(std, truncate=TRUNCATE):
    """Offsets and weights (summing to 1) of a sampled Gaussian of ``std`` grid cells."""
    radius = max(1, int(math.ceil(truncate * std)))
    offsets = np.arange(-radius, radius + 1)
    weights = np.exp(-0.5 * (offsets / std) ** 2)
    return offsets, weights / weights.sum()


class GaussianSmoother:
    """Approximates the surface heat flow to time ``t`` on band values.

    Parameters
    ----------
    band : Band
    t : float
        Heat time (squared surface units); the Gaussian's deviation is ``sqrt(2 t)``.
    weights : ndarray (N,), optional
        Non-negative weight of each point's data (default all 1); points of
        weight 0 carry no data.
    dtype : float32 or float64
    neighbours : dict, optional
        Kept between smoothers of one band: the band points each point's taps
        read along each axis, found once for the widest kernel (make the
        widest smoother first).

    Calling the smoother on rows (k, N) returns the smoothed rows.  Points that
    no weighted point reaches get 0; :attr:`covered` marks the others.
    """

    def __init__(self, band, t, weights=None, dtype=np.float32, neighbours=None):
        self.dtype = np.dtype(dtype)
        self.std = math.sqrt(2.0 * float(t)) / band.h
        weights = _weights(band, weights, self.dtype)
        if self.std > 0:
            offsets, taps = gaussian_taps(self.std)
            # first along z: in the band's (i, j, k) order those neighbours are near in memory
            self.passes = [SplitMatrix(_axis_matrix(band, axis, offsets, taps, self.dtype,
                                                    weights if first else None, neighbours))
                           for first, axis in zip((True, False, False), (2, 1, 0))]
        else:  # no blur: the weights alone
            self.passes = [sp.diags(weights, format="csr")]
        self.covered, self.scale = _normalisation(self._convolve(np.ones(band.size, self.dtype)), self.dtype)

    def _convolve(self, v):
        for M in self.passes:
            v = M @ v
        return v

    def __call__(self, rows):
        rows = np.asarray(rows)
        out = np.empty(rows.shape, dtype=self.dtype)
        for j in range(len(rows)):  # each pass already runs on all cores
            out[j] = self._convolve(rows[j].astype(self.dtype, copy=False)) * self.scale
        return out


def _axis_matrix(band, axis, offsets, taps, dtype, source_weights, neighbours=None):
    """CSR (N, N): row i holds the ``taps`` at the band points ``i + offsets * e_axis``.

    Taps that fall outside the band are left out; with ``source_weights``
    each tap is multiplied by its point's weight (zero weights left out).
    ``neighbours`` ({axis: neighbour indices of the offsets -R..R}) keeps the
    lookups for kernels no wider.
    """
    n = band.size
    radius = int(offsets[-1])
    held = None if neighbours is None else neighbours.get(axis)
    if held is not None and (held.shape[1] - 1) // 2 >= radius:
        centre = (held.shape[1] - 1) // 2
        nbr = held[:, centre - radius:centre + radius + 1]
    else:
        step = np.zeros((len(offsets), 3), np.int64)
        step[:, axis] = offsets
        nbr = band.neighbors(step)
        if neighbours is not None:
            neighbours[axis] = nbr
    weights = np.ones(n + 1, dtype)
    if source_weights is not None:
        weights[:n] = source_weights
    weights[n] = 0  # index -1 (no point) reads the appended zero
    data = taps.astype(dtype)[None, :] * weights[nbr]
    keep = data != 0
    indptr = np.concatenate([[0], np.cumsum(keep.sum(axis=1))])
    return sp.csr_matrix((data[keep], nbr[keep], indptr), shape=(n, n))


def taper(dist, reach):
    """Weights ``cos^2(pi d / (2 reach))`` for ``|d| < reach``, else 0.

    A data mask that falls smoothly to zero away from the surface: summed
    over grid points, it weighs every direction along the surface alike,
    where a cut-off mask would follow the grid's staircase and pull
    normalised averages sideways.
    """
    d = np.abs(np.asarray(dist, dtype=np.float64)) / reach
    return np.where(d < 1, np.cos(0.5 * np.pi * np.minimum(d, 1)) ** 2, 0.0)


def _normalisation(weight, dtype):
    """``(covered, scale)`` of a normalised convolution from the blurred weights: ``1 / weight`` where
    the weight is not negligible, else 0."""
    covered = weight > 1e-6 * float(weight.max())
    return covered, np.where(covered, 1.0 / np.where(covered, weight, 1.0), 0.0).astype(dtype)


def _weights(band, weights, dtype):
    if weights is None:
        return np.ones(band.size, dtype)
    weights = np.asarray(weights, dtype=dtype)
    if weights.shape != (band.size,) or not np.all(weights >= 0):
        raise ValueError(f"weights must be {band.size} non-negative numbers")
    return weights


#: The coarsest box grid :class:`GridGaussian` uses, in band spacings.
MAX_FACTOR = 4

#: The Gaussian left on the coarse grid must be at least this wide (in coarse
#: cells): narrower, the cell averages and the trilinear read-back do most of
#: the blurring, and they are neither Gaussian nor the same at every point.
MIN_COARSE_STD = 0.85


def _coarse_std(std, f):
    """Deviation (coarse cells) that leaves a total of ``std`` (fine cells) after averaging and read-back."""
    var = std**2 - (f * f - 1) / 12.0 - (f * f / 4.0 if f > 1 else 0.0)
    return math.sqrt(max(var, 0.0)) / f


class GridGaussian:
    """Approximates the surface heat flow to time ``t`` with a 3-D Gaussian on a coarser box grid.

    The weighted band values are summed into the cells of a box grid of
    spacing ``factor * h`` that covers the band, blurred there with a
    separable Gaussian (:func:`scipy.ndimage.gaussian_filter`, several rows
    at once on all cores), and read back at the band points by trilinear
    interpolation.  Numerator and weights go through the same steps
    (normalised convolution), so constants are kept exactly and no value
    leaves the range of the data.

    The cell sums and the trilinear read-back blur a little themselves
    (variance ``(factor^2 - 1) h^2 / 12`` and at most ``factor^2 h^2 / 4`` per
    axis); the Gaussian's own variance is reduced by their sum.  By default
    the coarsest grid (up to :data:`MAX_FACTOR`) is taken on which the
    Gaussian keeps a deviation of :data:`MIN_COARSE_STD` cells.  Unlike
    separable passes inside the band, the box grid sees every path of the
    3-D kernel, so the blur stays centred on each point.
    """

    def __init__(self, band, t, weights=None, dtype=np.float32, factor=None):
        self.dtype = np.dtype(dtype)
        std = math.sqrt(2.0 * float(t)) / band.h
        if factor is None:
            factor = max([1] + [f for f in range(2, MAX_FACTOR + 1) if _coarse_std(std, f) >= MIN_COARSE_STD])
        self.factor = f = int(factor)
        self.std = _coarse_std(std, f)
        weights = _weights(band, weights, self.dtype)
        ijk = band.ijk - band.ijk.min(axis=0)
        radius = int(math.ceil(TRUNCATE * self.std)) + 2
        cell = ijk // f + radius
        self.shape = tuple(int(s) for s in cell.max(axis=0) + 1 + radius)
        flat = flat_index(cell, self.shape)
        n_cells = int(np.prod(self.shape))
        # restriction: the weighted sum of the points of each cell
        src = np.flatnonzero(weights)
        src = src[np.argsort(flat[src], kind="stable")]
        counts = np.bincount(flat[src], minlength=n_cells)
        self.restrict = SplitMatrix(sp.csr_matrix(
            (weights[src], src.astype(np.int32), np.concatenate([[0], np.cumsum(counts)])),
            shape=(n_cells, band.size)))
        # read-back: trilinear weights at the band points; cell c has its centre at (c + 1/2) f - 1/2
        g = (ijk + 0.5) / f - 0.5 + radius
        base = np.floor(g).astype(np.int64)
        frac = (g - base).astype(self.dtype)
        corner0 = flat_index(base, self.shape)
        del g, base
        cols = np.empty((band.size, 8), np.int32 if n_cells < 2**31 else np.int64)
        vals = np.empty((band.size, 8), self.dtype)
        for k, corner in enumerate(itertools.product((0, 1), repeat=3)):
            cols[:, k] = corner0 + flat_index(np.array(corner), self.shape)
            vals[:, k] = 1
            for a in range(3):
                vals[:, k] *= frac[:, a] if corner[a] else 1 - frac[:, a]
        self.prolong = SplitMatrix(sp.csr_matrix(
            (vals.ravel(), cols.ravel(), np.arange(0, 8 * band.size + 1, 8, dtype=cols.dtype)),
            shape=(band.size, n_cells)))
        self._band, self._h, self._weights = band, band.h, weights
        self.covered, self.scale = _normalisation(self._blur(np.ones((1, band.size), self.dtype))[0], self.dtype)

    def at_time(self, t):
        """The same smoothing to heat time ``t``: on this one's box grid where the Gaussian left
        there stays wide enough (:data:`MIN_COARSE_STD`), so its grids are shared; else a new one."""
        std = _coarse_std(math.sqrt(2.0 * float(t)) / self._h, self.factor)
        if std < MIN_COARSE_STD and self.factor > 1:
            return GridGaussian(self._band, t, weights=self._weights, dtype=self.dtype)
        other = copy.copy(self)
        other.std = std
        other.covered, other.scale = _normalisation(other._blur(np.ones((1, self._band.size), self.dtype))[0],
                                                    self.dtype)
        return other

    def _blur(self, rows):
        out = np.empty((len(rows), self.prolong.shape[0]), dtype=self.dtype)

        def blur(j):  # one row at a time, so that only one box grid a thread is alive
            c = self.restrict @ np.ascontiguousarray(rows[j], dtype=self.dtype)
            if self.std > 0:
                c = ndimage.gaussian_filter(c.reshape(self.shape), self.std, truncate=TRUNCATE,
                                            mode="constant").ravel()
            out[j] = self.prolong @ c

        map_parallel(blur, range(len(rows)))
        return out

    def __call__(self, rows):
        """Smoothed copies of band values given as rows (k, N)."""
        return self._blur(np.asarray(rows)) * self.scale
