"""The Stylize operator never touches what the user did not ask it to change.

One test a case: files next to the .blend, the user's images during a
procedural bake, failures after the core has run, what the renderer reads
(UV maps, texture coordinates, shaders, colour spaces, image extension, muted
nodes), the scope of a run (loose vertices, linked duplicates, library data, a
second run), second runs on shared or edited results, shared meshes and UV
maps, the messages, and the limits.  Each test compares snapshots of the
whole file (``blender_state``) and the exact message the user sees.
"""

import os
import re

import numpy as np
import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_scenes import (BLUE, GREEN, RED, halves, image_material, node_material,  # noqa: E402
                            procedural_material, smooth_image, sphere, spread_over_tiles, surface_from, udim_image)
from blender_state import assert_unchanged, files, pixel_hash, snapshot  # noqa: E402

pytestmark = pytest.mark.blender

@pytest.fixture
def addon(addon):
    """The add-on on a coarse grid with a filter that barely changes the colours, so they can be checked."""
    addon.mode, addon.time = "gaussian", 1e-6
    addon.quality, addon.spacing = "CUSTOM", 0.04
    return addon


def remove_uvs(obj):
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])


def texture_node(material):
    return next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE")


def stylized_image(obj, slot=0):
    return obj.material_slots[slot].material.node_tree.nodes["cp_stylize"].image


def pixels(image):
    w, h = image.size
    buf = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf.reshape(h, w, 4)[..., :3]


def texel_points(obj, image, uv_name=None):
    """3-D points (M, 3, object space) and colours (M, 3) of the texels of ``image`` that ``obj``'s UV map covers."""
    from cp_stylize import TriangleMesh
    from cp_stylize.atlas import uv_atlas

    mesh = obj.data
    mesh.calc_loop_triangles()
    n = len(mesh.loop_triangles)
    tris, loops = np.empty(3 * n, np.int64), np.empty(3 * n, np.int64)
    mesh.loop_triangles.foreach_get("vertices", tris)
    mesh.loop_triangles.foreach_get("loops", loops)
    verts = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", verts)
    verts, tris, loops = verts.reshape(-1, 3), tris.reshape(-1, 3), loops.reshape(-1, 3)
    layer = mesh.uv_layers[uv_name] if uv_name else next(l for l in mesh.uv_layers if l.active_render)
    uv = np.empty(2 * len(mesh.loops))
    layer.data.foreach_get("uv", uv)
    tm = TriangleMesh(verts, tris)
    atlas = uv_atlas(tm, image.size[0], uv.reshape(-1, 2)[loops])
    points = np.einsum("mk,mkj->mj", atlas.bary, verts[tris[atlas.face]])
    return points, pixels(image).reshape(-1, 3)[atlas.texels]


def near(colours, colour, tol=0.12):
    return np.linalg.norm(colours - np.asarray(colour), axis=1) < tol


def run_error(**kwargs):
    """The exact message of a refused run (the operator raises it as RuntimeError in scripts)."""
    with pytest.raises(RuntimeError) as info:
        bpy.ops.object.cp_stylize(**kwargs)
    text = str(info.value)
    assert text.startswith("Error: ") and text.endswith("\n"), repr(text)
    return text[len("Error: "):-1]


def save_blend(folder, name="scene.blend"):
    bpy.ops.wm.save_as_mainfile(filepath=str(folder / name))


# -- 1. files next to the .blend -----------------------------------------------------------------


def test_saving_next_to_the_blend_never_overwrites_a_file(addon, tmp_path, capfd):
    sphere(material=image_material("Painted", halves("source")))
    (tmp_path / "wood.png").write_bytes(b"the user's own wood texture")
    save_blend(tmp_path)
    before = files(tmp_path)
    addon.storage, addon.image_name = "SAVE", "wood"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = files(tmp_path)
    assert {k: v for k, v in after.items() if k in before} == before  # every file there stays byte-identical
    assert set(after) - set(before) == {"wood.001.png"}
    image = stylized_image(bpy.data.objects["Ball"])
    assert image.filepath == "//wood.001.png" and image.packed_file is None
    assert "wood.001.png" in capfd.readouterr().out


@pytest.mark.parametrize("name, relief", [("y" * 250, False), ("y" * 242, True)])
def test_an_image_name_too_long_for_a_file_is_refused_before_the_run(addon, tmp_path, monkeypatch, name, relief):
    from cp_stylize.blender import stylize

    sphere(material=image_material("Painted", halves("source")))
    save_blend(tmp_path)
    if relief:                                     # the relief's file, "<name>_relief.000.exr", is the longer one
        addon.strokes, addon.relief = 1.0, 0.5
    addon.storage, addon.image_name = "SAVE", name
    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before, on_disk = snapshot(), files(tmp_path)
    refused = name + "_relief" if relief else name
    assert run_error() == (f"the image name {refused!r} is too long for a file name ({len(refused)} bytes; files may "
                           "have 255): choose a shorter Image Name, or choose Pack; nothing was changed")
    assert_unchanged(before, snapshot())
    assert files(tmp_path) == on_disk


def test_a_second_blend_in_the_same_folder_keeps_its_image(addon, tmp_path):
    sphere(material=image_material("Painted", halves("source")))
    save_blend(tmp_path, "first.blend")
    addon.storage = "SAVE"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    first = files(tmp_path)["Ball_stylized.png"]
    # another file in the same folder, with an object of the same name
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.context.scene.cp_stylize.quality, bpy.context.scene.cp_stylize.image_size = "CUSTOM", "512"
    bpy.context.scene.cp_stylize.spacing = 0.04
    bpy.context.scene.cp_stylize.mode, bpy.context.scene.cp_stylize.time = "gaussian", 1e-6
    bpy.context.scene.cp_stylize.storage = "SAVE"
    sphere(material=image_material("Painted", halves("source", GREEN, RED)))
    save_blend(tmp_path, "second.blend")
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = files(tmp_path)
    assert after["Ball_stylized.png"] == first
    assert stylized_image(bpy.data.objects["Ball"]).filepath == "//Ball_stylized.001.png"
    assert "Ball_stylized.001.png" in after


# -- 2. the procedural bake touches only its own image -------------------------------------------


def test_the_procedural_bake_leaves_the_users_images_alone(addon):
    source = halves("source")
    obj = sphere(material=image_material("Painted", source))
    obj.data.materials.append(procedural_material())
    centres = np.array([p.center.z for p in obj.data.polygons])
    obj.data.polygons.foreach_set("material_index", (centres < 0).astype(np.int32))
    source_hash = pixel_hash(source)
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert pixel_hash(source) == source_hash and not source.is_dirty
    after = snapshot()
    assert after["images"]["source"] == before["images"]["source"]
    assert set(after["images"]) - set(before["images"]) == {"Ball_stylized"}
    assert after["materials"]["Painted"] == before["materials"]["Painted"]
    assert after["materials"]["Checker"] == before["materials"]["Checker"]
    assert after["render"] == before["render"]
    # the checker's two tones reach the stylized image in the lower half
    points, colours = texel_points(obj, stylized_image(obj))
    grey = colours[points[:, 2] < -0.2].mean(axis=1)
    assert grey.max() - grey.min() > 0.3


def test_a_procedural_colour_on_a_mesh_without_uvs_is_baked_through_a_new_atlas(addon):
    obj = sphere(material=procedural_material())
    remove_uvs(obj)
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    # one new UV map, the atlas the image is laid out on; the bake's temporary one is gone
    assert after["meshes"]["Sphere"]["uv_maps"] == ["cp_stylize_atlas"]
    assert after["materials"]["Checker"] == before["materials"]["Checker"]
    assert set(after["images"]) - set(before["images"]) == {"Ball_stylized"}
    points, colours = texel_points(obj, stylized_image(obj), uv_name="cp_stylize_atlas")
    grey = colours.mean(axis=1)
    assert grey.max() - grey.min() > 0.3  # both checker tones


def _in_collection(obj, **flags):
    """Move ``obj`` into a new collection 'Props'; set ``flags`` on it (``layer_`` ones on its layer collection)."""
    collection = bpy.data.collections.new("Props")
    bpy.context.scene.collection.children.link(collection)
    collection.objects.link(obj)
    bpy.context.scene.collection.objects.unlink(obj)
    layer = bpy.context.view_layer.layer_collection.children["Props"]
    for flag, value in flags.items():
        setattr(layer if flag.startswith("layer_") else collection, flag.removeprefix("layer_"), value)


