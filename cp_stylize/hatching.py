"""Ink hatching: lines of ink at a set spacing on the surface, along the stroke field, denser in the darks.

A pen drawing renders tone by lines, not by grey: parallel lines where the
form is in light shadow, a second layer crossing them in the half-dark, a
third in the deepest darks, and the paper left white between them (Praun,
Hoppe, Webb and Finkelstein, "Real-time hatching", SIGGRAPH 2001, lay tone so
in layers of strokes).  Here the lines are the level set of a phase on the
surface itself, so they run on across UV seams and keep their spacing on the
surface whatever the charts' scale:

- **phasor noise** (Tricard, Efremov, Zanni, Neyret, Martínez and Lefebvre,
  "Procedural phasor noise", SIGGRAPH 2019): a sum of complex Gabor kernels
  at points spread over the surface, each a Gaussian of deviation
  :data:`KERNEL_SIGMA` spacings oscillating once a ``spacing`` across the
  local line direction.  The argument of the sum is a phase that rises by
  ``2 pi`` a spacing across the lines, whatever the kernels' amplitudes; a
  line is drawn where it is near 0;
- the kernels' own phases are **aligned** first: they begin as one plane
  wave (each kernel's phase at its centre is that of a wave across its own
  direction through the origin, so a uniform field gives straight lines at
  once), then a few sweeps let each kernel take the argument of its
  neighbours' sum at its centre, so that neighbours agree, and lines run on unbroken and parallel where the
  direction field is calm; they fork or end only where it turns, as a hand
  hatching does.  The direction is a line field (``d`` and ``-d`` alike):
  a neighbour whose direction points the other way enters with its
  frequency and phase negated, which is the same oscillation;
- **the direction** is a given field where it has one (the form's, or the
  picture's horizontal: :func:`cp_stylize.pipeline.hatching`), else the
  picture's structure over :data:`FIELD_SCALE` spacings
  (:class:`~cp_stylize.stroke_field.StrokeField`); the second layer is
  turned by ``angle`` and the third by half of it (0, 90 and 45 degrees by
  default, as an engraver crosses);
- **tone**: the ink each texel asks for is the darkness of the filtered
  colours there, each lightness first moved away from the picture's broad
  lightness around it (:data:`LOCAL`, :data:`BROAD`), then taken from clean
  paper at the picture's light tones (:data:`LIGHTEST`) to near-solid ink at
  its darkest (:data:`DARKEST`), the mid-tones open (:data:`TONE_POWER`).
  With ``light``, a light fixed to the object (:data:`LIGHT`) shades the
  tones first, as an illustrator models a form in line (Praun et al. lay
  their hatching by the light's angle), so an even tone still shows the
  form's turn.  The first layer's lines widen with it up to :data:`WIDEST` of a spacing;
  from there the second layer covers what is still asked for, then the
  third, which swells up to ``swell`` (:data:`DEEPEST` by default; towards 1
  the darkest tones fill with ink cut only by thin white lines, as a
  woodcut's, and at 1 with solid ink), so the ink builds up smoothly,
  layer on layer, without patches where a layer switches on.  A layer that
  should cover less than its narrowest line (:data:`LINE_MIN`) is drawn as
  dashes of that line, as many as make up its share (a smooth noise on the
  surface chooses which stretches); alike, where the swollen lines leave a
  white line narrower than that between them, it is cut as dashes of that
  width and the ink closes between them, so the darks keep clean white cuts
  instead of grey hairlines.  With ``smooth``, the widths follow the filtered
  picture's tone smoothed along the lines over that many spacings (Diewald
  and Rumpf's flow diffusion along their direction), so a line swells and
  thins smoothly instead of beading over fine detail, and a step of the tone
  across the lines stays a step (an edge that the lines cross is softened:
  the price of smooth lines);
- every line's edge is anti-aliased over one texel, from its distance to the
  line's centre (the phase's distance from 0 over its rate of change).

Lengths are those of the object normalised to a diameter of 2.
"""

from __future__ import annotations

import numpy as np

from .arrays import smooth_step
from .oklab import to_oklab
from .smoothing import GridGaussian, taper
from .stroke_field import StrokeField, Swirls
from .strokes import _spread

