"""Filter colour that lives on a mesh's vertices into colour at its vertices, with no image and no UV map.

A photogrammetry scan or a vertex-painted sculpt carries its colour on its
vertices (a colour attribute).  :func:`stylize_vertices` filters it where it
is and gives back one colour a vertex, so the result goes into a colour
attribute, not into a new image on a new atlas.  Two discretisations serve it,
and :func:`choose_method` picks one and says why:

- **the mesh's own finite elements** (:mod:`cp_stylize.mesh_diffusion`: Wu,
  Deng, Chen and Tai, "Scale-space analysis of discrete filtering over
  arbitrary triangulated surfaces", 2009), where the vertices lie closer than
  the band's grid: a scan's colour is finer than the band, and the mesh filter
  keeps it at its own resolution.  It runs Gaussian, Perona-Malik, EED and CED.
- **the closest point band** everywhere else (a coarser mesh, whose colour the
  band's finer grid filters better between the vertices, and the modes that
  run on the band only: Beltrami and Flow), its result read at the vertices
  with the same interpolation that bakes an image out.

Both take the settings' parameters in the same scale-free units (the object
scaled to a diameter of 2, :func:`cp_stylize.pipeline.normalisation`), so a
setting filters alike on either.  A look that paints (palette, strokes,
contours, oil paint, toon, watercolour, hatching, ink lines, painted light)
lays marks finer than a vertex apart: it needs an image, and
:func:`stylize_vertices` refuses it with a ValueError that says so.  Every
colour of the result stays within the hull of the input's colours.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .band import Band
from .colours import ColourHull
from .diffusion import diffuse
from .mesh import TriangleMesh, surface_faces
from .mesh_diffusion import MESH_MODES, mesh_diffuse
from .mesh_diffusion import available as mesh_filter_available
from .pipeline import normalisation, stencil_for, stroke_field
from .parameters import DIRECTED_MODES
from .sampling import ColourInput, sample_colours

__all__ = ["VertexResult", "choose_method", "corner_to_vertex", "mean_edge", "stylize_vertices"]

#: The mesh filter serves a mesh whose mean edge is at most this many grid spacings (``settings.spacing``,
#: relative to a diameter of 2): its vertices then sample the surface at least as finely as the band does.
MESH_EDGE = 1.0


@dataclasses.dataclass
class VertexResult:
    """The filtered colours at the vertices and how they were made."""

    colours: np.ndarray      # (V, C) float32, one row a vertex (a vertex no face uses keeps its input)
    method: str              # "mesh" (the mesh's own finite elements) or "band" (the closest point band)
    reason: str              # why that method, in a sentence
    seconds: float
    points: int              # the vertices filtered ("mesh") or the band's points ("band")


def _surface(vertices, faces):
    """The normalised vertices (V, 3), the faces that have an area, and their mean edge (diameter 2)."""
    centre, scale = normalisation(vertices, faces)
    normal = (np.asarray(vertices, dtype=np.float64) - centre) * scale
    faces = np.asarray(faces, dtype=np.int64)[surface_faces(vertices, faces)]
    corners = normal[faces]
    edge = float(np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).mean())
    return normal, faces, edge


def mean_edge(vertices, faces):
    """The mean edge of the mesh's faces that have an area, the mesh scaled to a diameter of 2 (what
    :func:`choose_method` compares with the grid spacing)."""
    return _surface(vertices, faces)[2]


def _refusal(settings):
    """Why a run with ``settings`` cannot write colour at the vertices, or None."""
    if settings.stylised:
        return ("the settings paint a look (palette, strokes, contours, oil paint, toon, watercolour, hatching, "
                "ink lines or painted light), whose marks are finer than a vertex apart: choose Image output, "
                "or a filter preset (Denoise, Gaussian Blur, Perona-Malik)")
    return None


def choose_method(vertices, faces, settings, *, edge=None):
    """``(method, reason)``: ``"mesh"`` where the mesh filter serves the run (its mode runs on the mesh, the
    mesh's mean edge is at most :data:`MESH_EDGE` grid spacings and libigl can be imported), else ``"band"``;
    the reason in a sentence.
    ``edge``: the mean edge of the mesh scaled to a diameter of 2, if known."""
    if edge is None:
        edge = _surface(vertices, faces)[2]
    h = settings.spacing
    if settings.mode not in MESH_MODES:
        return "band", f"{settings.mode!r} runs on the closest point band only; the band is read at the vertices"
    if edge > MESH_EDGE * h:
        return "band", (f"the vertices lie farther apart (mean edge {edge:.3g}) than the band's grid (h = {h:.3g}, "
                        "both for a diameter of 2): the band filters between them, and is read at the vertices")
    if not mesh_filter_available():
        return "band", ("the mesh filter needs libigl, which this Python cannot import (the extension ships it: "
                        "install the extension again): the band filters, read at the vertices")
    return "mesh", (f"the vertices lie as close as the band's grid or closer (mean edge {edge:.3g}, h = {h:.3g}, "
                    "both for a diameter of 2): filtered on the mesh's own finite elements")


def corner_to_vertex(faces, corner_colours, vertices):
    """Per-corner colours (F, 3, C) as per-vertex colours (V, C): each vertex the mean of its corners weighted
    by their faces' areas (a vertex no face uses gets 0)."""
    faces = np.asarray(faces, dtype=np.int64)
    corner_colours = np.asarray(corner_colours, dtype=np.float64)
    if corner_colours.ndim != 3 or corner_colours.shape[:2] != (len(faces), 3):
        raise ValueError(f"corner colours must have shape ({len(faces)}, 3, C), got {corner_colours.shape}")
    corners = np.asarray(vertices, dtype=np.float64)[faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    weights = np.repeat(np.maximum(area, 1e-300), 3)
    n = len(vertices)
    total = np.bincount(faces.ravel(), weights=weights, minlength=n)
    sums = np.stack([np.bincount(faces.ravel(), weights=weights * corner_colours[..., k].ravel(), minlength=n)
                     for k in range(corner_colours.shape[2])], axis=1)
    return (sums / np.where(total > 0, total, 1.0)[:, None]).astype(np.float32)


def stylize_vertices(vertices, faces, colours, settings, *, method=None, progress=None, log=None):
    """Filter per-vertex ``colours`` (V, C) of a triangle mesh with ``settings``; returns a :class:`VertexResult`.

    ``method``: ``"mesh"`` or ``"band"`` to force one (default: :func:`choose_method`).  ``progress(fraction)``
    may raise to stop the run; ``log(message)`` hears what the run finds.  Raises ValueError for colours of
    the wrong shape or not finite, and for settings that paint a look (see the module's notes).
    """
    start = time.perf_counter()
    report = progress or (lambda f: None)
    say = log or (lambda msg: None)
    refusal = _refusal(settings)
    if refusal is not None:
        raise ValueError(f"colour at the vertices cannot be stylized this way: {refusal}")
    colours = np.asarray(colours)
    if colours.ndim != 2 or colours.shape[0] != len(vertices) or colours.shape[1] < 1:
        raise ValueError(f"colours must have one row per vertex, shape ({len(vertices)}, C), got {colours.shape}")
    if not np.all(np.isfinite(colours)):
        raise ValueError("colours hold NaN or infinite numbers")
    normal, faces, edge = _surface(vertices, faces)
    chosen, reason = choose_method(normal, faces, settings, edge=edge)
    if method is not None:
        if method not in ("mesh", "band"):
            raise ValueError(f"method must be 'mesh' or 'band', got {method!r}")
        if method == "mesh" and settings.mode not in MESH_MODES:
            raise ValueError(f"mode {settings.mode!r} does not run on the mesh; it runs on {MESH_MODES}")
        if method != chosen:
            reason = f"asked for the {method}"
        chosen = method
    say(f"vertex colours: {reason}")
    values = colours.astype(np.float32)
    report(0.0)
    used = np.unique(faces)
    if chosen == "mesh":
        # the mesh filter on the faces that have an area (a vertex they do not use keeps its colour)
        result = mesh_diffuse(normal, faces, values.astype(np.float64), **settings.diffusion_parameters(),
                              progress=lambda f: report(0.05 + 0.9 * f))
        points = len(used)
    else:
        mesh = TriangleMesh(normal, faces)
        band = Band.build(mesh, settings.spacing, stencil=stencil_for(settings.mode))
        say(f"band: {band.size:,} points at h = {settings.spacing} (object normalised to a diameter of 2)")
        report(0.1)
        sampled = sample_colours(band, ColourInput(corner_colours=values[faces]))
        field = stroke_field(band, settings) if settings.mode in DIRECTED_MODES else None
        filtered = diffuse(band, sampled, **settings.diffusion_parameters(), field=field,
                           progress=lambda f: report(0.15 + 0.75 * f))
        result = values.copy()
        # each vertex read on the sheet of one face it belongs to, as the bake-out reads a texel
        face = np.empty(len(normal), dtype=np.int64)
        corner = np.empty(len(normal), dtype=np.int64)
        face[faces.ravel()] = np.repeat(np.arange(len(faces)), 3)
        corner[faces.ravel()] = np.tile(np.arange(3), len(faces))
        bary = np.eye(3)[corner[used]]
        result[used] = band.interpolate(filtered, normal[used], mesh.normal(normal[used], face[used], bary),
                                        mesh.piece[face[used]])
        points = band.size
    out = np.asarray(result, dtype=np.float32)
    out[used] = ColourHull(values[used]).limit(out[used])
    report(1.0)
    return VertexResult(colours=out, method=chosen, reason=reason, seconds=time.perf_counter() - start,
                        points=points)
