"""Textures on triangle meshes: bake-in through per-corner UVs, bake-out into a UV atlas.

Texture in
    :func:`sample_texture` reads an image at the UV coordinates of every band
    point's closest point, ``uv = sum_i bary_i uv_i`` over the corners of the
    face that holds it (``Band.face``, ``Band.bary``).

Texture out
    :func:`uv_atlas` decides where every face goes in the output image: the
    mesh's own UVs when they are usable, a new xatlas unwrap otherwise.
    :func:`bake_to_atlas` maps every texel centre inside a UV triangle to the
    3-D point with the same barycentric coordinates in that face, and takes
    the band's tricubic interpolant there (paper, eq. (47)).  Texels just
    outside the islands (the margin) continue their island's map onto the
    surface beyond its border (across the seam), so bilinear filtering and
    mipmaps read the surface's own colours there, never the background.

Usable UVs
    Per-corner UVs (F, 3, 2) are usable for an atlas of ``size`` x ``size``
    texels when, over the faces the mesh keeps (see
    :class:`~cp_stylize.mesh.TriangleMesh`):

    - every coordinate is finite and inside ``[0, 1]`` (to 1e-6);
    - no UV triangle has zero area (below 1e-6 square texels);
    - no texel centre lies inside two UV triangles by more than 1e-3 texel
      from their edges.  This is detected by rasterising every triangle at
      the atlas resolution, not assumed; triangles that meet along an edge
      or at a corner do not overlap, and overlaps too thin to hold a texel
      centre are not seen (and do not matter at that resolution).

Images are float arrays (H, W, C) with row 0 at the bottom, as in
:mod:`cp_stylize.texture`: texel ``(row, col)`` has its centre at
``uv = ((col + 0.5) / W, (row + 0.5) / H)``.
"""

from __future__ import annotations

import dataclasses
import importlib.util

import numpy as np
from scipy import ndimage

from .mesh import _expand, _split_counts
from .texture import bilinear

__all__ = ["Atlas", "UnusableUVs", "uv_atlas", "uv_problems", "sample_texture", "bake_to_atlas"]

#: Texel centres rasterised at once.
_TEXELS = 1 << 21
#: Band interpolations at once (each builds 64 weights a point).
_POINTS = 1 << 16
#: Inside test slack, in texels: a centre on an edge belongs to the triangle ...
_EDGE = 1e-6
#: ... but counts towards an overlap only this far inside.
_INSET = 1e-3
#: UV triangles below this area, in square texels, have zero area.
_MIN_AREA = 1e-6
#: UV coordinates may leave [0, 1] by this much.
_UV_SLACK = 1e-6
#: Margin texels continue their island's map linearly this far out, in texels.
_REACH = 2.0


@dataclasses.dataclass(frozen=True, eq=False)
class Atlas:
    """Where every face of a mesh lies in a square texture, and which texels it covers.

    Attributes
    ----------
    uvs : ndarray, shape (F, 3, 2)
        Per-corner UV coordinates of the mesh's input faces.
    size : int
        The image is ``size`` x ``size`` texels.
    generated : bool
        True when xatlas made ``uvs``; False when they are the mesh's own.
    reason : str
        Why these UVs: that the given ones are usable, or why they were not used.
    texels : ndarray of int64, shape (M,)
        Flat indices ``row * size + col`` of the texels whose centre lies in a
        UV triangle.
    face : ndarray of int64, shape (M,)
        The input face that covers each of them.
    bary : ndarray, shape (M, 3)
        Barycentric coordinates of the texel centre in that face's UV triangle.
    """

    uvs: np.ndarray = dataclasses.field(repr=False)
    size: int
    generated: bool
    reason: str
    texels: np.ndarray = dataclasses.field(repr=False)
    face: np.ndarray = dataclasses.field(repr=False)
    bary: np.ndarray = dataclasses.field(repr=False)

    @property
    def coverage(self):
        """Boolean image (size, size), row 0 at the bottom: texels inside a UV triangle."""
        mask = np.zeros(self.size * self.size, dtype=bool)
        mask[self.texels] = True
        return mask.reshape(self.size, self.size)


def _check_mesh(mesh):
    for name in ("faces", "face_index", "n_input_faces", "vertices"):
        if not hasattr(mesh, name):
            raise TypeError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
    return mesh


