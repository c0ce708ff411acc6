"""A result written into a colour attribute: a scan's or a vertex-painted mesh's colour filtered at its
vertices, with no image and no UV map, and everything else in the file as it was."""

import math

import numpy as np
import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")
pytest.importorskip("igl", reason="the mesh filter needs libigl (requirements.txt pins it; the extension ships it)")

from blender_scenes import halves, image_material, sphere  # noqa: E402
from cp_stylize_dev.scene import attribute_material  # noqa: E402
from blender_state import assert_unchanged, snapshot  # noqa: E402

pytestmark = pytest.mark.blender

#: A grid coarser than the test sphere's edges (the mesh filter serves it) and one finer (the band does).
COARSE, FINE = 0.08, 0.04


@pytest.fixture
def addon(addon):
    """The add-on writing colour attributes, with a Gaussian filter on a grid the sphere's vertices are finer
    than (so the mesh filter serves it)."""
    addon.result_kind = "ATTRIBUTE"
    addon.mode, addon.time = "gaussian", 2e-3
    addon.quality, addon.spacing = "CUSTOM", COARSE
    return addon


def _values(attribute):
    values = np.empty(4 * len(attribute.data), dtype=np.float32)
    attribute.data.foreach_get("color_srgb", values)
    return values.reshape(-1, 4)


def _scan(name="Scan", *, domain="POINT", data_type="FLOAT_COLOR", material=None):
    """A sphere whose colour attribute ``Col`` holds two halves (x > 0 light) with noise, at its points or
    face corners (mean edge about 0.063 for its diameter of 2); the object and the clean colours, which are 0.5
    (neither half) within 0.3 of the halves' border, so that the noise is measured away from it."""
    obj = sphere(name, material, segments=96, rings=48)
    mesh = obj.data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    clean = np.where(co[:, :1] > 0, 0.8, 0.2) * np.ones((1, 3))
    noisy = np.clip(clean + 0.1 * np.random.default_rng(0).standard_normal(clean.shape), 0, 1)
    rgba = np.concatenate([noisy, np.full((len(co), 1), 0.5)], axis=1).astype(np.float32)
    attribute = mesh.color_attributes.new("Col", data_type, domain)
    if domain == "CORNER":
        loops = np.empty(len(mesh.loops), dtype=np.int32)
        mesh.loops.foreach_get("vertex_index", loops)
        rgba = rgba[loops]
    attribute.data.foreach_set("color_srgb", rgba.ravel())
    mesh.color_attributes.active_color = attribute
    mesh.color_attributes.render_color_index = mesh.color_attributes.active_color_index
    clean[np.abs(co[:, 0]) < 0.3] = np.nan
    return obj, clean


def _rms(values, clean):
    """The colours' distance from the clean ones, away from the halves' border."""
    far = ~np.isnan(clean[:, 0])
    return float(np.sqrt(np.mean((values[far, :3] - clean[far]) ** 2)))


def _shown(material):
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    return bsdf.inputs["Base Color"].links[0].from_node


def test_a_scan_is_filtered_into_a_new_colour_attribute_on_its_own_vertices(addon):
    obj, clean = _scan()
    mesh = obj.data
    source = _values(mesh.color_attributes["Col"]).copy()
    counts = {k: len(getattr(bpy.data, k)) for k in ("images", "meshes", "objects")}
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    result = mesh.color_attributes["Col_stylized"]
    assert (result.domain, result.data_type) == ("POINT", "FLOAT_COLOR")
    np.testing.assert_array_equal(_values(mesh.color_attributes["Col"]), source)     # the scan's own colour stays
    assert (mesh.color_attributes.active_color_name, mesh.color_attributes.default_color_name) == ("Col", "Col")
    out = _values(result)
    assert _rms(out, clean) < 0.6 * _rms(source, clean)                               # the noise falls
    np.testing.assert_array_equal(out[:, 3], source[:, 3])                              # alpha as it was
    assert out[clean[:, 0] == 0.8, 0].mean() - out[clean[:, 0] == 0.2, 0].mean() > 0.5     # the halves stay apart
    # no image, no UV map; a material (the object had none) shows the new attribute
    assert {k: len(getattr(bpy.data, k)) for k in ("images", "meshes", "objects")} == counts
    assert [layer.name for layer in mesh.uv_layers] == ["UVMap"]
    node = _shown(obj.material_slots[0].material)
    assert node.type == "VERTEX_COLOR" and node.layer_name == "Col_stylized"
    assert mesh["cp_stylize_attributes"]["Col_stylized"]["source"] == "Col"


