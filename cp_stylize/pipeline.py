"""The whole stylization of a textured triangle mesh, from colours in to an atlas image out.

1. Normalise the mesh so that its diameter is 2 (the paper's scale, so a
   setting looks the same whatever the object's size and however it is
   turned).
2. Decide the output's UV atlas (first, so that a mesh that cannot get one
   fails before the long part).
3. Build the closest point band around the mesh.
4. Bake the surface colour into the band (textures through per-corner UVs,
   per-corner colours elsewhere).
5. Optionally map the colours onto a palette (:mod:`cp_stylize.palette`)
   and replace a fraction of the band points with palette colours.
6. Diffuse on the surface.
7. Bake the band's values into the atlas image, with the input's own detail
   finer than the band laid back where the filter left it
   (:func:`cp_stylize.baking.lay_detail`), brush strokes and contour lines
   painted over it (:mod:`cp_stylize.painting`), every colour kept within the
   hull of the input's colours (:class:`cp_stylize.colours.ColourHull`); the
   strokes' heights make a second image, the relief.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .atlas import UnusableUVs, uv_atlas
from .baking import Detail, atlas_points, bake_matrix, bake_to_atlas, layered
from .cache import RunCache, digest
from .colours import ColourHull, distinct_colours
from .contours import ink_colour
from .curvature import principal_curvatures
from .band import Band
from .diffusion import diffuse
from .extent import diameter
from .kuwahara import Kuwahara
from .toon import Toon
from .watercolour import Watercolour
from .hatching import INK, PAPER, Hatching
from .stars import find_stars, on_band, on_picture
from .lines import Lines
from .mesh import TriangleMesh, surface_faces
from .noise import inject_noise
from .oklab import to_oklab
from .painting import painting
from .palette import map_to_palette, palette_noise
from .shading import EDGE_DEPTH, LIGHT_DEPTH, FormShading, shaded
from .seams import SeamHealing, seam_edges
from .parameters import AXIS_DIRECTIONS, CURVATURE_DIRECTIONS, DIRECTED_MODES
from .stroke_field import form_field, level_field, level_share, sample_directions
from .strokes import Brush
from .sampling import ColourInput, Texture, colours_at, picture_level, sample_colours

# ColourInput and Texture (cp_stylize.sampling) are named here too: a run's colours are given as them
__all__ = ["RunCache", "ColourInput", "Texture", "StylizeResult", "UnusableUVs", "normalisation",
           "normalised_mesh", "decide_atlas", "stencil_for", "stroke_field", "sample_directions", "input_colours",
           "stylize"]

#: Every object is scaled so that its diameter (the greatest distance between two points of its surface)
#: is this long: the paper's scale, at which a sphere has radius 1.
NORMAL_DIAMETER = 2.0

#: Heat flow time, in h^2, that evens out the shape operator of a mesh before its principal
#: directions are taken (the interpolated normals bend face by face).
CURVATURE_SMOOTHING = 4.0
#: A band kept for re-runs keeps its bake-out's interpolation for atlases of up to this many baked
#: texels (a 1024 x 1024 atlas; 64 weights a texel, about 512 MiB), so a re-run bakes out in one product.
KEEP_BAKE_TEXELS = 1 << 20
#: A star's radius (:mod:`cp_stylize.stars`; its size varies about it) is this share of the strokes' length,
#: and its halo's rings a stroke's width apart: the star is painted at the brush's scale.
STAR_RADIUS = 0.3


def normalisation(vertices, faces):
    """``(centre, scale)`` that map the mesh's surface to a diameter of 2 centred at the origin.

    Only what the surface has counts: the vertices of its faces that have an
    area (:func:`cp_stylize.mesh.surface_faces`), so loose vertices and faces
    whose corners lie on a line or at one point change nothing.  The diameter
    (:func:`cp_stylize.extent.diameter`) does not change when the mesh is
    turned, so neither does the grid's spacing relative to the surface; the
    centre is that of the surface's box.  Raises ValueError for a mesh
    without surface or with positions that are not finite numbers.
    """
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) == 0:
        raise ValueError(f"vertices must have shape (V, 3) with V > 0, got {vertices.shape}")
    if faces.ndim != 2 or faces.shape[1] != 3 or len(faces) == 0:
        raise ValueError(f"faces must have shape (F, 3) with F > 0, got {faces.shape}")
    used = np.zeros(len(vertices), dtype=bool)
    used[faces.ravel()] = True
    if not np.all(np.isfinite(vertices[used])):
        raise ValueError("the mesh has vertex positions that are not finite numbers")
    surface = surface_faces(vertices, faces)
    if not surface.any():
        raise ValueError(f"the mesh has no surface: the corners of each of its {len(faces):,} face(s) lie on a "
                         "line or at one point")
    used[:] = False
    used[faces[surface].ravel()] = True
    used = vertices[used]
    lo, hi = used.min(axis=0), used.max(axis=0)
    return 0.5 * (lo + hi), NORMAL_DIAMETER / diameter(used)


def normalised_mesh(vertices, faces, cache):
    """The mesh scaled to a diameter of 2 about its centre (:func:`normalisation`) and the scale it was
    multiplied by, kept in ``cache`` as ``"mesh"`` (so the diameter is measured once a mesh).  Begins a
    run on the mesh in ``cache`` (:meth:`cp_stylize.cache.RunCache.start`)."""
    shape = digest(vertices, faces)
    if cache.owner == shape and cache.part("mesh") is not None:
        centre = scale = None                   # kept: the cache gives it back
    else:                                       # checked before the cache lets go of another mesh's parts
        centre, scale = normalisation(vertices, faces)
    cache.start(shape)
    return cache.get("mesh", shape,
                     lambda: (TriangleMesh((np.asarray(vertices, dtype=np.float64) - centre) * scale, faces), scale))


def decide_atlas(vertices, faces, size, uvs=None, *, new_atlas=True, cache=None):
    """The UV atlas a run on the mesh lays its ``size`` square image out on: the mesh's own ``uvs``
    (F, 3, 2) where usable, else a new one if ``new_atlas`` (see :func:`cp_stylize.atlas.uv_atlas`;
    :class:`UnusableUVs` otherwise).  Kept in ``cache`` as ``"atlas"``, so that a caller that decides it
    before the run (the add-on, to bake procedural colours into it) and the run share one."""
    cache = RunCache() if cache is None else cache
    mesh, _ = normalised_mesh(vertices, faces, cache)
    return _atlas(mesh, size, uvs, new_atlas, cache)


def _principal_directions(band, cache=None):
    """The band's principal directions (``"max"`` and ``"min"`` -> (N, 3), as
    :meth:`cp_stylize.curvature.Curvature.direction` names them) and the confidence in them (N,), single
    precision, read-only; kept in ``cache`` under ``"curvature"`` for the band."""
    def build():
        curvature = principal_curvatures(band, smooth=CURVATURE_SMOOTHING * band.h**2)
        return ({which: read_only(curvature.direction(which).astype(np.float32)) for which in CURVATURE_DIRECTIONS},
                read_only(curvature.confidence.astype(np.float32)))

    if cache is None:
        return build()
    return cache.get("curvature", (cache.owner, band.h, band.stencil), build)


def _atlas(mesh, size, uvs, new_atlas, cache):
    """:func:`decide_atlas` for the normalised ``mesh`` of the run begun in ``cache``."""
    return cache.get("atlas", (digest(uvs), size, new_atlas), lambda: uv_atlas(mesh, size, uvs, allow_new=new_atlas))


def stroke_field(band, settings, directions=None, cache=None):
    """The direction field the strokes follow, for :func:`cp_stylize.diffuse`'s ``field=``.

    From ``settings.stroke_direction`` (:data:`cp_stylize.parameters.DIRECTIONS`):
    None for ``"texture"`` (CED's own structure tensor) and for the modes that
    take no direction; else an (N, 3) line field whose length is the
    confidence in it, which the diffusion blends by:

    - ``"max"``, ``"min"``: a principal curvature direction times its
      confidence (0 at umbilics, on spheres and flat parts); with brush
      strokes, completed there by the object's z axis on the surface (its
      meridians for "min", its parallels for "max": :func:`cp_stylize.stroke_field.form_field`);
    - ``"axis"``: ``settings.axis`` (normalised); the diffusion keeps its
      tangential part, whose length falls to 0 where the surface faces it;
    - ``"around"``: the parallels about ``settings.axis`` on the surface, whose length
      (:data:`cp_stylize.stroke_field.FALLBACK_TRUST` at most) falls to 0 where the surface faces the axis
      (:func:`cp_stylize.stroke_field.form_field` with no form direction of its own);
    - ``"attribute"``: ``directions``, per-corner vectors (F, 3, 3) of the
      mesh, each normalised and mixed across its face with the signs of the
      face's first corner (see :func:`sample_directions`).

    The principal directions depend on the band alone: with a ``cache`` of the run on the band's mesh,
    they are kept for the next run on the same band (another preset or slider costs no second curvature).
    """
    source = settings.stroke_direction
    if source == "texture":
        return None
    if source in CURVATURE_DIRECTIONS:
        principal, confidence = _principal_directions(band, cache)
        field = principal[source] * confidence[:, None]
        if settings.strokes > 0 or settings.hatch_spacing > 0:   # strokes and lines: along the object's axis
            # where the form has no direction
            field = form_field(band, field, around=source == "max")
        return field
    if source in AXIS_DIRECTIONS:
        axis = np.asarray(settings.axis, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        if source == "around":
            return form_field(band, np.zeros((band.size, 3)), around=True, axis=axis)
        return np.broadcast_to(axis, (band.size, 3)).copy()
    if directions is None:
        raise ValueError("direction 'attribute' needs the mesh's vectors: pass directions= (F, 3, 3)")
    return sample_directions(band, directions)


def stencil_for(mode):
    """The band stencil a filter mode needs: the 7-point Laplacian for ``"gaussian"``, else scheme (51)'s."""
    return "laplacian" if mode == "gaussian" else "anisotropic"


