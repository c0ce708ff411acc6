"""A picture's colours mapped onto a painting's palette, by tone and by hue.

A painterly look paints the picture in a painting's colours.  Mapping by
tone alone (darks to the palette's darks, lights to its lights) loses what
the hues say: a grey sky and a yellow road marking of the same tone would
take the same colour.  :func:`map_to_palette` works in OKLab
(:mod:`cp_stylize.oklab`) and weighs both:

- **tone**: each colour's lightness rank among all the colours
  (:func:`tone_ranks`), so that the picture's tones spread over the
  palette's whatever its exposure; each
  palette colour takes the share of the ranks its weight asks for, and the
  lightness follows the palette's own at that rank;
- **hue**: where a colour and a palette colour both have a hue (a chroma
  above :data:`GREY`, counted from a fraction :data:`HUE_START` of it for the
  picture's colours), their hue difference counts too, so a yellow keeps to
  the palette's yellows and ochres, a red door to its warmest colour, a
  grey-blue overcast sky to the painting's blues, while a neutral grey
  takes whichever colour the palette gives its tone.  Hue counts in the
  picture's lighter tones only (from the tone rank :data:`HUE_FROM`, fully
  from :data:`HUE_FULL`): a dark brown or a dark green keeps to the
  palette's colours of its tone, rather than turn the palette's only warm
  colours, its light yellows, into stains.

``keep_values`` keeps the picture's own light and dark: from 0 (the equalised
ranks above) to 1, where a colour's place among the palette's tones is where
its own lightness lies among the palette colours' lightnesses, so that the
result's lightness is the picture's (within the palette's range) and the
palette chooses the hue and chroma: a dark forest floor stays dark, a pale
wall stays pale, whatever share of the tones the weights give each colour.
``keep_darks`` keeps more of it in the picture's darks than in its lights:
the share kept rises from ``keep_values`` towards 1 as the square of how
far a colour's tone rank lies below the lightest, so a forest's shade and
a wet asphalt stay as dark as the palette's darks allow, while its lights
still spread over the palette's light colours (a painter keys the darks to
the subject and paints the lights in the palette's own).

The palette colours are blended by how well they fit (a soft choice: no hard
splits where a tone crosses from one colour to the next).  ``fidelity``
then leads back to the picture's own colours: from 0 to 0.5 its hues turn
back (at 0.5 the picture's hues in the palette's tones and chroma), from 0.5
to 1 its lightness and chroma (at 1 the picture's colours).

``hue_snap`` turns the hues fidelity brings back to the palette's nearest (a
soft choice among the palette's hued colours, :data:`SNAP_SHARP`, those of
the colour's tone first), each at the chroma the palette gives its hue
family: at 1 a photograph's grey-blue sky takes a painting's pale
blue-green, where its own hue would be a lilac the painting never had, a
brown the palette's orange and sienna, and a green foliage the palette's
olive in its darks and its yellows in its lights.
"""

from __future__ import annotations

import numpy as np

from .arrays import unit_rows
from .oklab import from_oklab, to_oklab
from .sparse import map_parallel

__all__ = ["map_to_palette", "kept_chroma", "tone_ranks", "palette_noise", "palette_distance", "check_palette", "GREY",
           "jitter", "loaded"]

