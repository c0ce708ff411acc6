"""Texture in: images read at the band's closest points through per-corner UVs."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere
from cp_stylize.sampling import sample_texture


def test_an_affine_image_is_read_exactly_at_every_closest_point(uv_sphere):
    # bilinear lookup reproduces an affine function of uv, and uv is affine across a face:
    # the value at a closest point is the function of its interpolated uv
    mesh, uvs, band = uv_sphere
    size = 64
    v, u = np.meshgrid((np.arange(size) + 0.5) / size, (np.arange(size) + 0.5) / size, indexing="ij")
    image = np.stack([0.2 + 0.5 * u, 0.1 + 0.7 * v], axis=-1)
    found = sample_texture(band, uvs, image, wrap=("clamp", "clamp"))
    uv = np.einsum("ni,nij->nj", band.bary, uvs[band.face])
    inside = np.all((uv >= 0.5 / size) & (uv <= 1 - 0.5 / size), axis=1)   # away from the clamped rim
    np.testing.assert_allclose(found[inside], np.column_stack([0.2 + 0.5 * uv[inside, 0], 0.1 + 0.7 * uv[inside, 1]]),
                               atol=1e-6)
    assert inside.mean() > 0.9


@pytest.mark.parametrize("call, error, message", [
    (lambda u, b: sample_texture(Band.build(Sphere(), 0.2), u, np.zeros((4, 4, 3))), ValueError,
     "built from a triangle mesh"),
    (lambda u, b: sample_texture(b, u[:-1], np.zeros((4, 4, 3))), ValueError, r"uvs must have shape \(\d+, 3, 2\)"),
    (lambda u, b: sample_texture(b, u, np.zeros((4, 4, 3), dtype=np.uint8)), TypeError, "image must hold floats"),
])
def test_bad_input_is_reported(uv_sphere, call, error, message):
    _, uvs, band = uv_sphere
    with pytest.raises(error, match=message):
        call(uvs, band)
