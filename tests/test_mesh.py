import numpy as np
import pytest
from scipy.spatial import cKDTree

from cp_stylize import Band, Sphere, Torus, heat
from cp_stylize.mesh import TriangleMesh, parametric_mesh
from cp_stylize.tangent import jacobian_normals


def cylinder(s, t):
    """Open cylinder of radius 0.5 about the z axis, 0 <= z <= 1."""
    return np.stack([0.5 * np.cos(2 * np.pi * s), 0.5 * np.sin(2 * np.pi * s), t], axis=-1)


def plane(s, t):
    """The unit square in the xy-plane."""
    return np.stack([s, t, np.zeros_like(s)], axis=-1)


def sphere_mesh(n):
    vertices, faces, _ = parametric_mesh(Sphere().point, 2 * n, n, periodic_u=True)
    return TriangleMesh(vertices, faces)


def odd_mesh():
    """Two parts, three fins on one edge (non-manifold), a loose vertex, an inverted face."""
    vertices = np.array([
        [0.0, 0.0, 0.0], [1.0, 0.0, 0.0],                          # the shared edge
        [0.5, 0.8, 0.1], [0.5, -0.7, 0.3], [0.4, 0.1, -0.9],        # three fins
        [2.0, 2.0, 2.0],                                            # loose
        [-1.5, 0.0, 0.5], [-1.0, 0.6, 0.4], [-1.2, -0.2, 1.1],      # separate triangle
    ])
    faces = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [6, 8, 7]])
    return TriangleMesh(vertices, faces)


def surface_sample(mesh, n, rng):
    """``n`` points spread uniformly over the mesh's triangles."""
    a, b, c = (mesh.vertices[mesh.faces[:, k]] for k in range(3))
    area = np.linalg.norm(np.cross(b - a, c - a), axis=1)
    tri = rng.choice(len(area), size=n, p=area / area.sum())
    r1, r2 = rng.uniform(size=(2, n, 1))
    s = np.sqrt(r1)
    return (1 - s) * a[tri] + s * (1 - r2) * b[tri] + s * r2 * c[tri]


MESHES = {
    "torus": (lambda: TriangleMesh(*parametric_mesh(Torus(1.0, 0.4).point, 40, 16,
                                                     periodic_u=True, periodic_v=True)[:2]), 0.1),
    "open cylinder": (lambda: TriangleMesh(*parametric_mesh(cylinder, 32, 8, periodic_u=True)[:2]), 0.05),
    "plane": (lambda: TriangleMesh(*parametric_mesh(plane, 6, 6)[:2]), 0.05),
    "parts and fins": (odd_mesh, 0.05),
}


@pytest.mark.parametrize("name", sorted(MESHES))
def test_no_surface_point_is_nearer_than_the_closest_point(name):
    make, h = MESHES[name]
    mesh = make()
    band = Band.build(mesh, h)
    rng = np.random.default_rng(0)
    rows = rng.choice(band.size, size=min(band.size, 3000), replace=False)
    x, cp, dist = band.points[rows], band.cp[rows], band.dist[rows]
    nearest, _ = cKDTree(surface_sample(mesh, 300_000, rng)).query(x)
    assert np.all(nearest >= dist - 1e-12)
    assert np.median(nearest - dist) < 0.1 * h        # the sample is dense enough to matter
    # the closest point lies on the face that holds it, at the reported distance
    kept = mesh.faces[np.searchsorted(mesh.face_index, band.face[rows])]
    np.testing.assert_allclose(np.einsum("ij,ijk->ik", band.bary[rows], mesh.vertices[kept]), cp, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(x - cp, axis=1), dist, atol=1e-12)
    assert np.all(band.bary[rows] >= 0)


def test_closest_points_converge_to_the_sphere_as_the_mesh_refines():
    errors, heights = [], []
    for n in (12, 24, 48):
        band = Band.build(sphere_mesh(n), 0.1)
        exact, _ = Sphere().closest_point(band.points)
        errors.append(np.abs(band.cp - exact).max())
        heights.append(np.abs(np.linalg.norm(band.cp, axis=1) - 1.0).max())
    # off the surface the facets' normals tilt by O(edge) from the sphere's, on it
    # the facets lie O(edge^2) inside the sphere
    assert np.all(np.array(errors[:-1]) / errors[1:] > 1.8), errors
    assert np.all(np.array(heights[:-1]) / heights[1:] > 3.5), heights