#: Chroma (OKLab) below which a colour's hue is not trusted: a grey's hue is noise.
GREY = 0.04
#: How far in tone ranks a colour may lie beyond a palette colour's share and still take it (a
#: Gaussian's deviation, as a share of the ranks).
TONE_REACH = 0.2
#: How far in hue a colour may lie from a palette colour and still take it (distance of unit hue
#: vectors: 0.5 is about 29 degrees).
HUE_REACH = 0.5
#: A picture colour's hue counts from a chroma of HUE_START * GREY on: the blue of a grey-blue overcast sky
#: (chroma about 0.4 GREY) keeps it to the palette's blues rather than an ochre of its tone, where a neutral grey
#: (asphalt, concrete) takes whichever colour the palette gives its tone.  The hue of a strongly coloured one
#: (chroma of (HUE_WEIGHT + HUE_START) * GREY or more) counts HUE_WEIGHT times as much as one at
#: (1 + HUE_START) GREY.
HUE_START = 0.25
HUE_WEIGHT = 3.0
#: Keep Darks keeps a colour's own lightness by this power of how dark its tone ranks (1 - rank): the
#: higher, the more it keeps to the deepest shadows alone.
DARKS_POWER = 2.0
#: A colour's hue counts from this tone rank on, and fully from HUE_FULL: the picture's darks keep to the
#: palette's colours of their tone, whatever their hue (a dark brown does not turn the palette's yellow).
HUE_FROM = 0.25
HUE_FULL = 0.5
#: Fidelity turns a colour's hue back to the picture's where its chroma is above this share of GREY:
#: the dark, dull colours of a photograph have hues that read, although too weak to choose by.
TURN_GREY = 0.25
#: The lightness of the result: this share from the palette's lightness at the colour's tone rank
#: (a smooth ramp that keeps the picture's tonal detail), the rest from the chosen colours.
TONE_KEEP = 0.85
#: That ramp is this share an even one, from the palette's darkest lightness to its lightest, and the
#: rest the palette's own lightness at the rank: a palette with many dark colours (a night's blues)
#: would otherwise put half the picture's tones within a few steps of lightness, and a street and the
#: buildings on it would merge into one dark mass.
TONE_SPREAD = 0.4
#: How sharply the palette colours that fit best win, for the lightness and for the hue and chroma (the
#: fit's exponent per unit of squared distance).
SOFT = 4.0
SHARP = 16.0
#: Palette colours of different hues that fit alike average to a duller colour than any of them (an
#: umber, an olive and a sienna to a grey mud): the blend's chroma is raised back towards the chosen
#: colours' own, by at most this factor (a blue and a yellow, opposite hues, still meet in a dull
#: colour rather than one whose hue is noise).
CHROMA_KEEP = 2.0
#: A picture's grey (asphalt, an overcast sky, concrete) keeps this share of the palette colour's
#: chroma, and a colour of chroma VIVID (OKLab) or more all of it: what is grey in the picture reads as
#: a muted colour in the painting, what is coloured as a strong one (unless ``hue_snap`` turns its hue to
#: the palette's: it then takes the chroma the palette gives that hue, as much as a colour's hue is turned).
MUTED = 0.7
VIVID = 0.08
#: How sharply ``hue_snap`` chooses the palette's hues nearest a colour's (the fit's exponent per unit of
#: 1 - cos of the hue difference: a palette hue 40 degrees off counts a hundredth of one that matches).
SNAP_SHARP = 20.0
#: Colours mapped at once.
_CHUNK = 1 << 16


def check_palette(palette, weights=None):
    """``(palette (K, 3) float64, weights (K,) summing to 1)``, or ValueError naming what is wrong."""
    palette = np.asarray(palette, dtype=np.float64)
    if palette.ndim != 2 or palette.shape[1] < 3 or len(palette) == 0:
        raise ValueError(f"palette must have shape (K, 3) with K >= 1, got {palette.shape}")
    if weights is None or len(weights) == 0:
        weights = np.ones(len(palette))
    weights = np.asarray(weights, dtype=np.float64)
    if weights.shape != (len(palette),) or not np.all(np.isfinite(weights)) or np.any(weights < 0) \
            or weights.sum() <= 0:
        raise ValueError(f"palette weights must be {len(palette)} non-negative numbers, not all zero")
    return palette[:, :3], weights / weights.sum()


#: Lightness bins of :func:`tone_ranks`, and the most ranks a bin may take, in multiples of an even share.
TONE_BINS = 256
TONE_SLOPE = 4.0


