"""Mesh data out of Blender through NumPy: the evaluated mesh in world space, as plain arrays."""

from __future__ import annotations

import dataclasses
import hashlib

import bpy
import numpy as np

from .errors import StylizeError


@dataclasses.dataclass
class MeshData:
    """An object's evaluated mesh (modifiers applied), triangulated, in world units without its rotation.

    The vertices are the object's own stretched by its world matrix without
    the matrix's rotation and translation (:func:`shape_frame`): scale, shear
    and mirroring apply, the rotation (the object's and its parents') does
    not, so a turned object gives the core the same vertices.  Per-corner
    arrays are indexed by triangle and corner: ``(F, 3, ...)``.
    """

    vertices: np.ndarray            # (V, 3) world units, without the world matrix's rotation and translation
    triangles: np.ndarray           # (F, 3) vertex indices
    loops: np.ndarray               # (F, 3) loop (face corner) indices
    material_index: np.ndarray      # (F,)
    same_topology: bool             # the evaluated mesh's faces and corners are the original mesh's, in order
    uv_maps: dict = dataclasses.field(default_factory=dict)   # name -> (F, 3, 2)
    render_uv: str | None = None    # the UV map the renderer reads by default
    colours: dict = dataclasses.field(default_factory=dict)   # name -> (F, 3, 3) sRGB-encoded
    render_colour: str | None = None
    directions: np.ndarray | None = None   # (F, 3, 3) as the vertices: the vector attribute read, if asked for


def _get(collection, attr, count, dtype, width=1):
    data = np.empty(count * width, dtype=dtype)
    collection.foreach_get(attr, data)
    return data.reshape(-1, width) if width > 1 else data


#: The domains a direction attribute may have, and how a triangle corner finds its value.
VECTOR_DOMAINS = ("POINT", "CORNER", "FACE")


def vector_attributes(mesh):
    """Names of the mesh's 3-D vector attributes a stroke direction can be read from."""
    return [a.name for a in mesh.attributes if a.data_type == "FLOAT_VECTOR" and a.domain in VECTOR_DOMAINS
            and not (a.is_internal or a.is_required)]      # not the positions


def _vectors(mesh, name, tris, loops, polygons, obj_name):
    """Vector attribute ``name`` at the triangle corners (F, 3, 3), or StylizeError naming what there is."""
    attr = mesh.attributes.get(name)
    if attr is None or attr.data_type != "FLOAT_VECTOR" or attr.domain not in VECTOR_DOMAINS:
        found = ", ".join(repr(n) for n in vector_attributes(mesh)) or "none"
        kinds = {"FLOAT2": "a 2-D vector", "FLOAT_VECTOR": "a vector", "FLOAT_COLOR": "a colour",
                 "BYTE_COLOR": "a colour", "FLOAT": "a number", "INT": "a whole number", "BOOLEAN": "a true/false",
                 "QUATERNION": "a rotation", "FLOAT4X4": "a matrix", "INT8": "a whole number", "STRING": "a text"}
        places = {"POINT": "points", "CORNER": "face corners", "FACE": "faces", "EDGE": "edges",
                  "CURVE": "curves", "INSTANCE": "instances"}
        what = "no attribute" if attr is None else (
            f"no 3-D vector attribute on points, corners or faces (its attribute {name!r} holds "
            f"{kinds.get(attr.data_type, attr.data_type.lower())} on its {places.get(attr.domain, attr.domain.lower())})")
        raise StylizeError(f"the mesh of {obj_name!r} has {what} named {name!r} for the stroke direction: choose "
                           f"one of its 3-D vector attributes ({found})")
    values = _get(attr.data, "vector", len(attr.data), np.float64, 3)
    if attr.domain == "POINT":
        return values[tris]
    if attr.domain == "CORNER":
        return values[loops]
    return np.repeat(values[polygons][:, None, :], 3, axis=1)


