"""How large a surface is: the diameter of its points, which no rotation changes.

Every object is normalised to a diameter of 2 before a run (the paper's scale:
a sphere of radius 1), so that a setting looks the same whatever the object's
size and however it is turned.  The diameter is the greatest distance between
two points of the surface, that is between two vertices of its faces.

:func:`diameter` finds it without comparing every pair.  A lower bound ``L``
comes from a few double normals (the farthest point from a point, the farthest
from that, until it grows no more).  Then, with ``c`` the centre of a ball of
radius ``R`` holding every point, a point ``p`` can only reach farther than
``L`` if ``|p - c| + R > L``, and only towards points within
``rho(p) = sqrt(2 |p - c|^2 + 2 R^2 - L^2)`` of its reflection ``2 c - p``
(since ``|p - q|^2 = 2 |p - c|^2 + 2 |q - c|^2 - |q - (2 c - p)|^2``).  Pairs
of blocks of points, in Morton order, are refined level by level and dropped
where their boxes rule out both; the pairs of points left are measured.  On a
round surface the second test leaves each point a few partners, where the
first alone would leave it all of them.
"""

from __future__ import annotations

import numpy as np

from .arrays import as_points

__all__ = ["diameter", "RTOL"]

#: Pairs that cannot be longer than ``L (1 + RTOL)`` are not measured: the diameter found is exact to
#: this relative amount (a perfect sphere with no exactly opposite vertices would otherwise leave
#: every point its neighbours near the opposite side to measure).
RTOL = 1e-5
#: Points a block holds at each level of the refinement (each level's blocks split into 8 of the next).
_LEVELS = (4096, 512, 64, 8)
#: Double normals tried at most.
_ROUNDS = 20
#: Pairs of leaf blocks measured at once.
_CHUNK = 4096


def diameter(points, *, rtol=RTOL):
    """The greatest distance between two of ``points`` (N, 3), to a relative ``rtol``.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Finite points, N >= 1.
    rtol : float
        The result ``d`` satisfies ``D / (1 + rtol) <= d <= D`` for the true
        diameter ``D``; 0 measures every pair that could be the longest.

    Returns
    -------
    float
        0 for a single point.

    Examples
    --------
    >>> diameter([[0, 0, 0], [1, 0, 0], [0, 2, 0]])
    2.23606797749979
    """
    points = as_points(points)
    if len(points) == 0:
        raise ValueError("points must hold at least one point, got none")
    longest, (i, j) = _double_normal(points)
    if longest == 0.0:
        return 0.0
    centre, radius, offsets = _enclosing_ball(points, i, j)
    bound = longest * (1.0 + rtol)
    candidates = offsets + radius > bound
    if candidates.sum() < 2:
        return longest
    return max(longest, _longest_pair(points[candidates], centre, radius, bound))


def _double_normal(points):
    """``(|p - q|, (p, q))`` of the last of a few double normals: q the farthest point from p, then p from q."""
    start = int(np.argmax(_squared(points - points.mean(axis=0))))
    best, pair = -1.0, (start, start)
    for _ in range(_ROUNDS):
        far = _squared(points - points[start])
        other = int(np.argmax(far))
        if far[other] <= best:
            break
        best, pair, start = float(far[other]), (start, other), other
    return float(np.sqrt(best)), pair


def _enclosing_ball(points, i, j):
    """``(c, R, |points - c|)`` for the tighter of two balls around every point: centred at the box's centre,
    or at the middle of the pair ``i``, ``j``."""
    best = None
    for centre in (0.5 * (points.min(axis=0) + points.max(axis=0)), 0.5 * (points[i] + points[j])):
        offsets = np.sqrt(_squared(points - centre))
        if best is None or offsets.max() < best[1]:
            best = (centre, float(offsets.max()), offsets)
    return best