BAKE_VISIBILITY = {
    "hidden": (lambda o: o.hide_set(True),
               "'Ball' is hidden: show it (Alt+H) so that its procedural colours can be baked"),
    "disabled in viewports": (lambda o: setattr(o, "hide_viewport", True),
                              "'Ball' is disabled in viewports: enable it (the monitor icon in the Outliner, or Object "
                              "properties > Visibility > Show in Viewports) so that its procedural colours can be "
                              "baked"),
    "disabled in renders": (lambda o: setattr(o, "hide_render", True),
                            "'Ball' is disabled in renders: enable it (the camera icon in the Outliner, or Object "
                            "properties > Visibility > Show in Renders) so that its procedural colours can be baked"),
    "not selectable": (lambda o: setattr(o, "hide_select", True),
                       "'Ball' cannot be selected, and Cycles bakes only selected objects: make it selectable (the "
                       "arrow icon in the Outliner, or Object properties > Visibility > Selectable) so that its "
                       "procedural colours can be baked"),
    "a holdout": (lambda o: setattr(o, "is_holdout", True),
                  "'Ball' is a holdout, which Cycles bakes black: turn Holdout off (Object properties > Visibility > "
                  "Holdout) so that its procedural colours can be baked"),
    "in a hidden collection": (lambda o: _in_collection(o, layer_hide_viewport=True),
                               "'Ball' cannot be baked: its collection 'Props' is hidden: show it (the eye icon next "
                               "to it in the Outliner) so that its procedural colours can be baked"),
    "in a collection disabled in viewports": (lambda o: _in_collection(o, hide_viewport=True),
                                              "'Ball' cannot be baked: its collection 'Props' is disabled in "
                                              "viewports: enable it (the monitor icon next to it in the Outliner) so "
                                              "that its procedural colours can be baked"),
    "in a collection disabled in renders": (lambda o: _in_collection(o, hide_render=True),
                                            "'Ball' cannot be baked: its collection 'Props' is disabled in renders: "
                                            "enable it (the camera icon next to it in the Outliner) so that its "
                                            "procedural colours can be baked"),
    "in an unselectable collection": (lambda o: _in_collection(o, hide_select=True),
                                      "'Ball' cannot be baked: its collection 'Props' cannot be selected: make it "
                                      "selectable (the arrow icon next to it in the Outliner) so that its procedural "
                                      "colours can be baked"),
    "in a holdout collection": (lambda o: _in_collection(o, layer_holdout=True),
                                "'Ball' cannot be baked: its collection 'Props' is a holdout, which Cycles bakes "
                                "black: turn its Holdout off in the Outliner so that its procedural colours can be "
                                "baked"),
    "in an excluded collection": (lambda o: _in_collection(o, layer_exclude=True),
                                  "'Ball' is not in the view layer 'ViewLayer': its collection 'Props' is excluded "
                                  "from the view layer: include it (the checkbox next to it in the Outliner) so that "
                                  "its procedural colours can be baked"),
}


@pytest.mark.parametrize("case", list(BAKE_VISIBILITY))
def test_an_object_cycles_cannot_bake_is_refused_with_what_to_change(addon, case):
    obj = sphere(material=procedural_material())
    setup, message = BAKE_VISIBILITY[case]
    setup(obj)
    before = snapshot()
    with bpy.context.temp_override(active_object=obj, object=obj):   # the Outliner can make any object active
        assert run_error() == message
    assert_unchanged(before, snapshot())


def test_a_procedural_colour_is_refused_while_cycles_is_disabled(addon, monkeypatch):
    """Cycles is disabled for real (Preferences > Add-ons), as the bpy module allows.  The snapshots read
    Cycles's settings, so they are taken with Cycles enabled, before it is disabled and after it is enabled again
    (its settings live on in the scene meanwhile)."""
    from cp_stylize import band

    obj = sphere(material=procedural_material())
    monkeypatch.setattr(band.Band, "build", lambda *a, **k: pytest.fail("the band was built"))
    before = snapshot()
    assert bpy.ops.preferences.addon_disable(module="cycles") == {"FINISHED"}
    try:
        assert "cycles" not in bpy.context.preferences.addons and not hasattr(bpy.context.scene, "cycles")
        message = run_error()
    finally:
        bpy.ops.preferences.addon_enable(module="cycles")
    assert message == (f"the colours of {obj.name!r} come from procedural nodes, which are baked with Cycles, and "
                       "Cycles is disabled: enable it in Preferences > Add-ons")
    assert_unchanged(before, snapshot())


def test_slots_sharing_a_material_share_its_copy(addon):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    obj.data.materials.append(material)
    centres = np.array([p.center.z for p in obj.data.polygons])
    obj.data.polygons.foreach_set("material_index", (centres < 0).astype(np.int32))
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    copies = [slot.material for slot in obj.material_slots]
    assert copies[0] == copies[1] and copies[0].name == "Painted_stylized"
    assert sorted(bpy.data.materials.keys()) == ["Painted", "Painted_stylized"]


def _refused_before_the_band_is_built(monkeypatch):
    """The message of a run that must stop before the band is built; asserts that nothing changed."""
    from cp_stylize import band

    monkeypatch.setattr(band.Band, "build", lambda *a, **k: pytest.fail("the band was built"))
    before = snapshot()
    message = run_error()
    assert_unchanged(before, snapshot())
    return message


def flip_faces_modifier(obj):
    """A Geometry Nodes modifier that flips every face: the same counts, the corners in another order."""
    tree = bpy.data.node_groups.new("Flip", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    flip = tree.nodes.new("GeometryNodeFlipFaces")
    tree.links.new(tree.nodes.new("NodeGroupInput").outputs[0], flip.inputs[0])
    tree.links.new(flip.outputs[0], tree.nodes.new("NodeGroupOutput").inputs[0])
    obj.modifiers.new("Flip", "NODES").node_group = tree


@pytest.mark.parametrize("modifier", ["Subdivision", "Flip Faces"])
def test_a_mesh_without_uvs_whose_modifiers_change_its_corners_is_refused_before_the_run(addon, monkeypatch,
                                                                                       modifier):
    obj = _bare_sphere_with_material()
    if modifier == "Subdivision":
        obj.modifiers.new("Subdivision", "SUBSURF")
    else:
        flip_faces_modifier(obj)
    assert _refused_before_the_band_is_built(monkeypatch) == (
        "'Ball' has no usable UV map for the result (it has none) and cannot get a new one: its modifiers change its "
        "faces or the order of their corners: apply them first, or give the mesh a usable UV map")


@pytest.mark.parametrize("modifier", ["UV Warp", "Geometry Nodes"])
def test_modifiers_that_change_a_new_uv_map_are_refused(addon, modifier):
    obj = _bare_sphere_with_material()
    if modifier == "UV Warp":   # it warps the active UV map: the new one, on a mesh without UV maps
        obj.modifiers.new("Warp", "UV_WARP").scale = (2.0, 1.0)
    else:                       # a setup that writes every UV map it finds
        tree = bpy.data.node_groups.new("Scale UVs", "GeometryNodeTree")
        tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        store = tree.nodes.new("GeometryNodeStoreNamedAttribute")
        store.data_type, store.domain = "FLOAT2", "CORNER"
        store.inputs["Name"].default_value = "cp_stylize_atlas"
        tree.links.new(tree.nodes.new("NodeGroupInput").outputs[0], store.inputs["Geometry"])
        tree.links.new(store.outputs["Geometry"], tree.nodes.new("NodeGroupOutput").inputs[0])
        obj.modifiers.new("Scale UVs", "NODES").node_group = tree
    before = snapshot()
    assert run_error() == ("the modifiers of 'Ball' change the UVs of a new UV map, which the result needs as they "
                           "are; nothing was changed: apply the modifiers first, or give the mesh a usable UV map")
    assert_unchanged(before, snapshot())


def test_without_xatlas_a_mesh_without_uvs_gets_an_atlas_of_projected_charts(addon, monkeypatch):
    import sys

    obj = sphere(material=procedural_material())
    remove_uvs(obj)
    monkeypatch.setitem(sys.modules, "xatlas", None)   # as on a platform the zip has no xatlas wheel for
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert after["meshes"]["Sphere"]["uv_maps"] == ["cp_stylize_atlas"]
    assert after["materials"]["Checker"] == before["materials"]["Checker"]
    points, colours = texel_points(obj, stylized_image(obj), uv_name="cp_stylize_atlas")
    grey = colours.mean(axis=1)
    assert len(points) > 0.3 * stylized_image(obj).size[0] ** 2 and grey.max() - grey.min() > 0.3


# -- 3. a failure after the core has run leaves no trace -----------------------------------------


def _bare_sphere_with_material():
    """A sphere without UVs (the run adds an atlas UV map) whose material has a flat colour."""
    obj = sphere(material=node_material("Flat"))
    remove_uvs(obj)
    return obj


def test_a_failing_save_restores_everything(addon, tmp_path, monkeypatch):
    from cp_stylize.blender import images

    _bare_sphere_with_material()
    save_blend(tmp_path)
    addon.storage = "SAVE"

    def fail(image, path, file_format="PNG"):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(images, "write_file", fail)
    before = snapshot(tmp_path)
    message = run_error()
    assert message == (f"could not save the image 'Ball_stylized' as {str(tmp_path / 'Ball_stylized.png')!r}: "
                       "No space left on device; nothing was changed")
    assert_unchanged(before, snapshot(tmp_path))


def test_an_unwritable_folder_is_refused_before_the_run(addon, tmp_path, monkeypatch):
    _bare_sphere_with_material()
    save_blend(tmp_path)
    addon.storage = "SAVE"
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode, **kw: False if str(p) == str(tmp_path) else real(p, mode, **kw))
    from cp_stylize.blender import stylize

    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before = snapshot(tmp_path)
    assert run_error() == (f"cannot save the image next to the .blend file: the folder {str(tmp_path)!r} "
                           "is not writable; choose Pack, or save the .blend elsewhere")
    assert_unchanged(before, snapshot(tmp_path))


