"""The output's UV layout: usable UVs kept, unusable ones detected and replaced, coverage, bad input."""

import numpy as np
import pytest

from cp_stylize import atlas as atlas_module
from cp_stylize.atlas import Atlas, uv_atlas, uv_problems

from optional import needs_xatlas


def mirrored(uv):
    """The right half of the sphere's UVs folded onto the left half."""
    right = uv[:, :, 0].mean(axis=1) > 0.5
    out = uv.copy()
    out[right, :, 0] = 1.0 - out[right, :, 0]
    return out


def collapsed(uv, value):
    """Face 40's three corners at one UV point (or NaN)."""
    out = uv.copy()
    out[40] = value
    return out


@pytest.mark.parametrize("spoil, problem", [
    (mirrored, "overlap"),
    (lambda uv: uv * 1.5, "outside [0, 1]"),
    (lambda uv: collapsed(uv, 0.5), "zero area"),
    (lambda uv: collapsed(uv, np.nan), "not finite"),
])
def test_unusable_uvs_are_detected_and_replaced(uv_sphere, spoil, problem):
    mesh, uvs, _ = uv_sphere
    assert uv_problems(mesh, uvs, 256) == []    # islands that share edges do not overlap
    spoiled = spoil(uvs)
    assert any(problem in p for p in uv_problems(mesh, spoiled, 256))
    atlas = uv_atlas(mesh, 64, spoiled)
    assert atlas.generated and problem in atlas.reason


def test_a_new_atlas_can_be_forced(uv_sphere):
    mesh, uvs, _ = uv_sphere
    atlas = uv_atlas(mesh, 128, uvs, force_new=True)
    assert atlas.generated and atlas.uvs.shape == uvs.shape
    assert not np.allclose(atlas.uvs, uvs)


@needs_xatlas
def test_an_unwrapper_outlives_its_unwrap_until_the_next(uv_sphere):
    # xatlas's destructor can lose the wake-up of a worker thread that has not settled yet and
    # then wait for it for ever: an unwrapper is destroyed only when the next unwrap starts
    mesh, uvs, _ = uv_sphere
    uv_atlas(mesh, 64, uvs, force_new=True)
    first = list(atlas_module._RETIRED)
    assert first and all(type(a).__module__ == "xatlas" for a in first)
    uv_atlas(mesh, 64, uvs, force_new=True)
    assert atlas_module._RETIRED and not any(a is b for a in atlas_module._RETIRED for b in first)


@pytest.mark.parametrize("call, error, message", [
    (lambda m, u: uv_atlas(m, 0, u), ValueError, "size must be a positive integer number of texels, got 0"),
    (lambda m, u: uv_atlas(m, 64.0, u), TypeError, "size must be an integer number of texels, got 64.0"),
    (lambda m, u: uv_atlas("mesh", 64), TypeError, "mesh must be a TriangleMesh, got str"),
    (lambda m, u: uv_problems(m, u[..., :1], 64), ValueError, r"uvs must have shape"),
])
def test_bad_input_is_reported(uv_sphere, call, error, message):
    mesh, uvs, _ = uv_sphere
    with pytest.raises(error, match=message):
        call(mesh, uvs)


def test_atlas_reports_its_coverage(uv_sphere):
    mesh, uvs, _ = uv_sphere
    atlas = uv_atlas(mesh, 32, uvs)
    assert isinstance(atlas, Atlas) and atlas.coverage.shape == (32, 32)
    assert atlas.coverage.sum() == len(atlas.texels) == len(atlas.face) == len(atlas.bary)
    np.testing.assert_allclose(atlas.bary.sum(axis=1), 1.0)
