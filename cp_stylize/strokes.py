"""Brush strokes at the texture's own resolution, drawn along a line field on the surface.

The band holds the filtered colours at the grid's resolution; painterly
strokes want to be finer and longer than the diffusion alone draws them (its
strokes are a few grid spacings wide, and bend with the structure they
follow).  :class:`Strokes` lays strokes over the texels of the bake-out, seed
004's flow texture done as a line integral convolution:

- a solid value noise (:func:`solid_noise`), whose cells are the strokes'
  width, is defined in 3-D around the surface, so it has no seams and does
  not stretch;
- each texel's surface point follows the band's line field (:func:`line_field`)
  both ways for half the stroke length, step by step on the tangent plane of
  the nearest band point's closest point, and averages the noise along the
  way: long thin streaks along the field;
- the streaks shift each texel's tone rank, and the shifted rank picks its
  palette colour (as :func:`cp_stylize.noise.tone_noise` does for band
  points): strokes of the palette's colours, in the picture's tones.

Lengths are those of the object normalised to a diameter of 2, so the
strokes look the same on an object of any size.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .diffusion import GridSmoothing
from .noise import LUMA, palette_by_tone
from .sparse import map_parallel
from .structure import eigen_2x2, reduce_to_tangent
from .tangent import surface_normals, tangent_basis

__all__ = ["Strokes", "line_field", "solid_noise", "streaks", "streak_steps"]

#: Steps of a streak each way, per stroke length over width (at least 4, at most 32): a step of
#: about a noise cell.
_STEPS_PER_ASPECT = 0.5
#: Band closest points (about) the streaks' mean and deviation are measured on.
_SAMPLE = 1 << 14
#: Texels a streak works on at once.
_CHUNK = 1 << 16
#: A streak stops where the surface it walks on turns by more than this (cosine of the angle
#: between the normals of two steps), or onto another piece of the mesh: it has crossed to another
#: sheet (an ear's other side, an eyeball in its socket).
_SAME_SHEET = 0.5


class Strokes:
    """What :func:`cp_stylize.baking.bake_to_atlas` needs to paint strokes over its texels.

    ``field`` (N, 3) is a unit tangent line field at the band points (see
    :func:`line_field`); ``tones`` the band's tones that ranks are counted
    among; ``palette`` (K, 3) and ``weights`` (K,) the colours and the share
    of the tones each takes; ``strength`` in [0, 1] blends the strokes over
    the filtered colours; ``length`` and ``width`` are in the band's units;
    ``spread`` is how far a streak moves a texel's tone rank (its standard
    deviation, as a share of the tones).
    """

    def __init__(self, band, field, tones, palette, weights, *, strength, length, width, spread, seed=0):
        self.band = band
        self.tones = np.sort(np.asarray(tones, dtype=np.float64))
        self.palette = np.asarray(palette, dtype=np.float64)
        self.weights = None if weights is None else np.asarray(weights, dtype=np.float64)
        self.strength, self.length, self.width = float(strength), float(length), float(width)
        self.spread, self.seed = float(spread), int(seed)
        # what a streak's step reads at its nearest band point, gathered at once: the field, the
        # normal and the closest point (and, on a mesh, the connected piece, which a streak keeps to)
        pieces = np.zeros(band.size) if band.pieces is None else band.pieces
        self.frame = np.column_stack([field, surface_normals(band), band.cp, pieces]).astype(np.float64)
        self.lattice = _lattice(self.seed)
        self.scale = None           # the streaks' mean and deviation (streaks)

    def __call__(self, points, colours, progress=None):
        """The texels' colours (M, C) with the strokes laid over them, at their surface points (M, 3);
        ``progress(fraction)`` as the streaks advance (an exception it raises stops them)."""
        colours = np.asarray(colours)
        s = streaks(self, points, progress)
        tone = colours[:, :3].astype(np.float64) @ LUMA
        rank = np.searchsorted(self.tones, tone) / max(len(self.tones), 1)
        painted = palette_by_tone(rank + self.spread * s, self.palette, self.weights)
        out = colours.astype(np.float64, copy=True)
        out[:, :3] += self.strength * (painted - out[:, :3])
        return out.astype(colours.dtype, copy=False)


def line_field(band, values, rho, dtype=np.float32):
    """Unit stroke directions (N, 3) along the structure of band values (N, C): the smaller
    eigenvector of their tangent structure tensor integrated over ``rho`` (a time; deviation
    ``sqrt(2 rho)``), as a line field (its sign is arbitrary)."""
    smoothing = GridSmoothing(band, dtype, {"sigma": 0.0, "rho": float(rho)})
    for build in smoothing.builds():
        build()
    rows = np.ascontiguousarray(np.asarray(values, dtype=dtype).reshape(band.size, -1).T)
    J = smoothing.tensor(rows)
    q0, q1 = np.ascontiguousarray(tangent_basis(band).transpose(2, 1, 0), dtype=dtype)
    _, _, c, s = eigen_2x2(*reduce_to_tangent(J, q0, q1))
    # (c, s) is across the structure (the gradient's direction); the strokes run at right angles
    return np.ascontiguousarray((q1 * c - q0 * s).T)


#: Cells a side of the periodic lattice of the solid noise (its period, in cells).
_PERIOD = 128
#: The noise's lattice is turned against the object's axes, so that its period lines up with none.
_TURN = np.linalg.qr(np.array([[2.0, 1.0, 0.3], [-0.7, 1.9, 0.8], [0.2, -1.1, 2.4]]))[0]


def _lattice(seed):
    return np.random.default_rng([int(seed), 4]).random((_PERIOD,) * 3, dtype=np.float32)


def solid_noise(points, cell, seed=0, lattice=None):
    """Value noise in [0, 1] at 3-D points (M, 3): random values on a lattice of spacing ``cell``
    (periodic every :data:`_PERIOD` cells, turned against the axes), interpolated trilinearly.
    Defined in space, so any surface reads it without seams; deterministic for a seed."""
    lattice = _lattice(seed) if lattice is None else lattice
    x = (_TURN.T * (1.0 / cell)) @ np.asarray(points, dtype=np.float64).T          # (3, M), contiguous
    return ndimage.map_coordinates(lattice, x, order=1, mode="grid-wrap", prefilter=False)


def streaks(strokes, points, progress=None):
    """Line integral convolution of :func:`solid_noise` along the strokes' field, at surface points
    (M, 3), about ``length`` long and ``width`` wide, scaled to mean 0 and standard deviation 1
    over the band's closest points (so a point's value depends on that point alone, and texels on
    either side of a seam read the same).

    From each point a streak walks ``n`` steps each way: the step goes along the field at the
    nearest band point (its sign kept from the step before), is laid onto the tangent plane of that
    point's closest point, and the noise is read where it lands.  A walk that leaves the band or
    turns onto another sheet stops; the point averages what it read.
    """
    if strokes.scale is None:
        sample = strokes.band.cp[:: max(1, strokes.band.size // _SAMPLE)]
        raw = _convolve(strokes, sample)
        strokes.scale = (float(raw.mean()), max(float(raw.std()), 1e-12))
    mean, std = strokes.scale
    return (_convolve(strokes, points, progress) - mean) / std


def streak_steps(length, width):
    """Steps a streak takes each way for strokes ``length`` long and ``width`` wide."""
    return int(np.clip(round(_STEPS_PER_ASPECT * length / width), 4, 32))


def _convolve(strokes, points, progress=None):
    band = strokes.band
    points = np.asarray(points, dtype=np.float64)
    n = streak_steps(strokes.length, strokes.width)
    step = 0.5 * strokes.length / n
    lattice = strokes.lattice
    frame = strokes.frame

    def walk(s):
        x0 = points[s:s + _CHUNK]
        total = solid_noise(x0, strokes.width, lattice=lattice)
        count = np.ones(len(x0))
        for sign in (1.0, -1.0):
            x = x0.copy()
            live = np.ones(len(x0), dtype=bool)
            heading = normal = None
            for _ in range(n):
                g = band.lookup(np.rint(x * (1.0 / band.h)).astype(np.int64))
                live &= g >= 0
                f = np.take(frame, np.where(live, g, 0), axis=0)
                e, nrm, cp = f[:, 0:3], f[:, 3:6], f[:, 6:9]
                if normal is not None:
                    live &= (np.abs(np.einsum("ij,ij->i", nrm, normal)) >= _SAME_SHEET) & (f[:, 9] == piece)
                    e *= np.where(np.einsum("ij,ij->i", e, heading) < 0, -1.0, 1.0)[:, None]
                else:
                    piece = f[:, 9]
                    e *= sign
                heading, normal = e, nrm
                x += (step * live)[:, None] * e
                # back onto the tangent plane of the nearest band point's closest point
                x -= (np.einsum("ij,ij->i", x - cp, nrm) * live)[:, None] * nrm
                total += live * solid_noise(x, strokes.width, lattice=lattice)
                count += live
        return total / count

    return np.concatenate([np.empty(0)] + map_parallel(walk, range(0, len(points), _CHUNK), progress))
