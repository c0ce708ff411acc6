"""Where a mesh's faces lie in a square texture: the output's UV atlas.

:func:`uv_atlas` decides the layout: the mesh's own UVs when they are usable,
a new xatlas unwrap otherwise (or :class:`UnusableUVs`, when no new one may or
can be made).  The :class:`Atlas` also rasterises the layout: the texels each
face covers and their barycentric coordinates, from which
:func:`~cp_stylize.baking.bake_to_atlas` makes the image.

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

Texel ``(row, col)`` has its centre at ``uv = ((col + 0.5) / W, (row + 0.5) / H)``.
"""

from __future__ import annotations

import dataclasses
import importlib.util

import numpy as np

from .arrays import check_uvs, count
from .charts import projected_charts
from .mesh import check_mesh
from .raster import MIN_AREA, rasterise

__all__ = ["Atlas", "UnusableUVs", "uv_atlas", "uv_problems"]

#: UV coordinates may leave [0, 1] by this much.
_UV_SLACK = 1e-6
#: New atlases of meshes with up to this many faces are xatlas unwraps (14 s at 99,224 faces on two
#: cores, covering 62 % of a sphere's texels, and minutes beyond); larger meshes get charts projected
#: along the axes (:mod:`cp_stylize.charts`: 0.5 s and 55 % there, 1.5 s at 500,000 faces).
XATLAS_FACES = 100_000
#: The ways :func:`uv_atlas` makes a new atlas.
UNWRAPPERS = ("auto", "xatlas", "charts")


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
        True when ``uvs`` are new (unwrapped by xatlas, or charts projected along the axes); False when
        they are the mesh's own.
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


def _check_size(size):
    return count(size, "size", unit=" number of texels")


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
    mesh = check_mesh(mesh)
    size = _check_size(size)
    uvs = check_uvs(uvs, mesh.n_input_faces)
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
    flat = np.abs(det) <= 2 * MIN_AREA
    if flat.any():
        problems.append(f"{int(flat.sum())} face(s) have UV triangles of zero area")
    raster = rasterise(uv, size)
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


def uv_atlas(mesh, size, uvs=None, *, force_new=False, padding=None, allow_new=True, unwrap="auto"):
    """The UV layout of the output texture: the mesh's own UVs if usable, else a new one.

    Parameters
    ----------
    mesh : TriangleMesh
        The mesh the band was built from.
    size : int
        Texels a side of the square output image.
    uvs : array_like, shape (F, 3, 2), optional
        The mesh's own per-corner UVs for its input faces.
    force_new : bool
        Make a new atlas even when ``uvs`` are usable.
    padding : int, optional
        Texels between charts; default ``max(2, size // 256)``.
    allow_new : bool
        False: raise :class:`UnusableUVs` instead of unwrapping when ``uvs``
        are missing or not usable.
    unwrap : {"auto", "xatlas", "charts"}
        How a new atlas is made: an xatlas unwrap, or charts projected along
        the axes (:func:`cp_stylize.charts.projected_charts`); ``"auto"``
        takes xatlas for meshes of up to :data:`XATLAS_FACES` kept faces where
        it is installed, and charts otherwise.

    Returns
    -------
    Atlas

    Notes
    -----
    xatlas unwraps the kept faces (seam vertices duplicated) and packs the
    charts into one square atlas of about ``size`` texels with room around
    every chart for bilinear filtering; projected charts are made in time
    linear in the mesh, with ``padding`` texels around each.  The UVs are
    mapped back to the corners of the input faces; a skipped (degenerate)
    face, which covers no texel, gets the UVs of other corners at the same
    vertices.  :attr:`Atlas.reason` says which way the atlas was made.
    """
    mesh = check_mesh(mesh)
    size = _check_size(size)
    if uvs is not None:
        uvs = check_uvs(uvs, mesh.n_input_faces)
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
    if unwrap not in UNWRAPPERS:
        raise ValueError(f"unwrap must be one of {', '.join(map(repr, UNWRAPPERS))}, got {unwrap!r}")
    has_xatlas = importlib.util.find_spec("xatlas") is not None
    if unwrap == "xatlas" and not has_xatlas:
        raise UnusableUVs(problems, "xatlas, which makes new UV maps, is not installed for this platform and "
                                    "Python: add a UV map to the mesh (for example with Smart UV Project)")
    if padding is None:
        padding = max(2, size // 256)
    padding = count(padding, "padding", minimum=0, unit=" number of texels")
    if unwrap == "xatlas" or (unwrap == "auto" and has_xatlas and len(mesh.faces) <= XATLAS_FACES):
        corner = _xatlas_uvs(mesh, size, padding)
        texels, tri, bary, _ = rasterise(corner, size)
        how = "xatlas unwrapped it"
    else:
        try:
            corner, (texels, tri, bary, _), charts = projected_charts(mesh, size, padding)
        except ValueError as err:
            raise UnusableUVs(problems, str(err)) from None
        why = ("" if unwrap == "charts" else " (xatlas is not installed)" if not has_xatlas
               else f" (it has more than {XATLAS_FACES:,} faces, too many for xatlas)")
        how = f"{charts:,} charts were projected along the axes{why}"
    return Atlas(uvs=_input_uvs(mesh, corner), size=size, generated=True, reason=f"{reason}; {how}",
                 texels=texels, face=mesh.face_index[tri], bary=bary)


#: The xatlas unwrappers of the last unwrap, destroyed at the start of the next (see :func:`_xatlas_uvs`).
_RETIRED = []


def _xatlas_uvs(mesh, size, padding):
    """Per-corner UVs (K, 3, 2) of the kept faces from an xatlas unwrap.

    An ``xatlas.Atlas`` is not destroyed as soon as it is done: its destructor
    wakes its worker threads without their lock and joins them, and a worker
    that is between its wake-up check and its wait right then sleeps for ever,
    and the join with it (a lost wake-up; the workers settle microseconds after
    ``generate`` returns).  So each unwrapper is kept until the next unwrap
    starts, or the interpreter exits, when its workers have long been asleep.
    """
    import xatlas

    del _RETIRED[:]
    faces = mesh.faces
    atlas = xatlas.Atlas()
    _RETIRED.append(atlas)
    atlas.add_mesh(mesh.vertices.astype(np.float32), faces.astype(np.uint32))
    pack = xatlas.PackOptions()
    pack.resolution = size
    pack.padding = int(padding)
    pack.bilinear = True
    atlas.generate(xatlas.ChartOptions(), pack)
    if atlas.atlas_count != 1:
        pack.resolution = 0
        atlas = xatlas.Atlas()
        _RETIRED.append(atlas)
        atlas.add_mesh(mesh.vertices.astype(np.float32), faces.astype(np.uint32))
        atlas.generate(xatlas.ChartOptions(), pack)
    vmapping, indices, uv = atlas[0]
    indices = indices.astype(np.int64)
    if indices.shape != faces.shape or not np.array_equal(vmapping[indices], faces):
        raise RuntimeError("xatlas returned faces that do not match the mesh's faces")
    return uv.astype(np.float64)[indices]


def _input_uvs(mesh, corner):
    """Per-corner UVs (F, 3, 2) of the input faces from those of the kept faces ``corner`` (K, 3, 2): a
    skipped (degenerate) face, which covers no texel, gets the UVs of other corners at its vertices."""
    faces = mesh.faces
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


