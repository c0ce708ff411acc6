"""The picture's thin lines laid as a rigger brush's strokes.

A painter does not trace a crane's jib or a twig pixel by pixel: a fine,
long-haired brush (a rigger) lays it in a few overlapping strokes, each
straight or gently curved, swelling and tapering, its tail running dry.
:func:`line_dabs` turns the thin dark lines that
:func:`cp_stylize.contours.thin_lines` finds at an atlas's texels into such
strokes: dabs centred on the line, each along the line's own direction there
(the principal axis of the line's texels about it, on the surface, so the
same in every chart), as long as the line runs (up to :data:`LENGTH` widths),
as wide as the brush's pressure makes it, and a little out of true
(:data:`WOBBLE`).  :func:`cp_stylize.canvas.paint` draws them as it draws
every other dab: with their tapers, bristle streaks, dry tails and relief.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .arrays import ball_pairs
from .strokes import Dabs, _spread

__all__ = ["line_dabs", "HELD", "LENGTH", "STEP"]

#: A texel is on a line where the line's ink there is at least this.
HELD = 0.5
#: A line's dabs are at most this many of its widths long ...
LENGTH = 7.0
#: ... and laid about this share of that length apart (at most one in each cube of that side), so that
#: each overlaps the next and a line runs on without gaps.
STEP = 0.3
#: Each dab is turned from the line's direction by up to this angle (radians) either way, at random: a hand
#: lays a long straight line as strokes a little out of true, not as a ruled line.
WOBBLE = 0.06
#: A dab is laid only where its line runs on for at least this many of its widths (about it, either way): a
#: fleck or a short fragment of a busy texture is left to the dabs of colour, not drawn as a scratch.
RUN = 6.0
#: A line's run counts its texels within this many of its widths of the straight line through the dab's
#: centre: the line itself, a little bent, and not the lines of a busy texture about it.
STRAIGHT = 1.5
#: A dab is laid only where the line's texels about it lie along one direction: the spread across it is at
#: most this share of the spread along it (a blot of dark texels is not a line).
ELONGATED = 0.5


def line_dabs(ink, points, normals, faces, barys, pieces, width, *, seed=0, layer=0, run=0.0):
    """Dabs (:class:`~cp_stylize.strokes.Dabs`, colour unset: zeros) along the lines of ``ink`` (M,) in
    [0, 1] at texels with surface ``points`` and unit ``normals`` (M, 3), input ``faces`` (M,), barycentric
    coordinates ``barys`` (M, 3) and mesh ``pieces`` (M,); ``width`` (M,): the brush's width at each texel, a
    length on the surface; ``run``: a line is laid only where it runs on at least this far (a length on
    the surface), and at least :data:`RUN` of its widths.  Each dab takes the texel nearest its middle as
    its centre; None where no line is found.  Also returned: each dab's centre texel (n,) and its ink (n,),
    the mean of ``ink`` over its line.
    """
    on = np.flatnonzero(ink >= HELD)
    if len(on) < 3:
        return None, None, None
    at = np.asarray(points, dtype=np.float64)[on]
    reach = 0.5 * LENGTH * float(np.median(width[on]))
    rng = np.random.default_rng([int(seed), 31])
    seeds = _spread(at, STEP * 2.0 * reach, rng)
    tree = cKDTree(at)
    i, j = ball_pairs(tree, at[seeds], reach)
    weight = ink[on][j]
    total = np.bincount(i, weights=weight, minlength=len(seeds))
    mean = np.stack([np.bincount(i, weights=weight * at[j, k], minlength=len(seeds)) for k in range(3)], 1)
    mean /= total[:, None]
    offset = at[j] - mean[i]
    spread = np.zeros((len(seeds), 3, 3))
    for a in range(3):
        for b in range(a, 3):
            spread[:, a, b] = spread[:, b, a] = np.bincount(i, weights=weight * offset[:, a] * offset[:, b],
                                                            minlength=len(seeds))
    values, vectors = np.linalg.eigh(spread)
    normal = np.asarray(normals, dtype=np.float64)[on][seeds]
    direction = vectors[:, :, 2]
    direction -= np.einsum("ij,ij->i", direction, normal)[:, None] * normal
    size = np.linalg.norm(direction, axis=1)
    direction /= np.maximum(size, 1e-12)[:, None]
    lined = (values[:, 1] <= ELONGATED**2 * values[:, 2]) & (size > 0.5)
    # the dab runs over the line's texels about it, from the first to the last along its direction
    low, high = _span(i, np.einsum("ij,ij->i", offset, direction[i]), len(seeds))
    middle = mean + (0.5 * (low + high))[:, None] * direction
    _, centre = tree.query(middle)
    brush = width[on][centre]
    length = np.clip(high - low + brush, 2.0 * brush, 2.0 * reach)
    need = np.maximum(RUN * brush, float(run))
    keep = np.flatnonzero(lined)            # the run is measured only where the texels lie along a line
    keep = keep[_run(tree, at, seeds[keep], direction[keep], need[keep], STRAIGHT * brush[keep], brush[keep])
                >= need[keep]]
    if not len(keep):
        return None, None, None
    centre = on[centre[keep]]
    n = len(keep)
    normal = np.asarray(normals, np.float64)[centre]
    turn = rng.uniform(-WOBBLE, WOBBLE, n)[:, None]
    direction = np.cos(turn) * direction[keep] + np.sin(turn) * np.cross(normal, direction[keep])
    direction -= np.einsum("ij,ij->i", direction, normal)[:, None] * normal     # in the centre's tangent plane
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    dabs = Dabs(centre=np.asarray(points, dtype=np.float64)[centre], normal=normal, direction=direction,
                length=length[keep], width=brush[keep], colour=np.zeros((n, 3)),
                piece=np.asarray(pieces)[centre], phase=rng.uniform(0.0, 2.0 * np.pi, n),
                layer=np.full(n, layer, dtype=np.int32), face=np.asarray(faces)[centre],
                bary=np.asarray(barys, dtype=np.float64)[centre])
    return dabs, centre, (total / np.maximum(np.bincount(i, minlength=len(seeds)), 1))[keep]


def _run(tree, at, seeds, direction, reach, across, step):
    """How far the line of points ``at`` (a k-d ``tree`` of them) runs on, straight and unbroken, along each
    ``direction`` (n, 3) from the points ``seeds`` (n,), up to ``reach`` (n,) either way: the points within
    ``across`` (n,) of the straight line through the seed, in steps of ``step`` (n,) along it, counted out
    from the seed each way until a step holds none (the seed's own step counts for neither side).  The lines
    of a busy texture about it, which cross that line here and there, and a zigzag's turns do not run it
    on."""
    i, j = ball_pairs(tree, at[seeds], reach)
    offset = at[j] - at[seeds][i]
    along = np.einsum("ij,ij->i", offset, direction[i])
    straight = np.einsum("ij,ij->i", offset, offset) - along**2 <= across[i] ** 2
    steps = int(np.ceil(np.max(reach / step))) if len(seeds) else 0
    which = np.clip(np.round(along[straight] / step[i[straight]]).astype(np.int64), -steps, steps)
    held = np.zeros((len(seeds), 2 * steps + 1), dtype=bool)
    held[i[straight], which + steps] = True
    held[:, steps] = True                                            # the seed's own step
    ahead = np.argmin(np.c_[held[:, steps:], np.zeros(len(seeds), bool)], axis=1)      # steps held on each side
    behind = np.argmin(np.c_[held[:, steps::-1], np.zeros(len(seeds), bool)], axis=1)
    return (ahead + behind - 2) * step


def _span(i, t, n):
    """The least and greatest of the values ``t`` of each of ``n`` groups (``i``: each value's group)."""
    low, high = np.full(n, np.inf), np.full(n, -np.inf)
    np.minimum.at(low, i, t)
    np.maximum.at(high, i, t)
    return low, high