@dataclasses.dataclass
class StylizeResult:
    image: np.ndarray        # (size, size, C), row 0 at the bottom
    atlas: object            # the UV atlas the image is laid out on
    band_size: int
    spacing: float           # grid spacing in the mesh's own units
    seconds: float
    timings: dict = dataclasses.field(default_factory=dict)  # seconds: atlas, band, bake_in, diffusion, bake_out
    height: np.ndarray | None = None   # (size, size) the paint's height (settings.relief > 0), row 0 at the bottom


def seam_healing(mesh, colours):
    """The :class:`~cp_stylize.seams.SeamHealing` of a :class:`ColourInput`'s textures on ``mesh`` (normalised),
    or None where they have no UV seams."""
    parts = [seam_edges(mesh.welded_faces, t.uvs, t.faces) for t in colours.texture_list]
    if not parts or not sum(len(part[0]) for part in parts):
        return None
    seams = tuple(np.concatenate([part[k] for part in parts]) for k in range(4))
    return SeamHealing(mesh.vertices, mesh.input_faces, seams, lambda face, bary: colours_at(face, bary, colours))


def colour_digest(colours):
    """A digest of a :class:`ColourInput`'s arrays (see :func:`cp_stylize.cache.digest`)."""
    parts = [colours.corner_colours]
    for texture in colours.texture_list:
        parts += [texture.image, texture.uvs, texture.faces, *texture.wrap]
    return digest(*parts)