def tone_ranks(lightness):
    """Each lightness's rank (M,) in [0, 1] among all: an equalised histogram whose slope is limited.

    The ranks spread the picture's tones over [0, 1] whatever its exposure
    (histogram equalisation), but no bin of :data:`TONE_BINS` takes more
    than :data:`TONE_SLOPE` times an even share of the ranks (the rest is
    spread evenly, as contrast-limited equalisation does), and ranks are
    interpolated within a bin: nearly equal lightnesses get nearly equal ranks,
    so a flat or slowly graded region keeps one tone instead of splitting
    into the palette's far colours.
    """
    lightness = np.clip(np.asarray(lightness, dtype=np.float64), 0.0, 1.0)
    counts = np.bincount(np.minimum((lightness * TONE_BINS).astype(np.int64), TONE_BINS - 1),
                         minlength=TONE_BINS).astype(np.float64)
    if counts.sum() == 0:
        return lightness
    share = counts / counts.sum()
    for _ in range(8):                          # clip, and spread the excess evenly; a few rounds settle it
        limit = TONE_SLOPE / TONE_BINS
        excess = np.maximum(share - limit, 0.0).sum()
        share = np.minimum(share, limit) + excess / TONE_BINS
    edges = np.concatenate([[0.0], np.cumsum(share)])
    edges /= edges[-1]
    return np.interp(lightness, np.linspace(0.0, 1.0, TONE_BINS + 1), edges)


def map_to_palette(colours, palette, weights=None, *, fidelity=0.0, keep_values=0.0, keep_darks=0.0, hue_snap=0.0):
    """The colours (M, 3) mapped onto a palette by tone and hue (see the module's notes).

    Parameters
    ----------
    colours : ndarray, shape (M, C), C >= 3
        sRGB-encoded colours in [0, 1] (channels past the third are kept as they are).
    palette : sequence of colours, shape (K, 3)
        The painting's colours, sRGB-encoded.
    weights : sequence of K floats, optional
        The share of the picture's tones each palette colour takes (equal by default).
    fidelity : float in [0, 1]
        0: the palette's colours; 0.5: the picture's hues in the palette's
        tones; 1: the picture's own colours.
    keep_values : float in [0, 1]
        How much of the picture's own lightness is kept: 0 its tones spread
        over the palette's by rank, 1 its lightness (within the palette's).
    hue_snap : float in [0, 1]
        How far the hues fidelity brings back turn to the palette's nearest
        hues: 0 the picture's own, 1 the palette's.

    Returns
    -------
    ndarray, shape (M, C), float32
    """
    colours = np.asarray(colours)
    if colours.ndim != 2 or colours.shape[1] < 3:
        raise ValueError(f"colours must have shape (M, 3) or more channels, got {colours.shape}")
    if not 0.0 <= fidelity <= 1.0:
        raise ValueError(f"fidelity must lie in [0, 1], got {fidelity!r}")
    if not 0.0 <= keep_values <= 1.0:
        raise ValueError(f"keep_values must lie in [0, 1], got {keep_values!r}")
    if not 0.0 <= keep_darks <= 1.0:
        raise ValueError(f"keep_darks must lie in [0, 1], got {keep_darks!r}")
    if not 0.0 <= hue_snap <= 1.0:
        raise ValueError(f"hue_snap must lie in [0, 1], got {hue_snap!r}")
    palette, weights = check_palette(palette, weights)
    lab_palette = to_oklab(palette)
    order = np.argsort(lab_palette[:, 0], kind="stable")          # darkest first
    lab_palette, weights = lab_palette[order], weights[order]
    centres = np.cumsum(weights) - weights / 2                    # each colour's share of the ranks
    lab = to_oklab(colours[:, :3])
    ranks = tone_ranks(lab[:, 0])
    kept = keep_values + keep_darks * (1.0 - keep_values) * (1.0 - ranks) ** DARKS_POWER   # the share of the own lightness
    if np.any(kept > 0):        # the rank at which the palette's lightness is the colour's own
        ranks = (1.0 - kept) * ranks + kept * np.interp(lab[:, 0], lab_palette[:, 0], centres)
    out = np.empty((len(colours), 3))

    def chunk(s):
        part = slice(s, s + _CHUNK)
        out[part] = _mapped(lab[part], ranks[part], lab_palette, weights, centres, fidelity, kept[part],
                            hue_snap)

    map_parallel(chunk, range(0, len(colours), _CHUNK))
    result = colours.astype(np.float32, copy=True)
    result[:, :3] = from_oklab(out)
    return result


