"""Shared fixtures and markers.

Tests that need Blender (the ``bpy`` module) carry the ``blender`` marker; they
run in-process with the bpy wheel and, through ``tests/blender_runner.py``, under
``blender -b`` where a Blender binary exists.
"""

import os
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)


def pytest_unconfigure(config):
    """End the run with its own exit status where this Blender would crash at exit (4.2 to 4.4.2, see
    ``blender_support``): the result is already reported, only the interpreter's teardown is skipped."""
    bpy = sys.modules.get("bpy")
    if bpy is None:
        return
    from blender_support import exit_crashes

    if exit_crashes(bpy):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(getattr(config, "_cp_stylize_status", 0))


def pytest_sessionfinish(session, exitstatus):
    session.config._cp_stylize_status = int(exitstatus)


@pytest.fixture(scope="module")
def uv_sphere():
    """A UV sphere mesh with Blender's layout (seam at u = 0, fans at the poles), its UVs and its band."""
    from cp_stylize import Band, Sphere
    from cp_stylize.mesh import TriangleMesh, parametric_mesh

    vertices, faces, uvs = parametric_mesh(Sphere().point, 64, 32, periodic_u=True)
    mesh = TriangleMesh(vertices, faces)
    return mesh, uvs, Band.build(mesh, 0.05)


@pytest.fixture(scope="module")
def torus():
    """A torus mesh without UVs of its own, its band and an xatlas atlas."""
    from cp_stylize import Band, Torus
    from cp_stylize.atlas import uv_atlas
    from cp_stylize.mesh import TriangleMesh, parametric_mesh

    vertices, faces, _ = parametric_mesh(Torus(1.0, 0.4).point, 64, 24, periodic_u=True, periodic_v=True)
    mesh = TriangleMesh(vertices, faces)
    return mesh, Band.build(mesh, 0.05), uv_atlas(mesh, 512)


@pytest.fixture(scope="module", params=["xatlas", "charts"])
def unwrapped_torus(request, torus):
    """The torus, its band and a new atlas of each kind: xatlas's, and charts projected along the axes."""
    from cp_stylize.atlas import uv_atlas

    mesh, band, atlas = torus
    return mesh, band, atlas if request.param == "xatlas" else uv_atlas(mesh, 512, unwrap="charts")