def read_only(array):
    """``array``, no longer writable: a cached array that a run would change in place raises instead."""
    array.setflags(write=False)
    return array


def input_colours(colours, settings, channels=3):
    """The colours a run is given (M, channels): its textures' texels, its corner colours and the palette.

    Everything the band samples is a mix of these, so their hull holds every colour the input can make.
    A texture gives its distinct colours at 8 bits a channel (:func:`cp_stylize.colours.distinct_colours`),
    which have the hull of its texels, so a large image costs no copy of its pixels.
    """
    found = []
    for texture in colours.texture_list:
        image = np.asarray(texture.image)
        image = image[..., :channels] if image.ndim == 3 else image[..., None]
        found.append(_in_channels(distinct_colours(image), channels))
    if colours.corner_colours is not None:
        corners = np.asarray(colours.corner_colours, dtype=np.float32)
        found.append(_in_channels(corners.reshape(-1, corners.shape[-1]), channels))
    if (settings.noise_on or settings.strokes > 0) and settings.palette:   # the noise and the strokes paint with it
        found.append(_in_channels(settings.palette, channels))
    if settings.line_width > 0 or (settings.toon_levels and settings.toon_outlines > 0):   # ink goes to black
        found.append(np.zeros((1, channels), np.float32))
    if settings.wash_levels:                                     # watercolour: its paper, and pigment pooled dark
        found.append(_in_channels([PAPER, (0.0, 0.0, 0.0)], channels))
    if settings.hatch_spacing > 0:                               # hatching: ink and paper alone
        found.append(_in_channels(hatch_colours(settings), channels))
    if settings.contours > 0:                                    # the lines' ink: the palette's darkest, darker
        ink = ink_colour(settings.palette)
        found.append(np.zeros((1, channels), np.float32) if ink is None else _in_channels([ink], channels))
    if settings.shading_on:                                      # the painted light and shade: lighter and darker
        deepest = settings.shade_light * LIGHT_DEPTH + settings.shade_edges * EDGE_DEPTH
        given = np.concatenate(found)
        found += [shaded(given, np.full(len(given), shift), settings.shade_warmth).astype(np.float32)
                  for shift in (-deepest, -deepest / 2, deepest / 2, deepest)]
    covered = colours.corner_colours is not None or (
        bool(colours.textures) and np.all(np.any([np.asarray(t.faces, bool) for t in colours.texture_list], axis=0)))
    clipped = any("clip" in t.wrap for t in colours.texture_list)
    if not covered or clipped:
        found.append(np.zeros((1, channels), np.float32))      # faces that nothing colours, and CLIP, read black
    return np.concatenate(found)


