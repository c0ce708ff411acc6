"""Texture out: images of band values, on a UV atlas or over an analytic surface's parameters.

- :func:`bake_to_atlas`: each covered texel of a :class:`~cp_stylize.atlas.Atlas`
  maps through its triangle's barycentric coordinates to the 3-D point with
  the same coordinates in that face, and takes the band's tricubic interpolant
  there (paper, eq. (47)).  Texels just outside the islands (the margin)
  continue their island's map onto the surface beyond its border (across the
  seam), so bilinear filtering and mipmaps read the surface's own colours
  there, never the background.
- :func:`bake_map`: an image over a surface's parameters ``point(s, t)``.

Images are float arrays (H, W, C), row 0 at the bottom (see :mod:`~cp_stylize.texture`).

Notes
-----
A covered texel with barycentric coordinates ``bary`` in face ``f`` maps
to the 3-D point ``sum_i bary_i V[f_i]``, which lies on the mesh (no
closest point search is needed), and takes the band's tricubic
interpolant there, kept to the point's own sheet of the surface where
another one passes within the stencil (``Band.interpolation_matrix``).  A margin texel finds its nearest covered texel (a
Euclidean distance transform) and continues that texel's face map
linearly: its UV point, pulled back to within two texels of the face's
UV triangle, has barycentric coordinates (some negative) that give a
point of the face's plane just beyond the face, which
``mesh.closest_point`` snaps onto the surface, across the seam when there
is one.  Bilinear filtering at an island's border thus reads the colours
of the surface on the other side of the border, not a copy of the
border, and seams stay invisible to second order in the texel size;
farther margin texels repeat the colour two texels out, for mipmaps.
"""

from __future__ import annotations

import typing

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from .arrays import count
from .atlas import Atlas
from .band import apply
from .mesh import check_mesh
from .raster import barycentric_2d, closest_in_triangle_2d
from .sparse import SplitMatrix, map_parallel, workers
from .texture import texel_centres

__all__ = ["bake_to_atlas", "bake_map", "Detail", "lay_detail", "texel_lengths"]

#: Band interpolations at once (each builds 64 weights a point).
_POINTS = 1 << 16
#: Margin texels continue their island's map linearly this far out, in texels.
_REACH = 2.0
#: Where the filter changed the band's colour by this much (RGB distance, values in
#: [0, 1]), the input's own detail comes back at exp(-1) of its strength: see :func:`lay_detail`.
DETAIL_CHANGE = 0.01
#: Where the filter changed the colour, detail weaker than this many of its robust
#: standard deviations (a noise level) is dropped: see :func:`lay_detail`.
DETAIL_THRESHOLD = 1.5


class Detail(typing.NamedTuple):
    """The input's own detail, finer than the band, for :func:`bake_to_atlas` to lay back.

    ``sampled`` (N, C) are the band values the filter started from (the input
    read at the closest points, before any noise), and ``colour_at(face, bary)``
    gives the input's colour (M, C) at any points of the mesh, given by their
    input face (M,) and barycentric coordinates (M, 3).  ``strength`` in [0, 1]
    scales the detail (0: the band's resolution only).
    """

    sampled: np.ndarray
    colour_at: typing.Callable
    strength: float = 1.0