def test_an_unexpected_error_is_one_message_and_changes_nothing(addon, monkeypatch):
    from cp_stylize import pipeline

    _bare_sphere_with_material()

    def broken(*args, **kwargs):
        return 1 / 0

    monkeypatch.setattr(pipeline, "stylize", broken)
    before = snapshot()
    assert run_error() == ("cp_stylize failed unexpectedly (ZeroDivisionError: division by zero); "
                           "nothing was changed. The system console has the details")
    assert_unchanged(before, snapshot())


@pytest.mark.parametrize("change, message", [
    ("edit the mesh", "the mesh of 'Ball' changed while it was being stylized; nothing was changed: "
                      "press Stylize again"),
    ("enter Edit Mode", "'Ball' is in Edit Mode; nothing was changed: leave Edit Mode and press Stylize again"),
    ("delete the object", "'Ball' was deleted or renamed while it was being stylized; nothing was changed"),
    ("swap its material", "the materials of 'Ball' changed while it was being stylized; nothing was changed: "
                          "press Stylize again"),
])
def test_changes_during_a_run_are_detected_before_anything_is_written(addon, change, message):
    from cp_stylize.blender import stylize, writing

    obj = _bare_sphere_with_material()
    job = stylize.prepare(obj, addon.to_settings(), addon.output())
    stylize.run_core(job)
    if change == "edit the mesh":
        obj.data.vertices[0].co.x += 0.1
    elif change == "enter Edit Mode":
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.mode_set(mode="EDIT")
    elif change == "delete the object":
        bpy.data.objects.remove(obj)
    else:
        obj.material_slots[0].material = bpy.data.materials.new("Other")
    before = snapshot()
    with pytest.raises(stylize.StylizeError) as info:
        writing.apply(job)
    assert str(info.value) == message
    assert_unchanged(before, snapshot())


# -- 4-7. read what the renderer shows -----------------------------------------------------------


def test_an_image_without_a_uv_node_is_read_through_the_render_uv_map(addon):
    obj = sphere(material=image_material("Painted", halves("source")))
    obj.data.uv_layers.new(name="Mirrored")
    render, mirrored = obj.data.uv_layers["UVMap"], obj.data.uv_layers["Mirrored"]
    uv = np.empty(2 * len(obj.data.loops))
    render.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    uv[:, 0] = 1.0 - uv[:, 0]
    mirrored.data.foreach_set("uv", uv.ravel())
    obj.data.uv_layers.active = mirrored  # selected for editing; the render map stays the first
    assert render.active_render and not mirrored.active_render
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    image = stylized_image(obj)
    points, colours = texel_points(obj, image, uv_name=render.name)
    # the render map puts u < 1/2 (red) on one side of the sphere: the result is red there
    u_red = near(colours, RED).mean()
    assert u_red > 0.4 and near(colours, BLUE).mean() > 0.4
    cols = np.arange(image.size[0])
    red_cols = pixels(image)[:, cols < image.size[0] // 2].reshape(-1, 3)
    covered = red_cols.max(axis=1) > 0.05
    assert near(red_cols[covered], RED).mean() > 0.9


def test_generated_coordinates_are_read_as_the_renderer_shows_them(addon):
    material = image_material("Painted", halves("source", RED, BLUE, axis="v"))
    tree = material.node_tree
    coords = tree.nodes.new("ShaderNodeTexCoord")
    tree.links.new(coords.outputs["Generated"], texture_node(material).inputs["Vector"])
    obj = sphere(material=material)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    points, colours = texel_points(obj, stylized_image(obj))
    # Generated coordinates: v is the object's y across its bounding box; read as UVs it would be z
    south, north = points[:, 1] < -0.25, points[:, 1] > 0.25
    assert near(colours[south], RED).mean() > 0.9 and near(colours[north], BLUE).mean() > 0.9


def test_an_emission_shader_is_read_and_kept(addon):
    material = image_material("Glow", halves("source"), shader="ShaderNodeEmission")
    obj = sphere(material=material)
    addon.target = "APPLY"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    tree = material.node_tree
    emission = next(n for n in tree.nodes if n.type == "EMISSION")
    out = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL")
    assert out.inputs["Surface"].links[0].from_node == emission  # the user's shader stays
    assert emission.inputs["Color"].links[0].from_node.name == "cp_stylize"
    points, colours = texel_points(obj, stylized_image(obj))
    assert near(colours, RED).mean() > 0.4 and near(colours, BLUE).mean() > 0.4  # not flat grey


def _shader_without_colour(kind):
    """A Mix Shader named 'Blend', or a node group 'Toon' without a colour input, at the Material Output."""
    material = node_material("Mixed" if kind == "Mix Shader" else "Grouped")
    tree = material.node_tree
    if kind == "Mix Shader":
        node = tree.nodes.new("ShaderNodeMixShader")
        node.name = "Blend"
        tree.links.new(next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED").outputs[0], node.inputs[1])
    else:
        group = bpy.data.node_groups.new("Toon Group", "ShaderNodeTree")
        if hasattr(group, "interface"):
            group.interface.new_socket("Shader", in_out="OUTPUT", socket_type="NodeSocketShader")
        else:
            group.outputs.new("NodeSocketShader", "Shader")
        node = tree.nodes.new("ShaderNodeGroup")
        node.node_tree = group
        node.name = "Toon"
    surface_from(material, node)
    return material


@pytest.mark.parametrize("kind, material, node", [("Mix Shader", "Mixed", "Blend"), ("Group", "Grouped", "Toon")])
def test_a_shader_without_a_colour_input_is_refused_by_name(addon, kind, material, node):
    sphere(material=_shader_without_colour(kind))
    before = snapshot()
    assert run_error() == (f"material {material!r}: its surface comes from the node {node!r} ({kind}), which has "
                           "no colour input; cp_stylize reads and writes the Base Color or Color input of the shader "
                           "connected to the Material Output")
    assert_unchanged(before, snapshot())


def test_a_non_color_image_is_read_as_linear_data(addon):
    from cp_stylize.blender import stylize
    from cp_stylize.texture import linear_to_srgb

    image = halves("data", (0.5, 0.5, 0.5), (0.5, 0.5, 0.5), colorspace="Non-Color")
    obj = sphere(material=image_material("Data", image))
    job = stylize.prepare(obj, addon.to_settings(), addon.output())
    (pixels_read, _, _, _), = job.colours.textures
    # Non-Color data is used by the shader as it is, i.e. as linear values: encoded for display
    np.testing.assert_allclose(pixels_read[..., :3], linear_to_srgb(0.5), atol=2e-3)


def test_a_clipped_image_is_black_outside_its_unit_square(addon):
    material = image_material("Clipped", halves("source", GREEN, GREEN))
    tree = material.node_tree
    tex = texture_node(material)
    tex.extension = "CLIP"
    mapping = tree.nodes.new("ShaderNodeMapping")
    mapping.inputs["Scale"].default_value = (2.0, 1.0, 1.0)
    tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    uv = tree.nodes.new("ShaderNodeUVMap")
    tree.links.new(uv.outputs["UV"], mapping.inputs["Vector"])
    obj = sphere(material=material)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    image = stylized_image(obj)
    out = pixels(image)
    n = image.size[0]
    rows = slice(n // 8, -n // 8)
    # u < 1/2 maps into the image (green); u > 1/2 maps beyond it, where CLIP is black (REPEAT would be green)
    left, right = out[rows, n // 16:n // 2 - n // 16].reshape(-1, 3), out[rows, n // 2 + n // 16:-n // 16].reshape(-1, 3)
    assert near(left, GREEN).mean() > 0.9 and (right.max(axis=1) < 0.05).mean() > 0.9


def _configure(material, case):
    """Set up the image's coordinates, extension or colour space for a renderer-equivalence case."""
    tree = material.node_tree
    tex = texture_node(material)
    if case.startswith("mapping"):
        mapping = tree.nodes.new("ShaderNodeMapping")
        if case == "mapping texture":
            mapping.vector_type = "TEXTURE"
            mapping.inputs["Location"].default_value = (0.1, 0.2, 0.0)
            mapping.inputs["Rotation"].default_value = (0.0, 0.0, 0.5)
            mapping.inputs["Scale"].default_value = (1.5, 0.7, 1.0)
        else:
            mapping.inputs["Rotation"].default_value = (0.3, 0.0, 0.2)
            mapping.inputs["Scale"].default_value = (1.2, 2.0, 1.0)
        tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
        tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], mapping.inputs["Vector"])
    elif case in ("CLIP", "MIRROR", "EXTEND"):
        tex.extension = case
        mapping = tree.nodes.new("ShaderNodeMapping")
        mapping.inputs["Location"].default_value = (-0.2, -0.1, 0.0)
        mapping.inputs["Scale"].default_value = (1.4, 1.3, 1.0)
        tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
        tree.links.new(tree.nodes.new("ShaderNodeUVMap").outputs["UV"], mapping.inputs["Vector"])
    elif case == "unlinked mapping":   # its Vector input is a constant (0, 0, 0), not the UVs
        mapping = tree.nodes.new("ShaderNodeMapping")
        mapping.inputs["Location"].default_value = (0.3, 0.6, 0.0)
        tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    elif case == "second UV map":
        uv = tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = "Second"
        tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])