__all__ = ["Hatching", "INK", "PAPER"]

#: The kernels' Gaussians have this deviation, and are spread about one in a cube of this side, in spacings.
KERNEL_SIGMA = 0.6
KERNEL_CELL = 0.6
#: A kernel reaches this many deviations; a point sums at most this many kernels.
REACH = 2.5
NEIGHBOURS = 24
#: Sweeps of the kernels' phase alignment.
SWEEPS = 40
#: The direction follows the picture's structure over this many spacings.
FIELD_SCALE = 8.0
#: A layer's lines are at most this wide (a share of the spacing); the last layer's swell to ``swell`` (by
#: default :data:`DEEPEST`) in the darkest tones, so that those read as near-solid ink.
WIDEST, DEEPEST = 0.35, 0.55
#: The narrowest line (a share of the spacing): a layer that should cover less is drawn as dashes this wide;
#: and the narrowest white line between swollen lines: one that should be narrower is cut as dashes this wide,
#: the ink closed between them.
LINE_MIN = 0.15
#: With ``smooth``, the tone the lines' widths follow is smoothed across them by this share of the smoothing
#: along them (a step of the tone across the lines stays a step).
ACROSS = 0.02
#: The dashes' noise varies over about this many spacings; each layer reads it moved by this (in spacings).
DASH_SCALE = 2.5
DASH_SHIFT = np.array([7.3, -3.1, 5.7])
#: The lines are at least this many texels apart where the atlas's texels are longest (its 90th percentile):
#: a line too fine for its texels would turn grey.
MIN_TEXELS = 7.0
#: The darkness runs from 0 at this quantile of the picture's lightness (and lighter: clean paper) to 1 at
#: this one (and darker: near-solid ink), linearly between.
LIGHTEST, DARKEST = 0.85, 0.02
#: ... raised to this power: the mid-tones a little lighter than their place between, as a pen drawing keeps
#: its middle values open and saves the solid ink for the darkest.
TONE_POWER = 1.5
#: Before that, each lightness is moved away from the picture's broad light and dark around it (its lightness
#: blurred over :data:`BROAD` of the object, on the surface) by this share of the difference: a dark picture
#: keeps its forms in the ink instead of one mesh of crossing lines.
LOCAL, BROAD = 1.0, 0.15
#: The form light's direction in the object's own space (towards the light): from the upper left front, as
#: Blender's front view sees the object (its front faces -Y, up is +Z).  A surface turned from it keeps this
#: share of its lightness at full ``light``.
LIGHT = np.array([-0.45, -0.6, 0.66]) / np.linalg.norm([-0.45, -0.6, 0.66])
SHADOW = 0.3
#: The ink and the paper (sRGB) without a palette.
INK = (0.05, 0.045, 0.05)
PAPER = (0.97, 0.955, 0.92)
#: Texels whose ink is found at once.
_CHUNK = 65536


def _rotated(direction, normals, angle):
    """Tangent ``direction`` (M, 3) turned by ``angle`` (radians) about ``normals`` (M, 3)."""
    return np.cos(angle) * direction + np.sin(angle) * np.cross(normals, direction)


class _Layer:
    """One layer's kernels: centres (n, 3), across-line directions (n, 3), unit phases (n,) complex."""

    def __init__(self, centres, across, phases):
        self.centres, self.across, self.phases = centres, across, phases


