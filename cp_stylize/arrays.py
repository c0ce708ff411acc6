"""Small array helpers shared by the core: checked inputs, unit rows, runs, chunks and a smooth step."""

from __future__ import annotations

import numpy as np

__all__ = ["as_points", "check_uvs", "count", "unit_rows", "aligned", "expand_runs", "ball_pairs", "split_counts", "smooth_step", "before"]


def as_points(x, name="points"):
    """``x`` as finite float64 points (N, 3); ValueError or TypeError naming ``name`` otherwise."""
    x = np.asarray(x)
    if x.ndim != 2 or x.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {x.shape}")
    if not (np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.integer)):
        raise TypeError(f"{name} must hold real numbers, got dtype {x.dtype}")
    x = x.astype(np.float64, copy=False)
    if not np.all(np.isfinite(x)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
        raise ValueError(f"{name} must be finite, got {x[bad].tolist()} at row {bad}")
    return x


def check_uvs(uvs, n_faces):
    """Per-corner UVs (F, 3, 2) of ``n_faces`` faces as float64; ValueError or TypeError otherwise."""
    uvs = np.asarray(uvs)
    if uvs.shape != (n_faces, 3, 2):
        raise ValueError(f"uvs must have shape ({n_faces}, 3, 2), one UV per face corner, got {uvs.shape}")
    if not (np.issubdtype(uvs.dtype, np.floating) or np.issubdtype(uvs.dtype, np.integer)):
        raise TypeError(f"uvs must hold real numbers, got dtype {uvs.dtype}")
    return uvs.astype(np.float64, copy=False)


def count(value, name, *, minimum=1, unit=""):
    """``int(value)`` for an integer of at least ``minimum`` (1 or 0); TypeError or ValueError naming it.

    ``unit`` completes the messages, e.g. ``" number of texels"``.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer{unit}, got {value!r}")
    if value < minimum:
        sign = "positive" if minimum > 0 else "non-negative"
        raise ValueError(f"{name} must be a {sign} integer{unit}, got {value!r}")
    return int(value)


def unit_rows(v, fallback=None):
    """``(v / |v|, |v|)`` over the last axis; rows of zero length stay zero, or become ``fallback``."""
    length = np.linalg.norm(v, axis=-1)
    zero = length == 0.0
    unit = v / np.where(zero, 1.0, length)[..., None]
    if fallback is not None and np.any(zero):
        unit[zero] = fallback
    return unit, length


def aligned(v, reference):
    """Rows of ``v`` (M, 3), each turned round where it points against the same row of ``reference``: the
    sign a line field's direction takes to go on along ``reference``."""
    return v * np.where(np.einsum("ij,ij->i", v, reference) < 0, -1.0, 1.0)[:, None]


def expand_runs(counts):
    """For runs of lengths ``counts``: the run of every element and its position in the run."""
    run = np.repeat(np.arange(len(counts)), counts)
    start = np.cumsum(counts) - counts
    return run, np.arange(len(run)) - start[run]


def ball_pairs(tree, centres, radii):
    """Pairs ``(i, j)`` of every point ``j`` of a k-d ``tree`` (SciPy's ``cKDTree``) within ``radii`` (a number
    or one for each) of ``centres[i]`` (n, 3), as two int64 arrays."""
    found = tree.query_ball_point(centres, radii, return_sorted=False)
    counts = np.fromiter((len(f) for f in found), np.int64, len(found))
    if not counts.sum():
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    return np.repeat(np.arange(len(found)), counts), np.concatenate([np.asarray(f, dtype=np.int64) for f in found if len(f)])


def split_counts(counts, budget):
    """Boundaries ``[0, ..., len(counts)]`` of consecutive runs whose counts sum to about ``budget``."""
    total = np.cumsum(counts)
    cuts = np.searchsorted(total, np.arange(budget, total[-1] if len(total) else 0, budget), side="right")
    return np.unique(np.concatenate([[0], cuts, [len(counts)]]))


def smooth_step(x):
    """Hermite's smooth step ``3 x^2 - 2 x^3`` of ``x`` clipped to [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def before(p, q):
    """Whether each row of ``p`` (N, D) comes before the same row of ``q`` by its first coordinate, then
    its second, and so on (boolean (N,)): an order of points that their positions alone decide."""
    p, q = np.asarray(p), np.asarray(q)
    out = np.zeros(len(p), dtype=bool)
    for axis in range(p.shape[1] - 1, -1, -1):
        out = (p[:, axis] < q[:, axis]) | ((p[:, axis] == q[:, axis]) & out)
    return out