def _baked_twin(material):
    """A copy of ``material`` that Cycles must bake: a neutral Gamma node between the image and the shader."""
    twin = material.copy()
    tree = twin.node_tree
    gamma = tree.nodes.new("ShaderNodeGamma")
    gamma.inputs["Gamma"].default_value = 1.0
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    tree.links.new(texture_node(twin).outputs["Color"], gamma.inputs["Color"])
    tree.links.new(gamma.outputs["Color"], bsdf.inputs["Base Color"])
    return twin


def job_centres_uv(obj):
    """The render UV map's coordinates at the centre of each triangle of ``obj``'s mesh."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    loops = np.empty(3 * len(mesh.loop_triangles), np.int64)
    mesh.loop_triangles.foreach_get("loops", loops)
    uv = np.empty(2 * len(mesh.loops))
    next(l for l in mesh.uv_layers if l.active_render).data.foreach_get("uv", uv)
    return uv.reshape(-1, 2)[loops.reshape(-1, 3)].mean(axis=1)


def _colours_at_face_centres(job):
    import types

    from cp_stylize.sampling import sample_colours

    n = len(job.mesh.triangles)
    band = types.SimpleNamespace(face=np.arange(n), bary=np.full((n, 3), 1.0 / 3.0), size=n, surface=None)
    return sample_colours(band, job.colours)


@pytest.mark.parametrize("case", ["plain", "mapping texture", "mapping point", "CLIP", "MIRROR", "EXTEND",
                                  "Non-Color", "Linear Rec.709 float", "second UV map", "unlinked mapping"])
def test_images_are_read_as_cycles_renders_them(addon, case):
    from cp_stylize.blender import materials, stylize

    colorspace = {"Non-Color": "Non-Color", "Linear Rec.709 float": "Linear Rec.709"}.get(case, "sRGB")
    image = smooth_image("smooth", colorspace=colorspace, float_buffer=case.endswith("float"))
    material = image_material("Direct", image)
    _configure(material, case)
    obj = sphere(material=material, segments=48, rings=24)
    if case == "second UV map":
        second = obj.data.uv_layers.new(name="Second")
        uv = np.empty(2 * len(obj.data.loops))
        obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
        second = obj.data.uv_layers["Second"]
        second.data.foreach_set("uv", (0.25 + 0.5 * uv).ravel())
    direct_source = materials.colour_source(material, obj.data.uv_layers.keys(), obj.name)
    # read directly, except where only Cycles knows (then both sides are bakes and agree trivially)
    assert isinstance(direct_source, materials.BakeSource if case == "unlinked mapping" else materials.ImageSource)
    direct = _colours_at_face_centres(stylize.prepare(obj, addon.to_settings()))
    obj.material_slots[0].material = _baked_twin(material)
    baked = _colours_at_face_centres(stylize.prepare(obj, addon.to_settings()))
    error = np.abs(direct - baked).max(axis=1)
    if case == "CLIP":  # the bake blurs the image's sharp clipped border over a texel of the bake: leave it out
        t = job_centres_uv(obj) * (1.4, 1.3) + (-0.2, -0.1)
        error = error[np.all((np.abs(t) > 0.01) & (np.abs(t - 1) > 0.01), axis=1)]
    print(f"\n{case}: median {np.median(error):.4f}, 98th percentile {np.percentile(error, 98):.4f}")
    assert np.median(error) < 0.01 and np.percentile(error, 98) < 0.04


@pytest.mark.parametrize("packed", [False, True], ids=["files", "packed"])
def test_a_tiled_image_is_read_from_every_tile_as_cycles_renders_it(addon, tmp_path, packed):
    from cp_stylize.blender import stylize

    image = udim_image(tmp_path, packed=packed)
    material = image_material("Tiled", image)
    obj = sphere(material=material, segments=48, rings=24)
    spread_over_tiles(obj, off_tiles=True)
    centres = job_centres_uv(obj)
    job = stylize.prepare(obj, addon.to_settings())
    assert len(job.colours.textures) == 4          # one image a tile, each read on its own faces, and no tile
    direct = _colours_at_face_centres(job)
    obj.material_slots[0].material = _baked_twin(material)
    baked = _colours_at_face_centres(stylize.prepare(obj, addon.to_settings()))
    error = np.abs(direct - baked).max(axis=1)
    for tile in ((0, 0), (1, 0), (0, 1), (4, 0)):
        on = np.all(np.floor(centres) == tile, axis=1)
        assert on.sum() > 100
        print(f"\ntile {tile}: median {np.median(error[on]):.4f}, 98th percentile {np.percentile(error[on], 98):.4f}")
        # each tile's edges as Cycles reads them: clamped instead of repeated (the node's extension), the 98th
        # percentile would be 0.03
        assert np.median(error[on]) < 0.01 and np.percentile(error[on], 98) < 0.02
    # the tiles differ: reading the first tile everywhere would not pass
    assert np.abs(direct[np.all(np.floor(centres) == (1, 0), axis=1)].mean(axis=0)
                  - direct[np.all(np.floor(centres) == (0, 0), axis=1)].mean(axis=0)).max() > 0.1


@pytest.mark.parametrize("packed", [False, True], ids=["files", "packed"])
def test_a_tiled_image_is_stylized_into_a_new_atlas_and_its_tiles_stay_as_they_were(addon, tmp_path, packed):
    from cp_stylize.blender import stylize
    from cp_stylize.blender.writing import ATLAS_UV_NAME

    image = udim_image(tmp_path, packed=packed)
    obj = sphere(material=image_material("Tiled", image), segments=48, rings=24)
    spread_over_tiles(obj)
    source = _colours_at_face_centres(stylize.prepare(obj, addon.to_settings()))
    tiles = [bytes(p.packed_file.data) for p in image.packed_files]
    before = snapshot(tmp_path)
    addon.mode, addon.time, addon.image_size = "gaussian", 1e-5, "512"
    for run in range(2):                 # and again: the second run reads the tiles, not the first result
        assert bpy.ops.object.cp_stylize() == {"FINISHED"}
        result = stylized_image(obj)
        assert obj.data.uv_layers.get(ATLAS_UV_NAME) is not None     # the tiles' UVs span three squares
        points, colours = texel_points(obj, result, ATLAS_UV_NAME)
        # each tile's region of the surface keeps that tile's colours (the first tile alone would not)
        face_centres = np.array([p.center for p in obj.data.polygons])
        for region in (face_centres[:, 2] > 0.4, (face_centres[:, 2] < 0.2) & (face_centres[:, 0] < -0.1),
                       (face_centres[:, 2] < 0.2) & (face_centres[:, 0] > 0.1)):
            near_region = _nearest_face(points, face_centres, region)
            triangles, area = _triangles_of(obj, region)
            mean = (source[triangles] * area[triangles, None]).sum(axis=0) / area[triangles].sum()
            assert np.abs(colours[near_region].mean(axis=0) - mean).max() < 0.03
    after = snapshot(tmp_path)
    assert after["files"] == before["files"]
    assert [bytes(p.packed_file.data) for p in image.packed_files] == tiles
    assert after["images"][image.name] == before["images"][image.name]
    assert sorted(t.number for t in image.tiles) == [1001, 1002, 1011]
    assert len(bpy.data.images) == before["counts"]["images"] + 1          # the result; no tile left loaded


def _nearest_face(points, centres, region):
    """Of ``points``, those whose nearest face centre is in ``region`` (and not at its border)."""
    from scipy.spatial import cKDTree

    distance, nearest = cKDTree(centres).query(points, k=4)
    return region[nearest].all(axis=1)


def _triangles_of(obj, region):
    """Of the render triangles of ``obj``'s mesh, those of the polygons in ``region``, and every triangle's area."""
    mesh = obj.data
    mesh.calc_loop_triangles()
    polygon, area = np.empty(len(mesh.loop_triangles), np.int64), np.empty(len(mesh.loop_triangles))
    mesh.loop_triangles.foreach_get("polygon_index", polygon)
    mesh.loop_triangles.foreach_get("area", area)
    return region[polygon], area


def cycles_emission(obj, size=256):
    """The colour Cycles renders on ``obj`` (an Emit bake), sRGB-encoded, at its faces' centres."""
    from cp_stylize.texture import linear_to_srgb

    material = obj.material_slots[0].material
    target = bpy.data.images.new("cycles base colour", size, size, float_buffer=True)
    node = material.node_tree.nodes.new("ShaderNodeTexImage")
    node.image = target
    material.node_tree.nodes.active = node
    scene = bpy.context.scene
    scene.render.engine, scene.cycles.samples, scene.cycles.device = "CYCLES", 1, "CPU"
    render_uv = next(l.name for l in obj.data.uv_layers if l.active_render)
    bpy.ops.object.bake(type="EMIT", margin=4, use_clear=True, uv_layer=render_uv)
    baked = pixels(target)
    texel = np.clip((job_centres_uv(obj) * size).astype(int), 0, size - 1)
    return linear_to_srgb(np.clip(baked[texel[:, 1], texel[:, 0]], 0.0, None))


