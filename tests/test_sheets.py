"""Sheets of a surface that come near each other in space stay apart in the band (cp_stylize.sheets)."""

import itertools

import numpy as np
import pytest

from cp_stylize import Band, Sphere, diffuse
from cp_stylize.mesh import TriangleMesh, parametric_mesh


def box(size, cell):
    """A closed box mesh centred at the origin, its sides split into squares of about ``cell``, its
    vertices shared and its faces turned outwards."""
    size = np.asarray(size, dtype=np.float64)
    vertices, faces, count = [], [], 0
    for axis in range(3):
        u, v = (a for a in range(3) if a != axis)
        nu, nv = (max(1, int(round(size[a] / cell))) for a in (u, v))
        s, t = np.meshgrid(np.linspace(-0.5, 0.5, nu + 1) * size[u], np.linspace(-0.5, 0.5, nv + 1) * size[v],
                           indexing="ij")
        for side in (-1.0, 1.0):
            p = np.zeros(s.shape + (3,))
            p[..., u], p[..., v], p[..., axis] = s, t, side * size[axis] / 2
            index = count + np.arange(p[..., 0].size).reshape(p.shape[:2])
            a, b, c, d = index[:-1, :-1], index[1:, :-1], index[1:, 1:], index[:-1, 1:]
            quads = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
            flat = p.reshape(-1, 3)
            normal = np.cross(flat[quads[:, 1] - count] - flat[quads[:, 0] - count],
                              flat[quads[:, 2] - count] - flat[quads[:, 0] - count])
            inward = np.sign(normal[:, axis]) != side
            quads[inward] = quads[inward][:, ::-1]
            vertices.append(flat)
            faces.append(quads)
            count += len(flat)
    vertices, shared = np.unique(np.round(np.concatenate(vertices), 12), axis=0, return_inverse=True)
    return vertices, shared.reshape(-1)[np.concatenate(faces)]


def sphere(radius, n=48):
    vertices, faces, _ = parametric_mesh(Sphere(radius).point, 2 * n, n, periodic_u=True)
    return vertices, faces


@pytest.fixture(scope="module")
def shell():
    """A box of length 2 whose two large sides lie 0.02 apart: 1.25 grid spacings at h = 0.016."""
    mesh = TriangleMesh(*box((2.0, 1.0, 0.02), 0.05))
    return mesh, Band.build(mesh, 0.016, stencil="anisotropic")


def _sides(band, mesh, n=2000):
    """Interpolation matrices at random points of the top and bottom sides, away from the rim."""
    xy = np.random.default_rng(1).uniform([-0.7, -0.3], [0.7, 0.3], (n, 2))
    top = np.column_stack([xy, np.full(n, 0.01)])
    pieces = np.full(n, mesh.piece[0])
    return (band.interpolation_matrix(top, np.float64, np.tile([0.0, 0.0, 1.0], (n, 1)), pieces),
            band.interpolation_matrix(top * [1, 1, -1], np.float64, np.tile([0.0, 0.0, -1.0], (n, 1)), pieces))


@pytest.mark.parametrize("mode", ["gaussian", "perona_malik", "eed", "ced"])
def test_the_two_sides_of_a_thin_shell_keep_their_colours(shell, mode):
    mesh, band = shell
    assert band.separated > 0.5 * band.size      # nearly every point sees both sides
    u0 = (band.cp[:, 2] > 0).astype(np.float64)     # the top white, the bottom black
    u = diffuse(band, u0, mode=mode, T=0.002)
    top, bottom = _sides(band, mesh)
    # less than 2 % of either side's colour on the other (the whole of it before the sheets were kept apart)
    assert (top @ u).min() > 0.98 and (bottom @ u).max() < 0.02


def test_the_extension_and_the_operators_cross_only_where_sheets_meet(shell):
    mesh, band = shell
    E = band.extension_matrix(np.float64)
    inside = (np.abs(band.cp[:, 0]) < 0.9) & (np.abs(band.cp[:, 1]) < 0.4)    # away from the rim, where they meet
    up = inside & (band.cp[:, 2] > 0.0099)      # points whose closest point is on the top
    down = band.cp[:, 2] < -0.0099
    # no point of the top reads a point of the bottom, in E or in the Laplacian
    for M in (E, band.laplacian_matrix(np.float64)):
        reads = M[np.flatnonzero(up)].tocsr()
        reads.eliminate_zeros()
        assert not np.any(down[reads.indices])
    # rows still sum to one (E) and to zero (L): constants stay constants
    np.testing.assert_allclose(E @ np.ones(band.size), 1.0, atol=1e-12)
    np.testing.assert_allclose(band.laplacian_matrix(np.float64) @ np.ones(band.size), 0.0, atol=1e-6)
    # the rows of the top's points weigh with non-negative (trilinear) weights: no overshoot at the jump
    assert E[np.flatnonzero(up)].min() >= 0.0


def test_separate_pieces_of_a_mesh_do_not_exchange():
    """Two spheres 0.02 apart, facing the same way: only their being two pieces tells them apart."""
    inner, outer = sphere(1.0), sphere(1.02)
    vertices = np.concatenate([inner[0], outer[0]])
    mesh = TriangleMesh(vertices, np.concatenate([inner[1], outer[1] + len(inner[0])]))
    assert len(np.unique(mesh.piece)) == 2
    band = Band.build(mesh, 0.016)
    u0 = (np.linalg.norm(band.cp, axis=1) > 1.01).astype(np.float64)
    u = diffuse(band, u0, mode="gaussian", T=0.002)
    direction = np.random.default_rng(2).standard_normal((500, 3))
    direction /= np.linalg.norm(direction, axis=1)[:, None]
    for radius, colour in ((0.999, 0.0), (1.019, 1.0)):
        points, _, face, bary = mesh.closest_point_on_faces(radius * direction)
        values = band.interpolate(u, points, mesh.normal(points, face, bary), mesh.piece[face])
        assert np.abs(values - colour).max() < 0.02


def test_a_smooth_surface_is_one_sheet_and_keeps_the_tricubic_extension():
    band = Band.build(Sphere(1.0), 0.1, stencil="anisotropic")
    assert band.separated == 0
    plain = band.interpolation_matrix(band.cp, np.float32)         # without normals: no sheet test
    assert (band.extension_matrix() != plain).nnz == 0


def test_pieces_join_across_split_vertices_and_stay_apart_otherwise():
    vertices, faces = box((1.0, 1.0, 1.0), 0.5)
    # split every face's corners into vertices of their own, as a mesh exported with its seams cut
    split = TriangleMesh(vertices[faces].reshape(-1, 3), np.arange(faces.size).reshape(-1, 3))
    assert len(np.unique(split.piece)) == 1
    two = TriangleMesh(np.concatenate([vertices, vertices + 3.0]), np.concatenate([faces, faces + len(vertices)]))
    assert len(np.unique(two.piece)) == 2 and np.all(two.piece[:len(faces)] == two.piece[0])


def test_interpolation_normals_must_match_the_points():
    band = Band.build(Sphere(1.0), 0.1)
    x = band.cp[:5]
    with pytest.raises(ValueError, match=r"normals must have shape \(5, 3\), got \(4, 3\)"):
        band.interpolation_matrix(x, normals=x[:4])
    with pytest.raises(ValueError, match="pieces apply to bands of triangle meshes only"):
        band.interpolation_matrix(x, normals=x, pieces=np.zeros(5, dtype=int))
