"""The whole stylization without Blender: mesh and colours in, atlas image out."""

import numpy as np
import pytest

from cp_stylize import Torus
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize.estimate import BYTES_STROKES_PER_TEXEL, estimate_run
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import StylizeSettings, load_preset
from test_mesh import renumbered


@pytest.fixture(scope="module")
def torus_mesh():
    # a torus 20 units across: the pipeline normalises it to the paper's size
    torus = Torus(10.0, 4.0)
    return parametric_mesh(torus.point, 48, 24, periodic_u=True, periodic_v=True)


def _stripes(size=64):
    u = (np.arange(size) + 0.5) / size
    red = (np.sin(2 * np.pi * 4 * u) > 0).astype(np.float32)
    img = np.zeros((size, size, 3), np.float32)
    img[..., 0] = red[None, :]
    img[..., 2] = 1 - red[None, :]
    return img


def test_textures_on_some_faces_and_flat_colour_on_the_rest(torus_mesh):
    vertices, faces, uvs = torus_mesh
    first_half = np.arange(len(faces)) < len(faces) // 2
    colours = ColourInput.constant(len(faces), (0.0, 1.0, 0.0))
    colours.textures.append((_stripes(), uvs, first_half))
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.05, image_size=128)
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    assert result.image.shape == (128, 128, 3) and not result.atlas.generated
    assert result.spacing == pytest.approx(0.05 * 28.0 / 2)  # in the mesh's own units (diameter 28)
    img = result.image
    # the UV layout: s < 1/2 holds the textured faces; the surface joins s = 1 to s = 0 and
    # s = 1/2 to the stripes, so only the middle of the green half stays pure green
    left, right = img[:, 4:60], img[:, 72:120]
    assert left[..., 0].max() > 0.8 and left[..., 2].max() > 0.8  # red and blue stripes
    assert right[..., 1].min() > 0.95 and right[..., 0].max() < 0.05


def test_starry_night_paints_in_the_palettes_colours_of_the_pictures_hue(torus_mesh):
    vertices, faces, uvs = torus_mesh
    colours = ColourInput.constant(len(faces), (0.9, 0.4, 0.2))
    settings = load_preset("starry_night").replace(spacing=0.05, image_size=64)
    seen = []
    result = stylize(vertices, faces, colours, settings, uvs=uvs, progress=seen.append)
    assert seen[0] == 0.0 and seen[-1] == 1.0 and np.all(np.diff(seen) >= 0)
    covered = result.image.reshape(-1, 3)[result.atlas.texels]
    warm = covered[:, 0] > covered[:, 2] + 0.2
    assert warm.mean() > 0.9     # an orange picture takes the painting's star yellows, not its blues
    assert result.height is not None and result.height.shape == (64, 64) and result.height.max() > 0.3


def test_a_painting_does_not_change_when_the_meshs_faces_are_numbered_anew(torus_mesh):
    # an exported and re-imported mesh, or one that Blender triangulated in another order: the same surface
    vertices, faces, uvs = torus_mesh
    image = np.random.default_rng(1).random((32, 32, 3)).astype(np.float32)
    settings = load_preset("starry_night").replace(spacing=0.05, image_size=128)
    new_vertices, new_faces, old, corners = renumbered(vertices, faces, np.random.default_rng(4))
    new_uvs = uvs[old[:, None], corners]
    results = [stylize(v, f, ColourInput(textures=[(image, uv, np.ones(len(f), bool))]), settings, uvs=uv)
               for v, f, uv in ((vertices, faces, uvs), (new_vertices, new_faces, new_uvs))]
    covered = results[0].atlas.texels
    assert np.array_equal(covered, results[1].atlas.texels)
    change = np.abs(results[0].image - results[1].image).reshape(-1, 3)[covered].max(axis=1)
    # the strokes (chained ones too), the seams' healing and the colours are the same; a texel on the edge
    # of two UV triangles may take the other's colour
    assert np.mean(change > 1 / 255) <= 1e-3, np.mean(change > 1 / 255)


