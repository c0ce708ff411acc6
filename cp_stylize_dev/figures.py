"""Small figure tools for flattened surface maps: panels, captions, profile plots.

Images here are float arrays (H, W, 3) with row 0 at the TOP (reading order);
:func:`save` flips them into the library's bottom-up convention for
:func:`~cp_stylize.texture.write_png`.
"""

from __future__ import annotations

import numpy as np

from cp_stylize.texture import write_png

# 5x7 bitmap glyphs, one string of 7 rows of 5 bits per character
_GLYPHS = {
    "A": "01110100011000111111100011000110001", "B": "11110100011000111110100011000111110",
    "C": "01110100011000010000100001000101110", "D": "11110100011000110001100011000111110",
    "E": "11111100001000011110100001000011111", "F": "11111100001000011110100001000010000",
    "G": "01110100011000010111100011000101111", "H": "10001100011000111111100011000110001",
    "I": "01110001000010000100001000010001110", "K": "10001100101010011000101001001010001",
    "L": "10000100001000010000100001000011111", "M": "10001110111010110101100011000110001",
    "N": "10001110011010110011100011000110001", "O": "01110100011000110001100011000101110",
    "P": "11110100011000111110100001000010000", "R": "11110100011000111110101001001010001",
    "S": "01111100001000001110000010000111110", "T": "11111001000010000100001000010000100",
    "U": "10001100011000110001100011000101110", "V": "10001100011000110001100010101000100",
    "W": "10001100011000110101101011101110001", "X": "10001100010101000100010101000110001",
    "Y": "10001100010101000100001000010000100", "Z": "11111000010001000100010001000011111",
    "0": "01110100011001110101110011000101110", "1": "00100011000010000100001000010001110",
    "2": "01110100010000100010001000100011111", "3": "11110000010000101110000010000111110",
    "4": "00010001100101010010111110001000010", "5": "11111100001111000001000011000101110",
    "6": "00110010001000011110100011000101110", "7": "11111000010001000100010000100001000",
    "8": "01110100011000101110100011000101110", "9": "01110100011000101111000010001001100",
    ".": "00000000000000000000000000110001100", "-": "00000000000000011111000000000000000",
    "=": "00000000001111100000111110000000000", ",": "00000000000000000000001100010001000",
    "(": "00010001000100001000010000010000010", ")": "01000001000001000010000100010001000",
    ":": "00000011000110000000011000110000000", " ": "0" * 35,
}


def text(caption, scale=2, colour=(1.0, 1.0, 1.0), background=(0.0, 0.0, 0.0)):
    """A caption rendered with a 5x7 bitmap font: float image (7 scale + 2, ..., 3)."""
    caption = caption.upper()
    missing = sorted({ch for ch in caption if ch not in _GLYPHS})
    if missing:
        raise ValueError(f"no glyph for {''.join(missing)!r} in caption {caption!r}")
    cols = []
    for ch in caption:
        glyph = np.array([int(b) for b in _GLYPHS[ch]], dtype=float).reshape(7, 5)
        cols += [glyph, np.zeros((7, 1))]
    mask = np.kron(np.hstack(cols) if cols else np.zeros((7, 1)), np.ones((scale, scale)))
    mask = np.pad(mask, ((scale, scale), (scale, scale)))
    return mask[..., None] * np.asarray(colour) + (1 - mask[..., None]) * np.asarray(background)


def panel(image, caption):
    """An image (H, W, C) in [0, 1] with its caption above it, as RGB."""
    image = np.clip(np.asarray(image, dtype=float), 0.0, 1.0)
    if image.ndim == 2 or image.shape[2] == 1:
        image = np.repeat(image.reshape(image.shape[0], image.shape[1], 1), 3, axis=2)
    label = text(caption)
    width = max(image.shape[1], label.shape[1])
    return np.vstack([_pad_width(label, width), _pad_width(image[..., :3], width)])


def grid(panels, columns, gap=6):
    """Panels laid out row by row on a dark background."""
    h = max(p.shape[0] for p in panels)
    w = max(p.shape[1] for p in panels)
    rows = []
    for start in range(0, len(panels), columns):
        row = [np.pad(_pad_width(p, w), ((0, h - p.shape[0]), (0, 0), (0, 0))) for p in panels[start:start + columns]]
        row += [np.zeros((h, w, 3))] * (columns - len(row))
        rows.append(np.hstack([np.pad(p, ((gap, 0), (gap, 0), (0, 0))) for p in row]))
    out = np.vstack(rows)
    return np.pad(out, ((0, gap), (0, gap), (0, 0)))


