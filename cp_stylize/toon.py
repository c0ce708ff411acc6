"""Toon shading: the picture's lightness in a few flat bands with soft steps.

Winnemöller, Olsen and Gooch, "Real-time video abstraction" (2006), section
3.3: each colour's lightness ``L`` (OKLab) is moved to the middle of its
band of ``1 / levels``, with a step where two bands meet shaped by ``tanh``:
from one band's middle ``m`` to the next's, ``L' = m + (1 + tanh(phi (2 f -
1)) / tanh(phi)) / (2 levels)``, ``f`` the share of the way ``L`` has come.
Unlike the paper's form around the nearest boundary, this stays continuous
at every steepness ``phi`` (Softness 0: a hard step; 1: a gentle S).  The
darkest and lightest bands are flat to black and white.  Hue and chroma stay
the colour's own.  :class:`Toon` applies it at each texel of the
bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`), so the
bands' edges are as sharp as the texels; the smoothing before it (EED keeps
the picture's edges) decides how simple the shapes are, and contour lines
laid over it draw their outlines.
"""

from __future__ import annotations

import numpy as np

from .oklab import from_oklab, to_oklab

__all__ = ["quantise_lightness", "band_middles", "Toon"]

#: The steepness ``phi`` of a step at Softness 0 and at Softness 1.
STEEPEST, GENTLEST = 40.0, 1.0


def quantise_lightness(colours, levels, softness=0.3, middles=None):
    """sRGB colours (..., 3) with their OKLab lightness in ``levels`` soft bands (see the module's notes).

    ``middles`` (levels,), rising: the bands' lightness (default: evenly spaced from black to white,
    ``(k + 0.5) / levels``); a lightness is measured in bands' widths by the piecewise linear map that
    takes the middles to whole numbers, and steps halfway between two of them."""
    colours = np.asarray(colours)
    levels = int(levels)
    if levels < 2:
        raise ValueError(f"levels must be at least 2, got {levels!r}")
    if not 0.0 <= softness <= 1.0:
        raise ValueError(f"softness must lie in [0, 1], got {softness!r}")
    middles = (np.arange(levels) + 0.5) / levels if middles is None else np.asarray(middles, dtype=np.float64)
    if middles.shape != (levels,) or np.any(np.diff(middles) <= 0):
        raise ValueError(f"middles must be {levels} rising lightnesses, got {middles!r}")
    lab = to_oklab(colours)
    # the lightness in bands' widths from the darkest band's middle: the middles are whole numbers
    u = np.interp(lab[..., 0], middles, np.arange(levels, dtype=np.float64))
    whole = np.minimum(np.floor(u), levels - 2.0)
    steepness = STEEPEST * (GENTLEST / STEEPEST) ** float(softness)        # geometric in the softness
    # from one middle to the next: flat at both, a step where the bands meet (halfway), as steep as asked
    rise = 0.5 + 0.5 * np.tanh(steepness * (2.0 * (u - whole) - 1.0)) / np.tanh(steepness)
    low = middles[whole.astype(np.int64)]
    lab[..., 0] = low + rise * (middles[whole.astype(np.int64) + 1] - low)
    return from_oklab(lab).astype(colours.dtype if colours.dtype.kind == "f" else np.float64)


def band_middles(lightness, levels):
    """The middles of ``levels`` bands for the lightness ``lightness`` (M,): its quantiles at ``(k + 0.5) /
    levels``, each band centred in an equal share of it, kept apart by at least 0.02."""
    middles = np.quantile(lightness, (np.arange(levels) + 0.5) / levels) if len(lightness) else \
        (np.arange(levels) + 0.5) / levels
    apart = 0.02 * np.arange(levels)
    return np.maximum.accumulate(middles - apart) + apart


class Toon:
    """Toon bands at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): the texels'
    colours quantised by :func:`quantise_lightness`, the bands centred in equal shares of the texels'
    lightness (:func:`band_middles`): a dark picture's shadows and its paths stay apart in dark shades of their own
    colours, not one black.  Reads no band columns and leaves no height."""

    columns = None

    def __init__(self, levels, softness=0.3):
        self.levels, self.softness = int(levels), float(softness)

    def __call__(self, texels, colours, read, progress=None):
        middles = band_middles(to_oklab(np.asarray(colours)[:, :3])[:, 0], self.levels)
        out = quantise_lightness(colours, self.levels, self.softness, middles)
        if progress is not None:
            progress(1.0)
        return out, None
