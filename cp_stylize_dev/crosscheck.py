"""The two discretisations checked against each other: ``python -m cp_stylize crosscheck``.

The closest point method (the band, :func:`cp_stylize.diffuse`) and the
mesh's own finite elements (:func:`cp_stylize.mesh_diffusion.mesh_diffuse`;
Wu, Deng, Chen and Tai, "Scale-space analysis of discrete filtering over
arbitrary triangulated surfaces", 2009) discretise the same surface
diffusion.  Each case here filters one smooth function of position on a
triangle mesh with both, reads the band's result at the mesh's vertices, and
reports how far the two lie apart as a PSNR (peak: the range of the mesh's
result; the mean square weighted by the vertices' lumped areas).  The mesh's
vertex spacing is kept below the band's ``h``, and both are refined
together: the difference falls as they are.

Cases: an icosphere (filtering ``x y``, whose heat flow there is known, so
each discretisation's own error is reported too), a torus and the demo's
Suzanne at three levels of subdivision (the last needs Blender's Python
module, ``bpy``; it is skipped with the reason where that is missing).
"""

from __future__ import annotations

import dataclasses
import sys
import tempfile
import time

import numpy as np

#: The filter and its settings: the same for both discretisations.
MODE = "gaussian"
#: The diffusion time, in squared lengths of the object normalised to a diameter of 2.
TIME = 0.01