def _in_channels(rows, channels):
    """Colour rows (K, c) as float32 (K, channels): cut to ``channels``, any channel they lack 0."""
    rows = np.asarray(rows, dtype=np.float32)[:, :channels]
    return np.pad(rows, ((0, 0), (0, channels - rows.shape[1])))


def palette_colours(values, settings):
    """The band's colours (N, C) as the settings' palette asks: mapped onto it by tone and hue (mapping
    ``"tone"``: :func:`cp_stylize.palette.map_to_palette`) with palette noise, or the paper's random
    palette noise (:func:`cp_stylize.noise.inject_noise`); unchanged without either."""
    weights = settings.palette_weights or None
    if settings.noise_mapping == "tone":
        values = _recolour(settings)(values)
        if settings.noise_fraction > 0:
            values = palette_noise(values, settings.noise_fraction, settings.palette, weights,
                                   spread=settings.noise_spread, seed=settings.seed)
    elif settings.noise_fraction > 0:
        values = inject_noise(values, settings.noise_fraction, settings.palette, weights=weights, seed=settings.seed)
    return values


def _recolour(settings):
    """The settings' mapping of a picture's colours onto their palette (mapping ``"tone"``), or None."""
    if settings.noise_mapping != "tone":
        return None

    def recolour(picture):
        return map_to_palette(picture, settings.palette, settings.palette_weights or None,
                              fidelity=settings.fidelity, keep_values=settings.keep_values,
                              keep_darks=settings.keep_darks, hue_snap=settings.hue_snap)
    return recolour


def brush_for(settings):
    """The :class:`~cp_stylize.strokes.Brush` of the settings' strokes, or None without strokes."""
    if settings.strokes <= 0:
        return None
    return Brush(width=settings.stroke_width, length=settings.stroke_length, layers=settings.stroke_layers,
                 chain=settings.stroke_chain, broad=settings.broad_paint, jitter=settings.stroke_jitter,
                 swirl=settings.swirl, strength=settings.strokes, seed=settings.seed,
                 fidelity=settings.fidelity if settings.noise_mapping == "tone" else 0.0)


def hatch_colours(settings):
    """The ink and the paper (2, 3) of the settings' hatching: the palette's darkest and lightest where it has
    two colours or more, else :data:`cp_stylize.hatching.INK` and :data:`~cp_stylize.hatching.PAPER`."""
    if len(settings.palette) >= 2:
        palette = np.asarray(settings.palette, dtype=np.float64)[:, :3]
        lightness = to_oklab(palette)[:, 0]
        return np.stack([palette[np.argmin(lightness)], palette[np.argmax(lightness)]])
    return np.array([INK, PAPER], dtype=np.float64)