@pytest.mark.parametrize("name", sorted(MESHES))
def test_points_on_the_mesh_are_their_own_closest_points(name):
    mesh = MESHES[name][0]()
    rng = np.random.default_rng(1)
    a, b = mesh.vertices[mesh.faces[:, 0]], mesh.vertices[mesh.faces[:, 1]]
    points = np.vstack([mesh.vertices[np.unique(mesh.faces)], 0.5 * (a + b), surface_sample(mesh, 2000, rng)])
    cp, dist, face, bary = mesh.closest_point_on_faces(points)
    np.testing.assert_allclose(cp, points, atol=1e-12)
    np.testing.assert_allclose(dist, 0.0, atol=1e-12)


def test_band_holds_exactly_the_grid_points_within_its_width():
    mesh = MESHES["torus"][0]()
    h = 0.1
    band = Band.build(mesh, h)
    lo, hi = mesh.bounds()
    axes = [np.arange(np.floor((low - band.width) / h) - 1, np.ceil((high + band.width) / h) + 2)
            for low, high in zip(lo, hi)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3).astype(np.int64)
    _, dist = mesh.closest_point(h * grid)
    expected = grid[dist <= band.width]
    assert band.size == len(expected) == len(np.unique(band.ijk, axis=0))
    np.testing.assert_array_equal(band.ijk, expected[np.lexsort(expected.T[::-1])])
    # the band's closest points are the ones a fresh query finds
    cp, dist, face, _ = mesh.closest_point_on_faces(band.points)
    np.testing.assert_allclose(cp, band.cp, atol=1e-12)
    np.testing.assert_allclose(dist, band.dist, atol=1e-12)


def test_the_anisotropic_stencil_band_builds_on_a_mesh():
    band = Band.build(MESHES["open cylinder"][0](), 0.05, stencil="anisotropic")
    assert band.stencil == "anisotropic" and band.face.shape == (band.size,)


def test_degenerate_faces_are_skipped_and_faces_keep_their_input_numbers():
    vertices, faces, _ = parametric_mesh(plane, 2, 2)
    vertices = np.vstack([vertices, [[0.25, 0.0, 0.0]]])          # on the edge from (0,0) to (0.5,0)
    first_edge = [0, 3]                                            # vertex (s, t) = (0, 0) and (0.5, 0)
    bad = np.array([[0, 0, 4], [first_edge[0], 9, first_edge[1]]])  # repeated index; zero area
    faces = np.vstack([bad[:1], faces[:4], bad[1:], faces[4:]])
    mesh = TriangleMesh(vertices, faces)
    assert mesh.skipped_faces == 2
    np.testing.assert_array_equal(mesh.face_index, [1, 2, 3, 4, 6, 7, 8, 9])
    centres = vertices[faces].mean(axis=1) + [0.0, 0.0, 0.01]
    _, _, face, _ = mesh.closest_point_on_faces(centres[mesh.face_index])
    np.testing.assert_array_equal(face, mesh.face_index)


def test_interpolated_normals_follow_the_smooth_surface():
    mesh = sphere_mesh(32)
    band = Band.build(mesh, 0.1)
    n = mesh.normal(band.cp, band.face, band.bary)
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    angle = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, Sphere().normal(band.cp)), -1, 1)))
    assert angle.max() < 0.5                                     # outward, and smooth across edges
    # the faces and barycentric coordinates are found when not given
    np.testing.assert_allclose(mesh.normal(band.cp[:500]), n[:500], atol=1e-9)


def test_jacobian_normals_agree_with_the_mesh_normals():
    mesh = sphere_mesh(64)
    band = Band.build(mesh, 0.05)
    reference = mesh.normal(band.cp, band.face, band.bary)

    def angle(n):
        return np.degrees(np.arccos(np.clip(np.abs(np.einsum("ij,ij->i", n, reference)), 0, 1)))

    assert angle(jacobian_normals(band)).max() < 2.0
    near = np.abs(band.dist) <= band.h
    assert angle(jacobian_normals(band, extend=False))[near].max() < 2.0


@pytest.mark.parametrize("name, coordinate", [("open cylinder", 2), ("plane", 0)])
def test_heat_flow_on_an_open_mesh_has_a_zero_flux_border(name, coordinate):
    # cos(pi z) on the cylinder of height 1 (cos(pi x) on the unit square) is a
    # Neumann eigenfunction: u(t) = exp(-pi^2 t) cos(pi z); it varies along
    # the border's normal and is constant along the border itself
    mesh = MESHES[name][0]()
    t = 0.02
    errors = []
    for h in (0.05, 0.025):
        band = Band.build(mesh, h)
        z = band.cp[:, coordinate]
        u = heat(band, np.cos(np.pi * z), t)
        exact = np.exp(-np.pi**2 * t) * np.cos(np.pi * z)
        errors.append(np.abs(u - exact).max())
        assert np.abs(u).max() <= 1.0                             # no overshoot at the border
    assert errors[0] < 0.04 and errors[1] < 0.6 * errors[0], errors  # first order at the border