def _muted(material, case):
    """Mute a node (or link) of ``material``, whose Image Texture feeds an Emission, as ``case`` says."""
    tree = material.node_tree
    tex = texture_node(material)
    base = next(n for n in tree.nodes if n.type == "EMISSION").inputs["Color"]
    if case == "image":
        tex.mute = True
    elif case == "link":
        base.links[0].is_muted = True
    elif case.startswith("mix"):
        mix = tree.nodes.new("ShaderNodeMix")
        mix.data_type = "RGBA"
        socket = {s.identifier: s for s in mix.inputs}
        socket["B_Color"].default_value = (*GREEN, 1.0)
        tree.links.new(tex.outputs["Color"], socket["A_Color" if case == "mix, image on A" else "B_Color"])
        tree.links.new(next(s for s in mix.outputs if s.identifier == "Result_Color"), base)
        mix.mute = True   # passes A on, or nothing
    elif case == "gamma":
        gamma = tree.nodes.new("ShaderNodeGamma")
        gamma.inputs["Gamma"].default_value = 2.2
        tree.links.new(tex.outputs["Color"], gamma.inputs["Color"])
        tree.links.new(gamma.outputs["Color"], base)
        gamma.mute = True
    else:   # a UV Map node naming the second map, through a Mapping node or directly
        uv = tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = "Second"
        if case == "mapping":
            mapping = tree.nodes.new("ShaderNodeMapping")
            mapping.inputs["Scale"].default_value = (2.0, 2.0, 1.0)
            tree.links.new(uv.outputs["UV"], mapping.inputs["Vector"])
            tree.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
            mapping.mute = True   # passes the second map's UVs on
        else:
            tree.links.new(uv.outputs["UV"], tex.inputs["Vector"])
            uv.mute = True        # passes nothing: the image reads the render UV map


@pytest.mark.parametrize("case", ["image", "link", "mix, image on A", "mix, image on B", "gamma", "mapping",
                                  "UV map node"])
def test_muted_nodes_are_read_as_cycles_renders_them(addon, case):
    from cp_stylize.blender import stylize

    material = image_material("Muted", smooth_image("smooth"), shader="ShaderNodeEmission")
    _muted(material, case)
    obj = sphere(material=material, segments=48, rings=24)
    uv = np.empty(2 * len(obj.data.loops))
    obj.data.uv_layers["UVMap"].data.foreach_get("uv", uv)
    obj.data.uv_layers.new(name="Second").data.foreach_set("uv", 0.25 + 0.5 * uv)
    before = snapshot()
    read = _colours_at_face_centres(stylize.prepare(obj, addon.to_settings()))
    assert_unchanged(before, snapshot())
    error = np.abs(read - cycles_emission(obj)).max(axis=1)
    print(f"\n{case}: median {np.median(error):.4f}, 98th percentile {np.percentile(error, 98):.4f}")
    assert np.median(error) < 0.01 and np.percentile(error, 98) < 0.04
    assert (np.ptp(read, axis=0).max() > 0.5) == (case not in ("image", "link"))   # the image, or one colour


def test_a_muted_shader_is_named(addon):
    material = image_material("Painted", halves("source"))
    next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED").mute = True
    sphere(material=material)
    before = snapshot()
    assert run_error() == ("material 'Painted': its surface comes from the muted node 'Principled BSDF' (Principled "
                           "BSDF), so it renders no surface: unmute it (M in the Shader Editor)")
    assert_unchanged(before, snapshot())


# -- 8-11. scope -----------------------------------------------------------------------------------


def test_a_loose_vertex_far_away_does_not_change_the_grid(addon):
    from cp_stylize.blender.operators import estimate

    obj = sphere(material=image_material("Painted", halves("source")))
    h, n, _, _ = estimate(obj, addon.to_settings())
    obj.data.vertices.add(1)
    obj.data.vertices[-1].co = (50.0, 0.0, 0.0)
    obj.data.update()
    h_loose, n_loose, _, _ = estimate(obj, addon.to_settings())
    assert h == pytest.approx(0.04) and h_loose == pytest.approx(h) and n_loose == n
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    points, colours = texel_points(obj, stylized_image(obj))
    assert near(colours, RED).mean() > 0.4 and near(colours, BLUE).mean() > 0.4


def test_a_linked_duplicate_keeps_its_look(addon):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    twin = obj.copy()  # shares the mesh, and with it the material slots
    twin.name = "Twin"
    bpy.context.collection.objects.link(twin)
    assert twin.data is obj.data
    bpy.context.view_layer.objects.active = obj
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert twin.material_slots[0].material is material
    assert obj.material_slots[0].material.name == "Painted_stylized"
    assert obj.data.materials[0] is material  # the mesh's own slot is untouched


def _library(tmp_path):
    """A library .blend with a textured sphere 'Linked' and a material 'Libmat'; returns its path."""
    sphere("Linked", material=image_material("Libmat", halves("libsource")))
    path = str(tmp_path / "lib.blend")
    bpy.data.libraries.write(path, {bpy.data.objects["Linked"], bpy.data.materials["Libmat"]})
    bpy.data.objects.remove(bpy.data.objects["Linked"])
    for block in (bpy.data.materials["Libmat"], bpy.data.images["libsource"]):
        block.user_clear()
    bpy.data.materials.remove(bpy.data.materials["Libmat"])
    bpy.data.images.remove(bpy.data.images["libsource"])
    bpy.data.meshes.remove(bpy.data.meshes["Sphere"]) if "Sphere" in bpy.data.meshes else None
    return path


def test_a_library_linked_object_is_refused(addon, tmp_path):
    path = _library(tmp_path)
    with bpy.data.libraries.load(path, link=True) as (source, target):
        target.objects = ["Linked"]
    obj = target.objects[0]
    bpy.context.collection.objects.link(obj)
    bpy.context.view_layer.objects.active = obj
    before = snapshot(tmp_path)
    assert run_error() == ("'Linked' is linked from the library 'lib.blend' and cannot be changed here: "
                           "make it local first (Object > Relations > Make Local)")
    assert_unchanged(before, snapshot(tmp_path))


def test_applying_to_a_library_material_is_refused(addon, tmp_path):
    path = _library(tmp_path)
    with bpy.data.libraries.load(path, link=True) as (source, target):
        target.materials = ["Libmat"]
    sphere(material=target.materials[0])
    addon.target = "APPLY"
    before = snapshot(tmp_path)
    assert run_error() == ("material 'Libmat' is linked from the library 'lib.blend' and cannot be changed here: "
                           "choose New Material Copy, or make it local first")
    assert_unchanged(before, snapshot(tmp_path))
    addon.target = "NEW_MATERIAL"  # a copy of it is fine
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert bpy.data.objects["Ball"].material_slots[0].material.name == "Libmat_stylized"


def test_a_second_run_starts_again_from_the_original(addon):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    copy = obj.material_slots[0].material
    first = pixels(stylized_image(obj)).copy()
    assert copy.name == "Painted_stylized" and copy["cp_stylize_original"] == material
    assert not material.use_fake_user and material.users >= 1  # the copy keeps the original alive
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert obj.material_slots[0].material == copy  # the same copy, with its new image
    assert sorted(after["materials"]) == ["Painted", "Painted_stylized"]
    assert after["materials"]["Painted"] == before["materials"]["Painted"]
    # the second run read the original colours, not the first result: the same settings give the same image
    np.testing.assert_array_equal(pixels(stylized_image(obj)), first)


def test_a_second_apply_reads_the_original_colours(addon):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    addon.target = "APPLY"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    first = pixels(stylized_image(obj)).copy()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert sorted(n.name for n in material.node_tree.nodes if n.name.startswith("cp_stylize")) == [
        "cp_stylize", "cp_stylize UV"]
    np.testing.assert_array_equal(pixels(stylized_image(obj)), first)


# -- 14. second runs, duplicates and edited results --------------------------------------------------


def run_report(capfd):
    """The report of a finished run (printed in background mode): ``(kind, message)``."""
    capfd.readouterr()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    line = [l for l in capfd.readouterr().out.splitlines() if l.startswith(("Info: styl", "Warning: styl"))][-1]
    kind, _, message = line.partition(": ")
    return kind, message


def report_pattern(obj, image, tail=""):
    """A regular expression of a run's report, the run's time and band size left open."""
    import re

    return (rf"stylized {obj!r} into {image!r} in [0-9.]+ s \([0-9,]+ band points, grid spacing 0\.04"
            rf"(, the last run's band reused)?\){re.escape(tail)}")


def changed_paths(before, after):
    """The snapshot paths that differ (``images.Ball_stylized``, ``materials.Painted_stylized.nodes``, ...)."""
    from blender_state import differences

    return sorted({d.split(": ")[0] for d in differences(before, after)})


def two_material_sphere():
    """A sphere whose lower half wears 'Lower' (a red-blue image) and upper half 'Upper' (green-red)."""
    obj = sphere(material=image_material("Lower", halves("lower")))
    obj.data.materials.append(image_material("Upper", halves("upper", GREEN, RED)))
    centres = np.array([p.center.z for p in obj.data.polygons])
    obj.data.polygons.foreach_set("material_index", (centres > 0).astype(np.int32))
    return obj


