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

__all__ = ["quantise_lightness", "Toon"]

#: The steepness ``phi`` of a step at Softness 0 and at Softness 1.
STEEPEST, GENTLEST = 40.0, 1.0


def quantise_lightness(colours, levels, softness=0.3):
    """sRGB colours (..., 3) with their OKLab lightness in ``levels`` soft bands (see the module's notes)."""
    colours = np.asarray(colours)
    levels = int(levels)
    if levels < 2:
        raise ValueError(f"levels must be at least 2, got {levels!r}")
    if not 0.0 <= softness <= 1.0:
        raise ValueError(f"softness must lie in [0, 1], got {softness!r}")
    lab = to_oklab(colours)
    # the lightness in bands' widths from the darkest band's middle: the middles are whole numbers
    u = np.clip(lab[..., 0] * levels - 0.5, 0.0, levels - 1.0)
    whole = np.minimum(np.floor(u), levels - 2.0)
    steepness = STEEPEST * (GENTLEST / STEEPEST) ** float(softness)        # geometric in the softness
    # from one middle to the next: flat at both, a step where the bands meet (halfway), as steep as asked
    rise = 0.5 + 0.5 * np.tanh(steepness * (2.0 * (u - whole) - 1.0)) / np.tanh(steepness)
    lab[..., 0] = (whole + rise + 0.5) / levels
    return from_oklab(lab).astype(colours.dtype if colours.dtype.kind == "f" else np.float64)


class Toon:
    """Toon bands at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): the texels'
    colours quantised by :func:`quantise_lightness`.  Reads no band columns and leaves no height."""

    columns = None

    def __init__(self, levels, softness=0.3):
        self.levels, self.softness = int(levels), float(softness)

    def __call__(self, texels, colours, read, progress=None):
        out = quantise_lightness(colours, self.levels, self.softness)
        if progress is not None:
            progress(1.0)
        return out, None
