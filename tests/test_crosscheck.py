"""The band (the closest point method) and the mesh's own finite elements (Wu, Deng, Chen and Tai, 2009) filter
the same function on the same mesh alike, and more alike as both are refined (``python -m cp_stylize
crosscheck`` prints the full table)."""

import numpy as np
import pytest

pytest.importorskip("igl", reason="the mesh filters need libigl (requirements.txt pins it)")

from cp_stylize_dev.crosscheck import QUICK, compare, harmonic, harmonic_flow, icosphere, torus_mesh  # noqa: E402


def test_on_the_sphere_both_converge_to_the_known_flow_and_to_each_other():
    rows = [compare("sphere", *icosphere(k), h, field=harmonic, exact=harmonic_flow()) for k, h in QUICK["sphere"]]
    coarse, fine = rows
    assert fine.psnr > 54.0 and fine.psnr > coarse.psnr + 5.0, (coarse, fine)
    for row in rows:
        mesh_error, band_error = row.exact
        assert mesh_error > 60.0 and band_error > 45.0, row
    assert fine.exact[1] > coarse.exact[1] + 5.0


def test_on_the_torus_the_difference_falls_as_both_are_refined():
    coarse, fine = (compare("torus", *torus_mesh(around), h) for around, h in QUICK["torus"])
    assert fine.psnr > 58.0 and fine.psnr > coarse.psnr + 10.0, (coarse, fine)


def test_the_torus_mesh_is_closed_and_its_spacing_below_h():
    vertices, faces = torus_mesh(120)
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    _, counts = np.unique(edges, axis=0, return_counts=True)
    assert np.all(counts == 2)          # every edge between two triangles: no border
    assert len(vertices) - len(edges) // 2 + len(faces) == 0        # Euler characteristic of a torus
    lengths = np.linalg.norm(vertices[edges[:, 1]] - vertices[edges[:, 0]], axis=1)
    h = QUICK["torus"][1][1]
    assert lengths.max() < h and lengths.mean() < 0.75 * h