def _mapped(lab, ranks, lab_palette, weights, centres, fidelity, kept, hue_snap):
    """OKLab colours (M, 3) of :func:`map_to_palette` for OKLab ``lab`` (M, 3), tone ``ranks`` (M,) and the
    share of their own lightness ``kept`` (M,)."""
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    palette_chroma = np.hypot(lab_palette[:, 1], lab_palette[:, 2])
    # how much a hue counts: nothing for neutral greys (chroma up to HUE_START * GREY: asphalt), up to
    # HUE_WEIGHT times for strong colours (a saturated red must not turn blue however its tone ranks);
    # and whether a palette colour has a hue at all
    hued = np.clip(chroma / GREY - HUE_START, 0.0, HUE_WEIGHT)
    palette_hued = np.clip(palette_chroma / GREY, 0.0, 1.0)
    # distance in tone: how far the rank lies outside each colour's share
    tone = np.maximum(np.abs(ranks[:, None] - centres[None, :]) - weights[None, :] / 2, 0.0) / TONE_REACH
    # distance in hue: of the unit hue vectors, where both have a hue
    cos = (lab[:, 1:] @ lab_palette[:, 1:].T) / np.maximum(chroma[:, None] * palette_chroma[None, :], 1e-12)
    hued = hued * np.clip((ranks - HUE_FROM) / (HUE_FULL - HUE_FROM), 0.0, 1.0)
    d2 = tone**2 + hued[:, None] * palette_hued[None, :] * (2.0 - 2.0 * cos) / HUE_REACH**2
    # the lightness blends softly between colours that fit alike; the hue and chroma come from a far
    # sharper choice, so that between a blue and a yellow of one tone the blend is not their grey
    best = d2 - d2.min(axis=1, keepdims=True)
    mix = np.empty_like(lab)
    for sharpness, channels in ((SOFT, slice(0, 1)), (SHARP, slice(1, 3))):
        fit = np.exp(-sharpness * best) * weights[None, :]
        fit /= fit.sum(axis=1, keepdims=True)
        mix[:, channels] = fit @ lab_palette[:, channels]
    mix[:, 1:] = kept_chroma(mix[:, 1:], fit @ palette_chroma)
    darkest, lightest = lab_palette[0, 0], lab_palette[-1, 0]
    spread = TONE_SPREAD * (1.0 - kept)     # the picture's own lightness needs no spreading
    ramp = ((1.0 - spread) * np.interp(ranks, centres, lab_palette[:, 0])     # the palette's lightness at the
            + spread * (darkest + (lightest - darkest) * ranks))             # rank, spread evenly in part
    lightness = (1.0 - TONE_KEEP) * mix[:, 0] + TONE_KEEP * ramp
    # fidelity: the picture's hue first (full at 0.5), then its lightness and chroma
    turn = (min(1.0, 2.0 * fidelity) * np.clip(chroma / (TURN_GREY * GREY), 0.0, 1.0))[:, None]
    mix_chroma = np.hypot(mix[:, 1], mix[:, 2])[:, None]
    own_hue = lab[:, 1:] / np.maximum(chroma, 1e-12)[:, None]
    if hue_snap > 0:
        own_hue, mix_chroma = _snapped(own_hue, cos, tone, mix_chroma, lab_palette, palette_chroma, palette_hued,
                                       hue_snap)
    ab = (1.0 - turn) * mix[:, 1:] + turn * own_hue * mix_chroma
    # a grey stays a muted colour; but a hue snapped to the palette's takes the chroma the palette gives it
    muted = MUTED + (1.0 - MUTED) * np.clip(chroma / VIVID, 0.0, 1.0)
    ab *= (muted + (1.0 - muted) * hue_snap * turn[:, 0])[:, None]
    own = max(0.0, 2.0 * fidelity - 1.0)        # the picture's lightness and chroma: from 0.5 on
    # snapped, the picture's hue keeps the palette's chroma where the picture's own is weaker: a muted photograph
    # brings back its lightness without dulling the palette's yellows to khaki
    own_ab = (own_hue * np.maximum(chroma[:, None], np.hypot(ab[:, 0], ab[:, 1])[:, None]) if hue_snap > 0
              else lab[:, 1:])
    return np.column_stack([(1.0 - own) * lightness + own * lab[:, 0], (1.0 - own) * ab + own * own_ab])


