"""Texture in: colours from images at the band's closest points (the start of the data path).

The data path of a run reads from the tree: a mesh (:mod:`~cp_stylize.mesh`)
-> its band (:mod:`~cp_stylize.band`) -> colours sampled into the band (this
module) -> diffusion (:mod:`~cp_stylize.diffusion`) -> the result baked into an
image (:mod:`~cp_stylize.baking`) laid out on a UV atlas (:mod:`~cp_stylize.atlas`).

- :func:`sample_texture`: an image read through a triangle mesh's per-corner
  UVs, at ``uv = sum_i bary_i uv_i`` over the corners of the face holding each
  closest point (``Band.face``, ``Band.bary``);
- :func:`sample_map`: an image over an analytic surface's parameters
  (``surface.parameters(cp)``);
- :class:`ColourInput`: a run's colour on a mesh (per-corner colours and
  :class:`Texture` images through UVs), read at points of the mesh by
  :func:`colours_at` and at the band's closest points by
  :func:`sample_colours`; :func:`picture_level` gives each face's picture
  horizontal.

Images are float arrays (H, W, C), row 0 at the bottom (see :mod:`~cp_stylize.texture`).
"""

from __future__ import annotations

import dataclasses
import typing

import numpy as np

from .arrays import check_uvs
from .texture import bilinear, check_image

__all__ = ["sample_texture", "texture_at", "sample_map", "Texture", "ColourInput", "sample_colours", "colours_at",
           "picture_level"]


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
    return texture_at(face, bary, uvs, image, wrap=wrap, n_faces=n_faces)


def texture_at(face, bary, uvs, image, *, wrap=("repeat", "repeat"), n_faces=None):
    """Image values at surface points given by their face (M,) and barycentric coordinates (M, 3).

    The lookup of :func:`sample_texture` for any points of the mesh (the bake-out's texels, for one).
    """
    uvs = np.asarray(uvs)
    if n_faces is None:
        n_faces = len(uvs)
    uvs = check_uvs(uvs, n_faces)
    image = np.asarray(image)
    if not np.issubdtype(image.dtype, np.floating):
        raise TypeError(f"image must hold floats in [0, 1], got dtype {image.dtype}")
    uv = np.einsum("ni,nij->nj", bary, uvs[face])
    return bilinear(image.astype(np.float32, copy=False), uv, wrap=wrap).astype(np.float32, copy=False)


def sample_map(band, image, *, wrap=("repeat", "clamp")):
    """Values at the band's closest points of an image mapped by the surface parametrisation.

    The surface must have ``parameters(p) -> (s, t)`` (for example
    :class:`~cp_stylize.Sphere`, whose map is equirectangular).

    Returns
    -------
    ndarray, shape (N, C), float32
    """
    s, t = band.surface.parameters(band.cp)
    return bilinear(check_image(image).astype(np.float32, copy=False), np.column_stack([s, t]), wrap=wrap)


class Texture(typing.NamedTuple):
    """An image read through per-corner UVs on some faces of a mesh (see :class:`ColourInput`)."""

    image: np.ndarray              # (H, W, C), row 0 at the bottom
    uvs: np.ndarray                # (F, 3, 2)
    faces: np.ndarray              # (F,) bool: the faces it colours
    wrap: tuple = ("repeat", "repeat")  # beyond [0, 1]: see cp_stylize.texture.bilinear


@dataclasses.dataclass
class ColourInput:
    """Colour on a mesh's surface, sRGB-encoded values in [0, 1].

    Attributes
    ----------
    corner_colours : ndarray (F, 3, C) or None
        Colours at the corners of each face, interpolated across the face
        (a colour attribute, or a material's flat base colour).
    textures : list of :class:`Texture` or (image, uvs, faces) tuples
        Images (H, W, C), row 0 at the bottom, each read through per-corner UVs
        (F, 3, 2) on the faces where the boolean mask ``faces`` (F,) is set,
        with its ``wrap`` beyond [0, 1] (default: repeat).  Textures win over
        ``corner_colours``.
    """

    corner_colours: np.ndarray | None = None
    textures: list = dataclasses.field(default_factory=list)

    @classmethod
    def constant(cls, n_faces, colour):
        colour = np.asarray(colour, dtype=np.float32)
        return cls(corner_colours=np.broadcast_to(colour, (n_faces, 3, len(colour))).copy())

    @property
    def texture_list(self):
        """The textures, each as a :class:`Texture` (a tuple given is read as one, with its default wrap)."""
        return [Texture(*t) for t in self.textures]

    @property
    def image_pixels(self):
        """The pixels of the textures' images, for :func:`cp_stylize.estimate.estimate`."""
        return sum(int(np.prod(np.shape(t.image)[:2])) for t in self.texture_list)


def sample_colours(band, colours, channels=3):
    """Colour (N, channels) at the band's closest points from a :class:`ColourInput`."""
    if band.face is None:
        raise ValueError("the band was not built on a triangle mesh: it has no faces to read colours from")
    return colours_at(band.face, band.bary, colours, channels)


def colours_at(face, bary, colours, channels=3):
    """Colour (M, channels) of a :class:`ColourInput` at points of its mesh: input faces (M,), barycentrics (M, 3)."""
    values = np.zeros((len(face), channels), dtype=np.float32)
    if colours.corner_colours is not None:
        corners = np.asarray(colours.corner_colours, dtype=np.float32)[face, :, :channels]
        values[:, :corners.shape[2]] = np.einsum("nk,nkc->nc", np.asarray(bary, dtype=np.float32), corners)
    for image, uvs, faces, wrap in colours.texture_list:
        chosen = np.asarray(faces, dtype=bool)[face]
        sampled = texture_at(face[chosen], bary[chosen], uvs, np.asarray(image, dtype=np.float32), wrap=wrap)
        values[chosen, :min(channels, sampled.shape[1])] = sampled[:, :channels]
    return values


def picture_level(mesh, colours):
    """The picture's horizontal on each input face of ``mesh`` (F, 3): the unit 3-D direction along the u axis
    of the last of a :class:`ColourInput`'s textures that colours the face, 0 where none does or its UVs
    have no area."""
    corners = mesh.vertices[mesh.input_faces]
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]
    level = np.zeros((len(corners), 3))
    for _, uvs, faces, _ in colours.texture_list:
        uvs = np.asarray(uvs, dtype=np.float64)
        d1, d2 = uvs[:, 1] - uvs[:, 0], uvs[:, 2] - uvs[:, 0]
        det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            along = (d2[:, 1, None] * e1 - d1[:, 1, None] * e2) / det[:, None]      # d(point)/du on the face
            length = np.linalg.norm(along, axis=1)
            ok = np.asarray(faces, dtype=bool) & np.isfinite(length) & (length > 0)
        level[ok] = along[ok] / length[ok, None]
    return level
