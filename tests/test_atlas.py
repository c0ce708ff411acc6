import numpy as np
import pytest
from scipy import ndimage

from cp_stylize import Band, Sphere, Torus, heat
from cp_stylize.atlas import Atlas, bake_to_atlas, sample_texture, uv_atlas, uv_problems
from cp_stylize.mesh import TriangleMesh, parametric_mesh
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


@pytest.fixture(scope="module")
def uv_sphere():
    """A UV sphere with Blender's layout (seam at u = 0, fans at the poles) and its band."""
    vertices, faces, uvs = parametric_mesh(Sphere().point, 64, 32, periodic_u=True)
    mesh = TriangleMesh(vertices, faces)
    return mesh, uvs, Band.build(mesh, 0.05)


@pytest.fixture(scope="module")
def torus():
    """A torus mesh without UVs of its own, its band and an xatlas atlas."""
    vertices, faces, _ = parametric_mesh(Torus(1.0, 0.4).point, 64, 24, periodic_u=True, periodic_v=True)
    mesh = TriangleMesh(vertices, faces)
    return mesh, Band.build(mesh, 0.05), uv_atlas(mesh, 512)


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


def test_a_mesh_without_uvs_round_trips_through_a_new_atlas(torus):
    mesh, band, atlas = torus
    assert atlas.generated and uv_problems(mesh, atlas.uvs, atlas.size) == []
    values = colour(band.cp).astype(np.float32)
    out = bake_to_atlas(band, values, atlas)
    corners = mesh.vertices[mesh.input_faces[atlas.face]]
    texel_points = np.einsum("mi,mij->mj", atlas.bary, corners)
    assert psnr(out.reshape(-1, 3)[atlas.texels], colour(texel_points)) >= 35.0
    # and back in: closest points near island borders read margin texels
    assert psnr(sample_texture(band, atlas.uvs, out), values) >= 35.0


def test_both_sides_of_a_seam_show_the_same_colour_after_diffusion(torus):
    mesh, band, atlas = torus
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


def test_the_margin_continues_each_island(torus):
    mesh, band, atlas = torus
    out = bake_to_atlas(band, colour(band.cp), atlas, margin=4, fill=-1.0)
    near = atlas.coverage
    ring = ndimage.binary_dilation(near, iterations=4) & ~near
    assert np.all(out[ring] >= 0) and np.all(out[~ndimage.binary_dilation(near, iterations=6)] == -1)


def mirrored(uv):
    """The right half of the sphere's UVs folded onto the left half."""
    right = uv[:, :, 0].mean(axis=1) > 0.5
    out = uv.copy()
    out[right, :, 0] = 1.0 - out[right, :, 0]
    return out


def collapsed(uv, value):
    """Face 40's three corners at one UV point (or NaN)."""
    out = uv.copy()
    out[40] = value
    return out


@pytest.mark.parametrize("spoil, problem", [
    (mirrored, "overlap"),
    (lambda uv: uv * 1.5, "outside [0, 1]"),
    (lambda uv: collapsed(uv, 0.5), "zero area"),
    (lambda uv: collapsed(uv, np.nan), "not finite"),
])
def test_unusable_uvs_are_detected_and_replaced(uv_sphere, spoil, problem):
    mesh, uvs, _ = uv_sphere
    assert uv_problems(mesh, uvs, 256) == []    # islands that share edges do not overlap
    spoiled = spoil(uvs)
    assert any(problem in p for p in uv_problems(mesh, spoiled, 256))
    atlas = uv_atlas(mesh, 64, spoiled)
    assert atlas.generated and problem in atlas.reason


def test_a_new_atlas_can_be_forced(uv_sphere):
    mesh, uvs, _ = uv_sphere
    atlas = uv_atlas(mesh, 128, uvs, force_new=True)
    assert atlas.generated and atlas.uvs.shape == uvs.shape
    assert not np.allclose(atlas.uvs, uvs)


@pytest.mark.parametrize("call, error, message", [
    (lambda m, u, b: sample_texture(Band.build(Sphere(), 0.2), u, np.zeros((4, 4, 3))), ValueError,
     "built from a triangle mesh"),
    (lambda m, u, b: sample_texture(b, u[:-1], np.zeros((4, 4, 3))), ValueError,
     r"uvs must have shape \(\d+, 3, 2\)"),
    (lambda m, u, b: sample_texture(b, u, np.zeros((4, 4, 3), dtype=np.uint8)), TypeError,
     "image must hold floats"),
    (lambda m, u, b: uv_atlas(m, 0, u), ValueError, "size must be a positive number of texels, got 0"),
    (lambda m, u, b: uv_atlas(m, 64.0, u), TypeError, "size must be an integer number of texels, got 64.0"),
    (lambda m, u, b: uv_atlas("mesh", 64), TypeError, "mesh must be a TriangleMesh, got str"),
    (lambda m, u, b: uv_problems(m, u[..., :1], 64), ValueError, r"uvs must have shape"),
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


def test_atlas_reports_its_coverage(uv_sphere):
    mesh, uvs, _ = uv_sphere
    atlas = uv_atlas(mesh, 32, uvs)
    assert isinstance(atlas, Atlas) and atlas.coverage.shape == (32, 32)
    assert atlas.coverage.sum() == len(atlas.texels) == len(atlas.face) == len(atlas.bary)
    np.testing.assert_allclose(atlas.bary.sum(axis=1), 1.0)
    assert "uvs" not in repr(atlas)
