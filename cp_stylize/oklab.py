"""OKLab: a perceptual colour space for mapping colours and measuring their differences.

Björn Ottosson, "A perceptual color space for image processing" (2020).
``L`` is the perceived lightness (0 black, 1 white); ``a`` and ``b`` span
the hues, their length is the chroma.  Euclidean distances approximate
perceived colour differences, and a hue keeps its look as its lightness
changes (unlike HSV or CIELAB's blues).

Colours elsewhere in cp_stylize are sRGB-encoded values in [0, 1]; these
functions take and give such values.
"""

from __future__ import annotations

import numpy as np

from .texture import linear_to_srgb, srgb_to_linear

__all__ = ["to_oklab", "from_oklab", "within_gamut", "hue_difference"]

_LMS = np.array([[0.4122214708, 0.5363325363, 0.0514459929],
                 [0.2119034982, 0.6806995451, 0.1073969566],
                 [0.0883024619, 0.2817188376, 0.6299787005]])
_LAB = np.array([[0.2104542553, 0.7936177850, -0.0040720468],
                 [1.9779984951, -2.4285922050, 0.4505937099],
                 [0.0259040371, 0.7827717662, -0.8086757660]])
_LMS_INV = np.linalg.inv(_LMS)
_LAB_INV = np.linalg.inv(_LAB)


def to_oklab(colours):
    """OKLab ``(L, a, b)`` (..., 3), float64, of sRGB-encoded colours (..., 3)."""
    linear = srgb_to_linear(np.clip(np.asarray(colours, dtype=np.float64)[..., :3], 0.0, 1.0))
    return np.cbrt(linear @ _LMS.T) @ _LAB.T


def from_oklab(lab):
    """sRGB-encoded colours (..., 3), float64, of OKLab ``(L, a, b)`` (..., 3); clipped to [0, 1]."""
    lms = (np.asarray(lab, dtype=np.float64) @ _LAB_INV.T) ** 3
    return np.clip(linear_to_srgb(np.clip(lms @ _LMS_INV.T, 0.0, 1.0)), 0.0, 1.0)


def within_gamut(lab, steps=16):
    """OKLab colours (..., 3) with their chroma lowered as little as needed (by bisection, ``steps`` halvings)
    for them to lie in sRGB's gamut at their own lightness (clipped to [0, 1]) and hue: a dark colour of
    high chroma keeps its lightness and hue, where :func:`from_oklab`'s clipping would change both."""
    lab = np.array(lab, dtype=np.float64)
    lab[..., 0] = np.clip(lab[..., 0], 0.0, 1.0)

    def inside(colours, scale):
        scaled = np.concatenate([colours[:, :1], colours[:, 1:] * scale[:, None]], axis=1)
        linear = ((scaled @ _LAB_INV.T) ** 3) @ _LMS_INV.T
        return np.all((linear >= -1e-9) & (linear <= 1.0 + 1e-9), axis=1)

    flat = lab.reshape(-1, 3)
    outside = np.flatnonzero(~inside(flat, np.ones(len(flat))))     # greys are always inside
    beyond = flat[outside]
    low, high = np.zeros(len(outside)), np.ones(len(outside))
    for _ in range(steps):                               # the colours beyond the gamut alone
        middle = 0.5 * (low + high)
        ok = inside(beyond, middle)
        low, high = np.where(ok, middle, low), np.where(ok, high, middle)
    flat[outside, 1:] *= low[:, None]
    return lab


def hue_difference(a, b):
    """The angle in degrees (...,) between the hues of two OKLab colours (..., 3), in [0, 180]."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return np.degrees(np.abs(np.angle(np.exp(1j * (np.arctan2(a[..., 2], a[..., 1])
                                                   - np.arctan2(b[..., 2], b[..., 1]))))))
