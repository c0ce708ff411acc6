"""Stylize a Blender object: read its surface colour, run the core, write the result back.

The work is split so that nothing in the file changes until the core has
finished: :func:`prepare` reads (and may bake a procedural colour into a
temporary image that it removes again), :func:`run_core` touches no Blender
data (it may run in a worker thread), and :func:`apply` creates the new image
and material.  A run that fails or is cancelled before :func:`apply` leaves no
trace.
"""

from __future__ import annotations

import dataclasses
import os
import threading

import bpy
import numpy as np

from . import images, meshdata

#: Name of the UV map added to meshes that have no usable UVs of their own.
ATLAS_UV_NAME = "cp_stylize_atlas"


class StylizeError(ValueError):
    """A problem with the user's data, reported to the user as it is."""


@dataclasses.dataclass
class Job:
    obj: object
    vertices: np.ndarray
    faces: np.ndarray
    loops: np.ndarray                # (F, 3) loop indices of the triangles' corners
    material_index: np.ndarray       # (F,)
    uvs: np.ndarray | None           # (F, 3, 2) the UV map the output is laid out on, or None
    uv_name: str | None
    colours: object                  # ColourInput
    sources: dict                    # material slot index -> description of its colour source
    settings: object
    same_topology: bool              # evaluated mesh == original mesh (loops line up)
    result: object = None


# -- reading ---------------------------------------------------------------------------------


def _principled(material):
    """The Principled BSDF that feeds the material output's surface, or None."""
    if material is None or material.node_tree is None:
        return None
    tree = material.node_tree
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"]
    output = next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)
    node = None
    if output is not None and output.inputs["Surface"].is_linked:
        node = _upstream(output.inputs["Surface"])
    if node is None or node.type != "BSDF_PRINCIPLED":
        node = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    return node


def _upstream(socket):
    """The node feeding ``socket``, through reroutes."""
    while socket.is_linked:
        node = socket.links[0].from_node
        if node.type != "REROUTE":
            return node
        socket = node.inputs[0]
    return None


def _mapping_transform(node):
    """2-D affine map (A, b) of a Mapping node of type POINT/TEXTURE on UVs, or raises StylizeError."""
    if node.vector_type not in ("POINT", "TEXTURE"):
        raise StylizeError(f"mapping node {node.name!r} of type {node.vector_type} is not supported")
    if any(s.is_linked for s in node.inputs[1:]):
        raise StylizeError(f"mapping node {node.name!r} has driven inputs; only constant mappings are supported")
    loc = np.array(node.inputs["Location"].default_value[:2])
    angle = node.inputs["Rotation"].default_value[2]
    scale = np.array(node.inputs["Scale"].default_value[:2])
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    A = rot @ np.diag(scale)
    if node.vector_type == "TEXTURE":
        A = np.linalg.inv(A)
        return A, -A @ loc
    return A, loc


def _image_source(bsdf):
    """``(image_node, uv_name or None, (A, b) or None)`` if Base Color comes from an image texture."""
    node = _upstream(bsdf.inputs["Base Color"])
    if node is None or node.type != "TEX_IMAGE":
        return None
    transform, uv_name = None, None
    vec = _upstream(node.inputs["Vector"]) if node.inputs["Vector"].is_linked else None
    if vec is not None and vec.type == "MAPPING":
        transform = _mapping_transform(vec)
        vec = _upstream(vec.inputs["Vector"]) if vec.inputs["Vector"].is_linked else None
    if vec is not None:
        if vec.type == "UVMAP":
            uv_name = vec.uv_map or None
        elif vec.type == "TEX_COORD" and node.inputs["Vector"].links[0].from_socket.name == "UV":
            pass
        elif vec.type != "TEX_COORD":
            raise StylizeError(f"image texture {node.name!r} uses {vec.bl_label!r} coordinates; only UVs are supported")
    return node, uv_name, transform