def stack(images):
    """Images stacked top to bottom, narrower ones padded on the right."""
    width = max(i.shape[1] for i in images)
    return np.vstack([_pad_width(i, width) for i in images])


def profile_plot(curves, colours, height=160, ylim=(0.0, 1.0)):
    """Line plot of equal-length curves on a dark background: float image (height, len, 3)."""
    n = len(curves[0])
    img = np.full((height, n, 3), 0.08)
    lo, hi = ylim
    for curve, colour in zip(curves, colours):
        y = np.clip((np.asarray(curve) - lo) / (hi - lo), 0, 1)
        rows = np.round((1 - y) * (height - 1)).astype(int)
        for x in range(n):  # join consecutive samples with vertical runs
            r0 = rows[x]
            r1 = rows[x + 1] if x + 1 < n else r0
            img[min(r0, r1):max(r0, r1) + 1, x] = colour
    return img


def save(path, image):
    """Write a top-down image as PNG."""
    write_png(path, np.asarray(image)[::-1])


def _pad_width(img, width):
    extra = width - img.shape[1]
    return np.pad(img, ((0, 0), (0, extra), (0, 0))) if extra > 0 else img


def surface_view(band, values, *, size=(300, 400), elevation=35.0, azimuth=30.0, extent=1.1, steps=200):
    """A 3-D view (H, W) or (H, W, C) of band ``values`` (N,) or (N, C) on the band's surface, lit from
    the viewer's upper left.

    Orthographic rays from the direction given by ``elevation`` and
    ``azimuth`` (degrees) march to the surface with the closest point
    distance (sphere tracing), which every closest point surface has; the
    values are interpolated at the hits and shaded by the surface normal.
    ``extent`` is the half-width of the view (the band's surface should fit
    in it); pixels the rays miss are 0.
    """
    h, w = size
    e, a = np.radians(elevation), np.radians(azimuth)
    forward = -np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ys, xs = np.meshgrid(np.linspace(extent * h / w, -extent * h / w, h), np.linspace(-extent, extent, w),
                         indexing="ij")
    origins = (xs.ravel()[:, None] * right + ys.ravel()[:, None] * up) - 3.0 * extent * forward
    # march only inside the surface's box: the distances far from a mesh are the costly ones
    lo, hi = band.cp.min(axis=0) - band.h, band.cp.max(axis=0) + band.h
    inside = (origins >= lo) & (origins <= hi)
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = (lo - origins) / forward, (hi - origins) / forward
    moving = forward != 0
    enter = np.where(moving, np.minimum(a, b), np.where(inside, -np.inf, np.inf))
    leave = np.where(moving, np.maximum(a, b), np.where(inside, np.inf, -np.inf))
    t = np.maximum(enter.max(axis=1), 0.0)
    exit_at = leave.min(axis=1)
    live = t < exit_at
    hit = np.zeros(len(origins), dtype=bool)
    points = np.zeros((len(origins), 3))          # the closest points where the rays stop
    surface = band.surface
    tolerance = 1e-3 * band.h
    for _ in range(steps):
        if not live.any():
            break
        index = np.flatnonzero(live)
        p = origins[index] + t[index, None] * forward
        cp = surface.closest_point(p)[0]
        d = np.linalg.norm(p - cp, axis=1)
        near = d < tolerance
        hit[index[near]] = True
        points[index[near]] = cp[near]
        live[index[near]] = False
        t[index] += np.where(near, 0.0, d)
        live[index[t[index] > exit_at[index]]] = False
    values = np.asarray(values, dtype=np.float64)
    image = np.zeros((len(origins),) + values.shape[1:])
    if hit.any():
        shade = _lambert(band, points[hit], forward, right, up)
        image[hit] = band.interpolate(values, points[hit]) * shade.reshape((-1,) + (1,) * (values.ndim - 1))
    return image.reshape((h, w) + values.shape[1:])


def _lambert(band, points, forward, right, up):
    """Diffuse shading in [0.35, 1] of surface points, lit from the viewer's upper left."""
    light = -forward + 0.6 * up - 0.4 * right
    light /= np.linalg.norm(light)
    normal = getattr(band.surface, "normal", None)
    if normal is not None:
        n = normal(points)
    else:  # a mesh: the normal is the gradient of the distance, from nearby off-surface points
        n = _mesh_normals(band.surface, points, -forward, 0.25 * band.h)
    return 0.35 + 0.65 * np.abs(n @ light)


def _mesh_normals(surface, points, towards, step):
    off = points + step * towards
    cp = surface.closest_point(off)[0]
    n = off - cp
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
