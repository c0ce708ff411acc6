"""Palette noise for painterly looks (paper, section 5.2.3).

Before coherence-enhancing diffusion draws strokes, a fraction of the band
points takes random colours from a palette ("setting randomly 67% of the
voxels to a random selection of mostly dark blues"): :func:`inject_noise`.

That recipe suits a surface already painted in the palette's colours.  On a
photograph it erases the picture, so :func:`tone_noise` maps the picture's
tones onto the palette instead (darks to the palette's darks, lights to its
lights, each colour taking the share of tones its weight asks for) and draws
the noise from the palette colours near each point's own tone: the strokes
then carry the picture.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import rankdata

__all__ = ["palette_by_tone", "inject_noise", "tone_noise", "LUMA"]

#: Rec. 709 weights of a colour's tone (on the sRGB-encoded values: the tone as seen).
LUMA = np.array([0.2126, 0.7152, 0.0722])


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


def tone_noise(values, fraction, palette, *, weights=None, spread=0.1, seed=0):
    """Map the tones of ``values`` onto the palette, and jitter a ``fraction`` of them.

    Parameters
    ----------
    values : ndarray, shape (N, C)
        Band values, C >= 3 colour channels (sRGB-encoded).
    fraction : float
        Share of points, in [0, 1], whose tone is jittered before it picks its colour.
    palette : sequence of colours, shape (K, C)
        Sorted here by tone (:data:`LUMA`), darkest first.
    weights : sequence of K floats, optional
        The share of the tones each colour takes (uniform by default).
    spread : float
        Standard deviation of the jitter, as a share of the tones (the ranks
        in [0, 1]): how far from its own tone a point may pick its colour.
    seed : int
        Seed of the random generator.

    Returns
    -------
    ndarray
        A new array of palette colours.  Each point's tone is its rank among
        all points' tones (the picture's tones spread evenly over the
        palette, whatever its exposure); the colour is the one whose share of
        the ranks, counted from the darkest colour, holds that rank.
    """
    values, palette, p = _check(values, fraction, palette, weights)
    if values.shape[1] < 3:
        raise ValueError(f"tone noise needs colours of 3 channels or more, got {values.shape[1]}")
    if not 0.0 <= spread <= 1.0:
        raise ValueError(f"spread must lie in [0, 1], got {spread!r}")
    tone = values[:, :3].astype(np.float64) @ LUMA
    rank = (rankdata(tone) - 0.5) / len(values)           # equal tones share their mean rank
    rng = np.random.default_rng(seed)
    chosen = rng.random(len(values)) < fraction
    rank[chosen] += spread * rng.standard_normal(int(chosen.sum()))
    return palette_by_tone(rank, palette, p)


def palette_by_tone(rank, palette, weights=None):
    """The palette colour (M, C) for each tone rank (M,) in [0, 1] (clipped): the colours sorted by
    tone, darkest first, each taking its ``weights`` share (uniform by default) of the ranks."""
    palette = np.asarray(palette)
    p = np.full(len(palette), 1.0 / len(palette)) if weights is None else np.asarray(weights, dtype=np.float64)
    order = np.argsort(palette[:, :3].astype(np.float64) @ LUMA, kind="stable")
    bounds = np.cumsum(p[order] / p.sum())[:-1]
    return palette[order[np.searchsorted(bounds, np.clip(rank, 0.0, 1.0), side="right")]]