def bake_to_atlas(band, values, atlas, *, margin=16, fill=0.0, detail=None, paint=None, progress=None,
                  texels=None, matrix=None, limit=None):
    """Image of band values laid out on a UV atlas.

    Parameters
    ----------
    band : Band
        Built from the mesh the atlas belongs to.
    values : ndarray, shape (N,) or (N, C)
        Band values (a closest point extension, e.g. after diffusion).
    atlas : Atlas
        From :func:`uv_atlas`.
    margin : int
        Texels outside the UV islands, up to this distance, that receive the
        value of the nearest island border point.
    fill : float
        Value of the texels farther than ``margin`` from every island.
    detail : Detail, optional
        Lay the input's own detail, finer than the band, back over the
        result where the filter left it (:func:`lay_detail`): a run that
        changes nothing then gives back the input's colours texel for texel.
    paint : callable, optional
        Paint laid over the texels last (:class:`cp_stylize.painting.Painting`):
        ``paint(texels, colours, columns, progress)`` returns the texels'
        colours (M, C) and the height (M,) the paint leaves, or None, given
        :func:`atlas_points` ``texels``, the colours and the band columns
        ``paint.columns`` (N, E) interpolated at the texels (M, E).  With
        ``paint``, the height image comes back too.
    texels : tuple, optional
        :func:`atlas_points` ``(mesh, atlas, margin)``, made before (it depends
        on the mesh and atlas only).
    matrix : SplitMatrix, optional
        :func:`bake_matrix` of the band and these texels, in the values' type,
        made before (it depends on the band and atlas only).
    limit : callable, optional
        ``limit(colours)`` (M, C) -> (M, C), applied last to the baked texels'
        colours and to ``fill`` (such as :meth:`cp_stylize.colours.ColourHull.limit`).

    Returns
    -------
    ndarray, shape (size, size, C)
        Row 0 at the bottom; float64 values stay float64, others give float32.
        With ``paint``: ``(image, height)``, the height (size, size) or None.

    Notes
    -----
    The module's notes say how the covered texels and the margin find their
    points on the surface.
    """
    mesh = check_mesh(band.surface)
    if not isinstance(atlas, Atlas):
        raise TypeError(f"atlas must be an Atlas from uv_atlas, got {type(atlas).__name__}")
    if atlas.uvs.shape[0] != mesh.n_input_faces:
        raise ValueError(f"the atlas has UVs for {atlas.uvs.shape[0]} faces, but the band's mesh has "
                         f"{mesh.n_input_faces}")
    margin = count(margin, "margin", minimum=0, unit=" number of texels")
    values, channels, columns = _stacked(band, values, detail, paint)
    texels = atlas_points(mesh, atlas, margin) if texels is None else texels
    where, points, faces, barys = texels
    report = progress or (lambda fraction: None)
    share = 1.0 if paint is None else 0.5          # of the progress, for the interpolation
    found = _interpolated(band, mesh, values, texels, matrix, lambda f: report(share * f))
    colours = found[:, :channels]
    if detail is not None:
        original = np.asarray(detail.colour_at(faces, barys), dtype=values.dtype).reshape(len(points), -1)
        colours = lay_detail(colours, found[:, channels:2 * channels], original[:, :channels], detail.strength)
    height = None
    if paint is not None:
        read = None if columns is None else found[:, found.shape[1] - columns.shape[1]:]
        colours, height = paint(texels, colours, read, lambda f: report(share + (1.0 - share) * f))
    background = np.full((1, channels), fill, dtype=values.dtype)
    if limit is not None:
        colours, background = limit(colours), limit(background)
    image = _laid_out(np.asarray(colours, dtype=values.dtype), where, atlas.size, background)
    image = image.reshape(atlas.size, atlas.size, channels)
    if paint is None:
        return image
    return image, None if height is None else _laid_out(height.astype(np.float32), where, atlas.size, 0.0)


class _Layered:
    """Two paints of :func:`bake_to_atlas` (``paint=``), the second laid over the first."""

    def __init__(self, under, over):
        self.under, self.over = under, over
        parts = [None if p.columns is None else np.asarray(p.columns).reshape(len(p.columns), -1) for p in (under, over)]
        self._split = 0 if parts[0] is None else parts[0].shape[1]
        given = [p for p in parts if p is not None]
        self.columns = np.hstack(given) if given else None

    def __call__(self, texels, colours, read, progress=None):
        report = progress or (lambda fraction: None)
        first, second = (None, None) if read is None else (read[:, :self._split], read[:, self._split:])
        colours, low = self.under(texels, colours, None if self.under.columns is None else first,
                                  lambda f: report(0.5 * f))
        colours, high = self.over(texels, colours, None if self.over.columns is None else second,
                                  lambda f: report(0.5 + 0.5 * f))
        heights = [h for h in (low, high) if h is not None]
        return colours, sum(heights) if heights else None


def layered(under, over):
    """``over`` laid over ``under`` as one paint of :func:`bake_to_atlas` (either may be None)."""
    if under is None or over is None:
        return over if under is None else under
    return _Layered(under, over)


def _stacked(band, values, detail, paint):
    """The band ``values`` (N, C) checked, with the columns a bake-out also interpolates beside them (the
    ``detail``'s sampled values, the ``paint``'s columns): ``(values (N, C + ...), C, paint's columns or
    None)``."""
    values = band.check_values(values)
    channels = 1 if values.ndim == 1 else values.shape[1]
    extra = []
    if detail is not None:
        sampled = band.check_values(detail.sampled).reshape(band.size, -1)
        if sampled.shape[1] != channels:
            raise ValueError(f"the detail's sampled values have {sampled.shape[1]} channel(s), the values {channels}")
        extra.append(sampled)
    columns = None if paint is None or paint.columns is None else np.asarray(paint.columns).reshape(band.size, -1)
    if columns is not None:
        extra.append(columns)
    if extra:
        values = np.hstack([values.reshape(band.size, channels)] + [e.astype(values.dtype) for e in extra])
    return values, channels, columns


