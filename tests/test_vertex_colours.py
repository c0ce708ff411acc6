"""Colour at a mesh's vertices filtered into colour at its vertices: the mesh's own finite elements where the
vertices are finer than the band's grid, the band read at the vertices elsewhere, and the two agreeing."""

import numpy as np
import pytest

pytest.importorskip("igl", reason="the mesh filters need libigl (requirements.txt pins it)")

from cp_stylize.presets import load_preset  # noqa: E402
from cp_stylize.settings import StylizeSettings  # noqa: E402
from cp_stylize.vertex_colours import choose_method, corner_to_vertex, stylize_vertices  # noqa: E402
from cp_stylize_dev.crosscheck import icosphere  # noqa: E402

#: A coarse grid, so that the band's runs stay cheap: an icosphere of 5 subdivisions has a mean edge of
#: about 0.038 (its diameter 2), finer than it.
H = 0.04


@pytest.fixture(scope="module")
def sphere():
    vertices, faces = icosphere(5)
    return vertices, faces


def _gaussian(T=0.01):
    return StylizeSettings(mode="gaussian", T=T, spacing=H)


def test_a_mesh_finer_than_the_grid_is_filtered_on_its_own_elements_and_a_coarser_one_on_the_band(sphere):
    vertices, faces = sphere
    method, reason = choose_method(vertices, faces, _gaussian())
    assert method == "mesh" and "finite elements" in reason and f"h = {H:.3g}" in reason
    coarse, coarse_faces = icosphere(3)
    method, reason = choose_method(coarse, coarse_faces, _gaussian())
    assert method == "band" and "farther apart" in reason
    # the size and place of the object do not change the choice: the settings are for a diameter of 2
    assert choose_method(vertices * 37.0 + 5.0, faces, _gaussian())[0] == "mesh"
    # Beltrami runs on the band only
    method, reason = choose_method(vertices, faces, StylizeSettings(mode="beltrami", spacing=H))
    assert method == "band" and "band only" in reason


def test_the_band_and_the_mesh_filter_agree_at_the_vertices(sphere):
    vertices, faces = sphere
    x, y, z = vertices.T
    colours = np.column_stack([0.5 + 0.3 * x * y, 0.5 + 0.2 * z, 0.5 + 0.2 * x]).astype(np.float32)
    on_mesh = stylize_vertices(vertices, faces, colours, _gaussian(0.03))
    on_band = stylize_vertices(vertices, faces, colours, _gaussian(0.03), method="band")
    assert (on_mesh.method, on_band.method) == ("mesh", "band")
    assert on_band.reason == "asked for the band" and on_band.points > len(vertices)
    change = np.sqrt(np.mean((on_mesh.colours - colours) ** 2))
    gap = np.sqrt(np.mean((on_mesh.colours - on_band.colours) ** 2))
    # a smooth colour, filtered by both to time 0.03: they differ by under a tenth of what the filter changed
    assert change > 5e-3 and gap < 0.1 * change, (change, gap)


def test_noise_falls_and_an_edge_stays_with_edge_enhancing_diffusion(sphere):
    vertices, faces = sphere
    rng = np.random.default_rng(5)
    clean = np.where(vertices[:, :1] > 0, 0.8, 0.2) * np.ones((1, 3))
    noisy = np.clip(clean + 0.08 * rng.standard_normal(clean.shape), 0, 1).astype(np.float32)
    settings = StylizeSettings(mode="eed", T=2e-3, spacing=H, params={"lambda_rel": 0.1})
    result = stylize_vertices(vertices, faces, noisy, settings)
    assert result.method == "mesh"
    before = np.sqrt(np.mean((noisy - clean) ** 2))
    after = np.sqrt(np.mean((result.colours - clean) ** 2))
    assert after < 0.5 * before, (before, after)
    # and less than the linear filter's to the same time, which blurs the edge
    blurred = stylize_vertices(vertices, faces, noisy, StylizeSettings(mode="gaussian", T=2e-3, spacing=H))
    assert after < 0.75 * np.sqrt(np.mean((blurred.colours - clean) ** 2))
    # the great circle's edge is kept: the two sides stay far apart, away from the circle
    far = np.abs(vertices[:, 0]) > 0.3
    sides = [result.colours[far & (vertices[:, 0] > 0)].mean(), result.colours[far & (vertices[:, 0] < 0)].mean()]
    assert sides[0] - sides[1] > 0.55