@pytest.mark.parametrize("target", ["NEW_MATERIAL", "APPLY"])
def test_a_second_run_on_two_materials_replaces_their_image_once(addon, capfd, target):
    obj = two_material_sphere()
    addon.target = target
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    first = pixels(stylized_image(obj)).copy()
    addon.time = 0.004   # a different look
    before = snapshot()
    kind, message = run_report(capfd)
    after = snapshot()
    assert kind == "Info" and re.fullmatch(report_pattern("Ball", "Ball_stylized"), message), message
    # the one image both materials showed is replaced by the new one, under its name; nothing else changes
    assert changed_paths(before, after) == ["images.Ball_stylized"]
    assert stylized_image(obj, 0) == stylized_image(obj, 1) == bpy.data.images["Ball_stylized"]
    assert np.abs(pixels(stylized_image(obj)) - first).max() > 0.05


def _duplicate(obj, how):
    """A second object 'Other' that shows ``obj``'s first material: Shift+D, Link Materials or an object slot."""
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj
    if how == "Shift+D":
        bpy.ops.object.duplicate(linked=False)     # a copy of the mesh, the same materials
        other = bpy.context.active_object
    else:
        other = sphere("Other", material=image_material("Own", halves("own", GREEN, BLUE)), location=(3, 0, 0))
        if how == "Link Materials":
            for o in bpy.context.view_layer.objects:
                o.select_set(o in (obj, other))
            bpy.context.view_layer.objects.active = obj
            bpy.ops.object.make_links_data(type="MATERIAL")
        else:
            other.material_slots[0].link = "OBJECT"
            other.material_slots[0].material = obj.material_slots[0].material
    other.name = "Other"
    other.location.x = 3.0
    for o in bpy.context.view_layer.objects:
        o.select_set(o == other)
    bpy.context.view_layer.objects.active = other
    return other


@pytest.mark.parametrize("how", ["Shift+D", "Link Materials", "object slot"])
def test_another_object_showing_the_result_keeps_its_look(addon, how):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    copy = obj.material_slots[0].material
    copy.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value = 0.2   # the user's change
    other = _duplicate(obj, how)
    assert other.material_slots[0].material == copy
    other.data.transform(np.diag([1.0, 1.0, 0.5, 1.0]))   # a shape of its own
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    # the first object, its copy and its image are as they were
    assert after["objects"]["Ball"] == before["objects"]["Ball"]
    assert after["materials"]["Painted_stylized"] == before["materials"]["Painted_stylized"]
    assert after["images"]["Ball_stylized"] == before["images"]["Ball_stylized"]
    # the other object wears a copy of its own, with the user's change, pointing to the same original
    own = other.material_slots[0].material
    assert own.name == "Painted_stylized.001" and own["cp_stylize_original"] == material
    assert own.node_tree.nodes["Principled BSDF"].inputs["Roughness"].default_value == pytest.approx(0.2)
    assert stylized_image(other).name == "Other_stylized"
    assert set(after["materials"]) - set(before["materials"]) == {"Painted_stylized.001"}
    # and a run on the first object again still updates its own copy
    for o in bpy.context.view_layer.objects:
        o.select_set(o == obj)
    bpy.context.view_layer.objects.active = obj
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert obj.material_slots[0].material == copy and stylized_image(obj).name == "Ball_stylized"
    assert after["materials"] == before["materials"] and after["objects"]["Other"] == before["objects"]["Other"]


def test_a_result_another_object_shows_through_geometry_nodes_is_not_rewired(addon):
    material = image_material("Painted", halves("source"))
    obj = sphere(material=material)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    copy = obj.material_slots[0].material
    # another object shows the copy through a Set Material node of its own modifier
    tree = bpy.data.node_groups.new("Paint it", "GeometryNodeTree")
    tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    set_material = tree.nodes.new("GeometryNodeSetMaterial")
    set_material.inputs["Material"].default_value = copy
    tree.links.new(tree.nodes.new("NodeGroupInput").outputs[0], set_material.inputs["Geometry"])
    tree.links.new(set_material.outputs["Geometry"], tree.nodes.new("NodeGroupOutput").inputs[0])
    other = sphere("Other", location=(3.0, 0.0, 0.0))
    other.modifiers.new("Paint it", "NODES").node_group = tree
    bpy.context.view_layer.objects.active = obj
    addon.time = 0.004
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert after["materials"]["Painted_stylized"] == before["materials"]["Painted_stylized"]
    assert after["images"]["Ball_stylized"] == before["images"]["Ball_stylized"]
    assert obj.material_slots[0].material.name == "Painted_stylized.001"
    assert stylized_image(obj).name == "Ball_stylized.001"


@pytest.mark.parametrize("colour", ["image", "procedural"])
def test_a_copy_whose_original_node_was_deleted_reads_its_original_again(addon, colour):
    material = image_material("Painted", halves("source")) if colour == "image" else procedural_material()
    obj = sphere(material=material)
    addon.time = 0.004   # a filter that shows when it runs on its own result
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    first = pixels(stylized_image(obj)).copy()
    copy = obj.material_slots[0].material
    tree = copy.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.type in ("TEX_IMAGE", "TEX_CHECKER") and n.name != "cp_stylize"))
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    # the original's colours again, not the last result's: the same settings give the same image
    assert changed_paths(before, snapshot()) == []
    np.testing.assert_array_equal(pixels(stylized_image(obj)), first)


def _edit(image, how, tmp_path):
    """Edit a result image as a user would; returns it (reloaded after a save and reopen)."""
    px = pixels(image).copy()
    rgba = np.ones(px.shape[:2] + (4,), np.float32)
    rgba[..., :3] = px
    rgba[100:200, 100:200, :3] = (1.0, 1.0, 0.0)     # a yellow square
    if how == "made before results had digests":
        del image["cp_stylize_digest"]
        return image
    if how == "resized":
        image.scale(256, 256)
        return image
    image.pixels.foreach_set(rgba.ravel())
    if how == "painted":
        assert image.is_dirty
        return image
    image.pack()                                      # Image > Pack: no longer dirty
    assert not image.is_dirty
    if how == "painted, packed, saved and reopened":
        name = image.name
        save_blend(tmp_path)
        bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "scene.blend"))
        image = bpy.data.images[name]
        bpy.context.view_layer.objects.active = bpy.data.objects["Ball"]
    return image


@pytest.mark.parametrize("how", ["painted", "painted and packed", "painted, packed, saved and reopened", "resized",
                                 "made before results had digests"])
def test_an_edited_result_is_kept_by_the_next_run(addon, capfd, tmp_path, how):
    from blender_state import pixel_hash

    obj = sphere(material=image_material("Painted", halves("source")))
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    edited = _edit(stylized_image(obj), how, tmp_path)
    obj = bpy.data.objects["Ball"]
    edited_hash = pixel_hash(edited)
    before = snapshot()
    kind, message = run_report(capfd)
    after = snapshot()
    why = ("may have been edited (it was made before results remembered their pixels)"
           if how == "made before results had digests" else "was edited after its run")
    note = f"; the earlier result 'Ball_stylized' {why}, so it is kept, with a fake user so that saving keeps it"
    assert kind == "Warning" and re.fullmatch(report_pattern("Ball", "Ball_stylized.001", note), message), message
    assert changed_paths(before, after) == ["counts.images", "images.Ball_stylized", "images.Ball_stylized.001",
                                            "materials.Painted_stylized.nodes"]
    kept = bpy.data.images["Ball_stylized"]
    assert pixel_hash(kept) == edited_hash and kept.use_fake_user
    assert stylized_image(obj).name == "Ball_stylized.001"
    # saving keeps it (with its paint packed, as File > Save offers for modified images)
    if kept.is_dirty:
        kept.pack()
    save_blend(tmp_path, "after.blend")
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "after.blend"))
    assert pixel_hash(bpy.data.images["Ball_stylized"]) == edited_hash


def test_an_unedited_result_is_replaced_after_a_save_and_reopen(addon, capfd, tmp_path):
    obj = sphere(material=image_material("Painted", halves("source")))
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    save_blend(tmp_path)
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "scene.blend"))
    bpy.context.view_layer.objects.active = obj = bpy.data.objects["Ball"]
    before = snapshot()
    kind, message = run_report(capfd)
    assert kind == "Info" and re.fullmatch(report_pattern("Ball", "Ball_stylized"), message), message
    assert changed_paths(before, snapshot()) == []   # the same settings: the same image, under the same name
    assert [i.name for i in bpy.data.images] == ["Ball_stylized", "source"]


# -- 15. shared meshes, UV maps, and what the bake sees ------------------------------------------------


def _twin(obj, how):
    """Another object 'Twin' that uses ``obj``'s mesh, with an image material of its own at object level."""
    if how == "linked duplicate":
        twin = obj.copy()
        bpy.context.collection.objects.link(twin)
    else:   # Link Object Data (Ctrl+L) onto an object of another scene
        other = bpy.data.scenes.new("Other scene")
        bpy.ops.mesh.primitive_cube_add()
        twin = bpy.context.active_object
        bpy.context.collection.objects.unlink(twin)
        other.collection.objects.link(twin)
        twin.data = obj.data
    twin.name = "Twin"
    twin.location.x = 3.0
    twin.material_slots[0].link = "OBJECT"
    twin.material_slots[0].material = image_material("TwinMat", halves("twin"))
    bpy.context.view_layer.objects.active = obj
    return twin