def read(obj, depsgraph=None, *, corners=True, vectors=None):
    """The :class:`MeshData` of mesh object ``obj``; ``corners=False`` reads only vertices and triangles.

    ``vectors``: the name of a vector attribute to read into ``directions``
    (world space).  Raises StylizeError for a mesh without faces, with vertex
    positions that are not finite numbers, or without that attribute.
    """
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        n = len(mesh.loop_triangles)
        if n == 0:
            raise StylizeError(f"the mesh {obj.name!r} has no faces")
        tris = _get(mesh.loop_triangles, "vertices", n, np.int64, 3)
        verts = _get(mesh.vertices, "co", len(mesh.vertices), np.float64, 3)
        data = MeshData(vertices=verts, triangles=tris, loops=None, material_index=None,
                        same_topology=same_corners(mesh, obj.data))
        if corners:
            data.loops = _get(mesh.loop_triangles, "loops", n, np.int64, 3)
            data.material_index = _get(mesh.loop_triangles, "material_index", n, np.int64)
            for layer in mesh.uv_layers:
                data.uv_maps[layer.name] = _get(layer.data, "uv", len(mesh.loops), np.float64, 2)[data.loops]
                if layer.active_render:
                    data.render_uv = layer.name
            attributes = mesh.color_attributes
            for attr in attributes:
                if attr.domain in ("POINT", "CORNER"):
                    rgba = _get(attr.data, "color_srgb", len(attr.data), np.float32, 4)
                    data.colours[attr.name] = rgba[:, :3][data.loops if attr.domain == "CORNER" else tris]
            data.render_colour = getattr(attributes, "default_color_name", None) or (
                attributes.active_color_name if len(attributes) else None)
        if vectors:
            loops = data.loops if data.loops is not None else _get(mesh.loop_triangles, "loops", n, np.int64, 3)
            polygons = _get(mesh.loop_triangles, "polygon_index", n, np.int64)
            data.directions = _vectors(mesh, vectors, tris, loops, polygons, obj.name)
    finally:
        evaluated.to_mesh_clear()
    bad = ~np.isfinite(verts[np.unique(tris)]).all(axis=1)
    if bad.any():
        count = int(bad.sum())
        noun = "vertex whose position is" if count == 1 else "vertices whose positions are"
        raise StylizeError(f"the mesh of {obj.name!r} has {count} {noun} not a finite number")
    shape = shape_frame(obj.matrix_world)
    data.vertices = verts @ shape.T
    _check_surface(obj.name, verts, data.vertices, tris)
    if data.directions is not None:
        data.directions = data.directions @ shape.T   # tangent vectors move with the surface
    return data


def shape_frame(matrix):
    """The stretch ``S`` (3, 3) of a world matrix: the matrix without its rotation and translation.

    The polar decomposition ``A = U S`` of the matrix's linear part (``U``
    orthogonal, ``S`` symmetric with no negative eigenvalue, from the SVD
    ``A = W D V^T``: ``U = W V^T``, ``S = V D V^T``) splits it into a rotation
    (with any mirroring) and a stretch: world positions are ``U S x + t``,
    the shape ``S x`` turned and moved.  Blender keeps the matrix in single
    precision, so ``S`` is rounded to 2^-20 of its largest entry: a turned
    matrix's rounding then does not reach the mesh, and a turned object gives
    the same vertices as the object unturned.
    """
    matrix = np.array(matrix, dtype=np.float64)[:3, :3]
    _, d, vt = np.linalg.svd(matrix)
    stretch = vt.T @ np.diag(d) @ vt
    largest = np.abs(stretch).max()
    if largest > 0:
        step = 2.0 ** (np.floor(np.log2(largest)) - 20)
        stretch = np.round(stretch / step) * step
    return stretch


def axis_in_frame(obj, axis):
    """A stroke axis in ``obj``'s own space as the core sees it (:func:`shape_frame`), or StylizeError where
    the object's scale flattens it to nothing."""
    shape = shape_frame(obj.matrix_world)
    axis = np.asarray(axis, dtype=np.float64)
    moved = shape @ axis
    if np.linalg.norm(moved) <= 1e-6 * np.linalg.norm(shape, 2) * np.linalg.norm(axis):
        shown = ", ".join(f"{a:g}" for a in axis)
        raise StylizeError(f"{obj.name!r} is flattened along the stroke direction's axis ({shown}): its scale is 0 "
                           "there, so the axis has no direction on its surface; choose another axis, or give the "
                           "object a scale along it")
    return tuple(float(a) for a in moved)