def icosphere(subdivisions=4):
    """A unit icosphere: vertices (n, 3), faces (F, 3), its triangles all acute."""
    t = (1.0 + 5**0.5) / 2.0
    vertices = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t], [0, -1, -t], [0, 1, -t],
                [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    faces = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4], [11, 10, 2],
             [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9], [4, 9, 5], [2, 4, 11],
             [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    vertices = [np.asarray(v, float) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        middle, out = {}, []

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                m = vertices[a] + vertices[b]
                vertices.append(m / np.linalg.norm(m))
                middle[key] = len(vertices) - 1
            return middle[key]
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            out += [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
        faces = out
    return np.array(vertices), np.array(faces, dtype=np.int64)


def torus_mesh(around, R=0.7, r=0.3):
    """A torus of radii ``R`` and ``r`` (diameter 2 at the defaults) as ``around`` by about
    ``around * r / R`` quads, each split into two triangles: vertices (n, 3), faces (F, 3)."""
    from cp_stylize.mesh import parametric_mesh
    from cp_stylize.surfaces import Torus

    tube = max(3, int(round(around * r / R)))
    vertices, faces, _ = parametric_mesh(Torus(R, r).point, around, tube, periodic_u=True, periodic_v=True)
    return vertices, faces


def signal(vertices):
    """The smooth function of position that is filtered: ``x y`` plus a slower wave."""
    x, y, z = vertices.T
    return x * y + 0.5 * np.sin(2.0 * x + z)


@dataclasses.dataclass
class Comparison:
    """One case at one refinement: the PSNR of the band's result against the mesh's, and the times."""
    case: str
    vertices: int
    spacing: float        # the mesh's mean edge length
    h: float              # the band's grid spacing
    psnr: float           # band against mesh, dB
    mesh_seconds: float
    band_seconds: float
    exact: tuple = ()     # (mesh against exact, band against exact), dB, where the exact flow is known

    def row(self):
        exact = " / ".join(f"{e:.1f}" for e in self.exact) if self.exact else "-"
        return (f"| {self.case} | {self.vertices:,} | {self.spacing:.4f} | {self.h:g} | {self.psnr:.1f} | {exact} | "
                f"{self.mesh_seconds:.1f} / {self.band_seconds:.1f} |")


HEADER = ("| case | vertices | edge | h | band vs mesh, dB | mesh / band vs exact, dB | seconds, mesh / band |\n"
          "|---|---|---|---|---|---|---|")


def compare(case, vertices, faces, h, *, field=signal, mode=MODE, T=TIME, exact=None, **params):
    """The :class:`Comparison` of the band and the mesh filter on one mesh (already normalised to a
    diameter of about 2), filtering ``field`` (a function of the vertices) with ``mode`` to time ``T``;
    ``exact``, a function of the vertices, gives the exact result where it is known."""
    from cp_stylize import Band, diffuse
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize.mesh_diffusion import MeshOperators, mesh_diffuse

    u0 = field(vertices)
    start = time.perf_counter()
    operators = MeshOperators.of(vertices, faces)
    on_mesh = mesh_diffuse(vertices, faces, u0, mode=mode, T=T, operators=operators, **params)
    mesh_seconds = time.perf_counter() - start
    start = time.perf_counter()
    band = Band.build(TriangleMesh(vertices, faces), h)
    values = np.einsum("nk,nk->n", u0[faces[band.face]], band.bary)      # linear on each face, as the mesh's
    on_band = band.interpolate(diffuse(band, values, mode=mode, T=T, **params), vertices)
    band_seconds = time.perf_counter() - start
    weights = operators.mass / operators.mass.sum()

    def psnr(a, b):
        return float(20.0 * np.log10(np.ptp(on_mesh) / np.sqrt(weights @ (a - b) ** 2)))

    truth = () if exact is None else (psnr(on_mesh, exact(vertices)), psnr(on_band, exact(vertices)))
    return Comparison(case, len(vertices), float(operators.edge), float(h), psnr(on_band, on_mesh),
                      mesh_seconds, band_seconds, truth)


def harmonic(vertices):
    """``x y``: on the unit sphere a degree-2 spherical harmonic, whose heat flow is known
    (:func:`harmonic_flow`)."""
    return vertices[:, 0] * vertices[:, 1]


def harmonic_flow(T=TIME):
    """The heat flow of :func:`harmonic` on the unit sphere at time ``T``: it decays as ``exp(-6 T)``."""
    return lambda v: harmonic(v) * np.exp(-6.0 * T)


def sphere_cases(levels):
    for subdivisions, h in levels:
        v, f = icosphere(subdivisions)
        yield "sphere", v, f, h


def torus_cases(levels):
    for around, h in levels:
        v, f = torus_mesh(around)
        yield "torus", v, f, h


def suzanne_cases(levels, folder, log):
    """The demo's Suzanne at each ``(subdivision levels, h)``, normalised to a diameter of 2 (``bpy``
    makes it, in a process of its own); nothing, logged, where it cannot."""
    from cp_stylize_dev.bench import suzanne_arrays

    for subdivisions, h in levels:
        path = suzanne_arrays(folder, log, levels=subdivisions)
        if path is None:
            return
        data = np.load(path)
        v, f = data["vertices"].astype(np.float64), data["faces"].astype(np.int64)
        low, high = v.min(axis=0), v.max(axis=0)
        v = (v - (low + high) / 2) * (2.0 / np.linalg.norm(high - low))
        yield "suzanne", v, f, h


#: ``(refinement, h)`` for each case: the mesh's mean spacing half of ``h`` or less, both halved each time.
LEVELS = {"sphere": ((5, 0.08), (6, 0.04), (7, 0.02)),
          "torus": ((160, 0.08), (320, 0.04), (640, 0.02)),
          "suzanne": ((2, 0.08), (3, 0.04), (4, 0.02))}
QUICK = {"sphere": ((3, 0.16), (4, 0.08)), "torus": ((60, 0.16), (120, 0.08)), "suzanne": ((1, 0.16), (2, 0.08))}


def run(quick=False, cases=("sphere", "torus", "suzanne"), log=print):
    """Print the table of :class:`Comparison` rows (Markdown) and return the rows."""
    levels = QUICK if quick else LEVELS
    rows = []
    log(HEADER)
    with tempfile.TemporaryDirectory() as folder:
        meshes = {"sphere": lambda: sphere_cases(levels["sphere"]),
                  "torus": lambda: torus_cases(levels["torus"]),
                  "suzanne": lambda: suzanne_cases(levels["suzanne"], folder, log)}
        for case in cases:
            for name, v, f, h in meshes[case]():
                if name == "sphere":     # a spherical harmonic, whose flow is known
                    row = compare(name, v, f, h, field=harmonic, exact=harmonic_flow())
                else:
                    row = compare(name, v, f, h)
                rows.append(row)
                log(row.row())
    return rows


if __name__ == "__main__":
    run(quick="--quick" in sys.argv[1:])