@pytest.mark.parametrize("make, error, message", [
    (lambda: TriangleMesh(np.zeros((4, 2)), [[0, 1, 2]]), ValueError, r"vertices must have shape \(V, 3\)"),
    (lambda: TriangleMesh(np.array([["a", "b", "c"]] * 3), [[0, 1, 2]]), TypeError, "vertices must hold real"),
    (lambda: TriangleMesh([[0, 0, 0], [1, 0, np.nan], [0, 1, 0]], [[0, 1, 2]]), ValueError,
     r"vertices must be finite, got \[1.0, 0.0, nan\] at vertex 1"),
    (lambda: TriangleMesh(np.eye(3), [[0.0, 1.0, 2.0]]), TypeError, "faces must hold integer vertex indices"),
    (lambda: TriangleMesh(np.eye(3), [[0, 1, 2, 0]]), ValueError, r"faces must have shape \(F, 3\)"),
    (lambda: TriangleMesh(np.eye(3), [[0, 1, 3]]), ValueError,
     r"must lie in \[0, 3\), got \[0, 1, 3\] at face 0"),
    (lambda: TriangleMesh(np.eye(3), [[0, -1, 2]]), ValueError, r"must lie in \[0, 3\)"),
    (lambda: TriangleMesh([[0, 0, 0], [1, 0, 0], [2, 0, 0]], [[0, 1, 2], [0, 0, 1]]), ValueError,
     "non-degenerate triangle, got 2 degenerate"),
    (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]]).closest_point(np.zeros((3, 2))), ValueError,
     r"points must have shape \(N, 3\)"),
    (lambda: TriangleMesh(np.eye(3), [[0, 1, 2]]).closest_point([[0, np.inf, 0]]), ValueError,
     "points must be finite"),
    (lambda: TriangleMesh(np.eye(3), [[0, 1, 2], [0, 0, 1]]).normal(np.eye(3)[:1], face=np.array([1])),
     ValueError, "face 1 was skipped as degenerate"),
    (lambda: next(TriangleMesh(np.eye(3), [[0, 1, 2]]).band_points(0.0, 1.0)), ValueError,
     "grid spacing h must be a positive number, got 0.0"),
    (lambda: parametric_mesh(plane, 0, 3), ValueError, "n_u must be a positive integer, got 0"),
])
def test_bad_input_is_reported(make, error, message):
    with pytest.raises(error, match=message):
        make()


def renumbered(vertices, faces, rng):
    """The same surface numbered anew: its vertices and faces shuffled, each face started at another corner.
    Returns the new ``(vertices, faces)``, each new face's old face (F,) and the old corner of each of its
    corners (F, 3)."""
    old = rng.permutation(len(faces))
    corners = (rng.integers(0, 3, len(faces))[:, None] + np.arange(3)) % 3
    shuffle = rng.permutation(len(vertices))
    new = np.empty_like(shuffle)
    new[shuffle] = np.arange(len(vertices))
    return vertices[shuffle], new[faces[old[:, None], corners]], old, corners


def test_closest_points_samples_and_normals_do_not_depend_on_how_the_faces_are_numbered():
    vertices, faces, _ = parametric_mesh(Sphere().point, 24, 12, periodic_u=True)
    first = TriangleMesh(vertices, faces)
    second_vertices, second_faces, old, corners = renumbered(vertices, faces, np.random.default_rng(5))
    second = TriangleMesh(second_vertices, second_faces)
    bands = [Band.build(mesh, 0.1) for mesh in (first, second)]
    ties = np.mean(np.any(bands[0].bary == 0.0, axis=1))
    assert ties > 0.2                  # closest points on edges and vertices, each held by two faces or more
    assert np.array_equal(bands[0].cp, bands[1].cp)
    assert np.array_equal(bands[0].face, old[bands[1].face])                 # the same face at every tie
    rows = np.arange(bands[1].size)[:, None]
    bary = np.empty_like(bands[1].bary)
    bary[rows, corners[bands[1].face]] = bands[1].bary                       # by the old face's corners
    assert np.array_equal(bands[0].bary, bary)
    normals = [mesh.normal(band.cp.astype(np.float64), band.face, band.bary) for mesh, band in zip((first, second),
                                                                                                  bands)]
    assert np.array_equal(*normals)
    samples = [mesh.sample(500, np.random.default_rng(2)) for mesh in (first, second)]
    assert np.array_equal(samples[0][0], samples[1][0]) and np.array_equal(samples[0][1], old[samples[1][1]])
