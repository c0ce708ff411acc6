"""The sheets of a surface that comes back near itself, kept apart in the band.

Where a surface comes back near itself, closer than the band is wide (the
two sides of a thin ear, an eyelid over an eyeball), one grid point's
stencils would read the values of both sheets.  :class:`Sheets` tells them
apart at the band's points: by the surface's unit normals at their closest
points, and for triangle meshes by the connected piece of each point's face.
The band's interpolation keeps each stencil to its own sheet
(:meth:`Sheets.keep_to_own`) and its finite difference operators drop the
links between sheets (:meth:`Sheets.cut_links`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["Sheets"]

#: Band points tested at once (the tests' temporaries are (block, stencil) arrays).
_CHUNK = 1 << 17


class Sheets:
    """What tells a surface's sheets apart at the points of a band of spacing ``h`` and interpolation
    ``degree``: their closest points ``cp`` (N, 3), the surface's unit ``normals`` there (N, 3,
    read-only: :func:`cp_stylize.tangent.surface_normals` hands them out) and, for triangle meshes,
    the connected ``pieces`` (N,) of their faces (else None).  Make one with :meth:`of`."""

    def __init__(self, h, degree, cp, normals, pieces=None):
        self.h, self.degree, self.cp = float(h), int(degree), cp
        self.normals, self.pieces = normals, pieces
        self._columns = None

    @classmethod
    def of(cls, surface, h, degree, cp, face=None, bary=None):
        """The sheets of ``surface`` at the closest points ``cp`` (with their ``face`` and ``bary`` on
        a mesh), or None for a surface without normals (``surface.normal``)."""
        normal = getattr(surface, "normal", None)
        if normal is None:
            return None
        n = np.array(normal(cp, face, bary) if face is not None else normal(cp), dtype=np.float64)
        n.setflags(write=False)
        piece = getattr(surface, "piece", None)
        return cls(h, degree, cp, n, None if piece is None or face is None else piece[face])

    def other(self, nodes, x, normals, pieces=None):
        """Whether the band points ``nodes`` (M, K; -1 for none) lie on another sheet than the surface
        points ``x`` (M, 3) with ``normals`` (and ``pieces``): (M, K) bool.  See :meth:`keep_to_own`."""
        safe = np.maximum(nodes, 0)
        nx, ny, nz = self._by_axis()   # single precision, by component: (M, K) gathers only
        q = np.asarray(normals, dtype=np.float32)
        dot = nx[safe] * q[:, 0:1]
        dot += ny[safe] * q[:, 1:2]
        dot += nz[safe] * q[:, 2:3]
        facing = dot < 0.0
        other = np.zeros(safe.shape, dtype=bool)
        rows = np.flatnonzero(facing.any(axis=1))
        offset = np.einsum("ikj,ij->ik", self.cp[safe[rows]] - x[rows, None, :], normals[rows])
        other[rows] = facing[rows] & (np.abs(offset) > 0.5 * self.h)
        if pieces is not None:
            other |= self.pieces[safe] != pieces[:, None]
        other &= nodes >= 0
        return other

    def cut_links(self, nodes, rows=slice(None)):
        """Which finite difference links cross between sheets: (M, K) bool for the band points ``rows``
        (an index or mask) and their neighbours ``nodes`` (M, K).

        The operators drop these links (their rows still sum to zero), so
        that the sheets of a surface that comes back near itself exchange
        nothing; see :meth:`keep_to_own`.
        """
        rows = np.arange(len(self.cp))[rows]
        out = np.empty(nodes.shape, dtype=bool)
        for s in range(0, len(rows), _CHUNK):       # in blocks: its temporaries are (block, K) arrays
            part, r = slice(s, s + _CHUNK), rows[s:s + _CHUNK]
            out[part] = self.other(nodes[part], self.cp[r], self.normals[r],
                                   None if self.pieces is None else self.pieces[r])
        return out

    def _by_axis(self):
        """The band points' normals as three contiguous single-precision rows (made once)."""
        if self._columns is None:
            self._columns = np.ascontiguousarray(self.normals.T, dtype=np.float32)
        return self._columns

    def _may_cross(self, indices, corner, normals, pieces):
        """Which stencils (M,) might hold a point of another sheet than their surface point (see
        :meth:`keep_to_own`); the others surely do not, and skip the sheet test.

        Per distinct stencil (``corner``): the mean ``m`` of its points' unit
        normals and the widest angle ``theta`` between ``m`` and any of them.
        A surface point whose normal ``q`` lies within ``90 - theta`` degrees of
        ``m`` (``q.m > sin theta``, with a margin) makes an acute angle with every
        normal of the stencil, so no point faces the other way; with every point
        on the surface point's own piece, none is on another sheet.
        """
        cells, first, which = np.unique(corner, return_index=True, return_inverse=True)
        safe = np.maximum(indices[first], 0)                    # (U, K); missing points only widen the cone
        columns = [c[safe] for c in self._by_axis()]    # n_x, n_y, n_z (U, K), single precision
        m = np.stack([c.sum(axis=1) for c in columns], axis=1)
        m /= np.maximum(np.linalg.norm(m, axis=1, keepdims=True), 1e-30)
        spread = np.min(columns[0] * m[:, 0:1] + columns[1] * m[:, 1:2] + columns[2] * m[:, 2:3], axis=1)
        reach = np.where(spread > 0, np.sqrt(np.maximum(1.0 - spread * spread, 0.0)), np.inf) + 1e-3
        q = np.asarray(normals, dtype=np.float32)
        clean = np.einsum("ij,ij->i", q, m[which.ravel()]) > reach[which.ravel()]
        if pieces is not None:
            piece = self.pieces[safe[:, 0]]
            alike = np.all(self.pieces[safe] == piece[:, None], axis=1)
            clean &= alike[which.ravel()] & (pieces == piece[which.ravel()])
        return ~clean

    def keep_to_own(self, data, indices, x, t, nodes, normals, pieces, corner=None):
        """Keep each interpolation stencil on the sheet of the surface its point lies on (in place).

        Where a surface comes back near itself (the two sides of a thin ear,
        an eyelid over an eyeball), one stencil can hold grid points whose
        closest points lie on another sheet: far away along the surface but
        near in space.  Their values would leak across, and the negative
        tricubic weights next to such a jump make the repeated extension grow
        them.  A stencil point is on another sheet if its closest point lies
        on another connected piece of a mesh, or if its normal faces the other
        way and its closest point lies off the tangent plane at ``x`` by more
        than h / 2 (so a patch of flipped faces is not cut off from its
        neighbours).  Rows that hold such a point get trilinear weights on
        the same-sheet corners of the grid cell around ``x``, renormalised:
        non-negative, so the extension there is monotone, at second order
        instead of fourth.  Rows whose cell has no same-sheet corner keep
        their weights (the sheets are closer than the grid can tell apart).
        ``nodes`` (64, 3) are the stencil's offsets in the order of its
        weights.  Returns the number of rows changed.
        """
        p = self.degree
        test = np.arange(len(indices)) if corner is None else np.flatnonzero(
            self._may_cross(indices, corner, normals, pieces))
        other = self.other(indices[test], x[test], normals[test], None if pieces is None else pieces[test])
        rows = np.flatnonzero(other.any(axis=1) & (indices[test].min(axis=1) >= 0))
        other = other[rows]
        rows = test[rows]
        if not len(rows):
            return 0
        lower = (p - 1) // 2                      # the cell's corners are nodes lower and lower + 1 per axis
        w = np.ones((len(rows), len(nodes)))
        for a in range(3):
            ta = t[rows, a][:, None]
            w *= np.where(nodes[:, a] == lower, 1.0 - ta, np.where(nodes[:, a] == lower + 1, ta, 0.0))
        w[other] = 0.0
        total = w.sum(axis=1)
        keep = total > 1e-3
        data[rows[keep]] = w[keep] / total[keep, None]
        return int(keep.sum())