def test_estimate_grows_with_the_grid_and_the_filter():
    ced = load_preset("starry_night").replace(mode="ced", T=4e-4, strokes=0.0, image_size=16, sigma=1e-4, rho=2e-3,
                                              alpha=1e-3, b_rel=1e-6)

    def per_points(settings):                # what 100,000 more band points cost
        (s1, b1), (s2, b2) = estimate_run(100_000, settings), estimate_run(200_000, settings)
        return s2 - s1, b2 - b1

    (fine, b2), (gauss, _) = per_points(ced.replace(spacing=ced.spacing / 2)), per_points(ced.replace(mode="gaussian"))
    assert b2 == per_points(ced)[1] and fine > 1.5 * per_points(ced)[0]       # four times the steps
    assert gauss < 0.7 * per_points(ced)[0]                                   # no tensor
    s1, b1 = estimate_run(100_000, ced)
    # brush strokes cost by the texel
    painted, painted_bytes = estimate_run(100_000, ced.replace(strokes=1.0))
    larger, larger_bytes = estimate_run(100_000, ced.replace(strokes=1.0, image_size=2048))
    assert s1 < painted < larger
    assert painted_bytes > b1                                                 # and hold the painted texels
    unlit = ced.replace(image_size=2048, sheen=0.0)
    assert estimate_run(100_000, unlit.replace(strokes=1.0))[1] - estimate_run(100_000, unlit)[1] == \
        BYTES_STROKES_PER_TEXEL * 2048**2
    # their sheen by the texel too, and nothing without strokes
    lit, flat = (estimate_run(100_000, ced.replace(strokes=1.0, image_size=2048, sheen=sheen)) for sheen in (0.8, 0.0))
    assert lit[0] > flat[0] + 1.0 and lit[1] == flat[1] + 4 * 2048**2
    assert estimate_run(100_000, ced.replace(sheen=0.8)) == estimate_run(100_000, ced.replace(sheen=0.0))
    # hand-painted edges cost by the band point (the surface's curvature), its light next to nothing
    edged = estimate_run(100_000, ced.replace(shade_edges=1.0))
    assert edged[0] > s1 + 0.5 and edged[1] > b1 + 100_000 * 200
    assert estimate_run(100_000, ced.replace(shade_light=1.0)) == (s1, b1)
    # oil paint costs by the band point (the sectors' statistics) and by the texel (reading them)
    oil = estimate_run(100_000, ced.replace(oil_size=0.03))
    assert oil[0] > s1 + 1.0 and oil[1] > b1 + 100_000 * 100
    assert estimate_run(200_000, ced.replace(oil_size=0.03))[0] - oil[0] > per_points(ced)[0] + 1.0
    # toon bands and ink lines cost by the texel alone
    toon = estimate_run(100_000, ced.replace(toon_levels=4, image_size=2048))
    assert toon[0] > estimate_run(100_000, ced.replace(image_size=2048))[0] + 5
    lines = estimate_run(100_000, ced.replace(line_width=0.004, image_size=2048))
    bare = estimate_run(100_000, ced.replace(image_size=2048))
    assert lines[0] > bare[0] + 20 and lines[1] > bare[1] + 2048**2 * 300
    assert estimate_run(200_000, ced.replace(line_width=0.004, image_size=2048))[0] - lines[0] == pytest.approx(
        estimate_run(200_000, ced.replace(image_size=2048))[0] - bare[0])
    # the closest point search costs by the triangle, the atlas by the texel, in time and memory
    scan = estimate_run(100_000, ced, triangles=1_000_000)
    big = estimate_run(100_000, ced.replace(image_size=4096))
    assert scan[0] > s1 + 15 and scan[1] > b1 + 2**28
    assert big[0] > s1 + 10 and big[1] > b1 + 2**30
    # an unwrap costs by the triangle; a cache holds the bake-out's interpolation of atlases up to 1024 x 1024
    assert estimate_run(100_000, ced, triangles=100_000, unwrap=True)[0] > estimate_run(100_000, ced, triangles=100_000)[0] + 10
    kept = ced.replace(image_size=1024)
    assert estimate_run(100_000, kept, keep=True)[1] > estimate_run(100_000, kept)[1] + 2**28
    assert estimate_run(100_000, big_settings := ced.replace(image_size=4096), keep=True) == estimate_run(
        100_000, big_settings)
    # the input images cost by the pixel: an 8192 x 8192 texture, read out and held, is 2 GiB and seconds more
    photo = estimate_run(100_000, ced, image_pixels=8192**2)
    assert photo[0] > s1 + 5 and photo[1] >= b1 + 2 * 2**30


def test_the_estimate_counts_the_input_images(torus_mesh):
    from cp_stylize.estimate import estimate

    vertices, faces, uvs = torus_mesh
    colours = ColourInput(textures=[(np.zeros((2048, 1024, 3), np.float32), uvs, np.ones(len(faces), bool)),
                                    (np.zeros((64, 64), np.float32), uvs, np.ones(len(faces), bool))])
    assert colours.image_pixels == 2048 * 1024 + 64 * 64
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.05)
    plain = estimate(vertices, faces, settings, speed=1.0)
    read = estimate(vertices, faces, settings, image_pixels=colours.image_pixels, speed=1.0)
    assert read.bytes - plain.bytes == 32 * colours.image_pixels and read.seconds > plain.seconds
    assert estimate(vertices, faces, settings, speed=2.0).seconds == pytest.approx(2 * plain.seconds)