@pytest.mark.parametrize("method", ["mesh", "band"])
def test_a_constant_colour_stays_and_every_colour_stays_within_the_inputs(sphere, method):
    vertices, faces = sphere
    constant = np.full((len(vertices), 3), [0.2, 0.6, 0.9], dtype=np.float32)
    result = stylize_vertices(vertices, faces, constant, _gaussian(), method=method)
    np.testing.assert_allclose(result.colours, constant, atol=2e-6)
    assert result.colours.dtype == np.float32
    rng = np.random.default_rng(1)
    mixed = rng.choice(np.array([[1, 0, 0], [0, 0, 1]], np.float32), len(vertices))
    result = stylize_vertices(vertices, faces, mixed, _gaussian(), method=method)
    # red and blue mix to their purples, never to a green or beyond either
    assert np.all(result.colours[:, 1] <= 2e-3) and np.all(result.colours >= -1e-6)
    assert np.allclose(result.colours[:, 0] + result.colours[:, 2], 1.0, atol=3e-3)


def test_a_vertex_no_face_uses_keeps_its_colour(sphere):
    vertices, faces = sphere
    loose = np.vstack([vertices, [[5.0, 0.0, 0.0]]])
    colours = np.vstack([np.full((len(vertices), 3), 0.5), [[0.9, 0.1, 0.3]]]).astype(np.float32)
    result = stylize_vertices(loose, faces, colours, _gaussian())
    np.testing.assert_array_equal(result.colours[-1], colours[-1])
    assert result.method == "mesh"     # the loose vertex far away changes neither the scale nor the choice


def test_a_look_that_paints_is_refused_with_what_to_choose(sphere):
    vertices, faces = sphere
    colours = np.full((len(vertices), 3), 0.5, np.float32)
    with pytest.raises(ValueError, match="choose Image output"):
        stylize_vertices(vertices, faces, colours, load_preset("starry_night"))
    with pytest.raises(ValueError, match=r"one row per vertex, shape \(10242, C\)"):
        stylize_vertices(vertices, faces, colours[:-1], _gaussian())
    with pytest.raises(ValueError, match="NaN"):
        stylize_vertices(vertices, faces, np.full_like(colours, np.nan), _gaussian())
    with pytest.raises(ValueError, match="does not run on the mesh"):
        stylize_vertices(vertices, faces, colours, StylizeSettings(mode="beltrami", spacing=H), method="mesh")


def test_corner_colours_meet_at_the_vertices_weighted_by_their_faces_areas():
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [-3, 0, 0]], float)
    faces = np.array([[0, 1, 2], [0, 2, 3]])       # areas 0.5 and 1.5, sharing vertices 0 and 2
    corners = np.zeros((2, 3, 1))
    corners[1] = 1.0
    at = corner_to_vertex(faces, corners, vertices)[:, 0]
    np.testing.assert_allclose(at, [0.75, 0.0, 0.75, 1.0])


def test_the_estimate_counts_the_mesh_filters_vertices_and_steps_or_the_bands_points(sphere):
    from cp_stylize.estimate import estimate_vertices

    vertices, faces = sphere
    short, long = _gaussian(1e-3), _gaussian(1e-2)
    on_mesh = estimate_vertices(vertices, faces, short, "mesh", speed=1.0)
    assert on_mesh.band_points == 0 and on_mesh.spacing == pytest.approx(H)
    # ten times the time: more of the mesh filter's steps (1 and 4 at 2 mean edges squared each)
    assert estimate_vertices(vertices, faces, long, "mesh", speed=1.0).seconds > on_mesh.seconds
    on_band = estimate_vertices(vertices, faces, short, "band", speed=1.0)
    assert on_band.band_points > len(vertices) and on_band.bytes > on_mesh.bytes


def test_without_libigl_the_band_serves_and_says_why(sphere, monkeypatch):
    import cp_stylize.vertex_colours as vertex_colours

    vertices, faces = sphere
    monkeypatch.setattr(vertex_colours, "mesh_filter_available", lambda: False)
    method, reason = choose_method(vertices, faces, _gaussian())
    assert method == "band" and "needs libigl" in reason