def test_the_mesh_filter_serves_fine_vertices_and_the_band_coarse_ones(addon):
    from cp_stylize.blender import stylize

    obj, _ = _scan()
    job = stylize.prepare(obj, addon.to_settings(), addon.output())
    assert job.method == "mesh" and "finite elements" in job.reason and job.estimate.band_points == 0
    addon.spacing = FINE
    job = stylize.prepare(obj, addon.to_settings(), addon.output())
    assert job.method == "band" and "farther apart" in job.reason and job.estimate.band_points > 0
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert "Col_stylized" in obj.data.color_attributes


def test_a_second_run_reads_the_scan_again_and_updates_its_result(addon):
    obj, _ = _scan(material=attribute_material("Painted"))
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    first = _values(obj.data.color_attributes["Col_stylized"]).copy()
    copy = obj.material_slots[0].material
    assert copy.name == "Painted_stylized" and _shown(copy).layer_name == "Col_stylized"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    # the same result (from the scan, not from the first result), in the same attribute and material copy
    np.testing.assert_allclose(_values(obj.data.color_attributes["Col_stylized"]), first, atol=1e-6)
    assert [a.name for a in obj.data.color_attributes] == ["Col", "Col_stylized"]
    assert obj.material_slots[0].material == copy and len(bpy.data.materials) == 2
    assert _shown(bpy.data.materials["Painted"]).layer_name == "Col"                 # the original as it was


def test_a_result_painted_since_its_run_is_kept_and_the_next_goes_beside_it(addon):
    obj, _ = _scan()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    painted = obj.data.color_attributes["Col_stylized"]
    values = _values(painted)
    values[:50, :3] = (1.0, 0.0, 1.0)                                                    # a stroke of magenta
    painted.data.foreach_set("color_srgb", values.ravel())
    values = _values(painted).copy()                                                     # as Blender keeps them
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    np.testing.assert_array_equal(_values(obj.data.color_attributes["Col_stylized"]), values)
    assert _shown(obj.material_slots[0].material).layer_name == "Col_stylized.001"
    assert obj.data["cp_stylize_attributes"]["Col_stylized.001"]["source"] == "Col"


def test_runs_after_a_painted_result_update_their_own_result_in_place(addon):
    obj, _ = _scan()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    painted = obj.data.color_attributes["Col_stylized"]
    values = _values(painted)
    values[:50, :3] = 0.0
    painted.data.foreach_set("color_srgb", values.ravel())
    for _ in range(3):
        assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert [a.name for a in obj.data.color_attributes] == ["Col", "Col_stylized", "Col_stylized.001"]


def test_switching_between_image_and_colour_attribute_reuses_the_nodes_and_reads_the_source(addon):
    obj, _ = _scan(material=attribute_material("Painted"))
    kinds = ["IMAGE", "ATTRIBUTE", "IMAGE", "IMAGE", "ATTRIBUTE", "ATTRIBUTE"]
    for kind in kinds:
        addon.result_kind = kind
        assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    copy = obj.material_slots[0].material
    names = sorted(n.name for n in copy.node_tree.nodes)
    assert names == sorted(["Principled BSDF", "Material Output", "Color Attribute", "cp_stylize",
                            "cp_stylize attribute", "cp_stylize UV"]), names
    assert [a.name for a in obj.data.color_attributes] == ["Col", "Col_stylized"]
    assert len(bpy.data.images) == 1                       # the last image result; the earlier one retired
    first = _values(obj.data.color_attributes["Col_stylized"]).copy()
    addon.result_kind = "IMAGE"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    addon.result_kind = "ATTRIBUTE"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    # read from the scan each time, not from the image or the attribute a run wrote
    np.testing.assert_allclose(_values(obj.data.color_attributes["Col_stylized"]), first, atol=1e-6)


def test_a_result_whose_source_was_renamed_is_refused_and_nothing_changes(addon):
    obj, _ = _scan(material=attribute_material("Painted"))
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    obj.data.color_attributes["Col"].name = "Scan colour"
    _refused("the colour attribute 'Col_stylized' of 'Scan' is an earlier result, and the attribute it was filtered "
             "from, 'Col', is gone (renamed or removed)")


