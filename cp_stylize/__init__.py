"""cp_stylize: painterly and denoising filters on curved surfaces with the closest point method.

The numerical core (this package, except :mod:`cp_stylize.blender`) needs only
NumPy and SciPy.  Public API:

- surfaces: :class:`Sphere`, :class:`Torus`, :class:`Ellipsoid`, :class:`TriangleMesh`;
- the computational band: :class:`Band` (closest points, extension E, Laplacian L);
- surface heat flow: :func:`heat`;
- anisotropic and nonlinear surface diffusion: :func:`diffuse` (modes :data:`MODES`);
- texture in and out: :func:`sample_texture`, :func:`uv_atlas`, :func:`bake_to_atlas`,
  :func:`write_png`, and :func:`parametric_mesh` for a mesh with UVs made from a surface's parameters;
- the whole run: :func:`stylize` of a mesh's :class:`ColourInput` (:class:`Texture` images) with
  :class:`StylizeSettings`, from :func:`load_preset` (:func:`builtin_presets` in a checkout), giving a
  :class:`StylizeResult`; a :class:`RunCache` keeps what re-runs on the same mesh can reuse;
- colour at a mesh's vertices filtered into colour at its vertices (a scan, vertex paint):
  :func:`stylize_vertices`, giving a :class:`VertexResult`.

The names load on first use, so that importing the package (as the Blender
add-on does when it is enabled) does not import SciPy.
"""

import importlib

_PUBLIC = {"Band": "band", "band_width": "band", "MODES": "parameters", "diffuse": "diffusion", "heat": "heat_flow",
           "TriangleMesh": "mesh", "parametric_mesh": "mesh", "Sphere": "surfaces", "Torus": "surfaces",
           "Ellipsoid": "surfaces", "sample_texture": "sampling", "ColourInput": "sampling", "Texture": "sampling",
           "uv_atlas": "atlas", "bake_to_atlas": "baking", "write_png": "texture", "stylize": "pipeline",
           "StylizeResult": "pipeline", "RunCache": "cache", "StylizeSettings": "settings", "load_preset": "presets",
           "builtin_presets": "presets", "stylize_vertices": "vertex_colours", "VertexResult": "vertex_colours"}

__all__ = sorted(_PUBLIC)
__version__ = "0.1.0"


def __getattr__(name):
    if name in _PUBLIC:
        return getattr(importlib.import_module(f".{_PUBLIC[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