def _check_size(size):
    if isinstance(size, (bool, np.bool_)) or not isinstance(size, (int, np.integer)):
        raise TypeError(f"size must be an integer number of texels, got {size!r}")
    if size < 1:
        raise ValueError(f"size must be a positive number of texels, got {size!r}")
    return int(size)


def _check_uvs(uvs, n_faces):
    uvs = np.asarray(uvs)
    if uvs.shape != (n_faces, 3, 2):
        raise ValueError(f"uvs must have shape ({n_faces}, 3, 2), one UV per face corner, got {uvs.shape}")
    if not (np.issubdtype(uvs.dtype, np.floating) or np.issubdtype(uvs.dtype, np.integer)):
        raise TypeError(f"uvs must hold real numbers, got dtype {uvs.dtype}")
    return uvs.astype(np.float64, copy=False)


def _rasterise(uv, size):
    """Texels covered by UV triangles ``uv`` (K, 3, 2).

    Returns the covered texels (M,), the triangle chosen for each (the one
    whose edges its centre is farthest inside), the barycentric coordinates
    (M, 3), and the number of texels that lie inside two or more triangles
    by more than ``_INSET`` texels.
    """
    p = uv * size - 0.5                                  # texel centres at integers
    x0, y0, x1, y1, x2, y2 = (p[:, k, a] for k in range(3) for a in range(2))
    det = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)  # twice the signed area
    edge = np.stack([np.hypot(x2 - x1, y2 - y1), np.hypot(x0 - x2, y0 - y2), np.hypot(x1 - x0, y1 - y0)], 1)
    usable = (np.abs(det) > 2 * _MIN_AREA) & np.all(np.isfinite(p.reshape(len(p), -1)), axis=1)
    tri = np.flatnonzero(usable)
    lo = np.clip(np.ceil(p[tri].min(axis=1) - _EDGE), 0, size).astype(np.int64)
    hi = np.clip(np.floor(p[tri].max(axis=1) + _EDGE), -1, size - 1).astype(np.int64)
    rows = np.maximum(hi[:, 1] - lo[:, 1] + 1, 0)
    cols = np.maximum(hi[:, 0] - lo[:, 0] + 1, 0)
    rows[cols == 0] = 0
    # units: one texel row of one triangle's bounding box
    unit_tri, unit_row = _expand(rows)
    unit_row += lo[unit_tri, 1]
    unit_cols = cols[unit_tri]
    best_score = np.full(size * size, -np.inf, dtype=np.float32)
    best_tri = np.full(size * size, -1, dtype=np.int32)
    best_bary = np.zeros((size * size, 3), dtype=np.float32)
    claims = np.zeros(size * size, dtype=np.uint8)
    bounds = _split_counts(unit_cols, _TEXELS)
    for s, e in zip(bounds[:-1], bounds[1:]):
        unit, col = _expand(unit_cols[s:e])
        unit += s
        t = unit_tri[unit]
        k = tri[t]
        qx = (col + lo[t, 0]).astype(np.float64)
        qy = unit_row[unit].astype(np.float64)
        l0 = ((x1[k] - qx) * (y2[k] - qy) - (x2[k] - qx) * (y1[k] - qy)) / det[k]
        l1 = ((x2[k] - qx) * (y0[k] - qy) - (x0[k] - qx) * (y2[k] - qy)) / det[k]
        l2 = 1.0 - l0 - l1
        area = np.abs(det[k])
        score = np.minimum(np.minimum(l0 * area / edge[k, 0], l1 * area / edge[k, 1]), l2 * area / edge[k, 2])
        texel = unit_row[unit] * size + col + lo[t, 0]
        inside = np.flatnonzero(score >= -_EDGE)
        texel, score, k = texel[inside], score[inside], k[inside]
        bary = np.column_stack([l0[inside], l1[inside], l2[inside]])
        claimed, counts = np.unique(texel[score > _INSET], return_counts=True)
        claims[claimed] = np.minimum(claims[claimed] + np.minimum(counts, 2), 2)
        order = np.lexsort((score, texel))
        last = order[np.r_[texel[order][1:] != texel[order][:-1], True]]
        better = score[last].astype(np.float32) > best_score[texel[last]]
        chosen = last[better]
        best_score[texel[chosen]] = score[chosen]
        best_tri[texel[chosen]] = k[chosen]
        best_bary[texel[chosen]] = bary[chosen]
    texels = np.flatnonzero(best_tri >= 0)
    bary = np.clip(best_bary[texels].astype(np.float64), 0.0, None)
    bary /= bary.sum(axis=1, keepdims=True)
    return texels, best_tri[texels].astype(np.int64), bary, int(np.count_nonzero(claims > 1))