@pytest.mark.parametrize("how", ["linked duplicate", "object data linked in another scene"])
def test_a_mesh_without_uvs_shared_with_another_object_is_refused_before_the_run(addon, monkeypatch, how):
    obj = _bare_sphere_with_material()
    _twin(obj, how)
    assert _refused_before_the_band_is_built(monkeypatch) == (
        "'Ball' has no usable UV map for the result (it has none) and cannot get a new one: its mesh 'Sphere' is "
        "shared with 'Twin', and a new UV map would become the render UV map there too, changing how it renders: "
        "give 'Ball' its own mesh first (Object > Relations > Make Single User > Object & Data), or add a UV map to "
        "the mesh")


def overlapping_uvs(obj, name="UVMap"):
    """Fold the right half of ``obj``'s UV map ``name`` over its left half (unusable for a result)."""
    mesh = obj.data
    uv = np.empty(2 * len(mesh.loops), np.float32)
    mesh.uv_layers["UVMap"].data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    polygon = np.repeat(np.arange(len(mesh.polygons)), [p.loop_total for p in mesh.polygons])
    centre = np.bincount(polygon, uv[:, 0]) / np.bincount(polygon)
    right = centre[polygon] > 0.5
    uv[right, 0] = 1.0 - uv[right, 0]
    mesh.uv_layers[name].data.foreach_set("uv", uv.ravel())


def test_a_shared_mesh_with_unusable_uvs_gets_a_map_its_twin_does_not_render(addon):
    obj = sphere(material=node_material("Flat"))
    overlapping_uvs(obj)
    twin = _twin(obj, "linked duplicate")
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert after["meshes"]["Sphere"]["uv_maps"] == ["UVMap", "cp_stylize_atlas"]
    assert after["meshes"]["Sphere"]["uv_render"] == before["meshes"]["Sphere"]["uv_render"] == "UVMap"
    assert after["objects"]["Twin"] == before["objects"]["Twin"]
    assert after["materials"]["TwinMat"] == before["materials"]["TwinMat"]
    # a second run, on the twin, reads through the map the first one wrote, and rewrites nothing
    uv = np.empty(2 * len(obj.data.loops), np.float32)
    obj.data.uv_layers["cp_stylize_atlas"].data.foreach_get("uv", uv)
    bpy.context.view_layer.objects.active = twin
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    again = np.empty_like(uv)
    obj.data.uv_layers["cp_stylize_atlas"].data.foreach_get("uv", again)
    np.testing.assert_array_equal(again, uv)
    assert twin.material_slots[0].material.node_tree.nodes["cp_stylize UV"].uv_map == "cp_stylize_atlas"


@pytest.mark.parametrize("colour", ["procedural", "flat"])
def test_an_atlas_its_linked_duplicate_renders_through_is_not_rewritten(addon, monkeypatch, colour):
    """A mesh without UVs gets the atlas 'cp_stylize_atlas' as its render UV map; after Alt+D the twin shows an
    image of its own through it, so a run that would rewrite it is refused before the run: where the colour
    must be baked (a procedural) and where it need not (a flat colour, for which the core tries the UV map)."""
    obj = sphere(material=procedural_material() if colour == "procedural" else node_material("Flat"))
    remove_uvs(obj)
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    mesh = obj.data
    assert [(l.name, l.active_render) for l in mesh.uv_layers] == [("cp_stylize_atlas", True)]
    twin = _twin(obj, "linked duplicate")
    # the user's edit makes the atlas unusable: one triangle's UVs merged into one point (a face at a pole)
    face = next(p for p in mesh.polygons if p.loop_total == 3)
    atlas = mesh.uv_layers["cp_stylize_atlas"].data
    for loop in face.loop_indices:
        atlas[loop].uv = atlas[face.loop_start].uv
    assert _refused_before_the_band_is_built(monkeypatch) == (
        f"{obj.name!r} has no usable UV map for the result (1 face(s) have UV triangles of zero area) and cannot get "
        f"a new one: its mesh {mesh.name!r} is shared with {twin.name!r}, and rewriting its UV map "
        f"'cp_stylize_atlas' could change how it renders: give {obj.name!r} its own mesh first (Object > Relations > "
        "Make Single User > Object & Data)")


def _procedural_on_uvs(material):
    """Feed ``material``'s checker from the UV output of a Texture Coordinate node."""
    tree = material.node_tree
    checker = next(n for n in tree.nodes if n.type == "TEX_CHECKER")
    checker.inputs["Color1"].default_value = (*RED, 1.0)
    checker.inputs["Color2"].default_value = (*BLUE, 1.0)
    tree.links.new(tree.nodes.new("ShaderNodeTexCoord").outputs["UV"], checker.inputs["Vector"])
    return material


def test_a_procedural_on_uvs_of_a_mesh_without_uvs_is_baked_as_the_renderer_shows_it(addon):
    from cp_stylize.texture import linear_to_srgb

    obj = sphere(material=_procedural_on_uvs(procedural_material()))
    remove_uvs(obj)
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert after["meshes"]["Sphere"]["uv_maps"] == ["cp_stylize_atlas"]   # the bake's temporary maps are gone
    assert after["materials"]["Checker"] == before["materials"]["Checker"]
    # without UV maps the renderer reads UV (0, 0, 0), where the checker shows its second colour, everywhere
    points, colours = texel_points(obj, stylized_image(obj), uv_name="cp_stylize_atlas")
    assert len(colours) > 1000 and near(colours, linear_to_srgb(np.array(BLUE)), tol=0.03).all()


def eight_unusable_uv_maps(obj):
    while len(obj.data.uv_layers) < 8:
        obj.data.uv_layers.new(name=f"UV{len(obj.data.uv_layers)}")
    for layer in obj.data.uv_layers:
        overlapping_uvs(obj, layer.name)


@pytest.mark.parametrize("colour", ["image", "procedural"])
def test_a_mesh_at_the_limit_of_uv_maps_is_refused_before_the_run(addon, monkeypatch, colour):
    obj = sphere(material=image_material("Painted", halves("source")) if colour == "image" else procedural_material())
    eight_unusable_uv_maps(obj)
    message = _refused_before_the_band_is_built(monkeypatch)
    assert re.fullmatch(r"'Ball' has no usable UV map for the result \(UV triangles overlap at [0-9]+ texel\(s\)\) "
                        r"and cannot get a new one: its mesh 'Sphere' already has 8 UV maps, Blender's limit: remove "
                        r"one it does not need \(Object Data properties > UV Maps\) and press Stylize again",
                        message), message


def test_a_mesh_at_the_limit_of_uv_maps_with_a_usable_one_runs(addon):
    obj = sphere(material=procedural_material())
    while len(obj.data.uv_layers) < 8:
        obj.data.uv_layers.new(name=f"UV{len(obj.data.uv_layers)}")
    before = snapshot()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    after = snapshot()
    assert after["meshes"]["Sphere"]["uv_maps"] == before["meshes"]["Sphere"]["uv_maps"]
    assert stylized_image(obj).name == "Ball_stylized"


def _corrupt_image(tmp_path, packed):
    """An image 'good' whose file (or packed file) holds bytes that are not an image."""
    image = halves("good", pack=False)
    path = tmp_path / "good.png"
    image.filepath_raw = str(path)
    image.file_format = "PNG"
    image.save()
    path.write_bytes(b"\\x89PNG\\r\\n\\x1a\\nthis is not a png" * 10)
    if packed:
        image.pack(data=path.read_bytes(), data_len=len(path.read_bytes()))
        path.unlink()
    image.reload()
    return image


@pytest.mark.parametrize("case", ["one NaN UV", "corrupt file", "corrupt packed file"])
def test_bad_uvs_and_unreadable_images_are_named_before_the_run(addon, tmp_path, monkeypatch, case):
    if case == "one NaN UV":
        obj = sphere(material=image_material("Painted", halves("source")))
        obj.data.uv_layers["UVMap"].data[5].uv = (float("nan"), 0.5)
        message = ("the UV map 'UVMap' of 'Ball' has 1 corner whose UV is not a finite number, and material 'Painted' "
                   "reads the image 'source' through it: unwrap it again (UV > Unwrap in Edit Mode), or fix those "
                   "corners, and press Stylize again")
    else:
        sphere(material=image_material("Painted", _corrupt_image(tmp_path, case == "corrupt packed file")))
        message = (f"image 'good': its file {str(tmp_path / 'good.png')!r} could not be read (it is damaged, or not "
                   "an image Blender can open): replace the file, or choose another image" if case == "corrupt file"
                   else "image 'good': its packed file could not be read (it is damaged, or not an image Blender can "
                        "open): replace it (Image > Replace), or choose another image")
    assert _refused_before_the_band_is_built(monkeypatch) == message


# -- 12. messages that name the real cause ---------------------------------------------------------


