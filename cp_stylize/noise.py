"""Palette noise for painterly looks (paper, section 5.2.3).

Before coherence-enhancing diffusion draws strokes, a fraction of the band
points takes random colours from a palette ("setting randomly 67% of the
voxels to a random selection of mostly dark blues"): :func:`inject_noise`.

That recipe suits a surface already painted in the palette's colours.  On a
photograph it erases the picture: :func:`cp_stylize.palette.map_to_palette`
maps the picture's colours onto the palette by tone and hue instead, and
:func:`cp_stylize.palette.palette_noise` draws the noise from the palette
colours near each point's own.
"""

from __future__ import annotations

import numpy as np

__all__ = ["inject_noise"]


def inject_noise(values, fraction, palette, *, weights=None, seed=0):
    """Replace a random ``fraction`` of the rows of ``values`` by palette colours.

    Parameters
    ----------
    values : ndarray, shape (N, C)
        Band values (C colour channels).
    fraction : float
        Share of points replaced, in [0, 1].
    palette : sequence of colours, shape (K, C)
        Colours to draw from, in the same encoding as ``values``.
    weights : sequence of K floats, optional
        Relative frequency of each colour; uniform by default.
    seed : int
        Seed of the random generator: the same seed gives the same noise.

    Returns
    -------
    ndarray
        A new array; ``values`` is not modified.
    """
    values, palette, p = _check(values, fraction, palette, weights)
    out = values.copy()
    if fraction == 0:
        return out
    rng = np.random.default_rng(seed)
    chosen = rng.random(len(values)) < fraction
    out[chosen] = palette[rng.choice(len(palette), size=int(chosen.sum()), p=p)]
    return out


def _check(values, fraction, palette, weights):
    """``(values, palette, weights summing to 1 or None)``, or ValueError naming what is wrong."""
    values = np.asarray(values)
    if values.ndim != 2:
        raise ValueError(f"values must have shape (N, C), got {values.shape}")
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"fraction must lie in [0, 1], got {fraction!r}")
    palette = np.asarray(palette, dtype=values.dtype)
    if palette.ndim != 2 or palette.shape[1] != values.shape[1] or len(palette) == 0:
        raise ValueError(f"palette must have shape (K, {values.shape[1]}) with K >= 1, got {palette.shape}")
    p = None
    if weights is not None:
        p = np.asarray(weights, dtype=np.float64)
        if p.shape != (len(palette),) or np.any(p < 0) or p.sum() <= 0:
            raise ValueError(f"weights must be {len(palette)} non-negative numbers, not all zero")
        p = p / p.sum()
    return values, palette, p