def test_a_long_attribute_name_gives_a_result_name_blender_keeps(addon):
    obj, _ = _scan()
    long = "scan_" + "é" * 27 + "x"                  # 60 bytes of UTF-8
    obj.data.color_attributes["Col"].name = long
    for _ in range(2):
        assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    names = [a.name for a in obj.data.color_attributes]
    assert len(names) == 2 and names[1].endswith("_stylized") and len(names[1].encode()) <= 63, names
    assert obj.data["cp_stylize_attributes"][names[1]]["source"] == long


def test_corner_colours_in_bytes_give_corner_colours_in_bytes(addon):
    obj, clean = _scan(domain="CORNER", data_type="BYTE_COLOR", material=attribute_material("Painted", ""))
    original = snapshot()["materials"]["Painted"]
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    result = obj.data.color_attributes["Col_stylized"]
    assert (result.domain, result.data_type) == ("CORNER", "BYTE_COLOR")
    loops = np.empty(len(obj.data.loops), dtype=np.int32)
    obj.data.loops.foreach_get("vertex_index", loops)
    out = _values(result)
    assert _rms(out, clean[loops]) < 0.6 * _rms(_values(obj.data.color_attributes["Col"]), clean[loops])
    assert snapshot()["materials"]["Painted"] == original


def test_a_turned_object_gets_the_same_colours(addon):
    obj, _ = _scan()
    turned, _ = _scan("Turned")
    turned.rotation_euler = (0.3, math.pi / 5, 1.1)
    for o in (obj, turned):
        bpy.context.view_layer.objects.active = o
        assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    np.testing.assert_allclose(_values(turned.data.color_attributes["Col_stylized"]),
                               _values(obj.data.color_attributes["Col_stylized"]), atol=2e-5)


def _refused(message):
    before = snapshot()
    with pytest.raises(RuntimeError) as info:
        bpy.ops.object.cp_stylize()
    assert message in str(info.value), str(info.value)
    assert_unchanged(before, snapshot())


def test_a_look_that_paints_is_refused_and_nothing_changes(addon):
    _scan()
    addon.strokes = 1.0
    _refused("paints a look (palette, strokes, lines, oil paint, toon, watercolour, hatching or painted light) "
             "whose marks are finer than a vertex apart: choose Result: Image")


def test_a_shared_mesh_is_refused_and_nothing_changes(addon):
    obj, _ = _scan()
    twin = bpy.data.objects.new("Twin", obj.data)
    bpy.context.scene.collection.objects.link(twin)
    _refused(f"the mesh {obj.data.name!r} of 'Scan' is shared with 'Twin', which would get the new colour "
             "attribute too")


def test_an_image_or_no_colour_attribute_is_refused_and_nothing_changes(addon):
    obj = sphere("Ball", image_material("Photo", halves("photo")))
    _refused("material 'Photo' of 'Ball' shows an image, not a colour attribute")
    obj.data.materials.clear()
    _refused("the mesh of 'Ball' has no colour attribute to filter")


def test_a_material_other_objects_show_is_not_changed_to_a_result_they_lack(addon):
    material = attribute_material("Painted")
    _scan(material=material)
    other = sphere("Other", material)
    bpy.context.view_layer.objects.active = bpy.data.objects["Scan"]
    assert other.active_material == material
    addon.target = "APPLY"
    _refused("material 'Painted' is shown by other objects too, whose meshes have no result attribute")


def test_colours_that_are_not_numbers_are_refused_and_nothing_changes(addon):
    obj, _ = _scan()
    values = _values(obj.data.color_attributes["Col"])
    values[7, 0] = np.nan
    obj.data.color_attributes["Col"].data.foreach_set("color_srgb", values.ravel())
    _refused("the colour attribute 'Col' of 'Scan' holds colours that are not finite numbers at 1 vertex: repaint them")


def test_modifiers_that_change_the_faces_are_refused_and_nothing_changes(addon):
    obj, _ = _scan()
    obj.modifiers.new("Subdivision", "SUBSURF")
    _refused("the modifiers of 'Scan' change its vertices or faces")


def test_a_failure_while_wiring_leaves_nothing(addon, monkeypatch):
    from cp_stylize.blender import materials

    _scan(material=attribute_material("Painted"))

    def broken(*args, **kwargs):
        raise RuntimeError("the node tree is locked")
    monkeypatch.setattr(materials, "wire_attribute", broken)
    before = snapshot()
    with pytest.raises(RuntimeError, match="cp_stylize failed unexpectedly"):
        bpy.ops.object.cp_stylize()
    assert_unchanged(before, snapshot())