def _interpolated(band, mesh, values, texels, matrix, progress):
    """Band ``values`` (N,) or (N, K) interpolated at the :func:`atlas_points` ``texels``: (M, K), by
    ``matrix`` (:func:`bake_matrix`) where given, else row block by row block on all cores."""
    _, points, faces, barys = texels
    found = np.empty((len(points), values.shape[1] if values.ndim == 2 else 1), dtype=values.dtype)
    if matrix is None:
        def interpolate(s):
            part = slice(s, s + _POINTS)
            found[part] = apply(_rows(band, mesh, points, faces, barys, part, values.dtype), values).reshape(
                -1, found.shape[1])

        map_parallel(interpolate, range(0, len(points), _POINTS), progress=progress)
    else:
        for j in range(found.shape[1]):
            found[:, j] = matrix @ np.ascontiguousarray(values.reshape(band.size, -1)[:, j])
    return found


def _laid_out(values, where, size, background):
    """``values`` (M, ...) at the flat texels ``where`` (M,) of a ``size`` square image, ``background``
    elsewhere: (size * size, ...) for (M, C), (size, size) for (M,)."""
    image = np.empty((size * size,) + values.shape[1:], dtype=values.dtype)
    image[:] = background
    image[where] = values
    return image if values.ndim > 1 else image.reshape(size, size)


def texel_lengths(mesh, atlas, faces):
    """Each texel's length on the surface (M,), for texels of input ``faces`` (M,): the square root of
    its face's area over the face's share of the atlas's area (UV triangles with no area count as
    the largest texel of the others)."""
    corners = mesh.vertices[mesh.input_faces]
    area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1)
    uv = atlas.uvs
    uv_area = 0.5 * np.abs((uv[:, 1, 0] - uv[:, 0, 0]) * (uv[:, 2, 1] - uv[:, 0, 1])
                           - (uv[:, 2, 0] - uv[:, 0, 0]) * (uv[:, 1, 1] - uv[:, 0, 1])) * atlas.size**2
    length = np.sqrt(area / np.where(uv_area > 0, uv_area, np.inf))
    flat = (uv_area <= 0) | ~np.isfinite(length) | (length <= 0)
    if flat.all():
        return np.full(len(faces), np.sqrt(mesh.area / max(len(atlas.texels), 1)))
    length[flat] = length[~flat].max()
    return length[np.asarray(faces)]


def _rows(band, mesh, points, faces, barys, part, dtype):
    """The interpolation matrix of the texel points ``points[part]`` (see :func:`bake_to_atlas`)."""
    return band.interpolation_matrix(points[part], dtype, mesh.normal(points[part], faces[part], barys[part]),
                                     mesh.piece[faces[part]])


def bake_matrix(band, texels, dtype=np.float32, progress=None):
    """The band's interpolation (M, N) at the surface points of :func:`atlas_points` ``texels``, as a
    :class:`~cp_stylize.sparse.SplitMatrix` (built in blocks on all cores); 64 entries a texel."""
    mesh = check_mesh(band.surface)
    _, points, faces, barys = texels
    blocks = map_parallel(lambda s: _rows(band, mesh, points, faces, barys, slice(s, s + _POINTS), dtype),
                          range(0, len(points), _POINTS), progress=progress)
    return SplitMatrix.stacked(blocks or [sp.csr_matrix((0, band.size), dtype=dtype)], band.size, dtype)