def uv_problems(mesh, uvs, size):
    """Why per-corner UVs are not usable for an atlas of ``size`` texels (empty list: usable).

    Parameters
    ----------
    mesh : TriangleMesh
    uvs : array_like, shape (F, 3, 2)
        Per-corner UVs of the mesh's input faces.
    size : int
        Atlas resolution, texels a side.

    Returns
    -------
    list of str
        One sentence per problem found; see the module notes for the rules.
    """
    mesh = _check_mesh(mesh)
    size = _check_size(size)
    uvs = _check_uvs(uvs, mesh.n_input_faces)
    return _problems(uvs[mesh.face_index], size)[0]


def _problems(uv, size):
    """Problems of the UV triangles ``uv`` (K, 3, 2) of the kept faces, and their raster if made."""
    problems = []
    finite = np.all(np.isfinite(uv.reshape(len(uv), -1)), axis=1)
    if not finite.all():
        problems.append(f"{int((~finite).sum())} face(s) have UVs that are not finite numbers")
        return problems, None
    outside = np.any((uv < -_UV_SLACK) | (uv > 1 + _UV_SLACK), axis=(1, 2))
    if outside.any():
        problems.append(f"{int(outside.sum())} face(s) have UVs outside [0, 1]")
    p = uv * size
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    det = e1[:, 0] * e2[:, 1] - e2[:, 0] * e1[:, 1]
    flat = np.abs(det) <= 2 * _MIN_AREA
    if flat.any():
        problems.append(f"{int(flat.sum())} face(s) have UV triangles of zero area")
    raster = _rasterise(uv, size)
    if raster[3]:
        problems.append(f"UV triangles overlap at {raster[3]} texel(s)")
    return problems, raster


class UnusableUVs(ValueError):
    """The mesh's own UVs cannot hold the output and no new atlas can be made.

    ``problems`` says what is wrong with the UVs, ``why`` (if known here) why
    no new atlas can be made.
    """

    def __init__(self, problems, why=None):
        self.problems, self.why = problems, why
        super().__init__(f"the mesh has no usable UVs ({problems})" + (f" and {why}" if why else ""))


def uv_atlas(mesh, size, uvs=None, *, force_new=False, padding=None, allow_new=True):
    """The UV layout of the output texture: the mesh's own UVs if usable, else a new xatlas unwrap.

    Parameters
    ----------
    mesh : TriangleMesh
        The mesh the band was built from.
    size : int
        Texels a side of the square output image.
    uvs : array_like, shape (F, 3, 2), optional
        The mesh's own per-corner UVs for its input faces.
    force_new : bool
        Unwrap with xatlas even when ``uvs`` are usable.
    padding : int, optional
        Texels between xatlas charts; default ``max(2, size // 256)``.
    allow_new : bool
        False: raise :class:`UnusableUVs` instead of unwrapping when ``uvs``
        are missing or not usable.

    Returns
    -------
    Atlas

    Notes
    -----
    xatlas unwraps the kept faces (seam vertices duplicated) and packs the
    charts into one square atlas of about ``size`` texels with room around
    every chart for bilinear filtering.  Its UVs are mapped back to the
    corners of the input faces; a skipped (degenerate) face, which covers no
    texel, gets the UVs of other corners at the same vertices.
    """
    mesh = _check_mesh(mesh)
    size = _check_size(size)
    if uvs is not None:
        uvs = _check_uvs(uvs, mesh.n_input_faces)
    if uvs is not None and not force_new:
        problems, raster = _problems(uvs[mesh.face_index], size)
        if not problems:
            texels, tri, bary, _ = raster
            return Atlas(uvs=uvs.copy(), size=size, generated=False, reason="the mesh's own UVs are usable",
                         texels=texels, face=mesh.face_index[tri], bary=bary)
        problems = "; ".join(problems)
        reason = "the mesh's own UVs are not usable: " + problems
    else:
        reason = "a new atlas was requested" if force_new else "the mesh has no UVs"
        problems = "it has none" if uvs is None else reason
    if not allow_new:
        raise UnusableUVs(problems)
    if importlib.util.find_spec("xatlas") is None:
        raise UnusableUVs(problems, "xatlas, which makes new UV maps, is not installed for this platform and "
                                    "Python: add a UV map to the mesh (for example with Smart UV Project)")
    new = _xatlas_uvs(mesh, size, padding=padding)
    texels, tri, bary, _ = _rasterise(new[mesh.face_index], size)
    return Atlas(uvs=new, size=size, generated=True, reason=reason,
                 texels=texels, face=mesh.face_index[tri], bary=bary)