def check_image(image):
    """Raise StylizeError for images cp_stylize cannot read."""
    if image is None:
        raise StylizeError("an image texture node has no image")
    if image.source == "TILED":
        raise StylizeError(f"image {image.name!r} is tiled (UDIM), which is not supported")
    if image.source not in ("FILE", "GENERATED"):
        raise StylizeError(f"image {image.name!r} has source {image.source}; use a still image")
    if image.source == "FILE" and image.packed_file is None:
        path = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(path):
            raise StylizeError(f"image {image.name!r}: its file {path!r} is missing")
    if image.size[0] == 0 or image.size[1] == 0:
        raise StylizeError(f"image {image.name!r} has no pixels")


def image_colours(image):
    """Pixels as sRGB-encoded floats (H, W, 3): float (linear) images are encoded first."""
    from ..texture import linear_to_srgb

    pixels = images.image_to_array(image)[..., :3]
    linear = image.is_float or image.colorspace_settings.name not in ("sRGB", "Non-Color")
    return linear_to_srgb(pixels).astype(np.float32) if linear else pixels


def _corner_uvs(mesh, loops, name=None):
    layer = mesh.uv_layers.get(name) if name else (mesh.uv_layers.active if len(mesh.uv_layers) else None)
    if layer is None:
        return None, None
    data = np.empty(len(mesh.loops) * 2, dtype=np.float64)
    layer.data.foreach_get("uv", data)
    return data.reshape(-1, 2)[loops], layer.name


def _corner_colours(mesh, loops, tris):
    """Per-corner colours (F, 3, 3) of the active colour attribute (sRGB-encoded), or None."""
    attr = mesh.color_attributes.active_color if len(mesh.color_attributes) else None
    if attr is None:
        return None
    n = len(attr.data)
    data = np.empty(n * 4, dtype=np.float32)
    attr.data.foreach_get("color_srgb", data)
    data = data.reshape(-1, 4)[:, :3]
    if attr.domain == "CORNER":
        return data[loops]
    if attr.domain == "POINT":
        return data[tris]
    raise StylizeError(f"colour attribute {attr.name!r} on the {attr.domain} domain is not supported")


