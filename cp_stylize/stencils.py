"""Finite difference operators in the band: central gradients and ``div(G grad)`` (paper, eq. (51)).

Both act on band values and have rows only for the band's inner points (the
points the extension E reads); other rows are empty, since E overwrites those
points.  The band must support the 19-point stencil (``stencil="anisotropic"``)
for :class:`DivergenceOperator`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = ["gradient_matrices", "gershgorin_step", "DivergenceOperator", "TENSOR_COMPONENTS"]

#: Order of the six independent components of a symmetric 3x3 tensor field.
TENSOR_COMPONENTS = ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))

_AXIS = np.eye(3, dtype=np.int64)


def _rows_csr(band, rows, cols, data, per_row, dtype):
    """CSR (N, N) with ``per_row`` entries in each of ``rows`` (sorted) and none elsewhere."""
    counts = np.zeros(band.size, dtype=np.int64)
    counts[rows] = per_row
    indptr = np.concatenate([[0], np.cumsum(counts)])
    return sp.csr_matrix((np.asarray(data, dtype=dtype).ravel(), np.asarray(cols).ravel().astype(np.int32),
                          indptr), shape=(band.size, band.size))


def gradient_matrices(band, dtype=np.float32, rows=None):
    """Central differences ``D_a^c v = (v[x + h e_a] - v[x - h e_a]) / 2h`` for a = x, y, z.

    Returns three CSR matrices (N, N) with rows at the band points ``rows``
    (boolean mask), by default the inner points; ``rows="all"`` takes every
    point whose six face neighbours are in the band.
    """
    nbr = band.neighbors(np.vstack([_AXIS, -_AXIS]))
    if rows is None:
        rows = band.inner
    elif isinstance(rows, str) and rows == "all":
        rows = np.all(nbr >= 0, axis=1)
    rows = np.flatnonzero(rows)
    nbr = nbr[rows]
    if np.any(nbr < 0):
        raise ValueError("a gradient row lacks a face neighbour in the band")
    coef = np.tile([0.5 / band.h, -0.5 / band.h], (len(rows), 1))
    return tuple(_rows_csr(band, rows, nbr[:, [a, a + 3]], coef, 2, dtype) for a in range(3))


class DivergenceOperator:
    """Assembles ``A(G) v ~ div(G grad v)`` for tensor fields G on the band (paper, eq. (51)).

    For an inner point x, with ``G_ab`` the tensor's components:

    .. math::

        \\sum_a D_a^- \\big( A_a^+ G_{aa}\\, D_a^+ v \\big)
        + \\sum_{a \\ne b} D_a^c \\big( G_{ab}\\, D_b^c v \\big)

    where ``A_a^+`` averages to the edge centre ``x + h e_a / 2``.  The diagonal
    terms use compact differences, the mixed ones central differences, giving a
    19-point stencil whose rows sum to zero (constants are stationary).  With
    ``G = I`` it is the 7-point Laplacian; with ``G = g I`` it is the
    Morton-Mayers scheme for Perona-Malik (Biddle, "Nonlinear diffusion filtering on surfaces", 2011, section 3.3).
    The sparsity pattern is built once; each call fills in the coefficients.
    """

    def __init__(self, band, dtype=np.float32):
        if band.stencil != "anisotropic":
            raise ValueError("anisotropic diffusion needs a band built with stencil='anisotropic', "
                             f"got a band with stencil={band.stencil!r}")
        self.band = band
        self.dtype = np.dtype(dtype)
        self.rows = np.flatnonzero(band.inner)
        diagonals = [(a, b, sa, sb) for a in range(3) for b in range(a + 1, 3) for sa in (1, -1) for sb in (1, -1)]
        offsets = [np.zeros(3, np.int64)]
        offsets += [s * _AXIS[a] for a in range(3) for s in (1, -1)]
        offsets += [sa * _AXIS[a] + sb * _AXIS[b] for a, b, sa, sb in diagonals]
        self._diagonals = diagonals
        # A is canonical (each row's columns sorted), so that SciPy never sorts it in place and its
        # products sum each row in column order.  Band points are numbered in lexicographic grid
        # order, so the sorted order of the stencil slots is the offsets' own, the same in every row
        offsets = np.array(offsets)
        self._order = np.lexsort(offsets.T[::-1])
        columns = band.neighbors(offsets[self._order])[self.rows]   # (n_inner, 19), sorted
        if np.any(columns < 0):
            raise RuntimeError("an inner band point lacks part of its 19-point stencil")
        if not np.all(columns[:, :-1] < columns[:, 1:]):
            raise RuntimeError("the band's points are not numbered in grid order")
        self._template = _rows_csr(band, self.rows, columns, np.zeros(columns.shape), 19, self.dtype)
        self._template.has_sorted_indices = True
        #: band indices of the inner points' stencils by stencil slot (19, n_inner)
        self.columns = columns.T[np.argsort(self._order)]
        # links between sheets of a surface that comes back near itself (Band.cut_links): dropped
        cut = band.cut_links(self.columns[1:].T, self.rows)
        cut = None if cut is None else cut.T
        #: the stencil slots (1..18) and inner points where links are cut; None if there are none
        self._cut = None if cut is None or not cut.any() else (np.flatnonzero(cut.any(axis=0)), cut)

    def matrix(self, G):
        """The CSR matrix A(G) (N, N); rows outside the inner points are empty.

        The weights are computed in float64 whatever G's type.
        """
        A = self._template.copy()  # its own index arrays: SciPy may sort them in place
        self.fill(np.asarray(G, dtype=np.float64), A.data)
        return A

    def fill(self, G, data):
        """Write the weights of A(G) into ``data`` (19 n_inner,), in A's (sorted) entry order; returns ``data``.

        Computed in G's precision from the 21 gathers they need: each face's
        diagonal entry, the centre's, and each mixed entry at the four faces
        of its plane.
        """
        c = self.columns
        n, h2 = len(self.rows), self.band.h ** 2
        w = np.empty((19, n), dtype=G.dtype)  # by stencil slot: every step runs along memory
        for a in range(3):
            centre = G[a][c[0]]
            for j in (1 + 2 * a, 2 + 2 * a):
                np.add(centre, G[a][c[j]], out=w[j])
        w[1:7] *= 0.5
        w[1:7] /= h2
        np.sum(w[1:7], axis=0, out=w[0])
        np.negative(w[0], out=w[0])
        comp = {pair: k for k, pair in enumerate(TENSOR_COMPONENTS)}
        at = {}
        for k, (a, b, sa, sb) in enumerate(self._diagonals):
            g = G[comp[(a, b)]]
            for axis, sign in ((a, sa), (b, sb)):
                if (a, b, axis, sign) not in at:
                    at[(a, b, axis, sign)] = g[c[1 + 2 * axis + (0 if sign > 0 else 1)]]
            np.add(at[(a, b, a, sa)], at[(a, b, b, sb)], out=w[7 + k])
            w[7 + k] *= sa * sb
            w[7 + k] /= 4.0 * h2
        if self._cut is not None:           # rows that lose links still sum to zero
            points, cut = self._cut
            part = w[1:, points]
            part[cut[:, points]] = 0.0
            w[1:, points] = part
            w[0, points] = -part.sum(axis=0)
        data.reshape(n, 19)[:] = w[self._order].T
        return data

    def template(self):
        """A(G) with all weights zero, to fill in place with :meth:`fill` and multiply with.

        It shares its index arrays with the operator (they are as large as
        E's): use it for products only, since SciPy operations that sort
        indices do so in place and would break the order :meth:`fill` writes in.
        """
        T = self._template
        return sp.csr_matrix((np.zeros_like(T.data), T.indices, T.indptr), shape=T.shape, copy=False)

    @staticmethod
    def stable_step(A):
        """Largest forward Euler step for ``v + tau A v`` by Gershgorin's bound on A's spectrum.

        ``1.9 / max_i sum_j |A_ij|`` (a little under 2 / rho(A)); infinite for A = 0.  A must be
        canonical (as the operator's and the band's matrices are): SciPy's sum
        sorts the indices of any other matrix in place.
        """
        return gershgorin_step(np.asarray(abs(A).sum(axis=1)) if A.nnz else np.zeros(0))


def gershgorin_step(row_sums):
    """``1.9 / max(row_sums)`` from the rows' sums of absolute values; infinite if all are 0."""
    bound = float(np.max(row_sums)) if np.size(row_sums) else 0.0
    return np.inf if bound == 0 else 1.9 / bound
