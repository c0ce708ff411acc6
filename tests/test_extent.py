"""The diameter of a point set: exact to its tolerance, whatever the set's shape or rotation."""

import numpy as np
import pytest
from scipy.spatial.distance import pdist

from cp_stylize.extent import RTOL, diameter


def _sets(seed):
    """Point sets of every kind the pruning treats differently: blobs, flat and straight sets, round shells."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 5000))
    blob = rng.normal(size=(n, 3)) * rng.uniform(0.1, 3.0, 3)
    flat = blob * [1, 1, 0]
    line = blob * [1, 0, 0]
    shell = rng.normal(size=(n, 3))
    shell /= np.linalg.norm(shell, axis=1, keepdims=True)
    rough = shell * (1 + rng.uniform(0, 1e-3, (n, 1)))
    return {"blob": blob, "flat": flat, "line": line, "shell": shell, "rough shell": rough}


@pytest.mark.parametrize("seed", range(6))
def test_the_diameter_is_the_greatest_distance_between_two_points(seed):
    for kind, points in _sets(seed).items():
        exact = pdist(points).max()
        assert diameter(points, rtol=0) == pytest.approx(exact, rel=1e-13), kind
        assert exact / (1 + RTOL) * (1 - 1e-13) <= diameter(points) <= exact * (1 + 1e-13), kind


def test_a_uv_sphere_without_opposite_vertices_is_measured_quickly_to_its_tolerance():
    theta = np.linspace(0, np.pi, 300)[1:-1]
    phi = np.linspace(0, 2 * np.pi, 601, endpoint=False)     # odd: no vertex is opposite another on a parallel
    t, p = np.meshgrid(theta, phi, indexing="ij")
    points = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    points = np.vstack([points, [[0, 0, 1.0], [0, 0, -1.0]]])
    assert 2 / (1 + RTOL) <= diameter(points) <= 2.0


def test_the_diameter_does_not_change_when_the_points_turn():
    from scipy.spatial.transform import Rotation

    points = _sets(7)["blob"]
    d = diameter(points)
    for seed in range(4):
        turned = points @ Rotation.random(random_state=seed).as_matrix().T
        assert diameter(turned) == pytest.approx(d, rel=RTOL)


def test_small_sets():
    assert diameter([[1.0, 2.0, 3.0]]) == 0.0
    assert diameter([[1.0, 2.0, 3.0]] * 5) == 0.0
    assert diameter([[0, 0, 0], [3, 4, 0]]) == 5.0
    with pytest.raises(ValueError, match="at least one point"):
        diameter(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="must be finite"):
        diameter([[0, 0, 0], [np.nan, 0, 0]])
