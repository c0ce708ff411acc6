"""cp_stylize: painterly and denoising filters on curved surfaces with the closest point method.

The numerical core (this package, except :mod:`cp_stylize.blender`) needs only
NumPy and SciPy.  Public API:

- surfaces: :class:`Sphere`, :class:`Torus`, :class:`TriangleMesh`;
- the computational band: :class:`Band` (closest points, extension E, Laplacian L);
- surface heat flow: :func:`heat`;
- anisotropic and nonlinear surface diffusion: :func:`diffuse` (modes :data:`MODES`).
"""

from .band import Band, band_width
from .diffusion import MODES, diffuse
from .heat import heat
from .mesh import TriangleMesh
from .surfaces import Sphere, Torus

__all__ = ["Band", "MODES", "Sphere", "Torus", "TriangleMesh", "band_width", "diffuse", "heat"]
__version__ = "0.1.0"