def _xatlas_uvs(mesh, size, *, padding=None):
    """Per-corner UVs (F, 3, 2) of the input faces from an xatlas unwrap of the kept faces."""
    import xatlas

    if padding is None:
        padding = max(2, size // 256)
    if isinstance(padding, (bool, np.bool_)) or not isinstance(padding, (int, np.integer)) or padding < 0:
        raise ValueError(f"padding must be a non-negative integer number of texels, got {padding!r}")
    faces = mesh.faces
    atlas = xatlas.Atlas()
    atlas.add_mesh(mesh.vertices.astype(np.float32), faces.astype(np.uint32))
    pack = xatlas.PackOptions()
    pack.resolution = size
    pack.padding = int(padding)
    pack.bilinear = True
    atlas.generate(xatlas.ChartOptions(), pack)
    if atlas.atlas_count != 1:
        pack.resolution = 0
        atlas = xatlas.Atlas()
        atlas.add_mesh(mesh.vertices.astype(np.float32), faces.astype(np.uint32))
        atlas.generate(xatlas.ChartOptions(), pack)
    vmapping, indices, uv = atlas[0]
    indices = indices.astype(np.int64)
    if indices.shape != faces.shape or not np.array_equal(vmapping[indices], faces):
        raise RuntimeError("xatlas returned faces that do not match the mesh's faces")
    corner = uv.astype(np.float64)[indices]                     # (K, 3, 2)
    out = np.zeros((mesh.n_input_faces, 3, 2))
    out[mesh.face_index] = corner
    skipped = np.setdiff1d(np.arange(mesh.n_input_faces), mesh.face_index)
    if len(skipped):
        at_vertex = np.zeros((len(mesh.vertices), 2))
        at_vertex[faces.ravel()] = corner.reshape(-1, 2)
        out[skipped] = at_vertex[_input_faces(mesh)[skipped]]
    return out


def _input_faces(mesh):
    faces = getattr(mesh, "input_faces", None)
    if faces is None:
        raise RuntimeError("the mesh does not keep its input faces")
    return faces


def sample_texture(band, uvs, image, *, wrap=("repeat", "repeat")):
    """Image values at the band's closest points, read through per-corner UVs.

    Parameters
    ----------
    band : Band
        A band built from a :class:`~cp_stylize.mesh.TriangleMesh` (it has
        ``face`` and ``bary``).
    uvs : array_like, shape (F, 3, 2)
        Per-corner UVs of the mesh's input faces.
    image : ndarray, shape (H, W, C) or (H, W)
        Float image, row 0 at the bottom.
    wrap : pair of {"repeat", "clamp"}
        Lookup beyond the edge texel centres, for ``u`` and ``v``; "repeat"
        is Blender's default image extension.

    Returns
    -------
    ndarray, shape (N, C), float32
        Bilinear lookups at ``uv = sum_i bary_i uvs[face, i]``.
    """
    face, bary = getattr(band, "face", None), getattr(band, "bary", None)
    if face is None or bary is None:
        raise ValueError(f"the band must be built from a triangle mesh (it needs face and bary), got {band!r}")
    n_faces = getattr(band.surface, "n_input_faces", None)
    uvs = np.asarray(uvs)
    if n_faces is None:
        n_faces = len(uvs)
    uvs = _check_uvs(uvs, n_faces)
    image = np.asarray(image)
    if not np.issubdtype(image.dtype, np.floating):
        raise TypeError(f"image must hold floats in [0, 1], got dtype {image.dtype}")
    uv = np.einsum("ni,nij->nj", bary, uvs[face])
    return bilinear(image.astype(np.float32, copy=False), uv, wrap=wrap).astype(np.float32, copy=False)


def _barycentric_2d(q, a, b, c):
    """Barycentric coordinates (M, 3) of points ``q`` (M, 2) in triangles ``abc`` (unclamped)."""
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    v = ((q[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1])) / det
    w = ((b[:, 0] - a[:, 0]) * (q[:, 1] - a[:, 1]) - (q[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])) / det
    return np.column_stack([1.0 - v - w, v, w])


def _closest_in_triangle_2d(q, a, b, c):
    """Points (M, 2) of triangles ``abc`` nearest to ``q`` (M, 2): inside, or on the nearest edge."""
    def on_segment(p, r):
        d = r - p
        t = np.clip(np.einsum("ij,ij->i", q - p, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        return p + t[:, None] * d

    candidates = np.stack([on_segment(a, b), on_segment(b, c), on_segment(c, a)])
    gap = ((candidates - q[None]) ** 2).sum(axis=2)
    nearest = candidates[np.argmin(gap, axis=0), np.arange(len(q))]
    bary = _barycentric_2d(q, a, b, c)
    inside = np.all(bary >= 0, axis=1)
    return np.where(inside[:, None], q, nearest)


def bake_to_atlas(band, values, atlas, *, margin=16, fill=0.0):
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

    Returns
    -------
    ndarray, shape (size, size, C)
        Row 0 at the bottom; float64 values stay float64, others give float32.

    Notes
    -----
    A covered texel with barycentric coordinates ``bary`` in face ``f`` maps
    to the 3-D point ``sum_i bary_i V[f_i]``, which lies on the mesh (no
    closest point search is needed), and takes the band's tricubic
    interpolant there.  A margin texel finds its nearest covered texel (a
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
    mesh = _check_mesh(band.surface)
    if not isinstance(atlas, Atlas):
        raise TypeError(f"atlas must be an Atlas from uv_atlas, got {type(atlas).__name__}")
    if atlas.uvs.shape[0] != mesh.n_input_faces:
        raise ValueError(f"the atlas has UVs for {atlas.uvs.shape[0]} faces, but the band's mesh has "
                         f"{mesh.n_input_faces}")
    if isinstance(margin, (bool, np.bool_)) or not isinstance(margin, (int, np.integer)) or margin < 0:
        raise ValueError(f"margin must be a non-negative integer number of texels, got {margin!r}")
    values = band._check_values(values)
    size = atlas.size
    kept = mesh._kept
    corners = mesh.vertices[mesh.faces]                        # (K, 3, 3) kept faces
    texels = [atlas.texels]
    points = [np.einsum("mi,mij->mj", atlas.bary, corners[kept[atlas.face]])]

    covered = atlas.coverage
    if margin > 0 and len(atlas.texels):
        distance, nearest = ndimage.distance_transform_edt(~covered, return_indices=True)
        ring = np.flatnonzero((distance > 0) & (distance <= margin))
        if len(ring):
            owner = np.full(size * size, -1, dtype=np.int64)
            owner[atlas.texels] = atlas.face
            near = nearest[0].ravel()[ring] * size + nearest[1].ravel()[ring]
            face = owner[near]
            row, col = np.divmod(ring, size)
            q = np.column_stack([(col + 0.5) / size, (row + 0.5) / size])
            uv = atlas.uvs[face]
            border = _closest_in_triangle_2d(q, uv[:, 0], uv[:, 1], uv[:, 2])
            out = np.linalg.norm(q - border, axis=1) * size
            step = np.minimum(1.0, _REACH / np.where(out > 0, out, 1.0))
            q = border + step[:, None] * (q - border)
            bary = _barycentric_2d(q, uv[:, 0], uv[:, 1], uv[:, 2])
            plane = np.einsum("mi,mij->mj", bary, corners[kept[face]])
            texels.append(ring)
            points.append(mesh.closest_point(plane)[0])
    texels = np.concatenate(texels)
    points = np.concatenate(points)

    channels = 1 if values.ndim == 1 else values.shape[1]
    image = np.full((size * size, channels), fill, dtype=values.dtype)
    for s in range(0, len(points), _POINTS):
        out = band.interpolate(values, points[s:s + _POINTS])
        image[texels[s:s + _POINTS]] = out.reshape(len(out), channels)
    return image.reshape(size, size, channels)
