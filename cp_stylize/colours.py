"""The colours a run may give back: within the convex hull of the colours it was given.

Filters that are not convex combinations overshoot: the tricubic closest point
extension and the bake-out's interpolation have negative weights, and the
anisotropic schemes' stencils are not monotone.  Near a sharp edge between
two colours they can make a third, saturated one that the input never had
(a pure blue on a blue-grey edge, an orange fringe on a red-green one).
:class:`ColourHull` pulls such colours back onto the hull of the input's
colours, along the line to the hull's centre, so that their hue moves least
where the overshoot is small.

Inside the hull nothing changes: a colour the input could make by mixing its
own colours passes bit-identical.  Inputs whose colours span less than the
whole colour space (two colours, greys) have a flat hull: colours off its
plane or line are first projected onto it.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from .sparse import map_parallel

__all__ = ["ColourHull", "TOLERANCE", "distinct_colours"]

#: Colours are rounded to this grid before the hull is built (8 bits a channel): far
#: fewer points, and the hull of the input's colours "beyond rounding".
_LEVELS = 255
#: How far beyond the hull (colour distance) a colour may lie and pass unchanged: the rounding.
TOLERANCE = 1.0 / _LEVELS
#: Cells a side of the grid that tells at once which colours lie deep inside the hull.
_CELLS = 32
#: Colours tested against the facets at once.
_CHUNK = 1 << 16


#: Pixels rounded at once by :func:`distinct_colours`.
_PIXELS = 1 << 20


def distinct_colours(values):
    """The distinct colours of ``values`` (..., C) rounded to 8 bits a channel, as (M, C) float64 in [0, 1].

    The hull of these is :class:`ColourHull`'s, so a large image can hand it
    its few distinct colours instead of every pixel: the pixels are rounded a
    million at a time into a table of the 2^24 colours of three channels, so
    the memory this takes does not grow with the image.  Colours that are
    not finite numbers are left out.
    """
    values = np.asarray(values)
    flat = values.reshape(-1, values.shape[-1] if values.ndim > 1 else 1)
    channels = flat.shape[1]
    if channels > 3:
        finite = flat[np.all(np.isfinite(flat), axis=1)]
        return _distinct(np.clip(np.round(finite * _LEVELS), 0, _LEVELS).astype(np.int64)) / _LEVELS
    seen = np.zeros((_LEVELS + 1) ** channels, dtype=bool)
    weights = (_LEVELS + 1) ** np.arange(channels)
    for start in range(0, len(flat), _PIXELS):
        chunk = flat[start:start + _PIXELS].astype(np.float32, copy=False)
        finite = np.isfinite(chunk @ np.ones(channels, np.float32))      # NaN, and inf - inf, in any channel
        levels = np.rint(chunk * np.float32(_LEVELS))
        np.clip(levels, 0, _LEVELS, out=levels)
        keys = levels @ weights.astype(np.float32)                        # whole numbers below 2^24: exact
        seen[keys[finite].astype(np.int32)] = True
    keys = np.flatnonzero(seen)
    return ((keys[:, None] // weights) % (_LEVELS + 1)) / _LEVELS


def _distinct(levels):
    """The distinct rows of integer colours in [0, _LEVELS] (N, C), each channel packed into 8 bits of a key."""
    if levels.shape[1] > 7:
        return np.unique(levels, axis=0)
    weights = (_LEVELS + 1) ** np.arange(levels.shape[1], dtype=np.int64)
    keys = np.unique(levels @ weights)
    return (keys[:, None] // weights) % (_LEVELS + 1)


class ColourHull:
    """The convex hull of a set of colours (N, C) in [0, 1], and :meth:`limit` onto it."""

    def __init__(self, colours):
        colours = np.asarray(colours, dtype=np.float64)
        if colours.ndim != 2 or len(colours) == 0:
            raise ValueError(f"colours must have shape (N, C) with N > 0, got {colours.shape}")
        colours = colours[np.all(np.isfinite(colours), axis=1)]
        if len(colours) == 0:
            raise ValueError("colours hold no finite colour")
        points = _distinct(np.clip(np.round(colours * _LEVELS), 0, _LEVELS).astype(np.int64)) / _LEVELS
        self.origin = points.mean(axis=0)
        _, _, vt = np.linalg.svd(points - self.origin, full_matrices=False)
        # directions in which no colour lies further than the rounding from the centre do not count (a
        # direction's farthest colour decides, not its spread: a palette's few colours beside a
        # photograph's many span a direction the photograph alone would not)
        extent = np.abs((points - self.origin) @ vt.T).max(axis=0)
        rank = int(np.sum(extent > 2 * TOLERANCE))
        self.basis = vt[:rank].T                                  # (C, r): the span of the colours
        y = (points - self.origin) @ self.basis
        self.low, self.high = (y.min(axis=0), y.max(axis=0)) if rank else (np.zeros(0), np.zeros(0))
        self.equations, self._deep = None, None
        if rank >= 2:
            try:
                hull = ConvexHull(y)
            except QhullError:                                    # too thin to tell: keep the box
                hull = None
            if hull is not None:
                self.equations = hull.equations                   # (F, r + 1): n . y + b <= 0 inside, |n| = 1
                self.centre = y[hull.vertices].mean(axis=0)
                self._deep = self._deep_cells(rank) if rank <= 3 else None

    def _excess(self, y):
        """How far (M,) the points ``y`` (M, r) lie beyond the hull's farthest facet (<= 0 inside)."""
        return np.max(y @ self.equations[:, :-1].T + self.equations[:, -1], axis=1)

    def _deep_cells(self, rank):
        """A boolean grid (_CELLS,)*r over the box: the cells whose every corner lies inside the hull."""
        axes = [np.linspace(lo, hi, _CELLS + 1) for lo, hi in zip(self.low, self.high)]
        corners = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, rank)
        inside = (self._excess(corners) <= 0).reshape((_CELLS + 1,) * rank)
        deep = np.ones((_CELLS,) * rank, dtype=bool)
        for offset in np.ndindex(*(2,) * rank):
            deep &= inside[tuple(slice(o, o + _CELLS) for o in offset)]
        return deep

    def _in_deep_cell(self, y):
        span = np.where(self.high > self.low, self.high - self.low, 1.0)
        index = np.floor((y - self.low) / span * _CELLS).astype(np.int64)
        inside_box = np.all((index >= 0) & (index < _CELLS), axis=1)
        index = np.clip(index, 0, _CELLS - 1)
        return inside_box & self._deep[tuple(index.T)]

    def _onto(self, y):
        """Points ``y`` (M, r) outside the hull moved onto it towards its centre; and which moved."""
        if self.equations is None:                                # a line (or a point): its interval
            inside = np.all((y >= self.low - TOLERANCE) & (y <= self.high + TOLERANCE), axis=1)
            return np.clip(y, self.low, self.high), ~inside
        n, b = self.equations[:, :-1], self.equations[:, -1]
        outside = self._excess(y) > TOLERANCE
        if outside.any():
            c = self.centre
            x = y[outside] - c
            reach = x @ n.T                                       # how fast each facet is approached
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.where(reach > 0, (TOLERANCE - (n @ c + b)) / reach, np.inf).min(axis=1)
            y = y.copy()
            y[outside] = c + np.clip(t, 0.0, 1.0)[:, None] * x
        return y, outside

    def limit(self, values):
        """``values`` (..., C) with every colour outside the hull moved onto it.

        Returns a new array of the same dtype.  Colours inside the hull, or
        beyond it by no more than :data:`TOLERANCE` (8 bits' rounding), are
        unchanged, bit for bit.
        """
        values = np.asarray(values)
        out = values.copy()
        flat = out.reshape(-1, out.shape[-1])

        def chunk(s):                      # the chunks write to rows of their own: side by side on the cores
            rows = np.arange(s, min(s + _CHUNK, len(flat)))
            x = flat[rows].astype(np.float64) - self.origin
            y = x @ self.basis
            off = np.linalg.norm(x - y @ self.basis.T, axis=1) > TOLERANCE   # off the hull's plane or line
            if self._deep is not None:
                keep = self._in_deep_cell(y) & ~off
                rows, y, off = rows[~keep], y[~keep], off[~keep]
            moved_y, moved = self._onto(y)
            moved |= off
            flat[rows[moved]] = (self.origin + moved_y[moved] @ self.basis.T).astype(flat.dtype)

        map_parallel(chunk, range(0, len(flat), _CHUNK))
        return out
