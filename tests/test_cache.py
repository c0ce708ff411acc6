"""Re-runs with a RunCache: the same images as fresh runs, and only parts built from the same inputs reused."""

import numpy as np
import pytest

from cp_stylize import Torus
from cp_stylize.cache import RunCache, digest
from cp_stylize.mesh import parametric_mesh
from cp_stylize.estimate import BYTES_KEPT_CURVATURE_PER_POINT, estimate_run
from cp_stylize.pipeline import ColourInput, Texture, decide_atlas, stylize
from cp_stylize.presets import load_preset

#: every part a run on a textured mesh with detail builds before its filter
ALL_PARTS = ["mesh", "atlas", "band", "sampled", "seams", "healed", "extended", "texels", "texel_colours"]


@pytest.fixture(scope="module")
def scene():
    vertices, faces, uvs = parametric_mesh(Torus(1.0, 0.4).point, 40, 20, periodic_u=True, periodic_v=True)
    rng = np.random.default_rng(3)
    image = rng.random((48, 48, 3)).astype(np.float32)
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool))])
    return vertices, faces, uvs, colours


def _settings(preset="denoise_eed", **changes):
    return load_preset(preset).replace(**{"spacing": 0.05, "image_size": 64, **changes})


def _run(scene, settings, cache=None, vertices=None):
    v, faces, uvs, colours = scene
    return stylize(v if vertices is None else vertices, faces, colours, settings, uvs=uvs, cache=cache)


@pytest.mark.parametrize("preset", ["denoise_eed", "starry_night"])
def test_a_re_run_with_new_filter_parameters_matches_a_fresh_run(scene, preset):
    cache = RunCache()
    first = _run(scene, _settings(preset), cache)
    assert cache.reused == []
    again = _run(scene, _settings(preset), cache)
    detail_parts = {"extended", "texel_colours"}     # the input's detail, read where it is laid back without strokes
    laid_back = _settings(preset).detail > 0 and _settings(preset).strokes == 0
    healed = {"seams", "healed"}                      # the texture's UV seams, healed where a look paints
    painted = _settings(preset).stylised
    assert cache.reused == [p for p in ALL_PARTS
                            if (laid_back or p not in detail_parts) and (painted or p not in healed)]
    np.testing.assert_array_equal(again.image, first.image)
    # another filter on the same mesh and grid: the band's operators are kept, the image is a fresh run's
    changed = _settings(preset, T=2 * _settings(preset).T, detail=0.5)
    rerun = _run(scene, changed, cache)
    assert {"band", "texels", "sampled"} <= set(cache.reused)
    np.testing.assert_array_equal(rerun.image, _run(scene, changed).image)
    assert np.abs(rerun.image - first.image).max() > 0.01


def test_a_re_run_along_the_form_keeps_the_curvature_and_matches_a_fresh_run(scene):
    """The principal directions depend on the band alone: another look along the form on the same band
    takes them from the cache, and its image is a fresh run's; a new grid computes them again."""
    cache = RunCache()
    form = _settings("van_gogh_form")                  # strokes along the form
    _run(scene, form, cache)
    assert "curvature" not in cache.reused and "curvature" in cache
    # what it keeps is what a run's estimate counts for it
    band = cache.part("band")
    directions, confidence = cache.part("curvature")
    kept = sum(a.nbytes for a in directions.values()) + confidence.nbytes
    assert kept == band.size * BYTES_KEPT_CURVATURE_PER_POINT
    with_cache, alone = (estimate_run(band.size, form, 3, len(scene[1]), keep=k)[1] for k in (True, False))
    starry = [estimate_run(band.size, _settings("starry_night"), 3, len(scene[1]), keep=k)[1] for k in (True, False)]
    assert with_cache - alone == band.size * BYTES_KEPT_CURVATURE_PER_POINT + starry[0] - starry[1]
    longer = form.replace(T=2 * form.T)
    rerun = _run(scene, longer, cache)
    assert "curvature" in cache.reused
    np.testing.assert_array_equal(rerun.image, _run(scene, longer).image)
    _run(scene, form.replace(spacing=0.04), cache)
    assert "curvature" not in cache.reused