class Hatching:
    """Ink hatching at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): the texels'
    colours become paper and ink (see the module's notes).  Reads the picture's broad lightness (its band
    column, :attr:`columns`) at the texels and leaves no height.

    Parameters
    ----------
    mesh : TriangleMesh
        The surface (normalised to a diameter of 2).
    band : Band
    atlas : Atlas
        The output's atlas (its texels' lengths anti-alias the lines).
    structure : ndarray, shape (N, C)
        Band values whose structure the lines follow (OKLab).
    tone : ndarray, shape (N,), optional
        The filtered picture's OKLab lightness on the band, whose values smoothed along the lines (``smooth``)
        set the lines' widths; default the lightness of the colours at the texels.
    spacing : float
        The lines' spacing on the surface (at least :data:`MIN_TEXELS` of the atlas's longest texels).
    layers : int
        How many layers of lines the darkest tones take (1 to 3).
    angle : float
        Degrees the second layer is turned from the first (the third: half of it).
    ink : float in [0, 1]
        How much ink the tones take: 0.5 the picture's own values, towards 1 darker, towards 0 lighter.
    swell : float in [WIDEST, 1]
        How wide the last layer's lines grow in the darkest tones (a share of the spacing).
    light : float in [0, 1]
        How much the form light (:data:`LIGHT`) shades the tones.
    smooth : float
        How far ``tone`` is smoothed along the lines (a Gaussian's deviation, in spacings).
    field, level : ndarray, shape (N, 3), optional
        Where the lines run (see :meth:`cp_stylize.stroke_field.StrokeField.at`): ``field`` where its length is
        1 (:func:`cp_stylize.pipeline.hatching` gives the form's direction, or the picture's horizontal), the
        picture's structure elsewhere.
    colours : (ink, paper), optional
        sRGB colours of the ink and the paper (default :data:`INK`, :data:`PAPER`).
    seed : int
    """

    def __init__(self, mesh, band, atlas, structure, spacing, *, tone=None, layers=3, angle=90.0, ink=0.5, swell=DEEPEST,
                 light=0.0, smooth=0.0, field=None, level=None, colours=None, seed=0):
        from scipy.spatial import cKDTree

        from .baking import texel_lengths

        if not 1 <= int(layers) <= 3:
            raise ValueError(f"hatching layers must be 1 to 3, got {layers!r}")
        if not WIDEST <= float(swell) <= 1.0:
            raise ValueError(f"hatching swell must be {WIDEST} to 1, got {swell!r}")
        self.mesh, self.atlas, self.layers, self.swell = mesh, atlas, int(layers), float(swell)
        self.light, self.smooth = float(light), float(smooth)
        longest = float(np.quantile(texel_lengths(mesh, atlas, atlas.face), 0.9)) if len(atlas.face) else 0.0
        self.spacing = max(float(spacing), MIN_TEXELS * longest)
        self.shift = float(ink) - 0.5
        ink_colour, paper = (INK, PAPER) if colours is None else colours
        self.ink, self.paper = np.asarray(ink_colour, np.float64), np.asarray(paper, np.float64)
        self.frequency = 2.0 * np.pi / self.spacing
        self.sigma = KERNEL_SIGMA * self.spacing
        rng = np.random.default_rng([int(seed), 11])
        cell = KERNEL_CELL * self.spacing
        points, faces, bary = mesh.sample(int(4 * mesh.area / cell**2) + 16, rng)
        keep = _spread(points, cell, rng)
        points, faces, bary = points[keep], faces[keep], bary[keep]
        normals = mesh.normal(points, faces, bary)
        lines = StrokeField.layers(band, structure, [FIELD_SCALE * self.spacing])[0]
        lightness = np.ascontiguousarray(np.asarray(structure, np.float32)[:, :1].T)
        weights = taper(band.dist, 3.0 * band.h)
        broad = GridGaussian(band, 0.5 * BROAD**2, weights=weights)(lightness)[0]
        columns = [broad]
        if tone is not None and self.smooth > 0:
            columns.append(self._along_lines(band, lines, tone, field, level, weights))
        self.columns = np.stack(columns, axis=1).astype(np.float32)     # read at the texels (see __call__)
        along = lines.at(points, normals, field=field, level=level)
        self.normals, self.piece = normals, mesh.piece[faces]
        self.tree = cKDTree(points)
        near, index = self.tree.query(points, k=NEIGHBOURS + 1, distance_upper_bound=REACH * self.sigma)
        near, index = near[:, 1:], index[:, 1:]
        self._layers = []
        for k in range(self.layers):
            turn = np.radians(angle) * (0.0, 1.0, 0.5)[k]
            across = np.cross(normals, _rotated(along, normals, turn))
            phases = np.exp(1j * self.frequency * np.einsum("ij,ij->i", across, points))     # one plane wave
            layer = _Layer(points, across, phases)
            layer.phases = self._aligned(layer, near, index)
            self._layers.append(layer)
        self.dashes = Swirls(DASH_SCALE * self.spacing, seed)      # its omega and phases: a smooth noise

    def _along_lines(self, band, lines, tone, field, level, weights):
        """The band's ``tone`` (N,) smoothed along the first layer's lines (``smooth``): Diewald and
        Rumpf's flow diffusion along their direction, which leaves the tone's steps across the lines as they
        are; on a band without the anisotropic stencil, a Gaussian on the surface."""
        from .diffusion import diffuse
        from .tangent import surface_normals

        tone = np.asarray(tone, np.float32).reshape(-1)
        time = 0.5 * (self.smooth * self.spacing) ** 2
        if band.stencil != "anisotropic":
            return GridGaussian(band, time, weights=weights)(tone[None, :])[0]
        normals = np.asarray(surface_normals(band), dtype=np.float64)
        direction = lines.at(band.cp.astype(np.float64), normals, field=field, level=level)
        return diffuse(band, tone, mode="flow", T=time, field=direction, sigma=0.0, alpha=1.0, beta=ACROSS,
                       lambda_rel=1.0, contrast=0.0, ink=0.0)

    def _waves(self, layer, at, normals, piece, near, index, reference):
        """The kernels ``index`` (M, K) at distances ``near`` (M, K) from the points ``at`` (M, 3) with normals
        (M, 3) on pieces (M,): their Gaussians times their oscillations (M, K) without their own phases, and
        the sign (M, K) of each one's direction against ``reference`` (M, 3); 0 for kernels of another piece
        or facing away, or out of reach."""
        n = len(layer.centres)
        valid = index < n
        safe = np.where(valid, index, 0)
        valid &= (self.piece[safe] == piece[:, None]) & (np.einsum("mkc,mc->mk", self.normals[safe], normals) > 0.3)
        across = layer.across[safe]
        sign = np.where(np.einsum("mkc,mc->mk", across, reference) < 0, -1.0, 1.0)
        offset = np.einsum("mkc,mkc->mk", across, at[:, None, :] - layer.centres[safe])
        gauss = np.exp(-0.5 * (np.where(valid, near, 0.0) / self.sigma) ** 2) * valid
        return gauss * np.exp(1j * self.frequency * sign * offset), sign, safe

    @staticmethod
    def _signed(phases, sign):
        """Unit phases (M, K) of kernels whose direction points the other way (``sign`` < 0) negated."""
        return np.where(sign > 0, phases, np.conj(phases))

    def _aligned(self, layer, near, index):
        """The kernels' phases (n,) aligned with their neighbours' (see the module's notes)."""
        waves, sign, safe = self._waves(layer, layer.centres, self.normals, self.piece, near, index, layer.across)
        phases = layer.phases
        for _ in range(SWEEPS):
            total = np.sum(waves * self._signed(phases[safe], sign), axis=1) + phases
            size = np.abs(total)
            phases = np.where(size > 1e-12, total / np.maximum(size, 1e-12), phases)
        return phases

    def phase(self, layer, at, normals, piece):
        """The phase (M,) of layer ``layer`` at surface points ``at`` (M, 3) with normals (M, 3) on pieces (M,)."""
        near, index = self.tree.query(at, k=NEIGHBOURS, distance_upper_bound=REACH * self.sigma)
        kernels = self._layers[layer]
        reference = kernels.across[np.minimum(index[:, 0], len(kernels.centres) - 1)]
        waves, sign, safe = self._waves(kernels, at, normals, piece, near, index, reference)
        return np.angle(np.sum(waves * self._signed(kernels.phases[safe], sign), axis=1))

    def shading(self, normals):
        """The share (M,) of their lightness that points with unit ``normals`` (M, 3) keep under the form light:
        1 facing it (or without it), down to :data:`SHADOW` at full ``light`` where they turn away."""
        facing = np.clip(np.asarray(normals, np.float64) @ LIGHT, 0.0, 1.0)
        return 1.0 - self.light * (1.0 - SHADOW) * (1.0 - facing)

    def darkness(self, lightness):
        """The ink each lightness (M,) asks for, in [0, 1]: its place between the picture's lightest and darkest
        (:data:`LIGHTEST`, :data:`DARKEST`), shifted by the ink."""
        if not len(lightness):
            return np.zeros(0)
        dark, light = np.quantile(lightness, [DARKEST, LIGHTEST])
        return np.clip(np.clip((light - lightness) / max(light - dark, 1e-3), 0.0, 1.0) ** TONE_POWER + self.shift,
                       0.0, 1.0)

    def widths(self, darkness):
        """Each layer's line width (layers, M) as a share of the spacing, for the ink ``darkness`` (M,) asks
        for: each layer in turn covers what the layers before leave of it, up to :data:`WIDEST` (the last up to
        ``swell``), so the ink builds up smoothly, layer on crossing layer, with the tone."""
        clear = np.ones_like(darkness)
        found = []
        for k in range(self.layers):
            widest = self.swell if k == self.layers - 1 else WIDEST
            width = np.clip(1.0 - (1.0 - darkness) / np.maximum(clear, 1e-9), 0.0, widest)
            clear = clear * (1.0 - width)
            found.append(width)
        return np.array(found)

    def _noise(self, at):
        """A smooth noise in [0, 1] at surface points (M, 3): the dashes' (spread about evenly)."""
        from scipy.special import erf

        waves = np.cos(at @ self.dashes.omega.T + self.dashes.phase).sum(axis=1) / np.sqrt(len(self.dashes.phase))
        return 0.5 + 0.5 * erf(waves)          # a sum of cosines of random phase has a variance of 1/2

    def ink_at(self, at, normals, piece, lengths, darkness):
        """How much ink (M,) in [0, 1] the points ``at`` (M, 3) take, at texels ``lengths`` (M,) long, for the ink
        ``darkness`` (M,) asks for (see :meth:`widths`): each layer's lines at their width, and a layer narrower
        than :data:`LINE_MIN` as dashes that wide, as many as make up its share."""
        clear = np.ones(len(at))
        widths = self.widths(darkness)
        for k in range(self.layers):
            here = widths[k] > 0
            if not here.any():
                continue
            phase = self.phase(k, at[here], normals[here], piece[here])
            width = np.clip(widths[k][here], LINE_MIN, 1.0 - LINE_MIN)
            distance = np.abs(phase) / self.frequency
            line = np.clip(0.5 + (0.5 * width * self.spacing - distance) / lengths[here], 0.0, 1.0)
            share = widths[k][here] / LINE_MIN                          # of the dashes: 1 and more, whole lines
            noise = self._noise(at[here] + k * self.spacing * DASH_SHIFT)
            drawn = smooth_step((share - noise) / 0.1 + 0.5)
            cut = (1.0 - widths[k][here]) / LINE_MIN                    # of the white cuts: 1 and more, whole
            closed = np.where(cut < 1.0, smooth_step((noise - cut) / 0.1 + 0.5), 0.0)
            ink = line * drawn
            clear[here] *= 1.0 - (ink + (1.0 - ink) * closed)
        return 1.0 - clear

    def __call__(self, texels, colours, read, progress=None):
        from .baking import texel_lengths

        flat, points, faces, barys = texels
        mesh = self.mesh
        normals = mesh.normal(points, faces, barys)
        piece = mesh.piece[faces]
        lengths = texel_lengths(mesh, self.atlas, faces)
        read = None if read is None else np.asarray(read, np.float64).reshape(len(points), -1)
        if read is not None and read.shape[1] > 1:      # the tone smoothed on the surface
            lightness = read[:, 1]
        else:
            lightness = to_oklab(np.asarray(colours)[:, :3].astype(np.float64))[:, 0]
        if read is not None:                  # away from the broad light and dark around it
            lightness = lightness + LOCAL * (lightness - read[:, 0])
        lightness = lightness * self.shading(normals)
        darkness = self.darkness(lightness)
        amount = np.empty(len(points))
        for s in range(0, len(points), _CHUNK):
            part = slice(s, s + _CHUNK)
            amount[part] = self.ink_at(points[part], normals[part], piece[part], lengths[part], darkness[part])
            if progress is not None:
                progress(min(1.0, (s + _CHUNK) / max(len(points), 1)))
        out = np.array(colours, dtype=np.float64)
        out[:, :3] = self.paper + amount[:, None] * (self.ink - self.paper)
        return out, None