def atlas_points(mesh, atlas, margin):
    """The texels an atlas bakes and the surface points they read.

    Returns ``(texels, points, faces, barys)``: flat texel indices (M,), the
    points (M, 3) on the mesh, and each point's input face (M,) and
    barycentric coordinates (M, 3): the covered texels first, then the
    margin's (see :func:`bake_to_atlas`).
    """
    size = atlas.size
    corners = mesh.vertices[mesh.faces]                        # (K, 3, 3) kept faces
    n = len(atlas.texels)
    ring, near = _margin_ring(atlas.coverage, margin) if margin > 0 and n else (np.zeros(0, np.int64),) * 2
    texels = np.concatenate([atlas.texels, ring])
    points = np.empty((len(texels), 3))
    faces = np.empty(len(texels), dtype=np.int64)
    barys = np.empty((len(texels), 3))
    faces[:n], barys[:n] = atlas.face, atlas.bary          # which sheet each point is on (Sheets.keep_to_own)
    kept = mesh.kept_index(atlas.face)

    def covered(s):                                        # in blocks: no (M, 3, 3) corners at once
        part = slice(s, min(s + _POINTS, n))
        points[part] = np.einsum("mi,mij->mj", atlas.bary[part], corners[kept[part]])

    map_parallel(covered, range(0, n, _POINTS))
    if len(ring):
        owner = np.full(size * size, -1, dtype=np.int64)
        owner[atlas.texels] = atlas.face
        face = owner[near]
        row, col = np.divmod(ring, size)
        q = np.column_stack([(col + 0.5) / size, (row + 0.5) / size])
        uv = atlas.uvs[face]
        border = closest_in_triangle_2d(q, uv[:, 0], uv[:, 1], uv[:, 2])
        out = np.linalg.norm(q - border, axis=1) * size
        step = np.minimum(1.0, _REACH / np.where(out > 0, out, 1.0))
        q = border + step[:, None] * (q - border)
        bary = barycentric_2d(q, uv[:, 0], uv[:, 1], uv[:, 2])
        plane = np.einsum("mi,mij->mj", bary, corners[mesh.kept_index(face)])
        points[n:], _, faces[n:], barys[n:] = mesh.closest_point_on_faces(plane)
    return texels, points, faces, barys


def _margin_ring(covered, margin):
    """The uncovered texels within ``margin`` of a covered one (flat indices, in row order) and the flat
    index of the nearest covered texel of each.

    The distance transform runs in strips of rows, side by side on the cores:
    a strip grown by ``margin + 1`` rows each way holds every covered texel
    that lies within ``margin`` of its own rows.
    """
    size = covered.shape[1]
    step = max(64, -(-covered.shape[0] // (2 * workers())))

    def strip(r0):
        r1 = min(r0 + step, covered.shape[0])
        a, b = max(0, r0 - margin - 1), min(covered.shape[0], r1 + margin + 1)
        if not covered[a:b].any():
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        distance, nearest = ndimage.distance_transform_edt(~covered[a:b], return_indices=True)
        own = slice(r0 - a, r1 - a)
        d = distance[own].ravel()
        ring = np.flatnonzero((d > 0) & (d <= margin))
        near = (nearest[0][own].ravel()[ring] + a) * size + nearest[1][own].ravel()[ring]
        return ring + r0 * size, near

    parts = map_parallel(strip, range(0, covered.shape[0], step))
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def lay_detail(result, sampled, original, strength=1.0):
    """The result (M, C) with the input's detail finer than the band laid back over it.

    ``sampled`` is the band's interpolant of the input at the same points
    (what the filter started from, at the band's resolution) and ``original``
    the input's own colour there, so ``d = original - sampled`` is the detail
    the band cannot hold.  Where the filter changed little (``result -
    sampled`` small against :data:`DETAIL_CHANGE`) ``d`` comes back whole; a
    run that changes nothing returns ``original``.  Where it changed the
    colour, ``d`` is first shrunk (soft-thresholded) by
    :data:`DETAIL_THRESHOLD` times its robust standard deviation (the median
    absolute deviation, 1.4826 MAD, per channel): a texture's fine noise,
    which the filter was run to remove, stays away, while edges sharper than
    the band come back.  ``strength`` scales the detail.
    """
    result = np.asarray(result)
    d = np.asarray(original, dtype=result.dtype) - sampled
    change = np.linalg.norm(result - sampled, axis=1, keepdims=True)
    kept = np.exp(-(change / DETAIL_CHANGE) ** 2)
    noise = 1.4826 * np.median(np.abs(d), axis=0) if len(d) else 0.0
    shrunk = np.sign(d) * np.maximum(np.abs(d) - DETAIL_THRESHOLD * noise, 0.0)
    return (result + strength * (kept * d + (1.0 - kept) * shrunk)).astype(result.dtype, copy=False)


def bake_map(band, values, height, width):
    """Image (height, width, C) of band ``values`` at the surface points ``point(s, t)`` of its texels."""
    u, v = texel_centres(height, width)
    points = band.surface.point(u.ravel(), v.ravel())
    out = band.interpolate(values, points)
    return out.reshape(height, width, -1)
