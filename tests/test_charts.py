"""New atlases for large meshes: charts projected along the axes, packed without overlaps."""

import sys

import numpy as np
import pytest

from cp_stylize import Sphere
from cp_stylize import atlas as atlas_module
from cp_stylize.atlas import uv_atlas, uv_problems
from cp_stylize.mesh import TriangleMesh, parametric_mesh

from optional import needs_xatlas


def crumpled_sphere(n_u=160, noise=0.3, seed=0):
    """A UV sphere whose vertices move along the radius by ``noise`` of an edge: a scan's crumples."""
    vertices, faces, _ = parametric_mesh(Sphere().point, n_u, n_u // 2)
    rng = np.random.default_rng(seed)
    edge = 2 * np.pi / n_u
    return TriangleMesh(vertices * (1 + noise * edge * rng.standard_normal(len(vertices)))[:, None], faces)


def projections(mesh, atlas):
    """For every kept face, the scale of its UV triangle over its projection on each axis's plane (K, 3):
    the edges' Gram matrices compared, NaN where the two are not similar."""
    corners = mesh.vertices[mesh.faces]
    uv = atlas.uvs[mesh.face_index] * atlas.size
    edges_uv = uv[:, 1:] - uv[:, :1]
    gram_uv = np.einsum("kid,kjd->kij", edges_uv, edges_uv)
    scales = np.full((len(uv), 3), np.nan)
    for k in range(3):
        plane = np.delete(corners, k, axis=2)
        edges = plane[:, 1:] - plane[:, :1]
        gram = np.einsum("kid,kjd->kij", edges, edges)
        ratio = gram_uv / gram
        similar = np.all(np.abs(ratio - ratio[:, :1, :1]) <= 1e-6 * np.abs(ratio[:, :1, :1]), axis=(1, 2))
        scales[similar, k] = np.sqrt(ratio[similar, 0, 0])
    return scales


def test_each_face_is_its_projection_on_an_axis_plane_at_one_scale_without_overlaps(torus):
    mesh, _, _ = torus
    atlas = uv_atlas(mesh, 512, unwrap="charts")
    assert atlas.generated and "charts were projected along the axes" in atlas.reason
    assert uv_problems(mesh, atlas.uvs, 512) == []           # inside [0, 1], no zero areas, no overlaps
    scales = projections(mesh, atlas)
    found = np.isfinite(scales).any(axis=1)
    assert found.all()                                       # every face: a turned projection on a plane
    one = np.nanmax(scales, axis=1)
    assert np.allclose(one, np.median(one), rtol=1e-6)       # at the same texels per unit everywhere
    assert atlas.coverage.mean() > 0.4


def test_a_crumpled_scan_gets_charts_without_overlaps_and_without_crumbs():
    mesh = crumpled_sphere(noise=0.3)
    atlas = uv_atlas(mesh, 512, unwrap="charts")
    assert uv_problems(mesh, atlas.uvs, 512) == []
    charts = int(atlas.reason.split(" charts")[0].split()[-1].replace(",", ""))
    assert charts < len(mesh.faces) / 25                     # the noise does not cut the surface into crumbs
    assert atlas.coverage.mean() > 0.4


def test_a_badly_crumpled_scan_still_gets_charts_without_overlaps():
    mesh = crumpled_sphere(noise=0.5)                        # faces folded over their neighbours all over
    atlas = uv_atlas(mesh, 512, unwrap="charts")
    assert uv_problems(mesh, atlas.uvs, 512) == [] and atlas.coverage.mean() > 0.2


@needs_xatlas
def test_xatlas_unwraps_small_meshes_and_charts_take_large_ones(torus, monkeypatch):
    mesh, _, _ = torus
    assert "xatlas unwrapped it" in uv_atlas(mesh, 64).reason
    monkeypatch.setattr(atlas_module, "XATLAS_FACES", len(mesh.faces) - 1)
    assert "too many for xatlas" in uv_atlas(mesh, 64).reason


def test_without_xatlas_a_new_atlas_is_made_of_charts(torus, monkeypatch):
    mesh, _, _ = torus
    monkeypatch.setitem(sys.modules, "xatlas", None)         # as on a platform the zip has no xatlas wheel for
    atlas = uv_atlas(mesh, 128)
    assert atlas.generated and "(xatlas is not installed)" in atlas.reason
    with pytest.raises(atlas_module.UnusableUVs, match="xatlas, which makes new UV maps, is not installed"):
        uv_atlas(mesh, 128, unwrap="xatlas")


def test_charts_that_cannot_fit_are_refused_with_the_cause():
    rng = np.random.default_rng(1)
    # 400 separate triangles: each a chart, with its padding
    corners = rng.random((400, 1, 3)) * 10 + np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0.01]])
    mesh = TriangleMesh(corners.reshape(-1, 3), np.arange(1200).reshape(-1, 3))
    with pytest.raises(atlas_module.UnusableUVs) as refused:
        uv_atlas(mesh, 32, unwrap="charts")
    assert str(refused.value) == ("the mesh has no usable UVs (it has none) and 400 charts with 2 texels of padding "
                                  "do not fit in 32 x 32 texels: choose a larger image size")


def test_an_unknown_unwrapper_is_refused(torus):
    mesh, _, _ = torus
    with pytest.raises(ValueError, match="unwrap must be one of 'auto', 'xatlas', 'charts', got 'lscm'"):
        uv_atlas(mesh, 64, unwrap="lscm")
