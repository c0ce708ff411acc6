"""Smooth a texture on a triangle mesh and bake it into a UV atlas, step by step.

Run:  python examples/stylize_mesh.py [out.png]   (the README's set-up installs cp_stylize)

The mesh is a torus triangulated with NumPy (no Blender needed).  Its texture
is a noisy checkerboard in UV space; the heat equation smooths it on the
surface itself, so the result has no seams and no stretching where the UV
map is distorted.
"""

import sys
import time

import numpy as np

from cp_stylize import (Band, Torus, TriangleMesh, bake_to_atlas, heat, parametric_mesh, sample_texture, uv_atlas,
                        write_png)
from cp_stylize.texture import texel_centres

out = sys.argv[1] if len(sys.argv) > 1 else "stylize_mesh.png"
start = time.perf_counter()

# 1. A triangle mesh with per-corner UVs: a torus on a 96 x 32 grid of its
#    parameters (Blender gives the same arrays through foreach_get).
vertices, faces, uvs = parametric_mesh(Torus(R=1.0, r=0.4).point, 96, 32, periodic_u=True, periodic_v=True)
mesh = TriangleMesh(vertices, faces)
print(f"mesh: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles, area {mesh.area:.3f}")

# 2. The computational band: grid points within sqrt(17) h of the mesh, each
#    with its exact closest point, the face that holds it and its barycentric
#    coordinates there.
h = 0.02
band = Band.build(mesh, h)
print(f"band: {band.size:,} points at h = {h}")

# 3. Texture in: a noisy checkerboard image (row 0 at the bottom), read at
#    every closest point through the face's corner UVs.
size = 512
u, v = texel_centres(size, size)
checker = ((np.floor(12 * u) + np.floor(6 * v)) % 2).astype(np.float32)
rng = np.random.default_rng(0)
image = np.stack([0.2 + 0.6 * checker, 0.3 + 0.4 * (1 - checker), 0.5 + 0.0 * checker], axis=-1)
image = np.clip(image + rng.normal(scale=0.15, size=image.shape), 0.0, 1.0).astype(np.float32)
values = sample_texture(band, uvs, image)

# 4. Smooth on the surface: heat flow to time t (evolve with the 7-point
#    Laplacian, extend by tricubic interpolation at the closest points).
smoothed = heat(band, values, T=2e-3)

# 5. Texture out: the mesh's own UVs are usable here (inside [0, 1], no
#    overlaps); uv_atlas would unwrap with xatlas otherwise.
atlas = uv_atlas(mesh, size, uvs)
print(f"atlas: {size} x {size}, {atlas.reason}")
result = bake_to_atlas(band, smoothed, atlas, margin=8)

# 6. Save before and after, side by side.
write_png(out, np.concatenate([image, np.clip(result, 0.0, 1.0)], axis=1))
print(f"wrote {out} in {time.perf_counter() - start:.1f} s")
