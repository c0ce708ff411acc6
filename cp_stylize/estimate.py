"""What a run will cost, said before it starts: its grid spacing, band points, memory and seconds.

:func:`estimate` reads only the mesh's size and the settings (no band is
built); :func:`estimate_run` gives the seconds and bytes of a run of a given
number of band points.  The constants are rough costs measured on a 2-core
machine (``python -m cp_stylize bench`` and docs/performance.md);
:mod:`cp_stylize.calibration` scales the seconds by this machine's
speed.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .atlas import XATLAS_FACES
from .band_search import use_aabb
from .grid import estimate_band_size
from .parameters import CURVATURE_DIRECTIONS
from .pipeline import KEEP_BAKE_TEXELS, normalisation, stencil_for

__all__ = ["RunEstimate", "estimate", "estimate_run", "estimate_vertices"]


#: Rough costs on a 2-core machine, from ``python -m cp_stylize bench`` and the Suzanne cases of
#: docs/performance.md (fast scheme): seconds per band point to build the band and
#: the scheme's operators and to bake in and out ...
SECONDS_SETUP_PER_POINT = {"gaussian": 2.7e-6, "other": 3.6e-6}
#: ... per band point and colour channel for one step (an extension and a stencil product) ...
SECONDS_STEP_PER_POINT = 1.8e-8
#: ... per band point for one rebuild of the diffusion tensor (about every other step) ...
SECONDS_TENSOR_PER_POINT = 1.35e-7
#: ... per triangle for the mesh's set-up and the closest point search (it meets every triangle near each
#: block) ...
SECONDS_PER_TRIANGLE = 2.8e-5
#: ... or, where the band is found through libigl's AABB tree (:func:`cp_stylize.band_search.use_aabb`), per
#: triangle for the set-up and the tree, and per band point for the tree's queries (about one and a half a
#: point; a million-triangle Suzanne's 780,000 points 8.7 s in all, a 500,000-triangle sphere's 1.9 million
#: points 10.6 s, on two cores) ...
SECONDS_PER_TRIANGLE_TREE = 1.8e-5
SECONDS_TREE_PER_POINT = 5e-6
#: ... per triangle of a new atlas, where the mesh has no usable UVs: an xatlas unwrap (up to
#: ``atlas.XATLAS_FACES`` triangles), or charts projected along the axes (beyond) ...
SECONDS_UNWRAP_PER_TRIANGLE = {"xatlas": 1.6e-4, "charts": 3e-6}
#: ... per texel of the atlas (its raster, and the bake-out of the share it covers) ...
SECONDS_PER_TEXEL = 8e-7
#: ... per pixel of the input images (read out, their colours' hull, their detail) ...
SECONDS_PER_IMAGE_PIXEL = 1e-7
#: ... and once a run (the colour hull, the normalisation, small set-ups).
SECONDS_PER_RUN = 0.9

#: Brush strokes: seconds per baked texel and layer of strokes, per band point and layer for their
#: stroke fields (with the stars, contours and thin lines found on the band), and the share of an atlas's
#: texels that are baked (islands and margin); bytes per texel of the atlas (the painted texels' colours,
#: heights and places; the dabs are drawn in blocks of bounded size, :data:`cp_stylize.canvas._PAIRS`).
#: Fitted on 2026-12-08 to Starry Night on Suzanne (docs/performance.md, ``tools/estimate_cases.py``): at
#: 1024 x 1024 8.7 s of painting and 21 s of strokes at the bake-out, at 4096 x 4096 329 s and 7.11 GiB.
SECONDS_STROKES_PER_TEXEL = 9.5e-6
SECONDS_STROKE_FIELD_PER_POINT = 5.5e-6
BYTES_STROKES_PER_TEXEL = 220
#: Sheen (the relief lit into the colour): seconds per baked texel (a 2048 x 2048 atlas whole: 3 s on two
#: busy cores), and bytes per texel of the atlas (its texels' places in it).
SECONDS_SHEEN_PER_TEXEL = 8e-7
BYTES_SHEEN_PER_TEXEL = 4
BAKED_SHARE = 0.6
#: Oil paint (:mod:`cp_stylize.kuwahara`): seconds per band point for the sectors' statistics, and per
#: baked texel for reading them at the bake-out; bytes per band point and per baked texel for them.
SECONDS_OIL_PER_POINT = 1.4e-5
SECONDS_OIL_PER_TEXEL = 5e-6
BYTES_OIL_PER_POINT = 128
BYTES_OIL_PER_TEXEL = 256
#: Ink lines (:mod:`cp_stylize.lines`): seconds and bytes per texel of the atlas (a city photograph's
#: 2048 x 2048 frame, every texel covered: 22 s on two cores).
SECONDS_LINES_PER_TEXEL = 5.5e-6
BYTES_LINES_PER_TEXEL = 400
#: Toon bands (:mod:`cp_stylize.toon`) with the atlas's size (their islands and steps): seconds per texel of
#: the atlas.
SECONDS_TOON_PER_TEXEL = 1.5e-6
#: Watercolour (:mod:`cp_stylize.watercolour`): its washes (as toon bands), the noises of the surface and the
#: distances to the washes' borders, per texel of the atlas (1024 x 1024, every texel covered: 5 s on two cores,
#: at a peak of 330 MB).
SECONDS_WASH_PER_TEXEL = 5e-6
BYTES_WASH_PER_TEXEL = 330

#: Hand-painted edges (:func:`cp_stylize.shading.edge_strength`: the normals smoothed, the curvature of the band):
#: seconds and bytes a band point.
SECONDS_EDGES_PER_POINT = 9e-6
BYTES_EDGES_PER_POINT = 250

#: Peak memory of a colour run, in bytes a band point (matrices: E with 64 weights, the
#: 19-point stencil, L, gradients, smoothing passes; geometry, tensor fields, work arrays) ...
BYTES_PER_BAND_POINT = 1400
#: ... a triangle (the closest point search's candidate pairs, or libigl's AABB tree and its copy of the
#: triangles, on the meshes that take it: a million-triangle scan and a 500,000-triangle sphere peaked within
#: 3 % of the estimate), a texel of the atlas ...
BYTES_PER_TRIANGLE = 500
BYTES_PER_TEXEL = 128
#: ... an atlas texel, for the bake-out interpolation a run with a cache keeps (64 weights and
#: indices on the baked share and the margin) ...
BYTES_KEPT_PER_TEXEL = 680
#: ... a band point, for strokes along the form: its two principal directions and the confidence in them, in
#: single precision, which a run with a cache keeps (:func:`cp_stylize.pipeline.stroke_field`) ...
BYTES_KEPT_CURVATURE_PER_POINT = 28
#: ... a pixel of the input images (their float RGBA pixels read out, and the host's own buffer of
#: them: 16 bytes each for a float image in Blender) ...
BYTES_PER_IMAGE_PIXEL = 32
#: ... and the libraries a Python process with NumPy and SciPy holds.
BYTES_PER_RUN = 200 * 2**20


def estimate_run(n_points, settings, channels=3, triangles=0, keep=False, unwrap=False, image_pixels=0, speed=1.0):
    """Rough ``(seconds, bytes)`` of a run (atlas, band, bake-in, fast diffusion, bake-out) on
    ``n_points`` band points around a mesh of ``triangles``; ``keep``: with a :class:`RunCache`, which
    also holds the bake-out's interpolation at its peak; ``unwrap``: a new atlas is made;
    ``image_pixels``: the pixels of the input images; ``speed``: how many times longer than the
    machine the constants were measured on this computer takes (:mod:`cp_stylize.calibration`)."""
    from .heat_flow import PAPER_CFL, time_steps

    steps, _ = time_steps(settings.T, PAPER_CFL * settings.spacing ** 2)
    per_point = SECONDS_SETUP_PER_POINT["gaussian" if settings.mode == "gaussian" else "other"]
    per_point += steps * channels * SECONDS_STEP_PER_POINT
    if settings.mode != "gaussian":
        per_point += (1 + steps // 2) * SECONDS_TENSOR_PER_POINT
    if use_aabb(triangles, n_points):
        per_point += SECONDS_TREE_PER_POINT
        per_triangle = SECONDS_PER_TRIANGLE_TREE
    else:
        per_triangle = SECONDS_PER_TRIANGLE
    texels = settings.image_size ** 2
    seconds = SECONDS_PER_RUN + n_points * per_point + triangles * per_triangle + texels * SECONDS_PER_TEXEL
    seconds += image_pixels * SECONDS_PER_IMAGE_PIXEL
    if unwrap:
        seconds += triangles * SECONDS_UNWRAP_PER_TRIANGLE["xatlas" if triangles <= XATLAS_FACES else "charts"]
    nbytes = BYTES_PER_RUN + n_points * BYTES_PER_BAND_POINT + triangles * BYTES_PER_TRIANGLE + texels * BYTES_PER_TEXEL
    if settings.strokes > 0:
        layers = settings.stroke_layers
        seconds += (BAKED_SHARE * texels * SECONDS_STROKES_PER_TEXEL + n_points * SECONDS_STROKE_FIELD_PER_POINT) * layers
        nbytes += texels * BYTES_STROKES_PER_TEXEL
    if settings.strokes > 0 and settings.sheen > 0:
        seconds += BAKED_SHARE * texels * SECONDS_SHEEN_PER_TEXEL
        nbytes += texels * BYTES_SHEEN_PER_TEXEL
    if settings.oil_size > 0:
        seconds += n_points * SECONDS_OIL_PER_POINT + BAKED_SHARE * texels * SECONDS_OIL_PER_TEXEL
        nbytes += n_points * BYTES_OIL_PER_POINT + BAKED_SHARE * texels * BYTES_OIL_PER_TEXEL
    if settings.shade_edges > 0:
        seconds += n_points * SECONDS_EDGES_PER_POINT
        nbytes += n_points * BYTES_EDGES_PER_POINT
    if settings.toon_levels:
        seconds += texels * SECONDS_TOON_PER_TEXEL
    if settings.wash_levels:
        seconds += texels * SECONDS_WASH_PER_TEXEL
        nbytes += texels * BYTES_WASH_PER_TEXEL
    if settings.line_width > 0:
        seconds += texels * SECONDS_LINES_PER_TEXEL
        nbytes += texels * BYTES_LINES_PER_TEXEL
    nbytes += image_pixels * BYTES_PER_IMAGE_PIXEL
    if keep and BAKED_SHARE * texels <= KEEP_BAKE_TEXELS:
        nbytes += BAKED_SHARE * texels * BYTES_KEPT_PER_TEXEL
    if keep and settings.stroke_direction in CURVATURE_DIRECTIONS:
        nbytes += n_points * BYTES_KEPT_CURVATURE_PER_POINT
    return seconds * speed, nbytes


@dataclasses.dataclass(frozen=True)
class RunEstimate:
    """What a run on a mesh will take, before it runs."""

    spacing: float       # grid spacing in the mesh's own units
    band_points: int
    bytes: int
    seconds: float


def estimate(vertices, faces, settings, channels=3, keep=False, unwrap=False, image_pixels=0, speed=None):
    """A :class:`RunEstimate` of :func:`stylize` on a mesh with ``settings``.

    ``keep``: with a cache; ``unwrap``: the mesh has no UVs, so a new atlas is
    made; ``image_pixels``: the pixels of the input images
    (:attr:`ColourInput.image_pixels`); ``speed``: the time factor of this
    computer (None: :func:`cp_stylize.calibration.machine_speed`, measured
    once a process, well under a second).
    """
    centre, scale = normalisation(vertices, faces)
    vertices = np.asarray(vertices, dtype=np.float64)
    a, b, c = (vertices[np.asarray(faces)[:, k]] for k in range(3))
    area = 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum()) * scale**2
    n = estimate_band_size(area, settings.spacing, stencil=stencil_for(settings.mode))
    if speed is None:
        from .calibration import machine_speed

        speed = machine_speed()
    seconds, nbytes = estimate_run(n, settings, channels, len(faces), keep, unwrap, image_pixels, speed)
    return RunEstimate(settings.spacing / scale, n, nbytes, seconds)


#: The mesh filter's costs (:mod:`cp_stylize.mesh_diffusion`), per vertex: the operators once, and each
#: semi-implicit step (EED and CED: with the structure tensor's smoothings); its bytes at the peak.
SECONDS_MESH_PER_RUN = 0.1
SECONDS_MESH_SETUP_PER_VERTEX = 4e-6
SECONDS_MESH_STEP_PER_VERTEX = {"gaussian": 1.5e-6, "perona_malik": 3e-6, "eed": 6e-6, "ced": 6e-6}
BYTES_MESH_PER_VERTEX = 1200


def estimate_vertices(vertices, faces, settings, method, speed=None, edge=None):
    """A :class:`RunEstimate` of :func:`cp_stylize.vertex_colours.stylize_vertices` with ``method``
    (``"mesh"`` or ``"band"``); the band's is :func:`estimate`'s without an image to bake.  ``edge``: the
    mesh's :func:`~cp_stylize.vertex_colours.mean_edge`, if known."""
    if speed is None:
        from .calibration import machine_speed

        speed = machine_speed()
    if method == "band":
        return estimate(vertices, faces, settings.replace(image_size=64), speed=speed)
    from .mesh_diffusion import STEP_EDGES, step_count
    from .vertex_colours import mean_edge

    _, scale = normalisation(vertices, faces)
    edge = mean_edge(vertices, faces) if edge is None else edge
    steps = step_count(settings.T, STEP_EDGES * edge**2)
    n = len(vertices)
    per_vertex = SECONDS_MESH_SETUP_PER_VERTEX + steps * SECONDS_MESH_STEP_PER_VERTEX[settings.mode]
    seconds = SECONDS_MESH_PER_RUN + n * per_vertex
    return RunEstimate(settings.spacing / scale, 0, BYTES_PER_RUN + n * BYTES_MESH_PER_VERTEX, seconds * speed)
