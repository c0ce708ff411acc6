"""Mesh data out of Blender through NumPy: the evaluated mesh in world space."""

import bpy
import numpy as np


def evaluated_triangles(obj, depsgraph=None):
    """World-space vertices (V, 3) and triangles (F, 3) of ``obj`` with its modifiers applied."""
    if obj is None or obj.type != "MESH":
        raise ValueError("the active object must be a mesh")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        verts = np.empty(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", verts)
        tris = np.empty(len(mesh.loop_triangles) * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("vertices", tris)
    finally:
        evaluated.to_mesh_clear()
    verts = verts.reshape(-1, 3)
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    verts = verts @ matrix[:3, :3].T + matrix[:3, 3]
    return verts, tris.reshape(-1, 3)


def surface_area(verts, tris):
    """Total area of triangles (F, 3) over vertices (V, 3)."""
    a, b, c = (verts[tris[:, k]] for k in range(3))
    return 0.5 * float(np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())