@pytest.mark.parametrize("vertices", [np.zeros((3, 3)), [[0, 0, 0], [1, 1, 1], [2, 2, 2]]])
def test_a_mesh_without_surface_is_reported(vertices):
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.05)
    with pytest.raises(ValueError) as info:
        stylize(np.asarray(vertices, float), np.array([[0, 1, 2]]), ColourInput.constant(1, (1, 1, 1)), settings)
    assert str(info.value) == ("the mesh has no surface: the corners of each of its 1 face(s) lie on a line or at "
                               "one point")


def _box():
    """A box 4 x 2 x 1 (its diameter the space diagonal, sqrt(21)) as 12 triangles."""
    corners = np.array([[x, y, z] for x in (-2, 2) for y in (-1, 1) for z in (-0.5, 0.5)], float)
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return corners, faces


def test_the_scale_is_the_surfaces_diameter_and_does_not_change_when_the_mesh_is_turned():
    from scipy.spatial.transform import Rotation

    from cp_stylize import Sphere
    from cp_stylize.pipeline import normalisation

    box, box_faces = _box()
    assert normalisation(box, box_faces)[1] == pytest.approx(2 / np.sqrt(21), rel=1e-12)
    sphere, sphere_faces, _ = parametric_mesh(Sphere(3.0).point, 64, 32, periodic_u=True)
    assert normalisation(sphere, sphere_faces)[1] == pytest.approx(1 / 3, rel=1e-12)   # a sphere: radius 1
    for seed in range(5):
        turn = Rotation.random(random_state=seed).as_matrix()
        for vertices, faces in ((box, box_faces), (sphere, sphere_faces)):
            scale = normalisation(vertices, faces)[1]
            assert normalisation(vertices @ turn.T + 5.0, faces)[1] == pytest.approx(scale, rel=1e-5)


def test_a_face_without_area_far_away_changes_nothing(torus_mesh):
    from cp_stylize.estimate import estimate
    from cp_stylize.pipeline import normalisation

    vertices, faces, uvs = torus_mesh
    far = np.vstack([vertices, [[100.0, 0, 0], [101.0, 0, 0], [102.0, 0, 0]]])      # three corners on a line
    stray = np.vstack([faces, [len(vertices), len(vertices) + 1, len(vertices) + 2]])
    (centre, scale), (centre_far, scale_far) = normalisation(vertices, faces), normalisation(far, stray)
    assert scale_far == scale and np.array_equal(centre_far, centre)
    settings = StylizeSettings(mode="gaussian", T=1e-5, spacing=0.05, image_size=64)
    guess, guess_far = estimate(vertices, faces, settings), estimate(far, stray, settings)
    assert (guess_far.spacing, guess_far.band_points) == (guess.spacing, guess.band_points)
    colours = ColourInput.constant(len(stray), (0.0, 1.0, 0.0))
    colours.textures.append((_stripes(), np.vstack([uvs, np.zeros((1, 3, 2))]), np.ones(len(stray), bool)))
    with_stray = stylize(far, stray, colours, settings, uvs=np.vstack([uvs, np.full((1, 3, 2), 0.5)]))
    without = stylize(vertices, faces, ColourInput(textures=[(_stripes(), uvs, np.ones(len(faces), bool))]),
                      settings, uvs=uvs)
    assert with_stray.band_size == without.band_size and with_stray.spacing == pytest.approx(without.spacing)
    assert with_stray.image.std() > 0.3            # the stripes stay


def test_the_flow_mode_follows_the_minimum_curvature_of_the_mesh(torus_mesh):
    from cp_stylize import Band
    from cp_stylize.pipeline import stroke_field

    vertices, faces, uvs = torus_mesh
    settings = StylizeSettings(mode="flow", T=2e-3, spacing=0.05, image_size=64)
    band = Band.build(TriangleMesh(vertices / 14.0, faces), 0.05, stencil="anisotropic")   # diameter 2
    field = stroke_field(band, settings)
    x, y, _ = band.cp.T
    parallels = np.column_stack([-y, x, np.zeros_like(x)]) / np.hypot(x, y)[:, None]
    cosines = np.abs(np.sum(field * parallels, axis=1)) / np.linalg.norm(field, axis=1)
    assert np.percentile(cosines, 5) > 0.99                  # the torus' minimum curvature runs around its axis
    colours = ColourInput.constant(len(faces), (0.0, 1.0, 0.0))
    colours.textures.append((_stripes(), uvs, np.ones(len(faces), bool)))
    plain = stylize(vertices, faces, colours, settings.replace(T=1e-6), uvs=uvs).image
    result = stylize(vertices, faces, colours, settings, uvs=uvs).image
    assert np.all(np.isfinite(result)) and np.abs(result - plain).max() > 0.1
    assert stroke_field(band, settings.replace(mode="ced")) is None