def _check_surface(name, local, vertices, triangles):
    """StylizeError unless some triangle has an area: one whose corners do not lie on a line or at one point."""
    from ..mesh import surface_faces

    if surface_faces(vertices, triangles).any():
        return
    why = ", as the object's scale flattens it" if surface_faces(local, triangles).any() else ""
    raise StylizeError(f"the mesh of {name!r} has no surface to stylize: the corners of every face lie on a line "
                       f"or at one point{why}")


def same_corners(evaluated, original):
    """Whether mesh ``evaluated`` has ``original``'s faces and face corners, in the same order.

    Only then does a value written at a corner of the original mesh reach the
    same corner of the evaluated one.  Modifiers that keep the counts but not
    the order (Flip Faces, Sort Elements) fail this test.
    """
    if len(evaluated.loops) != len(original.loops) or len(evaluated.polygons) != len(original.polygons):
        return False
    return all(np.array_equal(_get(a, attr, len(a), np.int32), _get(b, attr, len(b), np.int32))
               for a, b, attr in ((evaluated.polygons, original.polygons, "loop_start"),
                                  (evaluated.polygons, original.polygons, "loop_total"),
                                  (evaluated.loops, original.loops, "vertex_index")))


def evaluated_uvs(obj, name, depsgraph=None):
    """UV map ``name`` (L, 2) of ``obj``'s evaluated mesh, as its modifiers leave it (None if it is not there)."""
    obj.data.update()
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        layer = mesh.uv_layers.get(name)
        return None if layer is None else _get(layer.data, "uv", len(mesh.loops), np.float32, 2)
    finally:
        evaluated.to_mesh_clear()


def fingerprint(obj):
    """A hash of what a run on ``obj`` read: its mesh, transform, modifiers, UV maps and material slots."""
    mesh = obj.data
    digest = hashlib.blake2b(digest_size=16)
    digest.update(_get(mesh.vertices, "co", len(mesh.vertices), np.float32, 3).tobytes())
    digest.update(_get(mesh.loops, "vertex_index", len(mesh.loops), np.int32).tobytes())
    digest.update(_get(mesh.polygons, "loop_total", len(mesh.polygons), np.int32).tobytes())
    digest.update(_get(mesh.polygons, "material_index", len(mesh.polygons), np.int32).tobytes())
    digest.update(np.array(obj.matrix_world, dtype=np.float64).tobytes())
    digest.update(repr([(m.name, m.type, m.show_viewport, m.show_render) for m in obj.modifiers]).encode())
    digest.update(repr([layer.name for layer in mesh.uv_layers]).encode())
    return digest.hexdigest()


def slots_state(obj):
    """The material slots as ``[(link, material name or None)]``, to notice a change."""
    return [(s.link, s.material.name_full if s.material else None) for s in obj.material_slots]


def write_corner_uvs(layer, loops, uvs):
    """Write per-corner ``uvs`` (F, 3, 2) into UV map ``layer`` at the triangle corners ``loops`` (F, 3).

    Returns what was written (L, 2).
    """
    data = np.zeros((len(layer.data), 2), dtype=np.float32)
    data[np.asarray(loops).ravel()] = np.asarray(uvs, dtype=np.float32).reshape(-1, 2)
    layer.data.foreach_set("uv", data.ravel())
    return data


def check_written_uvs(obj, name, written, *, after_run=False):
    """StylizeError unless ``obj``'s modifiers leave the UV map ``name`` just written (``written``, (L, 2)) as it is.

    A modifier that rewrites UV maps (UV Warp or UV Project on the active map,
    a Geometry Nodes setup) would otherwise show the result through UVs it
    was not made for.
    """
    evaluated = evaluated_uvs(obj, name)
    if evaluated is not None and evaluated.shape == written.shape and np.array_equal(evaluated, written):
        return
    raise StylizeError(f"the modifiers of {obj.name!r} change the UVs of a new UV map, which the result needs as "
                       f"they are{'; nothing was changed' if after_run else ''}: apply the modifiers first, or give "
                       "the mesh a usable UV map")
