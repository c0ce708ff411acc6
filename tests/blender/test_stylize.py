"""The Stylize operator in Blender: inputs, outputs, errors, cancel and undo."""

import numpy as np
import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_scenes import image_material, node_material, procedural_material, sphere  # noqa: E402
from cp_stylize.oklab import hue_difference, to_oklab  # noqa: E402

pytestmark = pytest.mark.blender


def _pixels(image):
    w, h = image.size
    buf = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf.reshape(h, w, 4)


def _gradient_image(name="source", size=256):
    v, u = np.meshgrid(np.linspace(0, 1, size), np.linspace(0, 1, size), indexing="ij")
    rgb = np.stack([0.2 + 0.6 * u, 0.3 + 0.4 * np.sin(6 * v) ** 2, 0.8 - 0.5 * u * v], axis=-1)
    image = bpy.data.images.new(name, size, size)
    rgba = np.concatenate([rgb, np.ones((size, size, 1))], axis=-1).astype(np.float32)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


def _warm_blobs(size=256):
    """Warm colours in soft, unoriented blobs: no blue, little coherence."""
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(5)
    t = gaussian_filter(rng.normal(size=(size, size)), 6, mode="wrap")
    t = (t - t.min()) / (t.max() - t.min())
    rgb = np.stack([0.6 + 0.4 * t, 0.2 + 0.5 * t, 0.1 + 0.1 * t], axis=-1)
    image = bpy.data.images.new("warm", size, size)
    image.pixels.foreach_set(np.concatenate([rgb, np.ones((size, size, 1))], axis=-1).astype(np.float32).ravel())
    image.pack()
    return image


def _textured_sphere(image=None, name="Ball"):
    image = image or _gradient_image()
    material = image_material("Painted", image)
    obj = sphere(name, material, segments=48, rings=24)
    return obj, material, image


