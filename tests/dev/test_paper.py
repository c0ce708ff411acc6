"""The paper command and its figure tools."""

import numpy as np
import pytest

from cp_stylize_dev import figures, paper


def test_fig4_at_a_coarse_grid_writes_the_figure_and_its_table(tmp_path):
    # at h = 0.08 the paper's stop time is a single step: this checks the command, not the filters
    path, psnr, size = paper.fig4(str(tmp_path), h=0.08, log=lambda *a: None)
    assert (tmp_path / "fig4_torus.png").stat().st_size > 10000 and size > 10000
    assert set(psnr) == {"noisy", "gaussian", "perona_malik", "eed"}
    assert all(np.isfinite(v) for v in psnr.values()) and psnr["gaussian"] > psnr["noisy"]


def test_captions_render_and_unknown_glyphs_are_reported():
    img = figures.text("EED 18.2 DB")
    assert img.shape == (18, 11 * 6 * 2 + 4, 3) and img.max() == 1.0
    with pytest.raises(ValueError, match="no glyph"):
        figures.text("~")


def test_grid_lays_out_panels_in_rows():
    a, b = np.zeros((10, 20, 3)), np.ones((5, 8, 3))
    out = figures.grid([a, b, a], 2, gap=2)
    assert out.shape == (2 * (10 + 2) + 2, 2 * (20 + 2) + 2, 3)


def test_the_flow_figure_draws_both_curvature_directions(tmp_path):
    path = paper.fig_flow(str(tmp_path), h=0.08, log=lambda *a: None)
    assert (tmp_path / "flow_torus.png").stat().st_size > 10000 and path.endswith("flow_torus.png")


def test_the_flow_figure_on_a_mesh_draws_both_directions_and_the_confidence(tmp_path):
    from cp_stylize import Torus
    from cp_stylize.mesh import parametric_mesh

    vertices, faces, _ = parametric_mesh(Torus(1.0, 0.4).point, 48, 24, periodic_u=True, periodic_v=True)
    path = paper.fig_flow_mesh(str(tmp_path), vertices, faces, h=0.08, log=lambda *a: None, name="torus_mesh",
                               size=120)
    assert path.endswith("flow_torus_mesh.png") and (tmp_path / "flow_torus_mesh.png").stat().st_size > 5000


def test_a_surface_view_shows_the_values_where_the_rays_meet_the_surface():
    from cp_stylize import Band, Sphere

    band = Band.build(Sphere(), 0.1)
    view = figures.surface_view(band, 1.0 + (band.cp[:, 2] > 0), size=(60, 60), elevation=0.0, azimuth=0.0,
                                extent=1.2)
    seen = view > 0
    # the unit sphere seen side-on fills a disc of radius 1 in a view 2.4 wide, brighter in its top half
    rows, cols = np.nonzero(seen)
    radius = np.hypot((cols + 0.5) / 30 - 1, (rows + 0.5) / 30 - 1) * 1.2
    assert radius.max() < 1.03 and abs(seen.mean() - np.pi / 2.4**2) < 0.03
    assert np.median(view[:25][seen[:25]]) > 1.5 * np.median(view[35:][seen[35:]])
