import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.texture import bake_map, bilinear, linear_to_srgb, sample_map, srgb_to_linear, write_png


def test_bilinear_hits_texel_centres_and_interpolates_linearly():
    img = np.arange(12, dtype=np.float64).reshape(3, 4, 1)
    # texel (row 1, col 2) has its centre at u = 2.5 / 4, v = 1.5 / 3
    assert bilinear(img, [[2.5 / 4, 1.5 / 3]])[0, 0] == pytest.approx(img[1, 2, 0])
    mid = bilinear(img, [[2.0 / 4, 1.0 / 3]])[0, 0]
    assert mid == pytest.approx(img[0:2, 1:3, 0].mean())
    # clamping past the edges, repeating across them
    assert bilinear(img, [[-1.0, 0.0]])[0, 0] == img[0, 0, 0]
    rep = bilinear(img, [[0.0, 0.5]], wrap=("repeat", "clamp"))[0, 0]
    assert rep == pytest.approx(0.5 * (img[1, 0, 0] + img[1, 3, 0]))


def test_mirror_reflects_the_image_at_its_edges():
    rng = np.random.default_rng(0)
    img = rng.random((5, 7, 2))
    uv = rng.uniform(-1.5, 2.5, (500, 2))
    folded = np.mod(uv, 2.0)
    folded = np.where(folded > 1.0, 2.0 - folded, folded)  # the same point of the unit square, reflected
    np.testing.assert_allclose(bilinear(img, uv, wrap=("mirror", "mirror")), bilinear(img, folded), atol=1e-12)


def test_clip_is_zero_outside_the_image_and_fades_over_its_edge_texels():
    img = np.ones((4, 4, 3))
    uv = np.array([[-0.01, 0.5], [0.5, 1.01], [0.5, 0.5], [0.5 / 4, 0.5], [0.0, 0.5], [1.0, 1.0]])
    out = bilinear(img, uv, wrap=("clip", "clip"))[:, 0]
    # outside: zero; inside: one; at the edge (u = 0, half a texel past the edge centre): half the texel,
    # at a corner a quarter (the texels beyond the edge are zero), as Blender's CLIP extension
    np.testing.assert_allclose(out, [0.0, 0.0, 1.0, 1.0, 0.5, 0.25])


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


def test_srgb_round_trip():
    c = np.linspace(0, 1, 101)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(c)), c, atol=1e-12)


def test_write_png_writes_a_valid_file(tmp_path):
    img = np.random.default_rng(0).uniform(size=(5, 7, 3))
    write_png(tmp_path / "a.png", img)
    data = (tmp_path / "a.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and b"IHDR" in data and data.endswith(b"IEND\xaeB`\x82")
    with pytest.raises(ValueError, match="1, 3 or 4 channels"):
        write_png(tmp_path / "b.png", np.zeros((2, 2, 2)))
