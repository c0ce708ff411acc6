"""Images: bilinear lookup with Blender's extensions, texel centres, sRGB encoding, PNG files.

Image convention (Blender's): an image is a float array of shape (H, W, C)
whose row 0 is the bottom row, so texture coordinate ``(u, v)`` in [0, 1]^2
lands at column ``u * W - 0.5`` and row ``v * H - 0.5`` (texel centres at
half-integers).
"""

from __future__ import annotations

import struct
import zlib

import numpy as np

__all__ = ["WRAPS", "bilinear", "check_image", "texel_centres", "write_png", "srgb_to_linear", "linear_to_srgb"]


def check_image(image):
    """``image`` as an array (H, W, C) of floats; ValueError or TypeError otherwise."""
    image = np.asarray(image)
    if image.ndim == 2:
        image = image[:, :, None]
    if image.ndim != 3 or image.shape[0] < 1 or image.shape[1] < 1:
        raise ValueError(f"image must have shape (H, W) or (H, W, C), got {image.shape}")
    if not np.issubdtype(image.dtype, np.floating):
        raise TypeError(f"image must hold floats in [0, 1], got dtype {image.dtype}")
    return image


#: How a lookup continues beyond the image's edge texel centres (Blender's Image Texture
#: "Extension": EXTEND is "clamp", REPEAT "repeat", MIRROR "mirror", CLIP "clip").
WRAPS = ("clamp", "repeat", "mirror", "clip")


def _texel_indices(coord, n, mode):
    """Lower and upper texel index, weight of the upper, and (for "clip") which indices lie inside."""
    x = coord * n - 0.5
    i0 = np.floor(x)
    f = x - i0
    i0 = i0.astype(np.int64)
    i1 = i0 + 1
    inside = None
    if mode == "repeat":
        i0, i1 = np.mod(i0, n), np.mod(i1, n)
    elif mode == "mirror":
        i0, i1 = np.mod(i0, 2 * n), np.mod(i1, 2 * n)
        i0, i1 = np.where(i0 >= n, 2 * n - 1 - i0, i0), np.where(i1 >= n, 2 * n - 1 - i1, i1)
    elif mode in ("clamp", "clip"):
        if mode == "clip":
            inside = ((i0 >= 0) & (i0 < n), (i1 >= 0) & (i1 < n), (coord >= 0) & (coord <= 1))
        i0, i1 = np.clip(i0, 0, n - 1), np.clip(i1, 0, n - 1)
    else:
        raise ValueError(f"wrap must be one of {WRAPS}, got {mode!r}")
    return i0, i1, f[:, None], inside


def bilinear(image, uv, *, wrap=("clamp", "clamp")):
    """Bilinear lookup of ``image`` (H, W, C) at texture coordinates ``uv`` (M, 2).

    Parameters
    ----------
    image : ndarray, shape (H, W, C) or (H, W)
        Float image, row 0 at the bottom (``v = 0``).
    uv : ndarray, shape (M, 2)
        Texture coordinates.
    wrap : pair of {"clamp", "repeat", "mirror", "clip"}
        What happens beyond the edge texel centres, for ``u`` and ``v``: the
        edge texels continue, the image repeats, repeats mirrored, or is zero
        outside (and texels beyond the edge count as zero), as Blender's
        EXTEND, REPEAT, MIRROR and CLIP.

    Returns
    -------
    ndarray, shape (M, C)
    """
    image = check_image(image)
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 2 or uv.shape[1] != 2:
        raise ValueError(f"uv must have shape (M, 2), got {uv.shape}")
    h, w = image.shape[:2]
    c0, c1, fu, cin = _texel_indices(uv[:, 0], w, wrap[0])
    r0, r1, fv, rin = _texel_indices(uv[:, 1], h, wrap[1])
    corner = {}
    for i, r in enumerate((r0, r1)):
        for j, c in enumerate((c0, c1)):
            value = image[r, c]
            if cin is not None:  # clip: texels beyond the edge, and everything outside [0, 1], are zero
                value = value * (cin[j] & cin[2])[:, None]
            if rin is not None:
                value = value * (rin[i] & rin[2])[:, None]
            corner[i, j] = value
    top = corner[1, 0] * (1 - fu) + corner[1, 1] * fu
    bottom = corner[0, 0] * (1 - fu) + corner[0, 1] * fu
    out = bottom * (1 - fv) + top * fv
    return out.astype(image.dtype, copy=False)


def texel_centres(height, width):
    """Texture coordinates ``(u, v)`` of all texel centres, each of shape (height, width)."""
    v, u = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width, indexing="ij")
    return u, v


def srgb_to_linear(c):
    """sRGB-encoded values in [0, 1] to linear light."""
    c = np.asarray(c)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c):
    """Linear light to sRGB-encoded values in [0, 1] (clipped)."""
    c = np.clip(np.asarray(c), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)


def _to_bytes(image):
    image = check_image(image)
    if image.shape[2] not in (1, 3, 4):
        raise ValueError(f"a PNG needs 1, 3 or 4 channels, got {image.shape[2]}")
    data = np.round(np.clip(image, 0.0, 1.0) * 255).astype(np.uint8)
    return data[::-1]  # PNG rows run top to bottom


def write_png(path, image):
    """Write a float image (H, W, C) in [0, 1], row 0 at the bottom, as an 8-bit PNG."""
    data = _to_bytes(image)
    h, w, c = data.shape
    colour_type = {1: 0, 3: 2, 4: 6}[c]
    raw = b"".join(b"\x00" + data[r].tobytes() for r in range(h))

    def chunk(kind, payload):
        return (struct.pack(">I", len(payload)) + kind + payload
                + struct.pack(">I", zlib.crc32(kind + payload) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(png)
