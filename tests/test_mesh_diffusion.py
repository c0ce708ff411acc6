"""Diffusion on a mesh's own vertices: the scale-space properties that Wu, Deng, Chen and Tai prove for
the discrete filters ("Scale-space analysis of discrete filtering over arbitrary triangulated surfaces",
2009), checked on their discretisation."""

import numpy as np
import pytest

pytest.importorskip("igl", reason="the mesh filters need libigl (requirements.txt pins it)")

from cp_stylize.mesh_diffusion import MESH_MODES, STEP_EDGES, MeshOperators, mesh_diffuse  # noqa: E402
from cp_stylize_dev.crosscheck import icosphere  # noqa: E402


@pytest.fixture(scope="module")
def sphere():
    vertices, faces = icosphere(4)
    rng = np.random.default_rng(3)
    # two colours split by a great circle, with noise: an edge to keep and noise to remove
    step = np.where(vertices[:, 0] > 0, 0.8, 0.2)
    values = np.column_stack([step + 0.05 * rng.standard_normal(len(vertices)), 0.5 + 0.3 * vertices[:, 2]])
    return vertices, faces, values, MeshOperators.of(vertices, faces)


def _mean(ops, u):
    return ops.mass @ u / ops.mass.sum()


def _variance(ops, u):
    return ops.mass @ (u - _mean(ops, u)) ** 2 / ops.mass.sum()


@pytest.mark.parametrize("mode", MESH_MODES)
def test_the_area_weighted_mean_is_kept_and_the_variance_falls_at_every_step(sphere, mode):
    vertices, faces, values, ops = sphere
    tau = STEP_EDGES * ops.edge**2
    variances = []
    for steps in range(5):
        u = mesh_diffuse(vertices, faces, values, mode=mode, T=steps * tau, tau=tau, operators=ops)
        np.testing.assert_allclose(_mean(ops, u), _mean(ops, values), rtol=0, atol=1e-9)
        variances.append(_variance(ops, u))
    variances = np.array(variances)
    assert np.all(np.diff(variances, axis=0) < 0)                    # information reduction, each channel


@pytest.mark.parametrize("mode", ["gaussian", "perona_malik"])
def test_the_values_stay_within_their_initial_range(sphere, mode):
    vertices, faces, values, ops = sphere
    u = mesh_diffuse(vertices, faces, values, mode=mode, T=0.01, operators=ops)
    assert np.all(u >= values.min(axis=0) - 1e-9) and np.all(u <= values.max(axis=0) + 1e-9)


@pytest.mark.parametrize("mode", MESH_MODES)
def test_the_values_tend_to_a_constant_their_mean(sphere, mode):
    vertices, faces, values, ops = sphere
    # CED diffuses across its coherent edges at alpha = 0.001 alone: it takes a thousand times longer
    T = 5e4 if mode == "ced" else 50.0
    u = mesh_diffuse(vertices, faces, values, mode=mode, T=T, tau=T / 10, operators=ops)
    np.testing.assert_allclose(u, np.broadcast_to(_mean(ops, values), u.shape), atol=1e-3)


def test_the_linear_filter_is_a_semigroup(sphere):
    vertices, faces, values, ops = sphere
    tau = STEP_EDGES * ops.edge**2
    once = mesh_diffuse(vertices, faces, values, mode="gaussian", T=8 * tau, tau=tau, operators=ops)
    first = mesh_diffuse(vertices, faces, values, mode="gaussian", T=3 * tau, tau=tau, operators=ops)
    twice = mesh_diffuse(vertices, faces, first, mode="gaussian", T=5 * tau, tau=tau, operators=ops)
    np.testing.assert_allclose(twice, once, atol=1e-9)


@pytest.mark.parametrize("mode", MESH_MODES)
def test_a_shift_of_the_grey_levels_shifts_the_result(sphere, mode):
    vertices, faces, values, ops = sphere
    u = mesh_diffuse(vertices, faces, values, mode=mode, T=0.004, operators=ops)
    shifted = mesh_diffuse(vertices, faces, values + 0.3, mode=mode, T=0.004, operators=ops)
    np.testing.assert_allclose(shifted, u + 0.3, atol=1e-8)