def _message_case(name):
    if name == "NaN vertex":
        obj = sphere(material=image_material("Painted", halves("source")))
        obj.data.vertices[3].co = (float("nan"), 0.0, 0.0)
    elif name == "NaN pixels":
        image = halves("source", float_buffer=True, pack=False)
        px = np.ones((64, 64, 4), np.float32)
        px[0, :3, 0] = np.nan
        image.pixels.foreach_set(px.ravel())
        sphere(material=image_material("Painted", image))
    elif name == "singular mapping":
        material = image_material("Painted", halves("source"))
        mapping = material.node_tree.nodes.new("ShaderNodeMapping")
        mapping.vector_type = "TEXTURE"
        mapping.inputs["Scale"].default_value = (0.0, 1.0, 1.0)
        material.node_tree.links.new(mapping.outputs["Vector"], texture_node(material).inputs["Vector"])
        sphere(material=material)
    elif name == "missing UV map":
        material = image_material("Painted", halves("source"))
        uv = material.node_tree.nodes.new("ShaderNodeUVMap")
        uv.uv_map = "Gone"
        material.node_tree.links.new(uv.outputs["UV"], texture_node(material).inputs["Vector"])
        sphere(material=material)
    elif name == "empty":
        bpy.ops.object.empty_add()
    elif name == "text":
        bpy.ops.object.text_add()


@pytest.mark.parametrize("case, message", [
    ("NaN vertex", "the mesh of 'Ball' has 1 vertex whose position is not a finite number"),
    ("NaN pixels", "image 'source' has 3 pixels that are not finite numbers"),
    ("singular mapping", "the Mapping node 'Mapping' in material 'Painted' has a zero scale, "
                         "which maps the whole texture to one line or point"),
    ("missing UV map", "the UV Map node 'UV Map' in material 'Painted' names the UV map 'Gone', "
                       "which the mesh of 'Ball' does not have"),
    ("empty", "'Empty' is an empty, not a mesh"),
    ("text", "'Text' is a text object, not a mesh: convert it first (Object > Convert > Mesh)"),
])
def test_messages_name_the_real_cause(addon, case, message):
    _message_case(case)
    before = snapshot()
    assert run_error() == message
    assert_unchanged(before, snapshot())


def test_an_image_sequence_is_refused_with_how_to_read_one_frame(addon, tmp_path, monkeypatch):
    image = halves("frames", pack=False)
    image.filepath_raw, image.file_format = str(tmp_path / "frame_0001.png"), "PNG"
    image.save()
    image.source = "SEQUENCE"
    sphere(material=image_material("Painted", image))
    assert _refused_before_the_band_is_built(monkeypatch) == (
        f"image {image.name!r} is an image sequence, which cp_stylize cannot read: use a still image (in the Image "
        "Editor's sidebar, Image tab: Source Single Image; or open one frame as an image)")


@pytest.mark.parametrize("case", ["missing file", "tiled image without files", "missing tile", "damaged tile",
                                  "tiled image with unsaved changes"])
def test_a_missing_image_file_or_tile_is_refused_with_what_to_do(addon, tmp_path, monkeypatch, case):
    if case == "missing file":
        save_blend(tmp_path)
        image = halves("wood", pack=False)
        image.filepath_raw, image.file_format = str(tmp_path / "textures" / "wood.png"), "PNG"
        os.mkdir(tmp_path / "textures")
        image.save()
        image.filepath = "//textures/wood.png"          # relative to the .blend, as Blender stores it
        os.remove(tmp_path / "textures" / "wood.png")   # moved or deleted since
        message = (f"image {image.name!r}: its file {str(tmp_path / 'textures' / 'wood.png')!r} is missing: find it "
                   "again (File > External Data > Find Missing Files), replace it (Image > Replace), or choose "
                   "another image")
    elif case == "tiled image without files":
        image = bpy.data.images.new("Tiles", 64, 64, tiled=True)
        image.tiles.new(tile_number=1002)
        message = (f"image {image.name!r} is a tiled (UDIM) image with no files (its tiles are read from their files "
                   "or packed data): save it (Image > Save in the Image Editor) and press Stylize again")
    elif case == "missing tile":
        image = udim_image(tmp_path, packed=False)
        os.remove(tmp_path / "Tiles.1002.png")
        message = (f"image {image.name!r}: the file {str(tmp_path / 'Tiles.1002.png')!r} of its tile 1002 is missing: "
                   "find it again (File > External Data > Find Missing Files), or choose another image")
    elif case == "damaged tile":
        image = udim_image(tmp_path, packed=False)
        (tmp_path / "Tiles.1011.png").write_bytes(b"not a PNG")
        message = (f"image {image.name!r}: its tile 1011 could not be read (it is damaged, or not an image Blender "
                   "can open): replace it, or choose another image")
    else:
        image = udim_image(tmp_path, packed=True)
        image.pixels[0] = 0.5           # painted since it was packed
        assert image.is_dirty
        message = (f"image {image.name!r} is a tiled (UDIM) image with changes that are not saved (its tiles are read "
                   "from their files or packed data): save it (Image > Save in the Image Editor) and press Stylize "
                   "again")
    obj = sphere(material=image_material("Painted", image))
    if case == "damaged tile":
        spread_over_tiles(obj)          # a tile no face reads is not read
    images = len(bpy.data.images)
    assert _refused_before_the_band_is_built(monkeypatch) == message
    assert len(bpy.data.images) == images          # no tile left loaded


def test_a_material_without_a_material_output_is_refused_with_how_to_add_one(addon, monkeypatch):
    material = image_material("Painted", halves("source"))
    tree = material.node_tree
    tree.nodes.remove(next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"))
    sphere(material=material)
    assert _refused_before_the_band_is_built(monkeypatch) == (
        f"material {material.name!r} has no Material Output node: add one (Add > Output > Material Output in the "
        "Shader Editor) and connect its Surface to the shader")


def test_a_material_whose_only_output_is_for_eevee_is_refused_with_how_to_set_its_target(addon, monkeypatch):
    material = image_material("Painted", halves("source"))
    next(n for n in material.node_tree.nodes if n.type == "OUTPUT_MATERIAL").target = "EEVEE"
    sphere(material=material)
    assert _refused_before_the_band_is_built(monkeypatch) == (
        f"material {material.name!r} has a Material Output node for EEVEE only, and the result is read as Cycles "
        "renders it: set the node's Target to All (the node's sidebar, Node tab > Properties), or add an output "
        "for Cycles")


def test_edit_mode_is_refused_by_the_poll_with_a_reason(addon):
    sphere(material=image_material("Painted", halves("source")))
    bpy.ops.object.mode_set(mode="EDIT")
    with pytest.raises(RuntimeError) as info:
        bpy.ops.object.cp_stylize()
    assert "leave Edit Mode first" in str(info.value)


# -- 13. limits --------------------------------------------------------------------------------------


@pytest.mark.parametrize("text, message", [
    ('mode = "ced"\nspacing = 5.0\n', "spacing must lie in [0.002, 0.1], got 5.0"),
    ('mode = "ced"\nT = 1000.0\n', "T must lie in [1e-06, 0.1], got 1000.0"),
    ('mode = "ced"\n[params]\nrho = 3.0\n', "[params] rho must lie in [0, 0.05], got 3.0"),
])
def test_presets_keep_the_panels_limits(addon, tmp_path, text, message):
    sphere(material=image_material("Painted", halves("source")))
    path = tmp_path / "bad.toml"
    path.write_text(text)
    before = snapshot()
    assert run_error(preset=str(path)) == f"{path}: {message}"
    assert_unchanged(before, snapshot())


def test_a_run_estimated_above_the_time_limit_is_refused(addon, monkeypatch):
    from cp_stylize.blender import operators, stylize

    sphere(material=image_material("Painted", halves("source")))
    addon.quality, addon.time, addon.mode = "HIGH", 0.05, "ced"
    # a computer four times slower than the reference one, so that the estimate runs to hours on any machine
    monkeypatch.setattr(operators, "machine_speed", lambda: 4.0)
    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before = snapshot()
    message = run_error()
    assert message.startswith("this run would take roughly ") and message.endswith(
        ", above the time limit of 15 min: lower the quality, the image size or the time, or raise Max Time "
        "(under Output)")
    assert " h " in message  # hours
    assert_unchanged(before, snapshot())


def test_the_memory_limit_stops_at_the_computers_memory(addon, monkeypatch):
    from cp_stylize.blender import stylize

    sphere(material=image_material("Painted", halves("source")))
    addon.memory_limit = 1024.0
    addon.quality = "HIGH"
    monkeypatch.setattr(stylize, "physical_memory", lambda: 2**30)
    before = snapshot()
    message = run_error()
    assert message.startswith("this run needs about ") and message.endswith(
        "more than this computer's 1.0 GiB of memory: lower the quality or the image size")
    assert_unchanged(before, snapshot())


def test_quality_applies_without_a_preset(addon, capfd):
    sphere(material=image_material("Painted", halves("source")))
    assert addon.quality == "CUSTOM" and addon.spacing == pytest.approx(0.04)
    assert bpy.ops.object.cp_stylize(quality="PREVIEW") == {"FINISHED"}
    assert "grid spacing 0.016" in capfd.readouterr().out