def _longest_pair(points, centre, radius, bound):
    """The greatest distance between two ``points`` if it exceeds ``bound``, else at most ``bound``."""
    points = _morton_sorted(points)
    top = _LEVELS[0]
    padded = -(-len(points) // top) * top
    points = np.concatenate([points, np.repeat(points[:1], padded - len(points), axis=0)])
    # rho^2: how near the reflection 2 c - p a partner of p farther than ``bound`` must lie
    reach2 = 2.0 * _squared(points - centre) + 2.0 * radius**2 - bound**2
    a, b = np.triu_indices(padded // top)
    for level, size in enumerate(_LEVELS):
        lo, hi, reach = _blocks(points, reach2, size)
        keep = _possible(lo, hi, reach, a, b, centre, bound)
        a, b = a[keep], b[keep]
        if level + 1 < len(_LEVELS):
            a, b = _children(a, b, size // _LEVELS[level + 1])
    leaves = points.reshape(-1, _LEVELS[-1], 3)
    best = 0.0
    for start in range(0, len(a), _CHUNK):
        gaps = leaves[a[start:start + _CHUNK], :, None, :] - leaves[b[start:start + _CHUNK], None, :, :]
        best = max(best, float(np.einsum("kijd,kijd->kij", gaps, gaps).max()))
    return float(np.sqrt(best))


def _possible(lo, hi, reach, a, b, centre, bound):
    """Which block pairs ``(a, b)`` may hold two points farther apart than ``bound``."""
    span = np.maximum(hi[a] - lo[b], hi[b] - lo[a])
    keep = _squared(span) > bound**2
    # b's box must come within reach of the reflection of a's, and a's of b's
    keep &= _box_gap(2 * centre - hi[a], 2 * centre - lo[a], lo[b], hi[b]) <= reach[a]
    keep &= _box_gap(2 * centre - hi[b], 2 * centre - lo[b], lo[a], hi[a]) <= reach[b]
    return keep


def _children(a, b, k):
    """The pairs of sub-blocks of block pairs ``(a, b)``, ``k`` sub-blocks a block (each pair once)."""
    i, j = (index.ravel() for index in np.meshgrid(np.arange(k), np.arange(k), indexing="ij"))
    ca, cb = (a[:, None] * k + i).ravel(), (b[:, None] * k + j).ravel()
    once = np.repeat(a != b, k * k) | (ca <= cb)
    return ca[once], cb[once]


def _blocks(points, reach2, size):
    """Boxes ``(lo, hi)`` of consecutive blocks of ``size`` points, and the greatest reach in each."""
    starts = np.arange(0, len(points), size)
    reach = np.sqrt(np.maximum(np.maximum.reduceat(reach2, starts), 0.0))
    return np.minimum.reduceat(points, starts), np.maximum.reduceat(points, starts), reach


def _box_gap(lo_a, hi_a, lo_b, hi_b):
    """The distance between boxes ``a`` and ``b`` (row by row), 0 where they meet."""
    return np.sqrt(_squared(np.maximum(0.0, np.maximum(lo_b - hi_a, lo_a - hi_b))))


def _squared(v):
    return np.einsum("ij,ij->i", v, v)


def _morton_sorted(points):
    """``points`` in Morton (Z) order of a 1024^3 grid over their box: nearby points in nearby rows."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    cell = np.floor((points - lo) / np.where(hi > lo, hi - lo, 1.0) * 1023.999).astype(np.uint64)
    code = np.zeros(len(points), dtype=np.uint64)
    for axis in range(3):
        code |= _spread_bits(cell[:, axis]) << np.uint64(axis)
    return points[np.argsort(code, kind="stable")]


def _spread_bits(x):
    """The 10 low bits of ``x`` spread to every third bit."""
    x = x & np.uint64(0x3FF)
    for shift, mask in ((16, 0x030000FF), (8, 0x0300F00F), (4, 0x030C30C3), (2, 0x09249249)):
        x = (x | (x << np.uint64(shift))) & np.uint64(mask)
    return x
