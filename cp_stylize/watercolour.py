"""Watercolour: washes of transparent pigment on grained paper.

After Curtis, Anderson, Seims, Fleischer and Salesin, "Computer-generated
watercolor" (1997), who list the effects a painter's washes show, and
Bousseau, Kaplan, Thollot and Sillion, "Interactive watercolor rendering with
temporal coherence and abstraction" (2006), who lay them over a simplified
picture by one rule, a pigment density ``d`` (1: the wash as it is) that
darkens or lightens a colour.  Here the colour is taken as the light a layer
of pigment lets through, in linear light, so ``d`` layers let through
``T ** d``: white paper stays white, and a hue keeps its hue (deeper where
more pigment lies).

:class:`Watercolour` paints at the texels of the bake-out (``paint=`` of
:func:`cp_stylize.baking.bake_to_atlas`), over the picture simplified before
it (the smoothing, and the anisotropic Kuwahara filter, which flattens regions
of like colour):

- **washes:** the picture's lightness in a few flat washes, as the toon
  bands make them (:class:`cp_stylize.toon.Toon`), hue and chroma the
  picture's own, the chroma a little stronger (:data:`CHROMA`); thinner than
  the picture (:data:`DILUTION`), so the darks stay transparent; the lightest
  wash, where it is light, left as the paper (:data:`WHITE`);
- **wobble:** a smooth noise of the surface moves each wash's border where
  the lightness changes slowly, so that borders meander as a brush leaves them;
- **edge darkening:** where a darker wash was laid over a lighter one, its
  pigment pooled at its border as it dried: it darkens towards the border,
  inside it, over about :data:`RIM_TEXELS` texels, more in some places than in
  others; the lighter wash keeps its colour up to the border, so there is no
  outline;
- **bleeding:** where a second noise says so, the wash ran wet into the next,
  so the border is soft (spread over :data:`BLEED_TEXELS` texels) and has no
  dark rim;
- **granulation:** pigment settles in the paper's hollows, a fine noise of the
  surface that shows most in the dark washes, and lies a little unevenly over
  broad patches; the paper's own grain shows everywhere, faintly.

Every noise is a function of the point on the surface (:func:`solid_noise`),
in the object's own space: the paint runs on across UV seams and islands, is
the same at a sphere's poles as at its equator, and does not change as the
object is turned.  Reads no band columns and leaves no height.
"""

from __future__ import annotations

import numpy as np

from .texture import linear_to_srgb, srgb_to_linear
from .hatching import PAPER            # the same warm white paper as the ink's
from .oklab import from_oklab, to_oklab
from .toon import Toon

__all__ = ["solid_noise", "Watercolour", "PAPER"]

#: A wash darkens towards its border, inside it, over about this many texels of a 1024 x 1024 atlas; by up to
#: this share less from place to place, in patches of about this wavelength.
RIM_TEXELS, RIM_VARIES, RIM_WAVELENGTH = 4.0, 0.4, 0.15
#: Within a wash, this share of the picture's own changes of lightness stays (a wash is laid in glazes, not flat).
GLAZE = 0.3
#: The washes' chroma, this many times the picture's: transparent pigment keeps its colour.
CHROMA = 1.15
#: The lightest wash, where its lightness (OKLab) is above this, is left as the paper, up to this share.
WHITE, RESERVED = 0.75, 0.85
#: At Edge Darkening 1, a wash passes this share less light at its border ...
RIM_SHARE = 1.0
#: ... if it takes at least this share of the light (lighter washes pool less, bare paper none), as up to
#: this many layers more of its pigment.
PIGMENTED, RIM_LAYERS = 0.3, 3.0
#: A bled border spreads over about this many texels of a 1024 x 1024 atlas.
BLEED_TEXELS = 14.0
#: The washes' borders wobble with a noise of about this wavelength (object normalised to a diameter of 2),
#: by up to this many bands' widths at Wobble 1.
WOBBLE_WAVELENGTH, WOBBLE_BANDS = 0.12, 0.45
#: The noise that decides which borders bleed: about this wavelength.
BLEED_WAVELENGTH = 0.25
#: Granulation's grain: about this wavelength; at Granulation 1, the pigment's density varies by up to this
#: share about its mean; the paper's grain, everywhere, by this share of the light.
GRAIN_WAVELENGTH, GRAIN_DENSITY, PAPER_GRAIN = 0.012, 0.4, 0.03
#: A wash lays this many layers of the picture's colour: thinner than the picture (below 1), so its darks
#: stay transparent.
DILUTION = 0.75
#: Islands of one wash smaller than this many texels of a 1024 x 1024 atlas go to the wash around them.
ISLAND = 400
#: At Granulation 1, the washes' density varies by this share over broad patches (pigment unevenly laid), of
#: this wavelength.
FLOW_DENSITY, FLOW_WAVELENGTH = 0.25, 0.2


