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