def test_directions_from_an_attribute_are_a_line_field(torus_mesh):
    from cp_stylize import Band
    from cp_stylize.pipeline import sample_directions, stroke_field

    vertices, faces, uvs = torus_mesh
    band = Band.build(TriangleMesh(vertices / 14.0, faces), 0.1, stencil="anisotropic")
    centres = (vertices / 14.0)[faces]                         # (F, 3, 3): corner positions
    parallels = np.stack([-centres[..., 1], centres[..., 0], 0 * centres[..., 0]], axis=-1)
    corners = 3.0 * parallels / np.linalg.norm(parallels, axis=-1, keepdims=True)   # any length
    field = sample_directions(band, corners)
    x, y, _ = band.cp.T
    exact = np.column_stack([-y, x, np.zeros_like(x)]) / np.hypot(x, y)[:, None]
    assert np.percentile(np.abs(np.sum(field * exact, axis=1)), 5) > 0.98
    # flipping corners (one of each face, or whole faces) does not change the line field
    flipped = corners.copy()
    flipped[:, 1] *= -1
    flipped[::2] *= -1
    again = sample_directions(band, flipped)
    np.testing.assert_allclose(np.abs(np.sum(again * field, axis=1)), np.sum(field * field, axis=1), atol=1e-12)
    # the settings choose the source; "attribute" needs the vectors
    settings = StylizeSettings(mode="ced", direction="attribute", spacing=0.1, T=1e-4, image_size=64)
    np.testing.assert_array_equal(stroke_field(band, settings, corners), field)
    with pytest.raises(ValueError, match=r"direction 'attribute' needs the mesh's vectors, directions= of shape"):
        stylize(vertices, faces, ColourInput.constant(len(faces), (1, 1, 1)), settings)
    with pytest.raises(ValueError, match="directions must have shape"):
        sample_directions(band, corners[:10])


def test_an_axis_gives_way_where_the_surface_faces_it(torus_mesh):
    from cp_stylize import Band
    from cp_stylize.pipeline import stroke_field
    from cp_stylize.tangent import surface_normals

    vertices, faces, _ = torus_mesh
    band = Band.build(TriangleMesh(vertices / 14.0, faces), 0.1, stencil="anisotropic")
    field = stroke_field(band, StylizeSettings(mode="ced", direction="axis", axis=(0, 0, 5)))
    n = surface_normals(band)
    tangential = np.linalg.norm(field - np.sum(field * n, axis=1)[:, None] * n, axis=1)
    np.testing.assert_allclose(tangential, np.sqrt(1 - n[:, 2] ** 2), atol=1e-9)   # sin of the angle to the axis
    assert tangential.min() < 0.05 and tangential.max() > 0.99   # the top of the torus faces the axis


def test_strokes_and_contours_without_a_palette_paint_the_pictures_own_colours(torus_mesh):
    vertices, faces, uvs = torus_mesh
    colours = ColourInput(textures=[(_stripes(), uvs, np.ones(len(faces), bool))])
    settings = StylizeSettings(mode="gaussian", T=2e-5, spacing=0.05, image_size=64, strokes=1.0, stroke_width=0.1,
                               stroke_length=0.4, contours=0.5, relief=0.5)
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    assert np.isfinite(result.image).all() and result.height is not None and result.height.max() > 0.3


def test_the_input_colours_hull_takes_every_colour_a_run_paints_in_its_channels():
    from cp_stylize.pipeline import input_colours

    image = np.zeros((4, 4, 4), np.float32)
    image[..., 3] = 1.0
    colours = ColourInput(textures=[(image, np.zeros((1, 3, 2)), np.ones(1, bool))])
    settings = load_preset("starry_night")                  # strokes in its palette, contour ink
    for channels in (3, 4):
        found = input_colours(colours, settings, channels=channels)
        assert found.shape[1] == channels
        palette = np.asarray(settings.palette, np.float32)
        # the palette's colours are among them, with no alpha of their own (0)
        assert all(np.any(np.all(np.isclose(found[:, :3], row), axis=1)) for row in palette)
        if channels == 4:
            rows = np.all(np.isclose(found[:, :3], palette[0]), axis=1)
            assert np.all(found[rows, 3] == 0.0)


def test_the_estimate_counts_the_aabb_trees_search_where_the_band_takes_it(monkeypatch):
    from cp_stylize import estimate as est

    settings = load_preset("denoise_eed")
    costs = {}
    for tree in (False, True):
        monkeypatch.setattr(est, "use_aabb", lambda triangles, points, tree=tree: tree)
        costs[tree] = estimate_run(780_000, settings, triangles=1_000_000)[0]
    # the tree costs by the band point, the blocks by the triangle: a million triangles round a scan's band
    assert costs[False] - costs[True] == pytest.approx(
        1_000_000 * (est.SECONDS_PER_TRIANGLE - est.SECONDS_PER_TRIANGLE_TREE) - 780_000 * est.SECONDS_TREE_PER_POINT)
    assert costs[True] < costs[False]