def hatching(mesh, band, atlas, settings, *, sampled, field, colours, filtered):
    """The :class:`~cp_stylize.hatching.Hatching` of a run: lines along ``field`` (the settings' direction)
    where it has a direction, else along the picture's horizontal, else along the structure of the
    picture's ``sampled`` colours; an engraver keeps the lines of an even tone calm.  Their widths follow the
    tone of the ``filtered`` band colours."""
    guide = None if field is None else np.asarray(field, dtype=np.float64)
    if colours.textures:
        level = np.asarray(level_field(band, field, picture_level(mesh, colours)), dtype=np.float64)
        guide = level if guide is None else np.where((np.linalg.norm(guide, axis=1) > 1e-3)[:, None], guide, level)
    if guide is not None:                 # trusted wholly where it has a direction
        length = np.linalg.norm(guide, axis=1, keepdims=True)
        guide = np.divide(guide, length, out=np.zeros_like(guide), where=length > 1e-3)
    tone = (to_oklab(np.asarray(filtered).reshape(band.size, -1)[:, :3])[:, 0] if settings.hatch_smooth > 0
            else None)
    return Hatching(mesh, band, atlas, to_oklab(np.asarray(sampled)[:, :3]).astype(np.float32),
                    settings.hatch_spacing, tone=tone, layers=settings.hatch_layers, angle=settings.hatch_angle,
                    ink=settings.hatch_ink, swell=settings.hatch_swell, light=settings.hatch_light,
                    smooth=settings.hatch_smooth, field=guide, colours=hatch_colours(settings), seed=settings.seed)


def stroke_level(mesh, band, settings, *, field, colours):
    """The level field (N, 3) strokes turn to where the picture has no structure
    (:func:`cp_stylize.stroke_field.level_field`, as long as its share), or None: the picture's horizontal,
    all of it for a brush that does not swirl and less as Swirl grows (:func:`cp_stylize.stroke_field.level_share`).
    A swirling brush lays no level strokes: where the picture is flat, its strokes swirl (where the picture
    is light) or turn each its own way (where it is dark), as van Gogh's do, instead of combing the ground."""
    share = level_share(settings.swirl)
    if not colours.textures or share <= 0:
        return None
    return share * level_field(band, field, picture_level(mesh, colours))


def run_painting(mesh, band, result, atlas, settings, *, sampled, field, colours, source):
    """The :class:`~cp_stylize.painting.Painting` of a run's filtered colours ``result`` (its strokes and
    contour lines), from the picture's ``sampled`` colours, the stroke ``field``, the run's
    :class:`ColourInput` and ``source(faces, barys)``, the picture at points of the mesh."""
    brush = brush_for(settings)
    level = stroke_level(mesh, band, settings, field=field, colours=colours) if brush else None
    return painting(mesh, band, result, atlas, brush=brush, contours=settings.contours, structure=sampled,
                    palette=settings.palette or None, weights=settings.palette_weights or None, field=field,
                    recolour=_recolour(settings), level=level, detail=settings.detail, source=source,
                    sheen=settings.sheen, keep_darks=settings.keep_darks)


