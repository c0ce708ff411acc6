"""cp_stylize: painterly and denoising filters on curved surfaces with the closest point method.

The numerical core (this package, except :mod:`cp_stylize.blender`) needs only
NumPy and SciPy.  Public API:

- surfaces: :class:`Sphere`, :class:`Torus`, :class:`Ellipsoid`, :class:`TriangleMesh`;
- the computational band: :class:`Band` (closest points, extension E, Laplacian L);
- surface heat flow: :func:`heat`;
- anisotropic and nonlinear surface diffusion: :func:`diffuse` (modes :data:`MODES`).

The names load on first use, so that importing the package (as the Blender
add-on does when it is enabled) does not import SciPy.
"""

import importlib

_PUBLIC = {"Band": "band", "band_width": "band", "MODES": "parameters", "diffuse": "diffusion", "heat": "heat_flow",
           "TriangleMesh": "mesh", "Sphere": "surfaces", "Torus": "surfaces",
           "Ellipsoid": "surfaces"}

__all__ = sorted(_PUBLIC)
__version__ = "0.1.0"


def __getattr__(name):
    if name in _PUBLIC:
        return getattr(importlib.import_module(f".{_PUBLIC[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_PUBLIC))