def prepare(obj, settings, depsgraph=None):
    """Read everything a run needs from ``obj``; changes nothing in the file.

    Raises StylizeError for problems with the object or its materials.
    """
    from ..pipeline import ColourInput

    if obj is None:
        raise StylizeError("no active object")
    if obj.type != "MESH":
        raise StylizeError(f"{obj.name!r} is a {obj.type.lower()}, not a mesh")
    depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        mesh.calc_loop_triangles()
        n = len(mesh.loop_triangles)
        if n == 0:
            raise StylizeError(f"the mesh {obj.name!r} has no faces")
        tris = np.empty(n * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("vertices", tris)
        loops = np.empty(n * 3, dtype=np.int64)
        mesh.loop_triangles.foreach_get("loops", loops)
        mat_index = np.empty(n, dtype=np.int64)
        mesh.loop_triangles.foreach_get("material_index", mat_index)
        tris, loops = tris.reshape(-1, 3), loops.reshape(-1, 3)
        verts = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", verts)
        matrix = np.array(obj.matrix_world)
        verts = verts.reshape(-1, 3) @ matrix[:3, :3].T + matrix[:3, 3]
        same_topology = (len(mesh.loops) == len(obj.data.loops) and len(mesh.polygons) == len(obj.data.polygons))
        uvs, uv_name = _corner_uvs(mesh, loops)
        colours = ColourInput(corner_colours=_corner_colours(mesh, loops, tris))
        sources = {}
        slots = obj.material_slots
        used = np.unique(mat_index)
        flat = np.zeros((n, 3, 3), dtype=np.float32) if colours.corner_colours is None else None
        for index in used:
            faces = mat_index == index
            material = slots[index].material if index < len(slots) else None
            bsdf = _principled(material)
            if bsdf is None:
                sources[int(index)] = "no material: grey" if material is None else "no Principled BSDF: grey"
                if flat is not None:
                    flat[faces] = 0.8
                continue
            found = _image_source(bsdf)
            if found is not None:
                node, name, transform = found
                check_image(node.image)
                tex_uvs, _ = _corner_uvs(mesh, loops, name)
                if tex_uvs is None:
                    raise StylizeError(f"material {material.name!r} reads an image through UVs, but the mesh has none")
                if transform is not None:
                    A, b = transform
                    tex_uvs = tex_uvs @ A.T + b
                colours.textures.append((image_colours(node.image), tex_uvs, faces))
                sources[int(index)] = f"image {node.image.name!r}"
            elif bsdf.inputs["Base Color"].is_linked:
                sources[int(index)] = "procedural"
            else:
                if flat is not None:
                    from ..texture import linear_to_srgb

                    flat[faces] = linear_to_srgb(np.array(bsdf.inputs["Base Color"].default_value[:3]))
                sources[int(index)] = "base colour" if flat is not None else "colour attribute"
        if flat is not None:
            colours.corner_colours = flat
    finally:
        evaluated.to_mesh_clear()
    if uvs is None and not same_topology:
        raise StylizeError(f"{obj.name!r} has no UV map and modifiers that change its topology; "
                           "add a UV map or apply the modifiers first")
    job = Job(obj=obj, vertices=verts, faces=tris, loops=loops, material_index=mat_index, uvs=uvs, uv_name=uv_name,
              colours=colours, sources=sources, settings=settings, same_topology=same_topology)
    if "procedural" in sources.values():
        _bake_procedural(job)
    return job


def _bake_procedural(job):
    """Bake procedural Base Colors with Cycles into a temporary image and read it as a texture."""
    if job.uvs is None:
        raise StylizeError(f"{job.obj.name!r} has a procedural Base Color but no UV map to bake it into; "
                           "add a UV map (e.g. Smart UV Project) first")
    size = 1024
    temp = bpy.data.images.new("cp_stylize_bake_tmp", size, size, alpha=False, float_buffer=True)
    added = []
    scene = bpy.context.scene
    saved = (scene.render.engine, scene.cycles.device, scene.cycles.samples, scene.render.bake.use_clear)
    state = _selection_state()
    try:
        for index, source in job.sources.items():
            if source != "procedural":
                continue
            tree = job.obj.material_slots[index].material.node_tree
            node = tree.nodes.new("ShaderNodeTexImage")
            node.image = temp
            tree.nodes.active = node
            added.append((tree, node))
        scene.render.engine = "CYCLES"
        scene.cycles.device = "CPU"
        scene.cycles.samples = 1
        scene.render.bake.use_clear = True
        for o in bpy.context.view_layer.objects:
            o.select_set(False)
        job.obj.select_set(True)
        bpy.context.view_layer.objects.active = job.obj
        bpy.ops.object.bake(type="DIFFUSE", pass_filter={"COLOR"}, margin=16, uv_layer=job.uv_name or "")
        baked = image_colours(temp)
    finally:
        for tree, node in added:
            tree.nodes.remove(node)
        bpy.data.images.remove(temp)
        scene.render.engine, scene.cycles.device, scene.cycles.samples, scene.render.bake.use_clear = saved
        _restore_selection(state)
    faces = np.isin(job.material_index, [i for i, s in job.sources.items() if s == "procedural"])
    job.colours.textures.append((baked, job.uvs, faces))


def _selection_state():
    layer = bpy.context.view_layer
    return layer.objects.active, [o for o in layer.objects if o.select_get()]


def _restore_selection(state):
    active, selected = state
    layer = bpy.context.view_layer
    for o in layer.objects:
        o.select_set(o in selected)
    layer.objects.active = active


# -- running -----------------------------------------------------------------------------


def run_core(job, progress=None, log=None):
    """Run the core on a prepared job (no Blender data is touched: safe in a worker thread)."""
    from ..pipeline import stylize

    job.result = stylize(job.vertices, job.faces, job.colours, job.settings, uvs=job.uvs,
                         progress=progress, log=log)
    return job.result


class Cancelled(Exception):
    """Raised inside a background run when the user cancels it."""


class BackgroundRun:
    """:func:`run_core` in a worker thread, with its progress, cancel and outcome.

    The main thread polls :attr:`fraction` and :attr:`done`; :meth:`cancel`
    makes the worker stop at its next progress report with :class:`Cancelled`
    as its :attr:`error`.  Nothing here touches Blender data.
    """

    def __init__(self, job):
        self.job = job
        self.fraction = 0.0
        self.error = None
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._work, daemon=True)

    def _progress(self, fraction):
        self.fraction = fraction
        if self._cancel.is_set():
            raise Cancelled

    def _work(self):
        try:
            run_core(self.job, progress=self._progress)
        except BaseException as err:  # handed to the main thread
            self.error = err

    def start(self):
        self._thread.start()
        return self

    def cancel(self):
        self._cancel.set()

    @property
    def done(self):
        return self._thread.ident is not None and not self._thread.is_alive()

    @property
    def cancelled(self):
        return isinstance(self.error, Cancelled)

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return self.done


