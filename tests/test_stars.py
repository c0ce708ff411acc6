"""Stars in the picture's sky, as in van Gogh's "The Starry Night" (1889)."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.baking import atlas_points
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize.oklab import to_oklab
from cp_stylize.pipeline import ColourInput, STAR_RADIUS, stylize
from cp_stylize.presets import StylizeSettings, load_preset
from cp_stylize.stars import CORE, CORE_SHARE, CORE_TILT, HALO, HALO_TILT, OVERLAP, SIZES, Stars, _border_points, find_stars, on_band


@pytest.fixture(scope="module")
def sphere():
    vertices, faces, uvs = parametric_mesh(Sphere().point, 96, 48, periodic_u=True)
    mesh = TriangleMesh(vertices, faces)
    return mesh, Band.build(mesh, 0.03), uvs


def _sky_and_ground(band, ground_light=0.7):
    """A light, calm sky over z > 0 and a busy, striped ground below."""
    z = band.cp[:, 2]
    stripes = ground_light * (0.5 + 0.5 * np.sign(np.sin(60 * band.cp[:, 0])))
    grey = np.where(z > 0, 0.85, stripes)
    return np.repeat(grey[:, None], 3, axis=1).astype(np.float32)


def test_stars_go_in_the_light_calm_sky_apart_and_no_more_than_asked(sphere):
    mesh, band, _ = sphere
    radius = 0.08
    stars = find_stars(mesh, band, _sky_and_ground(band), 6, radius, 0.03, seed=1)
    assert 1 <= len(stars) <= 6
    assert np.all(stars.centres[:, 2] > 0.2)                   # in the sky, clear of the busy ground
    pairs = np.triu_indices(len(stars), 1)
    d = np.linalg.norm(stars.centres[:, None] - stars.centres[None], axis=2)[pairs]
    reach = HALO * (stars.radii[:, None] + stars.radii[None, :])[pairs]
    assert np.all(d >= (1.0 - OVERLAP) * reach - 1e-9)
    assert np.all((stars.radii >= SIZES[1] * radius - 1e-12) & (stars.radii <= SIZES[0] * radius + 1e-12))
    np.testing.assert_allclose(np.einsum("ij,ij->i", stars.normals, stars.centres), 1.0, atol=0.02)   # outward
    # the same seed places the same stars; a dark or a busy picture has none
    np.testing.assert_array_equal(find_stars(mesh, band, _sky_and_ground(band), 6, radius, 0.03, seed=1).centres,
                                  stars.centres)
    dark = np.full((band.size, 3), 0.2, np.float32)
    assert len(find_stars(mesh, band, dark, 6, radius, 0.03)) == 0
    assert len(find_stars(mesh, band, _sky_and_ground(band), 0, radius, 0.03)) == 0


def test_a_grey_sky_with_one_light_gets_its_stars_at_the_light_the_largest_first(sphere):
    mesh, band, _ = sphere
    radius = 0.06
    light = np.array([0.0, -0.8, 0.6])                           # the sun behind cloud, in a grey sky
    glow = np.exp(-np.sum((band.cp - light) ** 2, axis=1) / (2 * 0.3**2))
    grey = np.where(band.cp[:, 2] > 0, 0.62 + 0.36 * glow, 0.1)
    stars = find_stars(mesh, band, np.repeat(grey[:, None], 3, axis=1).astype(np.float32), 6, radius, 0.03, seed=2)
    assert len(stars) >= 1
    assert stars.radii[0] == pytest.approx(SIZES[0] * radius)    # the light's star: the largest
    near = np.linalg.norm(stars.centres - light, axis=1)
    assert near[0] < 0.3 and np.all(near < 0.6)                  # at the light, none out in the dull sky
    even = np.repeat(np.where(band.cp[:, 2] > 0, 0.8, 0.1)[:, None], 3, axis=1).astype(np.float32)
    spread = find_stars(mesh, band, even, 6, radius, 0.03, seed=2)
    assert np.ptp(np.arctan2(spread.centres[:, 1], spread.centres[:, 0])) > 1.0   # an even sky: all over it


@pytest.mark.parametrize("cells", [(60, 30), (1, 1)])
def test_no_star_is_cut_by_the_meshs_open_border(cells):
    # a finely meshed frame, and one of two triangles whose border has vertices at its corners alone
    vertices, faces, _ = parametric_mesh(lambda u, v: np.stack([2 * u - 1, v - 0.5, 0 * u], axis=-1), *cells)
    mesh = TriangleMesh(vertices, faces)
    band = Band.build(mesh, 0.03)
    radius = 0.05
    stars = find_stars(mesh, band, np.full((band.size, 3), 0.9, np.float32), 40, radius, 0.02)
    assert len(stars) > 3
    box = np.abs(mesh.vertices[:, :2]).max(axis=0)
    room = (box[None, :] - np.abs(stars.centres[:, :2])).min(axis=1)
    assert np.all(room >= HALO * stars.radii - 0.01)                      # each star's whole halo


def test_a_uv_seam_with_its_vertices_split_is_no_border():
    # a frame whose two halves have their own vertices along x = 0 (a UV seam, as exported meshes have it):
    # its border is the outer rectangle alone
    left, faces, _ = parametric_mesh(lambda u, v: np.stack([u - 1, v - 0.5, 0 * u], axis=-1), 10, 10)
    right = left + [1.0, 0.0, 0.0]
    mesh = TriangleMesh(np.vstack([left, right]), np.vstack([faces, faces + len(left)]))
    border = _border_points(mesh, 0.05)
    assert len(border) and np.all((np.abs(np.abs(border[:, 0]) - 1) < 1e-9) | (np.abs(np.abs(border[:, 1]) - 0.5)
                                                                                < 1e-9))
    assert np.abs(border[:, 0]).max() == pytest.approx(1.0)


def test_a_star_is_a_core_ringed_by_alternating_halos_and_strokes_circle_it():
    star = Stars([[0.0, 0.0, 1.0]], [[0.0, 0.0, 1.0]], 0.1, 0.02)
    r = np.linspace(0.0, 0.5, 501)
    points = np.column_stack([r, np.zeros_like(r), np.ones_like(r)])
    up = np.tile([0.0, 0.0, 1.0], (len(r), 1))
    grey = np.full((len(r), 3), 0.1, np.float32)
    painted = star.paint(points, lambda i: up[i], grey)
    np.testing.assert_allclose(painted[0], CORE, atol=1e-6)                      # the core
    beyond = r > HALO * 0.1
    np.testing.assert_array_equal(painted[beyond], grey[beyond])                  # nothing past the halo
    blue = painted[:, 2] - painted[:, 0]                                          # the rings, by turns
    ring = (r > 0.07) & (r < 0.2)
    assert np.sum(np.diff(np.sign(blue[ring])) != 0) >= 3
    # the other side of a thin part is left alone
    np.testing.assert_array_equal(star.paint(points, lambda i: -up[i], grey), grey)
    field = star.field(points, lambda i: up[i])
    length = np.linalg.norm(field, axis=1)
    np.testing.assert_allclose(length[(r > 0.01) & (r < HALO * 0.1)], 1.0, atol=1e-9)
    assert np.all(length[r > 1.3 * HALO * 0.1] == 0)
    # about the centre, each star at its own angle to the circles: a loose spiral in the halo, a whirl in the core
    across = np.abs(field[:, 0]) / np.maximum(length, 1e-12)                      # the sine of the angle
    halo = (r > 1.3 * CORE_SHARE * 0.1) & (r < HALO * 0.1)
    assert np.all((across[halo] >= np.sin(HALO_TILT[0]) - 1e-9) & (across[halo] <= np.sin(HALO_TILT[1]) + 1e-9))
    core = (r > 0.005) & (r < 0.6 * CORE_SHARE * 0.1)
    assert np.all(across[core] >= np.sin(CORE_TILT[0]) - 1e-9)
    np.testing.assert_allclose(field[:, 2], 0.0, atol=1e-12)                     # in the tangent plane


def test_no_two_stars_are_alike_and_their_rings_are_not_circles():
    centres = [[-0.5, 0.0, 1.0], [0.5, 0.0, 1.0]]
    stars = Stars(centres, [[0.0, 0.0, 1.0]] * 2, 0.1, 0.02, seed=3)
    angle = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    grey = np.full((len(angle), 3), 0.1, np.float32)
    up = np.tile([0.0, 0.0, 1.0], (len(angle), 1))
    rings = []
    for centre in centres:
        for radius in (0.07, 0.09, 0.11, 0.13):     # circles through the halo: each crosses a lobed ring's edge
            points = np.column_stack([centre[0] + radius * np.cos(angle), radius * np.sin(angle),
                                      np.ones_like(angle)])
            rings.append(stars.paint(points, lambda i: up[i], grey))
    crossed = [np.ptp(ring, axis=0).max() > 0.1 for ring in rings]
    assert sum(crossed) >= 4                       # the colour changes along a circle about the centre
    assert not np.allclose(np.stack(rings[:4]), np.stack(rings[4:]), atol=0.05)   # the two stars differ
    # the same seed gives the same stars
    again = Stars(centres, [[0.0, 0.0, 1.0]] * 2, 0.1, 0.02, seed=3)
    np.testing.assert_array_equal(again.paint(points, lambda i: up[i], grey), rings[-1])


def test_a_star_on_the_uv_seam_is_painted_whole_on_both_sides(sphere):
    mesh, band, _ = sphere
    # the seam of the UV sphere runs at u = 0, the +x side; a star there spans both of its edges
    centre = np.array([[1.0, 0.0, 0.0]])
    star = Stars(centre, centre, 0.1, 0.03)
    painted, field = on_band(star, mesh, band, np.full((band.size, 3), 0.2, np.float32))
    yellow = np.linalg.norm(painted - np.float32(CORE), axis=1) < 0.05
    side = band.cp[yellow, 1]
    assert side.min() < -0.03 and side.max() > 0.03 and abs(side.mean()) < 0.01
    assert np.linalg.norm(field, axis=1).max() == pytest.approx(1.0)


def test_a_starry_run_puts_star_yellow_in_the_sky_and_none_without_stars(sphere):
    mesh, _, uvs = sphere
    image = np.zeros((64, 128, 3), np.float32)
    image[32:] = 0.8                                             # a light, calm sky over one half
    image[:32] = np.where((np.arange(128) // 4) % 2, 0.6, 0.05)[None, :, None]   # a busy ground over the other
    faces = np.arange(len(mesh.input_faces))
    colours = ColourInput(textures=[(image, uvs, np.ones(len(faces), bool))])
    preset = load_preset("starry_night")
    assert preset.stars > 0
    settings = preset.replace(image_size=256, spacing=0.03, relief=0.0, stroke_layers=1)
    starry = stylize(mesh.vertices, mesh.input_faces, colours, settings, uvs=uvs).image
    plain = stylize(mesh.vertices, mesh.input_faces, colours, settings.replace(stars=0), uvs=uvs).image
    result = stylize(mesh.vertices, mesh.input_faces, colours, settings, uvs=uvs)
    flat, points, _, _ = atlas_points(mesh, result.atlas, 0)
    changed = np.abs(result.image.reshape(-1, 3)[flat] - plain.reshape(-1, 3)[flat]).max(axis=1) > 0.1
    # the stars change a few discs of the surface, in the sky (the picture's upper half, z > 0); below, only
    # the palette's tone ranks move a little
    sky = points[:, 2] > 0
    assert 0.03 < np.mean(changed[sky]) < 0.3 and np.mean(changed[~sky]) < 0.005
    np.testing.assert_array_equal(result.image, starry)
    # star yellow in the stars' cores: light and yellow (OKLab b above 0.08)
    lab = to_oklab(starry.reshape(-1, 3)[flat][changed])
    assert np.mean((lab[:, 0] > 0.75) & (lab[:, 2] > 0.08)) > 0.05
    assert StylizeSettings().stars == 0 and STAR_RADIUS > 0
