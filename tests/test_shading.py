"""Hand-painted shading: the form's light and edges painted into the colour (cp_stylize.shading)."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere, Torus
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize.oklab import to_oklab
from cp_stylize.pipeline import ColourInput, stylize
from cp_stylize.presets import load_preset
from cp_stylize.shading import EDGE_DEPTH, LIGHT, LIGHT_DEPTH, edge_strength, shade_field, shaded


def test_the_form_light_lightens_the_side_facing_it_and_darkens_the_side_turned_away():
    band = Band.build(Sphere(), 0.1)
    normals = band.cp / np.linalg.norm(band.cp, axis=1, keepdims=True)
    shift = shade_field(band, light=1.0)
    facing = normals @ LIGHT
    assert abs(facing.mean()) < 0.02                 # a sphere faces every way alike: nothing to take away
    assert np.allclose(shift, LIGHT_DEPTH * facing, atol=0.03 * LIGHT_DEPTH)
    assert shift.max() > 0.95 * LIGHT_DEPTH and shift.min() < -0.95 * LIGHT_DEPTH
    assert np.allclose(shade_field(band, light=0.5), 0.5 * shift)
    assert not shade_field(band).any()              # nothing asked, nothing moved


def test_the_form_light_casts_nothing_over_a_plane_that_faces_one_way():
    vertices, faces, _ = parametric_mesh(lambda s, t: np.stack([2 * s - 1, t - 0.5, 0 * s], axis=-1), 8, 4)
    band = Band.build(TriangleMesh(vertices, faces), 0.05)
    assert np.abs(shade_field(band, light=1.0)).max() < 1e-6


def test_a_sphere_has_no_edges_and_a_cube_has_them_along_its_edges_and_none_on_its_faces():
    sphere = Band.build(Sphere(), 0.05)
    assert np.abs(edge_strength(sphere)).max() < 0.05
    side = 1 / np.sqrt(3)                                          # half a side: a diameter of 2
    vertices = side * np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    faces = np.array([t for a, b, c, d in quads for t in ((a, b, c), (a, c, d))])
    band = Band.build(TriangleMesh(vertices, faces), 0.02)
    edges = edge_strength(band)
    corner = np.sort(np.abs(band.cp), axis=1)                      # |coordinates|, smallest first
    on_face = corner[:, 1] < 0.6 * side                            # a face's middle: two coordinates small
    on_edge = (corner[:, 1] > 0.999 * side) & (corner[:, 0] < 0.6 * side)     # an edge, away from the corners
    assert on_face.sum() > 1000 and on_edge.sum() > 1000
    assert np.median(edges[on_edge]) > 0.15                        # a sharp convex edge is lit
    assert np.abs(edges[on_face]).max() < 0.01                     # flat faces are left alone


def test_a_crease_is_darkened():
    # a torus's inner ring bends the other way (its mean curvature is below the surface's median): shaded;
    # its outer ring is lit
    band = Band.build(Torus(1.0, 0.25), 0.04)
    edges = edge_strength(band)
    radius = np.hypot(band.cp[:, 0], band.cp[:, 1])
    assert np.median(edges[radius < 0.8]) < 0 < np.median(edges[radius > 1.2])


def test_warmth_moves_lights_towards_yellow_and_shadows_towards_blue():
    grey = np.full((3, 4), 0.5)
    grey[:, 3] = 0.25                                             # an alpha channel, kept
    out = shaded(grey, np.array([LIGHT_DEPTH, 0.0, -LIGHT_DEPTH]), warmth=1.0)
    lab = to_oklab(out[:, :3])
    start = to_oklab(grey[:1, :3])[0]
    assert lab[0, 0] == pytest.approx(start[0] + LIGHT_DEPTH, abs=1e-3) and lab[2, 0] == pytest.approx(
        start[0] - LIGHT_DEPTH, abs=1e-3)
    assert lab[0, 2] > 0.03 and lab[2, 2] < -0.03                  # OKLab b: yellow in the light, blue in shadow
    assert np.allclose(out[1], grey[1]) and np.all(out[:, 3] == 0.25)
    plain = to_oklab(shaded(grey, np.array([LIGHT_DEPTH, 0.0, -LIGHT_DEPTH]))[:, :3])
    assert np.allclose(plain[:, 1:], start[1:], atol=1e-3)        # without warmth: lighter and darker alone
    assert np.all((shaded(np.ones((1, 3)), np.array([1.0]), 1.0) <= 1.0))


def test_bad_strengths_are_refused():
    band = Band.build(Sphere(), 0.2)
    with pytest.raises(ValueError, match="light must lie in"):
        shade_field(band, light=1.5)
    with pytest.raises(ValueError, match="warmth must lie in"):
        shaded(np.zeros((1, 3)), np.zeros(1), warmth=-0.1)


def test_a_hand_painted_run_paints_the_light_and_the_edges_in_over_a_flat_colour():
    torus = Torus(1.0, 0.4)
    vertices, faces, uvs = parametric_mesh(torus.point, 48, 24, periodic_u=True, periodic_v=True)
    settings = load_preset("hand_painted").replace(spacing=0.04, image_size=128)
    result = stylize(vertices, faces, ColourInput.constant(len(faces), (0.6, 0.45, 0.3)), settings, uvs=uvs)
    atlas = result.atlas
    points = np.einsum("mk,mkd->md", atlas.bary, vertices[faces[atlas.face]])
    _, normals = torus.closest_point(points)[0], None
    ring = points - np.column_stack([points[:, :2] / np.hypot(points[:, 0], points[:, 1])[:, None], 0 * points[:, 2]])
    normals = ring / np.linalg.norm(ring, axis=1, keepdims=True)
    lab = to_oklab(result.image.reshape(-1, 3)[atlas.texels])
    facing = normals @ LIGHT
    assert np.corrcoef(lab[:, 0], facing)[0, 1] > 0.8           # the side facing the light is the lighter
    lit, shade = facing > 0.7, facing < -0.7
    assert lab[lit, 2].mean() > lab[shade, 2].mean() + 0.02       # and the warmer
    assert lab[lit, 0].mean() - lab[shade, 0].mean() > LIGHT_DEPTH          # and the lit side's margin holds
    assert EDGE_DEPTH > 0
