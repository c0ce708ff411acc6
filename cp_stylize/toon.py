"""Toon shading: the picture's lightness in a few flat bands with soft steps.

Winnemöller, Olsen and Gooch, "Real-time video abstraction" (2006), section
3.3: each colour's lightness ``L`` (OKLab) is moved to its band's value, with
a step where two bands meet shaped by ``tanh``: from one band's value ``v_k``
to the next's, ``L' = v_k + (v_{k+1} - v_k) (1 + tanh(phi (2 f - 1)) /
tanh(phi)) / 2``, ``f`` the share of the way ``L`` has come from the band's
middle to the next's.  Unlike the paper's form around the nearest boundary,
this stays continuous at every steepness ``phi`` (Softness 0: a hard step; 1:
a gentle S).  Hue and chroma stay the colour's own.

:class:`Toon` applies it at each texel of the bake-out (``paint=`` of
:func:`cp_stylize.baking.bake_to_atlas`), so the bands' edges are as sharp
as the texels: the bands are centred in equal shares of the picture's
lightness and each given the mean lightness of its texels (a dark picture
keeps its shapes apart, and its values), islands of a few texels go to the
band around them, each step is anti-aliased over a texel, and outlines may
be inked on the dark side of each step.  The smoothing before it
(EED keeps the picture's edges) decides how simple the shapes are, and ink
lines laid over it (:mod:`cp_stylize.lines`) draw their outlines.
"""

from __future__ import annotations

import numpy as np

from .oklab import from_oklab, to_oklab

__all__ = ["quantise_lightness", "band_middles", "Toon"]

#: The steepness ``phi`` of a step at Softness 0 and at Softness 1.
STEEPEST, GENTLEST = 1000.0, 1.0


def quantise_lightness(colours, levels, softness=0.3, middles=None, values=None, shift=None, sharpest=None,
                       lab=None):
    """sRGB colours (..., 3) with their OKLab lightness in ``levels`` soft bands (see the module's notes).

    ``middles`` (levels,), rising: the bands' middles in the input's lightness (default: evenly spaced
    from black to white, ``(k + 0.5) / levels``); a lightness is measured in bands' widths by the
    piecewise linear map that takes the middles to whole numbers, and steps halfway between two of
    them.  ``values`` (levels,): the lightness each band is given (default its middle).  ``shift``
    (...,): whole numbers of bands to move each colour by (see :class:`Toon`'s clean-up).  ``sharpest``
    (...,): the steepest each colour's step may be (see :class:`Toon`'s anti-aliasing).  ``lab`` (..., 3):
    the colours in OKLab, where the caller has them already."""
    colours = np.asarray(colours)
    levels = int(levels)
    if levels < 2:
        raise ValueError(f"levels must be at least 2, got {levels!r}")
    if not 0.0 <= softness <= 1.0:
        raise ValueError(f"softness must lie in [0, 1], got {softness!r}")
    middles = (np.arange(levels) + 0.5) / levels if middles is None else np.asarray(middles, dtype=np.float64)
    if middles.shape != (levels,) or np.any(np.diff(middles) <= 0):
        raise ValueError(f"middles must be {levels} rising lightnesses, got {middles!r}")
    values = middles if values is None else np.asarray(values, dtype=np.float64)
    lab = to_oklab(colours) if lab is None else np.array(lab, dtype=np.float64)
    u = band_position(lab[..., 0], middles)
    if shift is not None:
        u = np.clip(u + shift, 0.0, levels - 1.0)
    whole = np.minimum(np.floor(u), levels - 2.0)
    steepness = STEEPEST * (GENTLEST / STEEPEST) ** float(softness)        # geometric in the softness
    if sharpest is not None:
        steepness = np.clip(sharpest, GENTLEST, steepness)
    # from one middle to the next: flat at both, a step where the bands meet (halfway), as steep as asked
    rise = 0.5 + 0.5 * np.tanh(steepness * (2.0 * (u - whole) - 1.0)) / np.tanh(steepness)
    low = values[whole.astype(np.int64)]
    lab[..., 0] = low + rise * (values[whole.astype(np.int64) + 1] - low)
    return from_oklab(lab).astype(colours.dtype if colours.dtype.kind == "f" else np.float64)


def band_position(lightness, middles):
    """Lightness in bands' widths: the piecewise linear map that takes the bands' ``middles`` to 0, 1, ...
    (flat beyond the first and last)."""
    return np.interp(lightness, middles, np.arange(len(middles), dtype=np.float64))


def band_values(lightness, band, levels):
    """The lightness each of ``levels`` bands is given: the mean ``lightness`` (M,) of the texels in it
    (``band`` (M,), whole numbers), so the picture keeps its values on the whole, its darks dark and its
    lights light; a band no texel is in takes its neighbours' mean, and the values rise by at least
    0.02 a band."""
    counts = np.bincount(band, minlength=levels)[:levels].astype(np.float64)
    sums = np.bincount(band, weights=lightness, minlength=levels)[:levels]
    known = counts > 0
    k = np.arange(levels)
    values = np.interp(k, k[known], sums[known] / counts[known]) if known.any() else (k + 0.5) / levels
    apart = 0.02 * k
    return np.maximum.accumulate(values - apart) + apart


def band_middles(lightness, levels):
    """The middles of ``levels`` bands for the lightness ``lightness`` (M,): its quantiles at ``(k + 0.5) /
    levels``, each band centred in an equal share of it, kept apart by at least 0.02."""
    middles = np.quantile(lightness, (np.arange(levels) + 0.5) / levels) if len(lightness) else \
        (np.arange(levels) + 0.5) / levels
    apart = 0.02 * np.arange(levels)
    return np.maximum.accumulate(middles - apart) + apart


