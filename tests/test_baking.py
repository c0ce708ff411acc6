"""Texture out: band values baked into an atlas image (and round trips through sampling)."""

import numpy as np
import pytest
from scipy import ndimage

from cp_stylize import Band, Sphere, heat
from cp_stylize.atlas import uv_atlas, uv_problems
from cp_stylize.baking import bake_map, bake_to_atlas
from cp_stylize.mesh import TriangleMesh
from cp_stylize.sampling import sample_map, sample_texture
from cp_stylize.texture import bilinear, texel_centres


def colour(p):
    """A smooth RGB function of the 3-D point, in [0, 1]."""
    return np.column_stack([
        0.5 + 0.4 * np.sin(3 * p[:, 0] + 1) * np.cos(2 * p[:, 1]),
        0.5 + 0.4 * np.cos(2 * p[:, 2] - p[:, 0]),
        0.5 + 0.3 * p[:, 1] * p[:, 2],
    ])


def psnr(a, b):
    return -10 * np.log10(np.mean((np.asarray(a, np.float64) - b) ** 2))


def test_a_texture_baked_in_and_out_through_the_mesh_uvs_comes_back(uv_sphere):
    mesh, uvs, band = uv_sphere
    assert mesh.skipped_faces > 0               # pole triangles: face numbers must stay input numbers
    size = 256
    u, v = texel_centres(size, size)
    image = colour(Sphere().point(u.ravel(), v.ravel())).reshape(size, size, 3).astype(np.float32)
    values = sample_texture(band, uvs, image)
    assert values.shape == (band.size, 3) and values.dtype == np.float32
    atlas = uv_atlas(mesh, size, uvs)
    assert not atlas.generated
    out = bake_to_atlas(band, values, atlas)
    covered = atlas.coverage
    assert covered.mean() > 0.9
    assert psnr(out[covered], image[covered]) >= 35.0

def test_a_mesh_without_uvs_round_trips_through_a_new_atlas(unwrapped_torus):
    mesh, band, atlas = unwrapped_torus
    assert atlas.generated and uv_problems(mesh, atlas.uvs, atlas.size) == []
    values = colour(band.cp).astype(np.float32)
    out = bake_to_atlas(band, values, atlas)
    corners = mesh.vertices[mesh.input_faces[atlas.face]]
    texel_points = np.einsum("mi,mij->mj", atlas.bary, corners)
    assert psnr(out.reshape(-1, 3)[atlas.texels], colour(texel_points)) >= 35.0
    # and back in: closest points near island borders read margin texels
    assert psnr(sample_texture(band, atlas.uvs, out), values) >= 35.0

def test_both_sides_of_a_seam_show_the_same_colour_after_diffusion(unwrapped_torus):
    mesh, band, atlas = unwrapped_torus
    p = band.cp
    stripes = np.column_stack([np.sin(9 * p[:, 0]) > 0, np.cos(7 * p[:, 1] + 3 * p[:, 2]) > 0])
    stripes = stripes.astype(np.float32)
    image = bake_to_atlas(band, heat(band, stripes, 0.005), atlas)
    # edges shared by two faces whose UVs differ there: the seams
    faces, uvs = mesh.faces, atlas.uvs[mesh.face_index]
    face = np.repeat(np.arange(len(faces)), 3)
    corner = np.tile([0, 1, 2], len(faces))
    a, b = faces[face, corner], faces[face, (corner + 1) % 3]
    key = np.minimum(a, b) * len(mesh.vertices) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    pair = np.flatnonzero(key[order][1:] == key[order][:-1])
    one, other = order[pair], order[pair + 1]
    lo, hi = np.minimum(a[one], b[one]), np.maximum(a[one], b[one])

    def uv_at(edge, vertex):
        k = np.argmax(faces[face[edge]] == vertex[:, None], axis=1)
        return uvs[face[edge], k]

    ends = [uv_at(one, lo), uv_at(one, hi), uv_at(other, lo), uv_at(other, hi)]
    seam = (np.abs(ends[0] - ends[2]).max(axis=1) > 1e-9) | (np.abs(ends[1] - ends[3]).max(axis=1) > 1e-9)
    assert seam.sum() > 100
    for s in (0.25, 0.5, 0.75):                 # one 3-D point, seen from either island
        side = bilinear(image, (1 - s) * ends[0][seam] + s * ends[1][seam])
        across = bilinear(image, (1 - s) * ends[2][seam] + s * ends[3][seam])
        assert np.abs(side - across).max() <= 1 / 255

def test_the_margin_continues_each_island(unwrapped_torus):
    mesh, band, atlas = unwrapped_torus
    out = bake_to_atlas(band, colour(band.cp), atlas, margin=4, fill=-1.0)
    near = atlas.coverage
    ring = ndimage.binary_dilation(near, iterations=4) & ~near
    assert np.all(out[ring] >= 0) and np.all(out[~ndimage.binary_dilation(near, iterations=6)] == -1)


def test_sphere_map_round_trip_is_accurate_for_a_smooth_image():
    band = Band.build(Sphere(), 0.05)
    v, u = np.meshgrid((np.arange(64) + 0.5) / 64, (np.arange(128) + 0.5) / 128, indexing="ij")
    lat, lon = np.pi * v - np.pi / 2, 2 * np.pi * u - np.pi
    # a smooth function on the sphere (no singularity at the poles)
    img = (0.5 + 0.3 * np.cos(lat) * np.cos(lon) + 0.2 * np.sin(lat))[..., None]
    out = bake_map(band, sample_map(band, img.astype(np.float32)), 64, 128)
    err = np.abs(out - img)[..., 0]
    # bilinear sampling is second order; only the rows next to the poles clamp (first order)
    assert err[2:-2].max() < 1e-3 and err.max() < 6e-3


@pytest.mark.parametrize("call, error, message", [
    (lambda m, u, b: bake_to_atlas(b, np.zeros(b.size), object()), TypeError, "atlas must be an Atlas"),
    (lambda m, u, b: bake_to_atlas(b, np.zeros(b.size), uv_atlas(TriangleMesh(np.eye(3), [[0, 1, 2]]), 8)),
     ValueError, "the atlas has UVs for 1 faces"),
    (lambda m, u, b: bake_to_atlas(b, np.zeros(b.size), uv_atlas(m, 8, u), margin=-1), ValueError,
     "margin must be a non-negative integer"),
    (lambda m, u, b: bake_to_atlas(b, np.zeros(b.size + 1), uv_atlas(m, 8, u)), ValueError,
     "band values must have shape"),
])
def test_bad_input_is_reported(uv_sphere, call, error, message):
    mesh, uvs, band = uv_sphere
    with pytest.raises(error, match=message):
        call(mesh, uvs, band)
