"""Texture in: colours from images at the band's closest points (the start of the data path).

The data path of a run reads from the tree: a mesh (:mod:`~cp_stylize.mesh`)
-> its band (:mod:`~cp_stylize.band`) -> colours sampled into the band (this
module) -> diffusion (:mod:`~cp_stylize.diffusion`) -> the result baked into an
image (:mod:`~cp_stylize.baking`) laid out on a UV atlas (:mod:`~cp_stylize.atlas`).

- :func:`sample_texture`: an image read through a triangle mesh's per-corner
  UVs, at ``uv = sum_i bary_i uv_i`` over the corners of the face holding each
  closest point (``Band.face``, ``Band.bary``);
- :func:`sample_map`: an image over an analytic surface's parameters
  (``surface.parameters(cp)``).

Images are float arrays (H, W, C), row 0 at the bottom (see :mod:`~cp_stylize.texture`).
"""

from __future__ import annotations

import numpy as np

from .arrays import check_uvs
from .texture import bilinear, check_image

__all__ = ["sample_texture", "texture_at", "sample_map"]


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
