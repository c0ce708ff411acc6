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

What the bake sees is what the renderer shows: on a mesh without UV maps,
nodes that read UV coordinates see zeros (a temporary all-zero UV map is the
render UV map during the bake), not the atlas the bake is laid out on.
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
#: Name of the temporary all-zero render UV map a bake needs on a mesh without UV maps (removed afterwards).
ZERO_UV_NAME = "cp_stylize no UVs"
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


def _collections_of(obj, layer_collection, path=()):
    """The chains of layer collections, from the view layer's root, that hold ``obj``."""
    path = path + (layer_collection,)
    if obj.name in layer_collection.collection.objects:
        yield path
    for child in layer_collection.children:
        yield from _collections_of(obj, child, path)


def _hidden_by_collection(obj, layer):
    """What keeps ``obj`` out of the view layer's viewport or renders by way of a collection: a message, or None."""
    chains = list(_collections_of(obj, layer.layer_collection))
    if not chains:
        return None
    checks = (
        (lambda lc: lc.exclude, "is excluded from the view layer: include it (the checkbox next to it in the Outliner)"),
        (lambda lc: lc.collection.hide_viewport, "is disabled in viewports: enable it (the monitor icon next to it in "
                                                 "the Outliner)"),
        (lambda lc: lc.hide_viewport, "is hidden: show it (the eye icon next to it in the Outliner)"),
        (lambda lc: lc.collection.hide_render, "is disabled in renders: enable it (the camera icon next to it in the "
                                               "Outliner)"),
        (lambda lc: lc.collection.hide_select, "cannot be selected: make it selectable (the arrow icon next to it in "
                                               "the Outliner)"),
        (lambda lc: lc.holdout, "is a holdout, which Cycles bakes black: turn its Holdout off in the Outliner"),
    )
    for test, what in checks:
        # a collection matters only if every chain that holds the object passes through one that fails the test
        blocking = [next((lc for lc in chain[1:] if test(lc)), None) for chain in chains]
        if all(lc is not None for lc in blocking):
            return f"its collection {blocking[0].name!r} {what}"
    return None


def check_bakeable(obj):
    """Raise StylizeError if Cycles cannot bake ``obj`` now, saying what to change."""
    scene = bpy.context.scene
    if "cycles" not in bpy.context.preferences.addons or not hasattr(scene, "cycles"):
        raise StylizeError(f"the colours of {obj.name!r} come from procedural nodes, which are baked with Cycles, "
                           "and Cycles is disabled: enable it in Preferences > Add-ons")
    layer = bpy.context.view_layer
    so = "so that its procedural colours can be baked"
    if obj.name not in layer.objects:
        why = _hidden_by_collection(obj, layer)
        raise StylizeError(f"{obj.name!r} is not in the view layer {layer.name!r}" + (f": {why} {so}" if why else
                           f"; its procedural colours can be baked only there: link it to a collection of the "
                           f"view layer {layer.name!r}"))
    why = _hidden_by_collection(obj, layer)
    if why is not None:
        raise StylizeError(f"{obj.name!r} cannot be baked: {why} {so}")
    if obj.hide_viewport:
        raise StylizeError(f"{obj.name!r} is disabled in viewports: enable it (the monitor icon in the Outliner, or "
                           f"Object properties > Visibility > Show in Viewports) {so}")
    if obj.hide_get():
        raise StylizeError(f"{obj.name!r} is hidden: show it (Alt+H) {so}")
    if obj.hide_render:
        raise StylizeError(f"{obj.name!r} is disabled in renders: enable it (the camera icon in the Outliner, or "
                           f"Object properties > Visibility > Show in Renders) {so}")
    if obj.hide_select:
        raise StylizeError(f"{obj.name!r} cannot be selected, and Cycles bakes only selected objects: make it "
                           f"selectable (the arrow icon in the Outliner, or Object properties > Visibility > "
                           f"Selectable) {so}")
    if obj.is_holdout:
        raise StylizeError(f"{obj.name!r} is a holdout, which Cycles bakes black: turn Holdout off (Object "
                           f"properties > Visibility > Holdout) {so}")
    if not obj.visible_get():
        raise StylizeError(f"{obj.name!r} is not visible in the view layer {layer.name!r}: show it {so}")


def _temporary_uv_maps(obj, uvs, loops, changes):
    """Write ``uvs`` (F, 3, 2) at the triangle corners ``loops`` into a temporary UV map; returns its name.

    On a mesh without UV maps, an all-zero map comes first: it is the render
    UV map while the bake runs, so that nodes reading UVs see what the renderer
    shows for a mesh without them (zeros), not the bake's atlas.
    """
    mesh = obj.data
    if not mesh.uv_layers:
        zero = changes.new_uv_map(mesh, ZERO_UV_NAME)
        zero.data.foreach_set("uv", np.zeros(2 * len(mesh.loops), dtype=np.float32))
        zero.active_render = True
    layer = changes.new_uv_map(mesh, BAKE_UV_NAME)
    if layer is None:
        raise StylizeError(f"the mesh of {obj.name!r} has {len(mesh.uv_layers)} UV maps, Blender's limit, and the "
                           "bake of its procedural colours needs one more: remove a UV map it does not need "
                           "(Object Data properties > UV Maps) and press Stylize again")
    name = layer.name
    written = meshdata.write_corner_uvs(layer, loops, uvs)
    meshdata.check_written_uvs(obj, name, written)
    return name


def bake(obj, sockets, size, *, uv_name=None, uvs=None, loops=None):
    """Colours of output sockets baked on ``obj``: (size, size, 3) sRGB.

    ``sockets`` maps slot indices to ``(material, output socket of its node
    tree)``: the colour each slot's faces bake.

    The bake reads through the UV map ``uv_name``, or through per-corner
    ``uvs`` (F, 3, 2) at the mesh's triangle corners ``loops`` (F, 3), written
    into a temporary UV map.  Faces of other slots bake black.  Raises
    StylizeError if Cycles cannot bake the object, with Cycles's reason.
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
            if index in sockets:
                temp = _emitting_copy(changes, *sockets[index], image)
            else:
                blank = blank or _blank_material(changes, image)
                temp = blank
            changes.set(slot, "link", "OBJECT")
            changes.set(slot, "material", temp)
        if uvs is not None:
            uv_name = _temporary_uv_maps(obj, uvs, loops, changes)
        changes.set(scene.render, "engine", "CYCLES")
        changes.set(scene.cycles, "device", "CPU")
        changes.set(scene.cycles, "samples", 1)
        for other in layer.objects:
            if other.select_get() != (other == obj):
                selected = other.select_get()
                other.select_set(other == obj)
                changes.record(lambda o=other, s=selected: o.select_set(s))
        changes.set(layer.objects, "active", obj)
        try:
            bpy.ops.object.bake(type="EMIT", margin=16, margin_type="EXTEND", use_clear=True,
                                target="IMAGE_TEXTURES", save_mode="INTERNAL", use_selected_to_active=False,
                                use_cage=False, use_split_materials=False, uv_layer=uv_name or "")
        except RuntimeError as err:
            reason = str(err).strip().removeprefix("Error:").strip()
            raise StylizeError(f"Cycles could not bake the procedural colours of {obj.name!r}: {reason}") from None
        baked = images.image_to_array(image)[..., :3]
    finally:
        changes.undo()
    return linear_to_srgb(np.clip(baked, 0.0, None)).astype(np.float32)