def _base_color_image(material):
    bsdf = next(n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
    link = bsdf.inputs["Base Color"].links[0]
    return link.from_node.image


def _counts():
    return {k: len(getattr(bpy.data, k)) for k in ("images", "materials", "meshes", "objects", "node_groups")}


def _blurred(img, sigma):
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(img, (sigma, sigma, 0), mode="wrap")


def test_starry_night_on_an_image_textured_sphere(addon):
    from cp_stylize.presets import load_preset

    obj, material, source = _textured_sphere(_warm_blobs())
    before_pixels = _pixels(source).copy()
    before_nodes = len(material.node_tree.nodes)
    assert bpy.ops.object.cp_stylize(preset="starry_night", quality="PREVIEW") == {"FINISHED"}

    image = bpy.data.images["Ball_stylized"]
    copy = obj.material_slots[0].material
    assert copy is not material and copy.name == "Painted_stylized"
    assert _base_color_image(copy) is image and image.packed_file is not None
    out = _pixels(image)
    assert out.shape == (512, 512, 4)
    # the original image and material are untouched
    np.testing.assert_array_equal(_pixels(source), before_pixels)
    assert len(material.node_tree.nodes) == before_nodes and _base_color_image(material) is source
    # the palette's hues (its star yellows and ochres: the picture is warm), where the input's hues were others
    palette = to_oklab(np.array(load_preset("starry_night").palette))
    off = lambda img: np.min(hue_difference(to_oklab(img[..., None, :3]), palette[None, None]), axis=-1)
    covered = out[..., :3].max(axis=2) > 0.0
    assert np.median(off(out)[covered]) < 15 and np.median(off(before_pixels)) > 20
    # the strokes: coherent marks that the same run without them does not make, and their relief under the shader
    relief = bpy.data.images["Ball_stylized_relief"]
    bump = copy.node_tree.nodes["cp_stylize bump"]
    assert relief.colorspace_settings.name == "Non-Color" and relief.packed_file is not None
    assert next(n for n in copy.node_tree.nodes if n.type == "BSDF_PRINCIPLED").inputs["Normal"].links[0].from_node == bump
    assert _pixels(relief)[covered, 0].max() > 0.3
    # both images clamp at their borders: an atlas texel at the top edge is not blended with the bottom row's,
    # which would draw a line of the far side's colour and a slope of its height along an open border
    assert copy.node_tree.nodes["cp_stylize"].extension == "EXTEND"
    assert copy.node_tree.nodes["cp_stylize relief"].extension == "EXTEND"
    bpy.ops.cp_stylize.preset_load(name="starry_night")
    addon.quality, addon.strokes = "PREVIEW", 0.0
    obj.material_slots[0].material = material
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    plain = _pixels(_base_color_image(obj.material_slots[0].material))
    marks = lambda img: float(np.std(img[..., :3] - _blurred(img[..., :3], 4.0)))    # detail at the strokes' scale
    print(f"\nmarks: without strokes {marks(plain):.4f}, Starry Night {marks(out):.4f}")
    assert marks(out) > 2 * marks(plain)


def test_a_procedural_material_is_baked_then_stylized(addon):
    obj = sphere("Checkers")
    material = procedural_material()
    obj.data.materials.append(material)
    images_before = set(bpy.data.images.keys())
    nodes_before = len(material.node_tree.nodes)
    addon.mode, addon.time = "gaussian", 1e-4
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert set(bpy.data.images.keys()) - images_before == {"Checkers_stylized"}  # the bake image is gone
    out = _pixels(bpy.data.images["Checkers_stylized"])[..., :3]
    # the checker's two colours, smoothed: both dark and light regions survive, with blurred edges between
    grey = out.mean(axis=2)
    covered = grey > 0.01
    assert grey[covered].max() - grey[covered].min() > 0.3
    assert len(material.node_tree.nodes) == nodes_before  # no bake node left behind


def test_an_object_without_uvs_gets_an_atlas(addon):
    obj = sphere("Bare")
    while obj.data.uv_layers:
        obj.data.uv_layers.remove(obj.data.uv_layers[0])
    attr = obj.data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    z = np.array([v.co.z for v in obj.data.vertices])
    colours = np.stack([0.5 + 0.5 * z, 0.2 + 0 * z, 0.5 - 0.5 * z, 1 + 0 * z], axis=1).astype(np.float32)
    attr.data.foreach_set("color", colours.ravel())
    obj.data.color_attributes.active_color = attr
    addon.mode, addon.time = "gaussian", 1e-4
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert "cp_stylize_atlas" in obj.data.uv_layers
    material = obj.material_slots[0].material
    tex = next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE")
    uv_node = tex.inputs["Vector"].links[0].from_node
    assert uv_node.type == "UVMAP" and uv_node.uv_map == "cp_stylize_atlas"
    out = _pixels(tex.image)[..., :3]
    assert out[..., 0].max() > 0.7 and out[..., 2].max() > 0.7  # both ends of the gradient are there


def test_an_object_with_two_materials(addon):
    obj, painted, source = _textured_sphere(name="Duo")
    plain = node_material("Plain")
    next(n for n in plain.node_tree.nodes if n.type == "BSDF_PRINCIPLED").inputs["Base Color"].default_value = (
        0.0, 0.8, 0.0, 1.0)
    obj.data.materials.append(plain)
    centres = np.array([p.center.z for p in obj.data.polygons])
    obj.data.polygons.foreach_set("material_index", (centres < 0).astype(np.int32))
    addon.mode, addon.time = "gaussian", 1e-5
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    image = bpy.data.images["Duo_stylized"]
    copies = [slot.material for slot in obj.material_slots]
    assert [m.name for m in copies] == ["Painted_stylized", "Plain_stylized"]
    assert all(m.node_tree.nodes["cp_stylize"].image is image for m in copies)
    out = _pixels(image)[..., :3]
    h = out.shape[0]
    # the UV sphere's lower half (v < 1/2) is the plain green material, the upper half the painted one
    lower, upper = out[h // 16:h // 2 - h // 16], out[h // 2 + h // 16:-h // 16]
    assert lower[..., 1].min() > 0.6 and lower[..., 0].max() < 0.2
    assert np.abs(upper - lower.mean(axis=(0, 1))).max() > 0.3


def _error_case(name, addon):
    """Set up the scene for an error case; returns the operator call."""
    if name == "no active object":
        bpy.ops.object.empty_add()
        bpy.context.view_layer.objects.active = None
    elif name == "non-mesh":
        bpy.ops.object.camera_add()
    elif name == "no faces":
        mesh = bpy.data.meshes.new("Edges")
        mesh.from_pydata([(0, 0, 0), (1, 0, 0)], [(0, 1)], [])
        obj = bpy.data.objects.new("Edges", mesh)
        bpy.context.collection.objects.link(obj)
        bpy.context.view_layer.objects.active = obj
    elif name == "missing image file":
        image = bpy.data.images.new("Lost", 8, 8)
        image.source = "FILE"
        image.filepath = "/nonexistent/lost.png"
        _textured_sphere(image)
    elif name == "tiled image":
        image = bpy.data.images.new("Tiles", 8, 8, tiled=True)
        _textured_sphere(image)
    elif name == "save without a file":
        _textured_sphere()
        addon.storage, addon.mode, addon.time = "SAVE", "gaussian", 1e-5
    elif name == "memory limit":
        _textured_sphere()
        addon.memory_limit = 0.1
        addon.quality = "HIGH"


@pytest.mark.parametrize("case, message", [
    ("no active object", "no active object"),
    ("non-mesh", "not a mesh"),
    ("no faces", "has no faces"),
    ("missing image file", "is missing"),
    ("tiled image", "tiled"),
    ("memory limit", "above the memory limit"),
    ("save without a file", "save the .blend file first"),
])
def test_errors_are_reported_and_change_nothing(addon, case, message):
    _error_case(case, addon)
    counts = _counts()
    pixels = {im.name: _pixels(im).copy() for im in bpy.data.images if im.has_data}
    with pytest.raises(RuntimeError, match=message):
        bpy.ops.object.cp_stylize()
    assert _counts() == counts
    for name, before in pixels.items():
        np.testing.assert_array_equal(_pixels(bpy.data.images[name]), before)


def test_a_core_error_is_reported(addon, tmp_path):
    _textured_sphere()
    bad = tmp_path / "bad.toml"
    bad.write_text('mode = "ced"\nT = -1.0\n')
    counts = _counts()
    with pytest.raises(RuntimeError, match=r"T must lie in \[1e-06, 0.1\], got -1.0"):
        bpy.ops.object.cp_stylize(preset=str(bad))
    assert _counts() == counts


def test_cancel_mid_run_leaves_no_new_datablocks(addon):
    from cp_stylize.blender import stylize

    obj, material, _ = _textured_sphere()
    counts = _counts()
    job = stylize.prepare(obj, addon.to_settings().replace(mode="eed", T=5e-4))

    class Cancel(Exception):
        pass

    def cancel(fraction):
        if fraction > 0.3:
            raise Cancel

    with pytest.raises(Cancel):
        stylize.run_core(job, progress=cancel)
    assert _counts() == counts and obj.material_slots[0].material is material


def test_the_original_material_survives_saving_without_a_fake_user(addon, tmp_path):
    # the copy points to its original, which keeps it in the file; undo itself is tested in a real window
    obj, material, _ = _textured_sphere()
    addon.mode, addon.time = "gaussian", 1e-4
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert obj.material_slots[0].material.name == "Painted_stylized" and not material.use_fake_user
    path = str(tmp_path / "saved.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    copy = bpy.data.objects["Ball"].material_slots[0].material
    assert copy.name == "Painted_stylized" and copy["cp_stylize_original"] == bpy.data.materials["Painted"]
    assert _base_color_image(bpy.data.materials["Painted"]).name == "source"


def test_the_image_can_be_saved_next_to_the_blend_file(addon, tmp_path):
    obj, _, _ = _textured_sphere()
    bpy.ops.wm.save_as_mainfile(filepath=str(tmp_path / "scene.blend"))
    addon.storage, addon.mode, addon.time, addon.image_name = "SAVE", "gaussian", 1e-5, "Ball Look"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    image = bpy.data.images["Ball Look"]
    assert image.packed_file is None and (tmp_path / "Ball_Look.png").stat().st_size > 1000


def test_a_background_run_reports_progress_and_finishes(addon):
    from cp_stylize.blender import stylize

    obj, material, _ = _textured_sphere()
    job = stylize.prepare(obj, addon.to_settings().replace(mode="gaussian", T=1e-5))
    run = stylize.BackgroundRun(job)
    assert not run.done
    run.start()
    assert run.wait(timeout=600) and run.error is None and not run.cancelled
    assert run.fraction == 1.0 and job.result.image.shape == (512, 512, 3)
    assert obj.material_slots[0].material is material  # nothing applied until the main thread does it


def test_cancelling_a_background_run_stops_it_and_changes_nothing(addon):
    from cp_stylize.blender import stylize

    obj, material, _ = _textured_sphere()
    counts = _counts()
    run = stylize.BackgroundRun(stylize.prepare(obj, addon.to_settings().replace(mode="ced", T=1e-3)))
    run.cancel()  # Esc before the first progress report: the worker stops at it
    run.start()
    assert run.wait(timeout=600) and run.cancelled and run.job.result is None
    assert _counts() == counts and obj.material_slots[0].material is material


def _suzanne(material):
    bpy.ops.mesh.primitive_monkey_add()
    obj = bpy.context.active_object
    obj.name = "Suzanne"
    bpy.ops.object.shade_smooth()
    bpy.ops.object.modifier_add(type="SUBSURF")
    obj.modifiers[-1].levels = 1
    obj.rotation_euler = (0.4, 0.0, 0.7)
    obj.data.materials.append(material)
    bpy.context.view_layer.update()
    return obj


def _vector_attribute(obj, name, vector, domain="POINT"):
    attr = obj.data.attributes.new(name, "FLOAT_VECTOR", domain)
    attr.data.foreach_set("vector", np.tile(np.asarray(vector, np.float32), len(attr.data)))
    return attr


def test_the_stroke_direction_is_read_from_a_mesh_attribute(addon):
    from cp_stylize.blender import meshdata, stylize

    obj = _suzanne(image_material("Painted", _warm_blobs()))
    addon.quality, addon.spacing = "CUSTOM", 0.03
    addon.noise_fraction, addon.time = 0.6, 2e-3                      # strokes to draw
    for colour in ((0.05, 0.05, 0.2), (0.95, 0.9, 0.3)):
        addon.palette.add().colour = colour
    _vector_attribute(obj, "comb", (0.0, 0.0, 2.0))                  # any length: a direction
    _vector_attribute(obj, "across", (1.0, 0.0, 0.0), domain="FACE")
    addon.mode, addon.direction = "ced", "attribute"
    addon.direction_attribute = "nothing"
    with pytest.raises(Exception, match=r"has no attribute named 'nothing' for the stroke direction: choose one "
                                        r"of its 3-D vector attributes \('comb', 'across'\)"):
        stylize.prepare(obj, addon.to_settings())
    addon.direction_attribute = "comb"
    job = stylize.prepare(obj, addon.to_settings())
    # read at every triangle corner, stretched as the mesh is in the core: the world matrix without its rotation
    world = meshdata.shape_frame(obj.matrix_world) @ np.array([0.0, 0.0, 2.0])
    assert job.mesh.directions.shape == (len(job.mesh.triangles), 3, 3)
    np.testing.assert_allclose(job.mesh.directions.reshape(-1, 3), np.tile(world, (3 * len(job.mesh.triangles), 1)),
                               atol=1e-6)
    # the attribute is the one used: a constant one gives the axis' strokes, another attribute other strokes
    results = {}
    for key, direction, attribute, axis in (("comb", "attribute", "comb", (0, 0, 1)),
                                            ("axis", "axis", "", (0, 0, 1)),
                                            ("across", "attribute", "across", (0, 0, 1))):
        addon.direction, addon.direction_attribute, addon.axis = direction, attribute, axis
        job = stylize.prepare(obj, addon.to_settings())
        results[key] = stylize.run_core(job).image
    covered = np.any(results["comb"] > 0, axis=-1)
    same, other = (np.abs(results["comb"] - results[k])[covered].mean() for k in ("axis", "across"))
    print(f"\nmean change over the covered texels: axis {same:.2e}, other attribute {other:.3f}")
    assert same < 1e-4 and other > 0.02


def test_a_re_run_reuses_the_band_and_gives_a_fresh_runs_image(addon, capfd):
    from cp_stylize.blender import stylize

    obj, material, source = _textured_sphere()
    addon.mode, addon.time = "eed", 2e-4
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert stylize.kept_bytes() > 10 * 2**20
    addon.time = 4e-4                                          # a new filter parameter, the same mesh and grid
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert {"mesh", "band", "texels", "sampled"} <= set(stylize.run_cache().reused)
    again = _pixels(bpy.data.images["Ball_stylized"]).copy()
    bpy.ops.cp_stylize.release()
    assert stylize.kept_bytes() == 0 and len(stylize.run_cache()) == 0
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert stylize.run_cache().reused == []
    np.testing.assert_array_equal(_pixels(bpy.data.images["Ball_stylized"]), again)
    # an edited mesh is read afresh
    obj.data.vertices[0].co.z += 0.2
    obj.data.update()
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert "band" not in stylize.run_cache().reused and "mesh" not in stylize.run_cache().reused
    # loading a file frees what was kept
    assert stylize.kept_bytes() > 0
    bpy.ops.wm.read_homefile(use_empty=True)
    assert stylize.kept_bytes() == 0


def test_without_keep_a_run_keeps_nothing_and_frees_what_was_kept(addon):
    from cp_stylize.blender import stylize

    _textured_sphere()
    addon.mode, addon.time = "gaussian", 1e-4
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert stylize.kept_bytes() > 0
    addon.keep = False
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    assert stylize.kept_bytes() == 0 and len(stylize.run_cache()) == 0
    assert bpy.ops.cp_stylize.release.poll() is False          # nothing to free