def _snapped(own_hue, cos, tone, mix_chroma, lab_palette, palette_chroma, palette_hued, hue_snap):
    """The unit hues ``own_hue`` (M, 2) turned ``hue_snap`` of the way to the palette's nearest hues, and the
    chroma ``mix_chroma`` (M, 1) (that of the palette colours of the colour's tone) turned as far to the chroma
    the palette gives those hues: their mean weighted by chroma, so that the strongest of like hues counts most
    (a yellow takes the palette's chrome yellow, not the mean of it and its pale lemon; a brown its orange
    and sienna, not the dull chroma of a blue-green that shares its tone).  Of hues alike, those of colours
    nearer the colour's tone count more (``tone`` (M, K): its distance in tone to each palette colour, as in
    the mapping's fit): a green picture's darks take a palette's olive, its mid-tones the yellow-green and its
    lights the yellows beside it, as a painter lights foliage.  ``cos`` (M, K): the cosines of the hue
    differences to the palette colours, of which only the ``palette_hued`` (K,) have a hue."""
    near = palette_hued[None, :] * np.exp(-SNAP_SHARP * (1.0 - cos) - tone**2)
    hue = (1.0 - hue_snap) * own_hue + hue_snap * unit_rows(near @ unit_rows(lab_palette[:, 1:])[0])[0]
    chroma = near @ (palette_chroma**2)[:, None] / np.maximum(near @ palette_chroma[:, None], 1e-12)
    return unit_rows(hue)[0], (1.0 - hue_snap) * mix_chroma + hue_snap * chroma


def kept_chroma(ab, chroma):
    """A blend's OKLab hue and chroma ``ab`` (M, 2) with its chroma raised towards ``chroma`` (M,), the
    blended colours' mean chroma, by at most :data:`CHROMA_KEEP` times: colours of different hues
    blend to their mean hue without turning dull."""
    blended = np.hypot(ab[:, 0], ab[:, 1])
    return ab * np.clip(chroma / np.maximum(blended, 1e-12), 1.0, CHROMA_KEEP)[:, None]


#: In :func:`palette_distance`, a difference of hue and chroma counts this many times a difference of lightness.
HUE_DISTANCE = 2.0


def palette_distance(a, b):
    """The distance between OKLab colours ``a`` and ``b`` (broadcast, ..., 3) that picks a colour's neighbours in a
    palette: lightness, and :data:`HUE_DISTANCE` times hue and chroma (so that a dull yellow's neighbours
    are the palette's yellows and ochres, not a blue of its tone)."""
    d = np.asarray(a) - np.asarray(b)
    return np.sqrt(d[..., 0] ** 2 + HUE_DISTANCE**2 * (d[..., 1] ** 2 + d[..., 2] ** 2))