# -- writing ---------------------------------------------------------------------------------


def apply(job, *, image_name="", target="NEW_MATERIAL", storage="PACK"):
    """Create the stylized image and wire it into the object's materials; returns the image."""
    obj, result = job.obj, job.result
    if storage == "SAVE" and not bpy.data.filepath:
        raise StylizeError("save the .blend file first to save the image next to it, or choose Pack")
    atlas_is_new = getattr(result.atlas, "generated", False) or job.uvs is None
    uv_name = job.uv_name
    if atlas_is_new:
        if not job.same_topology:
            raise StylizeError(f"{obj.name!r} has no usable UV map and modifiers that change its topology; "
                               "add a UV map or apply the modifiers first")
        uv_name = _write_atlas_uvs(obj.data, job.loops, result.atlas.uvs)
    name = image_name or f"{obj.name}_stylized"
    image = images.array_to_image(name, result.image)
    if storage == "SAVE":
        image.filepath_raw = os.path.join(os.path.dirname(bpy.data.filepath), bpy.path.clean_name(image.name) + ".png")
        image.file_format = "PNG"
        image.save()
    else:
        image.pack()
    for index in sorted(job.sources):
        slot = obj.material_slots[index] if index < len(obj.material_slots) else None
        material = slot.material if slot is not None else None
        if material is None:
            material = bpy.data.materials.new(f"{obj.name}_stylized")
            if material.node_tree is None:
                material.use_nodes = True
            if slot is None:
                obj.data.materials.append(material)
            else:
                slot.material = material
        elif target == "NEW_MATERIAL":
            copy = material.copy()
            copy.name = f"{material.name}_stylized"
            material.use_fake_user = True  # the original stays in the file
            slot.material = copy
            material = copy
        _wire(material, image, uv_name)
    return image


def _wire(material, image, uv_name):
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    bsdf = _principled(material)
    if bsdf is None:
        bsdf = tree.nodes.new("ShaderNodeBsdfPrincipled")
        out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"), None) or tree.nodes.new("ShaderNodeOutputMaterial")
        tree.links.new(bsdf.outputs["BSDF"], out.inputs["Surface"])
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.name = tex.label = "cp_stylize"
    tex.image = image
    tex.location = (bsdf.location.x - 400, bsdf.location.y + 200)
    if uv_name:
        uv = tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = uv_name
        uv.location = (tex.location.x - 250, tex.location.y)
        tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
    tree.links.new(tex.outputs["Color"], bsdf.inputs["Base Color"])


def _write_atlas_uvs(mesh, loops, uvs):
    layer = mesh.uv_layers.get(ATLAS_UV_NAME) or mesh.uv_layers.new(name=ATLAS_UV_NAME, do_init=False)
    data = np.zeros((len(mesh.loops), 2), dtype=np.float32)
    data[loops.ravel()] = np.asarray(uvs, dtype=np.float32).reshape(-1, 2)
    layer.data.foreach_set("uv", data.ravel())
    return layer.name