def stylize(vertices, faces, colours, settings, *, uvs=None, atlas=None, new_atlas=True, scheme="fast",
            directions=None, progress=None, log=None, cache=None):
    """Stylize a mesh's surface colour; returns a :class:`StylizeResult`.

    Parameters
    ----------
    vertices : ndarray (V, 3)
    faces : ndarray (F, 3)
    colours : ColourInput
    settings : StylizeSettings
        Relative to an object whose diameter is 2.
    uvs : ndarray (F, 3, 2), optional
        The mesh's own per-corner UVs for the output atlas; used where usable,
        otherwise a new atlas is made (see :func:`cp_stylize.atlas.uv_atlas`).
    atlas : Atlas, optional
        The output atlas, already decided by the caller (``uvs`` is then not used).
    new_atlas : bool
        False: raise :class:`UnusableUVs` (before the band is built) rather than
        make a new atlas when ``uvs`` are missing or unusable.
    scheme : {"fast", "reference"}
        The diffusion's time stepping (see :func:`cp_stylize.diffuse`).
    directions : ndarray (F, 3, 3), optional
        Per-corner vectors the strokes follow when ``settings.stroke_direction``
        is ``"attribute"`` (see :func:`stroke_field`), in the mesh's space.
    progress : callable, optional
        ``progress(fraction)``; an exception it raises stops the run.
    log : callable, optional
        ``log(message)`` for what the run finds on its way (skipped faces, the band's size).
    cache : RunCache, optional
        Takes the normalised mesh, the atlas, the band with its operators and
        the atlas's surface points from an earlier run on the same mesh, grid
        and atlas, and keeps this run's for the next (see :mod:`cp_stylize.cache`).
    """
    clock = _Clock()
    report = progress or (lambda f: None)
    say = log or (lambda msg: None)
    if settings.stroke_direction == "attribute" and np.shape(directions) != (len(faces), 3, 3):
        raise ValueError(f"direction 'attribute' needs the mesh's vectors, directions= of shape ({len(faces)}, 3, 3), "
                         f"got {'none' if directions is None else np.shape(directions)}")
    keep = cache is not None
    cache = RunCache() if cache is None else cache
    mesh, scale = normalised_mesh(vertices, faces, cache)
    if mesh.skipped_faces:
        say(f"skipped {mesh.skipped_faces} degenerate face(s)")
    report(0.0)
    if atlas is None:
        atlas = _atlas(mesh, settings.image_size, uvs, new_atlas, cache)
    clock.lap("atlas")
    band = _band(mesh, settings, cache, keep)
    clock.lap("band")
    say(f"band: {band.size:,} points at h = {settings.spacing} (object normalised to a diameter of 2)")
    report(0.1)
    painted = (cache.owner, band.h, band.stencil, colour_digest(colours))     # the key of the band's colours
    sampled, picture_at = _bake_in(mesh, band, colours, settings, cache, painted)
    star_field = None
    if settings.strokes > 0 and settings.stars > 0:      # stars in the picture's sky, as painted
        stars = find_stars(mesh, band, sampled, settings.stars, STAR_RADIUS * settings.stroke_length,
                           settings.stroke_width, settings.seed)
        sampled, star_field = on_band(stars, mesh, band, sampled)
        picture_at = on_picture(stars, mesh, picture_at)
    values = palette_colours(sampled, settings)
    clock.lap("bake_in")
    report(0.15)
    field = stroke_field(band, settings, directions, cache)
    result = diffuse(band, values, **settings.diffusion_parameters(), scheme=scheme,
                     field=field if settings.mode in DIRECTED_MODES else None,
                     progress=lambda f: report(0.15 + 0.7 * f))
    clock.lap("diffusion")
    # oil paint: the anisotropic Kuwahara filter's statistics, weighed at the texels
    paint = (Kuwahara(band, result, settings.oil_size, settings.oil_sharpness, settings.oil_eccentricity)
             if settings.oil_size > 0 else None)
    if paint is not None:
        clock.lap("oil")
    if settings.toon_levels:               # toon bands over the colours, under any strokes and lines
        paint = layered(paint, Toon(settings.toon_levels, settings.toon_softness, atlas.size, settings.toon_outlines))
    if settings.wash_levels:               # washes of pigment on paper, under any lines
        paint = layered(paint, Watercolour(settings.wash_levels, atlas.size, edges=settings.wash_edges,
                                           granulation=settings.wash_granulation, bleed=settings.wash_bleed,
                                           wobble=settings.wash_wobble, seed=settings.seed))
    if settings.hatch_spacing > 0:         # the tones in lines of ink on paper
        paint = layered(paint, hatching(mesh, band, atlas, settings, sampled=sampled, field=field, colours=colours,
                                        filtered=result))
        clock.lap("hatching")
    if settings.line_width > 0:            # ink lines over the flat colours, under any strokes
        paint = layered(paint, Lines(mesh, atlas, settings.line_width, detail=settings.line_detail,
                                     source=picture_at))
    if settings.strokes > 0 or settings.contours > 0:
        if star_field is not None:              # strokes circle the stars
            field = star_field if field is None else np.where(
                (np.linalg.norm(star_field, axis=1) > np.linalg.norm(field, axis=1))[:, None], star_field, field)
        paint = layered(paint, run_painting(mesh, band, result, atlas, settings, sampled=sampled, field=field,
                                            colours=colours, source=picture_at))
        report(0.9)
        clock.lap("painting")
    if settings.shading_on:                                      # the form's light and edges over all the paint
        paint = layered(paint, FormShading(band, light=settings.shade_light, edges=settings.shade_edges,
                                           warmth=settings.shade_warmth))
        clock.lap("shading")
    image, height = _bake_out(mesh, band, result, atlas, settings, cache, (colours, sampled, painted), paint, report)
    clock.lap("bake_out")
    report(1.0)
    return StylizeResult(image=np.clip(image, 0.0, 1.0), atlas=atlas, band_size=band.size,
                         spacing=settings.spacing / scale, seconds=clock.total(), timings=clock.timings,
                         height=height if settings.relief > 0 else None)