def test_edge_enhancing_diffusion_removes_the_noise_and_keeps_the_edge(sphere):
    vertices, faces, values, ops = sphere
    # the structure tensor smoothed over about an edge length and two: this mesh is coarse
    T = 0.01
    eed = mesh_diffuse(vertices, faces, values[:, 0], mode="eed", T=T, operators=ops, sigma=2e-3, rho=8e-3,
                       lambda_rel=0.05)
    blur = mesh_diffuse(vertices, faces, values[:, 0], mode="gaussian", T=T, operators=ops)
    x = vertices[:, 0]
    inside = np.abs(x) > 0.3
    clean = np.where(x > 0, 0.8, 0.2)
    noise_before = np.std((values[:, 0] - clean)[inside])
    assert np.std((eed - clean)[inside]) < noise_before / 3             # the noise is gone within each half
    near = np.abs(x) < 0.1                                                # the step: still sharp
    jump = lambda u: np.mean(u[near & (x > 0)]) - np.mean(u[near & (x < 0)])   # noqa: E731
    assert jump(eed) > 1.5 * jump(blur)


def test_bad_input_is_refused_with_what_is_wrong(sphere):
    vertices, faces, values, ops = sphere
    with pytest.raises(ValueError, match="mode must be one of"):
        mesh_diffuse(vertices, faces, values, mode="beltrami", T=0.001)
    with pytest.raises(ValueError, match="one row per vertex"):
        mesh_diffuse(vertices, faces, values[:-1], mode="gaussian", T=0.001, operators=ops)
    bad = values.copy()
    bad[3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        mesh_diffuse(vertices, faces, bad, mode="gaussian", T=0.001, operators=ops)
    with pytest.raises(TypeError, match="takes no parameter 'rho'"):
        mesh_diffuse(vertices, faces, values, mode="perona_malik", T=0.001, rho=1e-4, operators=ops)
    flat = faces.copy()
    flat[0] = [flat[0, 0], flat[0, 0], flat[0, 1]]
    with pytest.raises(ValueError, match="1 faces have no area"):
        MeshOperators.of(vertices, flat)


def test_the_linear_filter_converges_to_the_heat_flow_on_the_sphere_at_second_order():
    # x y is a spherical harmonic of degree 2: the heat flow on the unit sphere scales it by exp(-6 T)
    T, errors = 0.05, []
    for subdivisions in (3, 4, 5):
        vertices, faces = icosphere(subdivisions)
        ops = MeshOperators.of(vertices, faces)
        u0 = vertices[:, 0] * vertices[:, 1]
        exact = u0 * np.exp(-6 * T)
        u = mesh_diffuse(vertices, faces, u0, mode="gaussian", T=T, operators=ops)
        errors.append(np.sqrt(ops.mass @ (u - exact) ** 2 / (ops.mass @ exact**2)))
    # each halving of the edges (and so a quarter of the time step) divides the error by about 4
    assert errors[0] / errors[1] > 2.4 and errors[1] / errors[2] > 3.0 and errors[2] < 0.005


def test_the_stiffness_sums_each_faces_part_of_its_tensor(sphere):
    """The stiffness, summed into its pattern face by face, is ``sum_T |T| G_T^T D_T G_T``: for the identity the
    cotangent Laplacian, for a face diffusivity that many times each face's part, and for a tensor along and
    across a direction in each face's plane the same as the full 3 x 3 tensor would give."""
    vertices, faces, values, ops = sphere
    rng = np.random.default_rng(7)
    F = len(faces)
    assert abs(ops.stiffness(np.ones(F)) - ops.laplacian).max() < 1e-12
    g = rng.uniform(0.1, 1.0, F)
    B = ops.basis
    reference = np.zeros((len(vertices), len(vertices)))
    local = np.einsum("fai,faj->fij", B, B) * (ops.area * g)[:, None, None]
    for k in range(3):
        for m in range(3):
            np.add.at(reference, (faces[:, k], faces[:, m]), local[:, k, m])
    np.testing.assert_allclose(ops.stiffness(g).toarray(), reference, atol=1e-12)
    angle = rng.uniform(0, np.pi, F)[:, None]
    w = np.cos(angle) * ops.tangents[:, 0] + np.sin(angle) * ops.tangents[:, 1]
    along, across = rng.uniform(0.5, 1.0, F), rng.uniform(0.0, 0.2, F)
    P = np.einsum("fki,fkj->fij", ops.tangents, ops.tangents)
    tensor = along[:, None, None] * P + (across - along)[:, None, None] * (w[:, :, None] * w[:, None, :])
    directed = ops.directed_stiffness(along, across, w)
    assert abs(directed - ops.stiffness(tensor)).max() < 1e-12
    np.testing.assert_allclose(directed @ np.ones(len(vertices)), 0.0, atol=1e-12)    # constants in its null space