_MIX = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xC2B2AE3D27D4EB4F), np.uint64(0x165667B19E3779F9))


def _unit(h):
    """Numbers in [0, 1) from 64-bit integers (M,): their bits mixed (MurmurHash3's finaliser)."""
    h = h ^ (h >> np.uint64(33))
    h *= np.uint64(0xFF51AFD7ED558CCD)
    h ^= h >> np.uint64(33)
    h *= np.uint64(0xC4CEB9FE1A85EC53)
    h ^= h >> np.uint64(33)
    return (h >> np.uint64(11)).astype(np.float64) * (1.0 / 2**53)


def solid_noise(points, wavelength, seed=0, octaves=3):
    """A smooth random function of space at ``points`` (M, 3), in [0, 1] with mean 1/2, its features
    about ``wavelength`` across: value noise on a cubic lattice (smoothstep between the corners' random
    values), summed over ``octaves`` octaves, each half the size and half the strength of the one before,
    each lattice turned and shifted so that their cells do not line up."""
    points = np.asarray(points, dtype=np.float64)
    rng = np.random.default_rng([int(seed), 77])
    total, weights = np.zeros(len(points)), 0.0
    for octave in range(int(octaves)):
        turn, _ = np.linalg.qr(rng.standard_normal((3, 3)))
        p = (points @ turn) / (wavelength * 0.5 ** octave) + rng.random(3) * 1000.0
        base = np.floor(p)
        f = p - base
        w = f * f * (3.0 - 2.0 * f)
        cells = base.astype(np.int64).view(np.uint64)
        salt = np.uint64((int(seed) * 8 + octave) * 0x27D4EB2F165667C5 % 2**64)
        # each axis's two lattice lines, hashed once; a corner's hash is their exclusive or
        keys = [(cells[:, a] * _MIX[a], (cells[:, a] + np.uint64(1)) * _MIX[a]) for a in range(3)]
        sides = [(1.0 - w[:, a], w[:, a]) for a in range(3)]
        value = np.zeros(len(points))
        for i in (0, 1):
            for j in (0, 1):
                xy, wxy = keys[0][i] ^ keys[1][j] ^ salt, sides[0][i] * sides[1][j]
                for k in (0, 1):
                    value += wxy * sides[2][k] * _unit(xy ^ keys[2][k])
        strength = 0.5 ** octave
        total += strength * (value - 0.5)
        weights += strength
    # a value noise's sum of corners is about half as wide as the uniform; widen it back to about [0, 1]
    return np.clip(0.5 + 1.6 * total / weights, 0.0, 1.0)