def palette_noise(colours, fraction, palette, weights=None, *, spread=0.1, seed=0):
    """A random ``fraction`` of the colours (M, 3) replaced by a palette colour near their own.

    Each chosen colour takes one of the palette colours nearest to it
    (:func:`palette_distance`), at random among the nearest ``1 + round(spread * (K - 1))`` of the
    palette's K (``spread`` 0: always the nearest; 1: any).  The noise keeps
    the picture's tones and hues; the filter then draws it out into strokes.
    """
    colours = np.asarray(colours)
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"fraction must lie in [0, 1], got {fraction!r}")
    if not 0.0 <= spread <= 1.0:
        raise ValueError(f"spread must lie in [0, 1], got {spread!r}")
    palette, _ = check_palette(palette, weights)
    out = colours.astype(np.float32, copy=True)
    rng = np.random.default_rng(seed)
    chosen = np.flatnonzero(rng.random(len(colours)) < fraction)
    if not len(chosen):
        return out
    k = 1 + int(round(spread * (len(palette) - 1)))
    lab_palette = to_oklab(palette)
    nearest = np.empty((len(chosen), k), dtype=np.int64)

    def chunk(s):
        part = slice(s, s + _CHUNK)
        distance = palette_distance(to_oklab(colours[chosen[part], :3])[:, None, :], lab_palette[None])
        nearest[part] = np.argsort(distance, axis=1, kind="stable")[:, :k]

    map_parallel(chunk, range(0, len(chosen), _CHUNK))
    pick = nearest[np.arange(len(chosen)), rng.integers(0, k, len(chosen))]
    out[chosen, :3] = palette[pick]
    return out


# -- a brush's broken colour ---------------------------------------------------------------------------

#: The most a dab's jitter moves its lightness (OKLab), at a jitter of 1.
SHADE = 0.2


def jitter(colours, draws, pull, shade, lab_palette):
    """sRGB colours (n, 3), each moved towards one of the three palette colours nearest to it
    (:func:`cp_stylize.palette.palette_distance`: its neighbours in hue first) by up to ``pull``, and
    its lightness by up to ``shade`` times :data:`SHADE`: broken colour.  ``draws`` (n, 3) in [0, 1) pick the
    neighbour, the share of ``pull`` and the lightness, so that a dab keeps its jitter whatever
    colour it picks up."""
    return _jittered(to_oklab(colours), draws, pull, shade, lab_palette)


def loaded(colours, draws, pull, shade, lab_palette):
    """The two sRGB colours (n, 3 each) a brush is loaded with from the colours (n, 3) it picks up: each
    jittered (:func:`jitter`) by its own ``draws`` and by those of its second colour (:func:`_loaded`),
    the palette's neighbours of each colour found once for both."""
    lab = to_oklab(colours)
    near = _palette_neighbours(lab, pull, lab_palette)
    return tuple(_jittered(lab.copy(), d, pull, shade, lab_palette, near) for d in (draws, _loaded(draws)))


def _palette_neighbours(lab, pull, lab_palette):
    """The three palette colours nearest to each OKLab colour (n, 3) (indices, (n, 3)), or None without a pull."""
    if pull > 0 and lab_palette is not None:
        return np.argsort(palette_distance(lab[:, None, :], lab_palette[None]), axis=1)[:, :3]
    return None


def _jittered(lab, draws, pull, shade, lab_palette, near=None):
    """:func:`jitter` of OKLab colours ``lab`` (n, 3, changed in place), given their palette neighbours ``near``
    (found here when None)."""
    near = _palette_neighbours(lab, pull, lab_palette) if near is None else near
    if near is not None:
        pick = near[np.arange(len(lab)), np.minimum((draws[:, 0] * near.shape[1]).astype(np.int64), near.shape[1] - 1)]
        lab += (pull * draws[:, 1])[:, None] * (lab_palette[pick] - lab)
    lab[:, 0] += SHADE * shade * (2.0 * draws[:, 2] - 1.0)
    return from_oklab(lab)


def _loaded(draws):
    """The jitter draws (n, 3) of the second colour a brush is loaded with, from those of its first: another of
    the neighbouring palette colours, and a lightness on the other side of the picked-up colour's."""
    return (draws + 0.5) % 1.0
