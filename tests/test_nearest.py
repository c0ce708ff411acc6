"""The closest point search on triangles: its pruning never loses the nearest triangle."""

import numpy as np
import pytest

from cp_stylize.nearest import TriangleSearch


def _soup(n, seed):
    """``n`` random, non-degenerate triangles in the unit cube, of mixed sizes."""
    rng = np.random.default_rng(seed)
    a = rng.uniform(-1, 1, (n, 3))
    size = rng.choice([0.02, 0.2, 1.0], n)[:, None]
    return a, a + size * rng.normal(size=(n, 3)), a + size * rng.normal(size=(n, 3))


def _brute_force(search, x):
    """Squared distance from every point to every triangle, by the exact point-triangle formula."""
    k = len(search)
    p = np.repeat(x, k, axis=0)
    tri = np.tile(np.arange(k), len(x))
    *_, d2 = search._closest(np.ascontiguousarray(p.T), tri)
    return d2.reshape(len(x), k)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_search_finds_the_nearest_triangle_of_every_point(seed):
    search = TriangleSearch(*_soup(150, seed))
    x = np.random.default_rng(10 + seed).uniform(-1.5, 1.5, (400, 3))
    tri, v, w, d2 = search.nearest(x)
    all_d2 = _brute_force(search, x)
    np.testing.assert_allclose(d2, all_d2.min(axis=1), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(np.sum((search.point(tri, v, w) - x) ** 2, axis=1), d2, rtol=1e-9, atol=1e-15)
    assert np.all((v >= 0) & (w >= 0) & (v + w <= 1 + 1e-12))


@pytest.mark.parametrize("search_by", ["blocks", "blocks sorted", "aabb"])
def test_the_band_holds_every_grid_point_within_its_width_once(search_by, monkeypatch):
    if search_by == "blocks sorted":  # the blocks' keys grouped by sorting, as for a grid too large for a dense count
        monkeypatch.setattr("cp_stylize.band_search._DENSE_KEYS", 0)
    corners = _soup(60, 5)
    search = TriangleSearch(*corners)
    h, width = 0.1, 0.23
    if search_by == "aabb":         # libigl's tree, and the octree of cells over the grid
        pytest.importorskip("igl", reason="the AABB search needs libigl (requirements.txt pins it)")
        from cp_stylize.band_search import aabb_band_points

        faces = np.arange(3 * len(search)).reshape(3, -1).T
        chunks = list(aabb_band_points(search, np.concatenate(corners), faces, h, width))
    else:
        chunks = list(search.band(h, width))
    ijk = np.concatenate([c[0] for c in chunks])
    d2 = np.concatenate([c[4] for c in chunks])
    inside = np.sqrt(d2) <= width
    found = {tuple(p) for p in ijk[inside]}
    assert len(found) == inside.sum()                        # no grid point twice
    points = np.concatenate(corners)
    lo, hi = np.floor((points.min(axis=0) - width) / h), np.ceil((points.max(axis=0) + width) / h)
    grid = np.stack(np.meshgrid(*[np.arange(a, b + 1) for a, b in zip(lo, hi)], indexing="ij"), axis=-1).reshape(-1, 3)
    near = np.sqrt(_brute_force(search, h * grid).min(axis=1)) <= width
    assert found == {tuple(p) for p in grid[near].astype(np.int64)}
    # and each point's distance is the least over all triangles
    np.testing.assert_allclose(d2, _brute_force(search, h * ijk.astype(float)).min(axis=1), rtol=1e-12, atol=1e-15)


def test_a_large_mesh_finds_its_band_through_the_aabb_tree_with_the_same_points(monkeypatch):
    pytest.importorskip("igl", reason="the AABB search needs libigl (requirements.txt pins it)")
    from cp_stylize import band_search
    from cp_stylize.band import Band
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize_dev.crosscheck import torus_mesh

    mesh = TriangleMesh(*torus_mesh(60))
    own = Band.build(mesh, 0.03)
    calls, original = [], band_search.aabb_band_points
    monkeypatch.setattr(band_search, "use_aabb", lambda triangles, points: True)
    monkeypatch.setattr(band_search, "aabb_band_points", lambda *args: calls.append(1) or original(*args))
    tree = Band.build(mesh, 0.03)
    assert calls
    order = [np.lexsort(b.ijk.T) for b in (own, tree)]
    np.testing.assert_array_equal(own.ijk[order[0]], tree.ijk[order[1]])
    np.testing.assert_allclose(own.dist[order[0]], tree.dist[order[1]], rtol=0, atol=1e-14)
    # the closest points agree but where two faces are as near (above a fold of the mesh)
    moved = np.linalg.norm(own.cp[order[0]] - tree.cp[order[1]], axis=1)
    assert np.mean(moved > 1e-9) < 0.02
    np.testing.assert_allclose(np.linalg.norm(tree.cp - tree.points, axis=1), tree.dist, atol=1e-12)


def test_the_aabb_tree_is_chosen_where_it_is_faster():
    pytest.importorskip("igl", reason="the AABB search needs libigl (requirements.txt pins it)")
    from cp_stylize.band_search import use_aabb

    # measured on tori (docs/performance.md): the blocks win at 62,640 triangles and a million band points
    # (about even) and at 136,800 and 2.7 million; the tree wins at 136,800 and a million, and at a million
    # triangles and 880,000 points (a scan at Standard)
    assert not use_aabb(15_744, 880_000) and not use_aabb(15_744, 220_000)     # Suzanne, Standard and Preview
    assert not use_aabb(62_640, 1_070_000) and not use_aabb(136_800, 2_700_000)
    assert use_aabb(136_800, 1_070_000) and use_aabb(1_007_616, 882_000)