class Watercolour:
    """Watercolour at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`): see the module's
    notes.

    ``levels`` washes of lightness (at least 2), on a ``size`` x ``size`` atlas; ``edges`` (0 to 1): how
    much pigment pools at a wash's border; ``granulation`` (0 to 1): how much the pigment settles in the
    paper's grain; ``bleed`` (0 to 1): the share of borders where one wash ran into the next; ``wobble``
    (0 to 1): how far borders meander; ``paper`` (sRGB): the paper's colour."""

    columns = None

    def __init__(self, levels, size, *, edges=0.5, granulation=0.5, bleed=0.3, wobble=0.5, paper=PAPER, seed=0):
        self.levels, self.size = int(levels), int(size)
        self.edges, self.granulation, self.bleed, self.wobble = float(edges), float(granulation), float(bleed), \
            float(wobble)
        self.paper, self.seed = np.asarray(paper, dtype=np.float64), int(seed)

    def bled(self, points):
        """How far (M,) in [0, 1] each border at the surface points ``points`` (M, 3) has bled (0: a hard edge,
        1: wet into wet): about the ``bleed`` share of the surface, in patches, softly bounded."""
        if self.bleed <= 0:
            return np.zeros(len(points))
        noise = solid_noise(points, BLEED_WAVELENGTH, self.seed + 2, octaves=2)
        threshold = np.quantile(noise, 1.0 - self.bleed) if self.bleed < 1 else -1.0
        return np.clip((noise - threshold) / 0.06 + 0.5, 0.0, 1.0)

    def __call__(self, texels, colours, read, progress=None):
        from scipy import ndimage

        from .raster import nearest_filled, nearest_texels

        colours = np.asarray(colours)
        flat, points = texels[0], np.asarray(texels[1], dtype=np.float64)
        scale = self.size / 1024.0
        shift = None
        if self.wobble > 0:
            noise = solid_noise(points, WOBBLE_WAVELENGTH, self.seed, octaves=2)
            shift = self.wobble * WOBBLE_BANDS * 2.0 * (noise - 0.5)
        out, position, _ = Toon(self.levels, 0.0, self.size, island=ISLAND).bands(texels, colours, shift=shift)
        if progress is not None:
            progress(0.4)
        # in the atlas, whose margin texels continue the surface past each chart's edge: how far each texel
        # lies from the nearest border between washes, and from the nearest border of its own wash where the
        # next wash is lighter (the darker wash was laid over the lighter and dried there)
        nearest = nearest_texels(flat, self.size)
        wash = nearest_filled(np.rint(position), flat, self.size, nearest)
        border = _beside(wash, np.not_equal)               # the texels on either side of a step
        edge = _beside(wash, np.less)                      # those on its darker side
        away = ndimage.distance_transform_edt(~border).ravel()[flat]
        inward, (rows, cols) = ndimage.distance_transform_edt(~edge, return_indices=True)
        inward = np.where(wash.ravel()[flat] == wash[rows, cols].ravel()[flat], inward.ravel()[flat], np.inf)
        bled = self.bled(points)
        if bled.any():       # wet into wet: the washes run into each other across their border
            spread = bled * np.exp(-away / (BLEED_TEXELS * scale))
            for c in range(3):
                blurred = ndimage.gaussian_filter(nearest_filled(out[:, c], flat, self.size, nearest),
                                                  BLEED_TEXELS * scale / 2.0)
                out[:, c] += spread * (blurred.ravel()[flat] - out[:, c])
        # layers of pigment: fewer than the picture's, so the darks stay transparent; grained and unevenly laid
        uneven = solid_noise(points, FLOW_WAVELENGTH, self.seed + 3, octaves=2)
        grain = solid_noise(points, GRAIN_WAVELENGTH, self.seed + 1, octaves=2)
        density = DILUTION * (1.0 + self.granulation * FLOW_DENSITY * 2.0 * (uneven - 0.5)) * \
            (1.0 + self.granulation * GRAIN_DENSITY * 2.0 * (grain - 0.5))
        lab = to_oklab(out[:, :3])
        lab[:, 0] += GLAZE * (to_oklab(colours[:, :3])[:, 0] - lab[:, 0])       # soft gradients within a wash
        lab[:, 1:] *= CHROMA
        # the lightest wash, where it is light, left as the paper
        top = np.clip(position - (self.levels - 1.5), 0.0, 1.0) * np.clip((lab[:, 0] - WHITE) / 0.05, 0.0, 1.0)
        out[:, :3] = from_oklab(lab)
        density *= 1.0 - RESERVED * top
        paper = srgb_to_linear(self.paper)
        light = np.clip(srgb_to_linear(np.clip(out[:, :3], 0.0, 1.0)) / paper, 0.0, 1.0)   # what the pigment passes
        passed = light ** np.maximum(density, 0.0)[:, None]
        # where a wash dried hard, its pigment pooled at the border: the same share darker in every wash that
        # has pigment to pool (none on bare paper)
        mean = passed.mean(axis=1)
        pooled = 1.0 - RIM_VARIES * solid_noise(points, RIM_WAVELENGTH, self.seed + 4, octaves=2)
        share = RIM_SHARE * self.edges * np.clip((1.0 - mean) / PIGMENTED, 0.0, 1.0) * pooled * \
            np.exp(-inward / (RIM_TEXELS * scale)) * (1.0 - bled)
        # as more layers of the wash's own pigment (deeper in its hue, not greyer): as many as take that share
        more = np.log1p(-share) / np.log(np.clip(mean, 1e-6, 1.0 - 1e-6))
        passed **= 1.0 + np.minimum(more, RIM_LAYERS)[:, None]
        paper = paper * (1.0 - PAPER_GRAIN * self.granulation * 2.0 * (0.5 - grain))[:, None]
        out[:, :3] = linear_to_srgb(paper * passed)
        if progress is not None:
            progress(1.0)
        return out, None


def _beside(image, relation):
    """The texels (H, W) of ``image`` (H, W) that stand in ``relation`` (``relation(texel, neighbour)``, such as
    :func:`numpy.less`) to at least one of their four neighbours."""
    found = np.zeros(image.shape, dtype=bool)
    found[1:] |= relation(image[1:], image[:-1])
    found[:-1] |= relation(image[:-1], image[1:])
    found[:, 1:] |= relation(image[:, 1:], image[:, :-1])
    found[:, :-1] |= relation(image[:, :-1], image[:, 1:])
    return found
