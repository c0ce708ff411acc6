import numpy as np

from cp_stylize.mesh import TriangleMesh
from cp_stylize.sampling import ColourInput, Texture, colours_at
from cp_stylize.seams import REACH, SeamHealing, seam_edges


def _strip(split_vertices=False, n=40):
    """A flat 2 x 1 strip of triangles, x in [-1, 1]: its left half reads the image's left column
    (red), its right half the right column (blue), so its UVs and its colour jump at x = 0."""
    x = np.linspace(-1.0, 1.0, n + 1)
    y = np.linspace(0.0, 1.0, 3)
    X, Y = np.meshgrid(x, y)
    vertices = np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)])
    idx = np.arange(len(vertices)).reshape(len(y), len(x))
    a, b, c, d = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    left = vertices[faces][:, :, 0].mean(axis=1) < 0
    uvs = np.where(left[:, None, None], 0.1, 0.9) * np.ones((len(faces), 3, 2))
    uvs[:, :, 1] = vertices[faces][:, :, 1]
    if split_vertices:                       # each face its own corners, as a file with split UVs has them
        vertices, faces = vertices[faces].reshape(-1, 3), np.arange(3 * len(faces)).reshape(-1, 3)
    image = np.zeros((4, 2, 3), np.float32)
    image[:, 0] = [1.0, 0.0, 0.0]
    image[:, 1] = [0.0, 0.0, 1.0]
    return vertices, faces, uvs, image


def _healing(vertices, faces, uvs, image):
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool), ("clamp", "clamp"))])
    seams = seam_edges(TriangleMesh(vertices, faces).welded_faces, uvs)
    return seams, SeamHealing(vertices, faces, seams, lambda f, b: colours_at(f, b, colours)), colours


def test_the_seams_are_the_edges_whose_uvs_differ_on_their_two_sides():
    for split in (False, True):
        vertices, faces, uvs, image = _strip(split)
        face_a, corners_a, face_b, corners_b = seam_edges(TriangleMesh(vertices, faces).welded_faces, uvs)
        assert len(face_a) == 2                                   # the two edges along x = 0
        ends = vertices[faces[face_a[:, None], corners_a]]
        np.testing.assert_allclose(ends[..., 0], 0.0, atol=1e-12)
        np.testing.assert_allclose(ends, vertices[faces[face_b[:, None], corners_b]])   # the same ends, in order
    vertices, faces, uvs, image = _strip()
    uvs[:, :, 0] = vertices[faces][:, :, 0]                       # one UV map without a cut: no seam
    assert len(seam_edges(TriangleMesh(vertices, faces).welded_faces, uvs)[0]) == 0


def test_colours_meet_in_their_mean_at_a_seam_and_are_untouched_beyond_its_reach():
    vertices, faces, uvs, image = _strip()
    seams, heal, colours = _healing(vertices, faces, uvs, image)
    rng = np.random.default_rng(0)
    face = rng.integers(0, len(faces), 20000)
    bary = rng.dirichlet(np.ones(3), len(face))
    points = np.einsum("mk,mkd->md", bary, vertices[faces[face]])
    before = colours_at(face, bary, colours)
    after = heal(face, bary, before)
    distance = np.abs(points[:, 0])
    # beyond the reach nothing changes, bit for bit
    far = distance > REACH
    np.testing.assert_array_equal(after[far], before[far])
    # at the seam both sides are the mean of red and blue; the change fades with the distance
    at = distance < 0.05 * REACH
    assert at.sum() > 10
    np.testing.assert_allclose(after[at], np.broadcast_to([0.5, 0.0, 0.5], after[at].shape), atol=0.01)
    change = np.abs(after - before).max(axis=1)
    assert np.all(np.diff(change[np.argsort(distance)][distance[np.argsort(distance)] < REACH]) <= 1e-3)


def test_a_texture_that_matches_across_its_seam_is_not_changed():
    vertices, faces, uvs, image = _strip()
    image[:] = [0.2, 0.6, 0.3]                                    # the same colour on both sides
    seams, heal, colours = _healing(vertices, faces, uvs, image)
    assert len(seams[0]) == 2 and len(heal) > 0
    rng = np.random.default_rng(1)
    face = rng.integers(0, len(faces), 5000)
    bary = rng.dirichlet(np.ones(3), len(face))
    before = colours_at(face, bary, colours)
    np.testing.assert_array_equal(heal(face, bary, before), before)


def test_a_look_heals_the_textures_jump_at_its_uv_seam_and_a_filter_keeps_it():
    """A torus's texture that jumps where its UV map is cut (a ramp in u, dark at u = 0 and light at u = 1,
    read clamped): a filter keeps the texture as it is, seam and all; Oil Paint paints over the seam healed,
    so the jump is spread over the healing's reach instead of standing as an edge of the picture."""
    from cp_stylize import Torus
    from cp_stylize.mesh import parametric_mesh
    from cp_stylize.pipeline import stylize
    from cp_stylize.presets import StylizeSettings, load_preset
    from cp_stylize_dev.looks import seam_step

    size = 256
    vertices, faces, uvs = parametric_mesh(Torus(1.0, 0.45).point, 64, 32, periodic_u=True, periodic_v=True)
    u = (np.arange(size) + 0.5) / size
    picture = np.ones((size, size, 3), np.float32) * ((0.3 + 0.4 * u)[None, :, None] * np.array([1.0, 0.8, 0.6]))
    colours = ColourInput(textures=[Texture(picture, uvs, np.ones(len(faces), bool), ("clamp", "clamp"))])
    steps = {}
    for name, settings in (("filter", StylizeSettings(mode="eed", T=1e-6)), ("oil_paint", load_preset("oil_paint"))):
        result = stylize(vertices, faces, colours, settings.replace(spacing=0.03, image_size=size), uvs=uvs)
        mask = result.atlas.coverage.reshape(size, size)
        steps[name] = seam_step(result.image, np.flatnonzero(mask[:, 0] & mask[:, -1]))[0]
    print("\nthe colour's step across the seam:", {k: round(v, 3) for k, v in steps.items()})
    assert steps["filter"] >= 0.28                                # the picture's own jump, 0.32
    assert steps["oil_paint"] <= 0.3 * steps["filter"]            # unhealed, the band's blur alone leaves 0.39 of it


def test_every_look_heals_the_seams_and_no_filter_does():
    from cp_stylize.presets import builtin_presets, load_preset

    looks = {name for name in builtin_presets() if load_preset(name).stylised}
    assert looks == set(builtin_presets()) - {"denoise_eed", "gaussian_blur", "perona_malik"}