#: Outlines (:func:`_borders`) are this wide (in texels of a 1024 x 1024 atlas), in this ink (sRGB).
OUTLINE_TEXELS = 1.0
OUTLINE_INK = 0.02
#: A step between two bands spans about this many texels (it is anti-aliased over them).
STEP_TEXELS = 1.0
#: Islands of one band smaller than this many texels of a 1024 x 1024 atlas (four times as many at 2048)
#: go to the band around them.
ISLAND = 40


class Toon:
    """Toon bands at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): the texels'
    colours quantised by :func:`quantise_lightness`.

    - The bands are centred in equal shares of the texels' lightness (:func:`band_middles`), so a dark
      picture's shadows and its paths stay apart, and each is given the mean lightness of its texels
      (:func:`band_values`), so the picture keeps its values.
    - With the atlas's ``size``, at the texels: islands of a band smaller than :data:`ISLAND` texels go
      to the band around them (no speckle where the picture's lightness hovers at a step), and each
      step is made no steeper than spans :data:`STEP_TEXELS` texels, from the lightness's own gradient,
      so it is anti-aliased over a texel however shallow the picture's gradient there.  The gradient is
      read across the atlas's margin texels, which continue the surface past each chart's edge.

    Reads no band columns and leaves no height."""

    columns = None

    def __init__(self, levels, softness=0.3, size=None, outlines=0.0, island=ISLAND):
        self.levels, self.softness, self.size, self.outlines = int(levels), float(softness), size, float(outlines)
        self.island = island

    def __call__(self, texels, colours, read, progress=None):
        out, position, change = self.bands(texels, colours)
        if change is not None and self.outlines > 0:
            ink = self.outlines * _borders(position, change, self.levels, self.size)
            out[:, :3] = out[:, :3] + ink[:, None] * (OUTLINE_INK - out[:, :3])
        if progress is not None:
            progress(1.0)
        return out, None

    def bands(self, texels, colours, shift=None):
        """The texels' ``colours`` (M, C) in the bands: ``(colours (M, C), band position (M,), its change a
        texel (M,) or None without the atlas's size)``.  ``shift`` (M,): bands' widths to move each texel's
        lightness by before it is quantised (a noise wobbles the borders where the lightness changes
        slowly)."""
        colours = np.asarray(colours)
        lab = to_oklab(colours[:, :3])
        lightness = lab[:, 0]
        middles = band_middles(lightness, self.levels)
        position = band_position(lightness, middles)
        if shift is not None:
            position = np.clip(position + shift, 0.0, self.levels - 1.0)
        moved = shift
        sharpest = change = None
        if self.size is not None:
            islands = _islands(np.rint(position).astype(np.int64), texels[0], self.size, self.island)
            moved = islands if shift is None else shift + islands
            change = _change(position, texels[0], self.size)
            sharpest = 1.0 / (STEP_TEXELS * change)
            position = np.clip(position + islands, 0.0, self.levels - 1.0)
        values = band_values(lightness, np.rint(position).astype(np.int64), self.levels)
        out = np.array(colours, dtype=np.float64 if colours.dtype.kind != "f" else colours.dtype)
        out[:, :3] = quantise_lightness(colours[:, :3], self.levels, self.softness, middles, values, moved, sharpest,
                                        lab)
        return out, position, change


def _image(values, flat, size, fill):
    image = np.full(size * size, fill, dtype=values.dtype)
    image[flat] = values
    return image.reshape(size, size)


def _islands(band, flat, size, island=ISLAND):
    """Whole numbers of bands (M,) that move the texels ``flat`` (M,) of islands of one band smaller than
    ``island`` texels of a 1024 x 1024 atlas (scaled by the atlas's ``size``) to the band most of their
    neighbours have."""
    from scipy import ndimage

    image = _image(band, flat, size, -1)
    smallest = island * (size / 1024.0) ** 2
    small = np.zeros((size, size), dtype=bool)
    for k in np.unique(band):
        labels, count = ndimage.label(image == k)
        if count:
            sizes = np.bincount(labels.ravel())
            tiny = sizes < smallest
            tiny[0] = False
            small |= tiny[labels]
    if not small.any():
        return np.zeros(len(flat))
    around = ndimage.median_filter(np.where(image < 0, np.median(band), image), size=5)
    return np.where(small.ravel()[flat], around.ravel()[flat] - band, 0).astype(np.float64)


def _borders(position, change, levels, size):
    """How much ink (M,) in [0, 1] texels take along the borders between bands: on the dark side of each
    step (within :data:`OUTLINE_TEXELS` texels of a 1024 x 1024 atlas, twice as many at 2048, below the
    band position ``position`` (M,) where it steps), measured by the band position's change a texel
    ``change`` (M,); anti-aliased over a texel.  It reads no neighbours in the atlas, so it runs on
    across UV seams as the bands do."""
    above = np.floor(position - 0.5) + 1.5                     # the next step up
    texels = (above - position) / change                       # how far below it, in texels
    width = OUTLINE_TEXELS * size / 1024.0
    return np.where(above <= levels - 1.0, np.clip(width + 0.5 - texels, 0.0, 1.0), 0.0)


def _change(position, flat, size):
    """How fast (M,) the band position (M,) at the texels ``flat`` (M,) changes, in bands a texel: from
    the atlas (one-sided at its border and where its texels end), whose margin texels continue the
    surface past each chart's edge."""
    from .raster import nearest_filled

    rows, cols = np.gradient(nearest_filled(position, flat, size))
    return np.maximum(np.hypot(rows, cols).ravel()[flat], 1e-9)