def test_a_moved_vertex_or_a_new_grid_builds_the_band_again(scene):
    cache = RunCache()
    _run(scene, _settings(), cache)
    moved = scene[0].copy()
    moved[0, 2] += 0.05
    result = _run(scene, _settings(), cache, vertices=moved)
    assert "mesh" not in cache.reused and "band" not in cache.reused
    np.testing.assert_array_equal(result.image, _run(scene, _settings(), vertices=moved).image)
    finer = _settings(spacing=0.04)
    result = _run(scene, finer, cache, vertices=moved)
    assert "mesh" in cache.reused and "band" not in cache.reused
    np.testing.assert_array_equal(result.image, _run(scene, finer, vertices=moved).image)


def test_an_atlas_decided_before_the_run_is_the_runs_own(scene):
    """The add-on decides the atlas before the run (to bake procedural colours into it): the run takes
    that one from the cache, and it is the atlas a run on its own would make, on the mesh at any scale."""
    v, faces, uvs, colours = scene
    settings = _settings()
    for uv in (uvs, None):                                        # the mesh's own UVs, and a new atlas
        cache = RunCache()
        ahead = decide_atlas(100.0 * v, faces, settings.image_size, uv, cache=cache)
        result = stylize(100.0 * v, faces, colours, settings, uvs=uv, cache=cache)
        assert "atlas" in cache.reused and result.atlas is ahead
        alone = stylize(v, faces, colours, settings, uvs=uv).atlas
        np.testing.assert_allclose(ahead.uvs, alone.uvs, atol=1e-9)
        np.testing.assert_array_equal(ahead.texels, alone.texels)
        assert ahead.generated == (uv is None)


def test_new_colours_are_read_again(scene):
    cache = RunCache()
    _run(scene, _settings(), cache)
    v, faces, uvs, colours = scene
    other = ColourInput(textures=[Texture(1.0 - colours.textures[0].image, uvs, np.ones(len(faces), bool))])
    result = stylize(v, faces, other, _settings(), uvs=uvs, cache=cache)
    assert "band" in cache.reused and "sampled" not in cache.reused and "texel_colours" not in cache.reused
    np.testing.assert_array_equal(result.image, stylize(v, faces, other, _settings(), uvs=uvs).image)


def test_a_cache_keeps_one_version_of_each_part_and_drops_it_before_building_another():
    cache = RunCache()
    assert cache.get("band", 1, lambda: "first") == "first"
    assert cache.get("band", 1, lambda: "second") == "first"
    seen = []

    def build():
        seen.append("band" in cache)         # the old part is gone while the new one is built
        return "third"

    assert cache.get("band", 2, build) == "third" and seen == [False]
    with pytest.raises(RuntimeError):
        cache.get("band", 3, lambda: (_ for _ in ()).throw(RuntimeError("failed")))
    assert "band" not in cache and len(cache) == 0
    cache.get("atlas", 0, lambda: 1)
    cache.clear()
    assert len(cache) == 0


def test_kept_arrays_cannot_be_changed_in_place(scene):
    cache = RunCache()
    _run(scene, _settings(), cache)
    sampled = cache._parts["sampled"][1]
    with pytest.raises(ValueError, match="read-only"):
        sampled[0, 0] = 1.0


def test_the_digest_tells_dtype_shape_and_values_apart():
    a = np.arange(6, dtype=np.float32)
    assert digest(a) == digest(a.copy())
    assert len({digest(a), digest(a.astype(np.float64)), digest(a.reshape(2, 3)), digest(a + 1), digest(None),
                digest(a[::2]), digest(0.05), digest(0.04)}) == 8


def test_a_run_on_another_mesh_drops_every_kept_part_first(scene):
    cache = RunCache()
    _run(scene, _settings(), cache)
    band = cache._parts["band"][1]
    held = cache.nbytes()
    # the band's own arrays and matrices, and the bake-out's interpolation kept with it, are counted once
    bake_out = sum(b.data.nbytes + b.indices.nbytes for b in band.memo._parts["bake_out"][1].blocks)
    assert held > band.ijk.nbytes + band.cp.nbytes + band.E.data.nbytes + bake_out
    # and what is kept stays below the run's own estimated peak
    assert held < estimate_run(band.size, _settings(), 3, len(scene[1]))[1]
    cache.start(owner="another mesh")
    assert len(cache) == 0 and cache.nbytes() == 0
