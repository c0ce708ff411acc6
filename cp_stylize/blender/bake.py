"""Bake colours the add-on cannot read itself (procedural nodes) with Cycles, touching nothing of the user's.

Cycles bakes into the active Image Texture node of every material on the
object.  So for the bake, every material slot of the object points (at
object level, which leaves the mesh and its other users alone) to a
temporary material: a copy of the slot's material in which the colour to
bake drives an Emission shader, or a blank one for the other slots, each with
the temporary target image as its active node.  The render engine, samples,
selection and, where the mesh has no usable UV map, a temporary UV map are
set for the bake.  All of it is undone afterwards, whether the bake worked or
not: the user's materials, images and meshes are never written to.
"""

from __future__ import annotations

import bpy
import numpy as np

from . import images, meshdata
from .changes import Changes
from .errors import StylizeError
from .materials import material_output

#: Name of the temporary UV map a bake may need (removed afterwards).
BAKE_UV_NAME = "cp_stylize bake"
#: Largest bake image, in texels a side.
MAX_SIZE = 2048


def _blank_material(changes, image):
    material = changes.new_id(bpy.data.materials, bpy.data.materials.new("cp_stylize bake blank"))
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    _target(tree, image)
    return material


def _target(tree, image):
    node = tree.nodes.new("ShaderNodeTexImage")
    node.image = image
    node.select = True
    tree.nodes.active = node


def _emitting_copy(changes, material, socket, image):
    """A temporary copy of ``material`` that emits the colour of its output ``socket``."""
    copy = changes.new_id(bpy.data.materials, material.copy())
    tree = copy.node_tree
    source = tree.nodes[socket.node.name]
    output = next(s for s in source.outputs if s.identifier == socket.identifier)
    out = material_output(tree)
    for name in ("Displacement", "Volume"):
        for link in list(out.inputs[name].links):
            tree.links.remove(link)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(output, emission.inputs["Color"])
    tree.links.new(emission.outputs[0], out.inputs["Surface"])
    _target(tree, image)
    return copy


def check_bakeable(obj):
    """Raise StylizeError if Cycles cannot bake ``obj`` now."""
    scene = bpy.context.scene
    if "cycles" not in bpy.context.preferences.addons or not hasattr(scene, "cycles"):
        raise StylizeError("procedural colours are baked with Cycles, which is disabled: enable it in "
                           "Preferences > Add-ons")
    if not obj.visible_get():
        raise StylizeError(f"{obj.name!r} is hidden: show it (Alt+H) so that its procedural colours can be baked")


def bake(obj, sockets, size, *, uv_name=None, uvs=None, loops=None):
    """Emitted colours of the output ``sockets`` ``{slot index: socket}`` baked on ``obj``: (size, size, 3) sRGB.

    The bake reads through the UV map ``uv_name``, or through per-corner
    ``uvs`` (F, 3, 2) at the mesh's triangle corners ``loops`` (F, 3), written
    into a temporary UV map.  Faces of other slots bake black.
    """
    from ..texture import linear_to_srgb

    check_bakeable(obj)
    size = min(int(size), MAX_SIZE)
    scene = bpy.context.scene
    layer = bpy.context.view_layer
    changes = Changes()
    try:
        image = changes.new_id(bpy.data.images, bpy.data.images.new(
            "cp_stylize bake", size, size, alpha=False, float_buffer=True))
        blank = None
        for index, slot in enumerate(obj.material_slots):
            material = slot.material
            if index in sockets:
                temp = _emitting_copy(changes, material, sockets[index], image)
            else:
                blank = blank or _blank_material(changes, image)
                temp = blank
            changes.set(slot, "link", "OBJECT")
            changes.set(slot, "material", temp)
        if uvs is not None:
            mesh = obj.data
            uv = changes.new_id(mesh.uv_layers, mesh.uv_layers.new(name=BAKE_UV_NAME, do_init=False))
            meshdata.write_corner_uvs(uv, loops, uvs)
            uv_name = uv.name
        changes.set(scene.render, "engine", "CYCLES")
        changes.set(scene.cycles, "device", "CPU")
        changes.set(scene.cycles, "samples", 1)
        for other in layer.objects:
            if other.select_get() != (other == obj):
                selected = other.select_get()
                other.select_set(other == obj)
                changes.record(lambda o=other, s=selected: o.select_set(s))
        changes.set(layer.objects, "active", obj)
        bpy.ops.object.bake(type="EMIT", margin=16, margin_type="EXTEND", use_clear=True,
                            target="IMAGE_TEXTURES", save_mode="INTERNAL", use_selected_to_active=False,
                            use_cage=False, use_split_materials=False, uv_layer=uv_name or "")
        baked = images.image_to_array(image)[..., :3]
    finally:
        changes.undo()
    return linear_to_srgb(np.clip(baked, 0.0, None)).astype(np.float32)