class _Clock:
    """The seconds a run's stages take (:attr:`timings`, by name) and the whole run's."""

    def __init__(self):
        self.start = self.last = time.perf_counter()
        self.timings = {}

    def lap(self, name):
        now = time.perf_counter()
        self.timings[name] = now - self.last
        self.last = now

    def total(self):
        return time.perf_counter() - self.start


def _band(mesh, settings, cache, keep):
    """The band of the normalised ``mesh`` at the settings' grid (kept in ``cache``; with ``keep``, the
    structures its runs build are kept with it in its memo)."""
    stencil = stencil_for(settings.mode)

    def new_band():
        band = Band.build(mesh, settings.spacing, stencil=stencil)
        if keep:
            band.memo = RunCache()      # the diffusion's operators stay with the band
        return band

    return cache.get("band", (cache.owner, settings.spacing, stencil), new_band)


def _bake_in(mesh, band, colours, settings, cache, painted):
    """The input colours at the band's closest points (N, C), kept in ``cache`` under the key ``painted``,
    and ``picture_at(face, bary)``: the picture's colours at points of the mesh; where the run paints a look
    (:attr:`~cp_stylize.settings.StylizeSettings.stylised`), the texture's UV seams healed."""
    sampled = cache.get("sampled", painted, lambda: read_only(sample_colours(band, colours)))
    heal = None
    if settings.stylised:
        heal = cache.get("seams", (cache.owner, painted[3]), lambda: seam_healing(mesh, colours))
        if heal is not None:
            sampled = cache.get("healed", painted, lambda: read_only(heal(band.face, band.bary, sampled)))

    def picture_at(face, bary):
        found = colours_at(face, bary, colours)
        return found if heal is None else heal(face, bary, found)

    return sampled, picture_at


def _bake_out(mesh, band, result, atlas, settings, cache, inputs, paint, report):
    """The image (and the paint's height, or None) of the filtered band values ``result`` on ``atlas``:
    with the input's own detail laid back (without strokes; with them the painting keeps the detail),
    the ``paint`` over it, every colour within the input colours' hull.  ``inputs``: the run's
    colours, the band's samples of them and their key, from :func:`_bake_in`."""
    colours, sampled, painted = inputs
    layout = (cache.owner, digest(atlas.uvs, atlas.texels), atlas.size, settings.margin)
    detail = None
    if settings.detail > 0 and settings.strokes <= 0 and settings.oil_size <= 0:   # oil paint takes none of it
        # what the filter starts from: the sampled colours extended once, as every step extends
        detail = Detail(cache.get("extended", painted, lambda: read_only(band.extend(sampled))),
                        lambda face, bary: cache.get("texel_colours", (painted, layout),
                                                     lambda: read_only(colours_at(face, bary, colours))),
                        settings.detail)
    texels = cache.get("texels", layout,
                       lambda: tuple(read_only(a) for a in atlas_points(mesh, atlas, settings.margin)))
    matrix = None
    if band.memo is not None and len(texels[0]) <= KEEP_BAKE_TEXELS:
        matrix = band.structure("bake_out", (layout, result.dtype.str),
                                lambda: bake_matrix(band, texels, result.dtype, progress=lambda f: report(0.95)))
    baked = bake_to_atlas(band, result, atlas, margin=settings.margin, detail=detail, paint=paint,
                          progress=lambda f: report(0.9 + 0.1 * f), texels=texels, matrix=matrix,
                          limit=ColourHull(input_colours(colours, settings)).limit)
    return baked if paint is not None else (baked, None)
