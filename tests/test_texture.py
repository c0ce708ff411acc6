import struct
import zlib

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.texture import bilinear, linear_to_srgb, srgb_to_linear, write_png


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


def test_srgb_round_trip():
    c = np.linspace(0, 1, 101)
    np.testing.assert_allclose(linear_to_srgb(srgb_to_linear(c)), c, atol=1e-12)


def _read_png(path):
    """A strict reader for what write_png promises: 8-bit grey, RGB or RGBA, no interlace, filter 0."""
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, chunks = 8, []
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, payload = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        assert crc == zlib.crc32(kind + payload) & 0xFFFFFFFF, kind
        chunks.append((kind, payload))
        pos += 12 + length
    assert [k for k, _ in chunks][0] == b"IHDR" and chunks[-1] == (b"IEND", b"")
    w, h, depth, colour_type, compression, filtering, interlace = struct.unpack(">IIBBBBB", chunks[0][1])
    assert (depth, compression, filtering, interlace) == (8, 0, 0, 0)
    c = {0: 1, 2: 3, 6: 4}[colour_type]
    raw = np.frombuffer(zlib.decompress(b"".join(p for k, p in chunks if k == b"IDAT")), np.uint8)
    rows = raw.reshape(h, 1 + w * c)
    assert np.all(rows[:, 0] == 0)
    return rows[:, 1:].reshape(h, w, c)


@pytest.mark.parametrize("channels", [1, 3, 4])
def test_write_png_round_trips_the_pixels(tmp_path, channels):
    img = np.random.default_rng(0).uniform(-0.1, 1.1, size=(5, 7, channels))
    write_png(tmp_path / "a.png", img)
    back = _read_png(tmp_path / "a.png")
    # 8 bits, clipped to [0, 1], row 0 of the array at the bottom of the picture
    expected = np.round(np.clip(img, 0, 1) * 255).astype(np.uint8)[::-1]
    np.testing.assert_array_equal(back, expected)
    assert back.shape == (5, 7, channels)


def test_write_png_refuses_two_channels(tmp_path):
    with pytest.raises(ValueError, match="1, 3 or 4 channels"):
        write_png(tmp_path / "b.png", np.zeros((2, 2, 2)))
    assert not (tmp_path / "b.png").exists()
