"""The Stylize add-on's settings never lose or half-change anything, and a run's size does not depend on how
the object is turned.

One test a case: presets that load back as they were saved, presets with bad
fields refused whole (the panel and the file as they were, a message naming
the file and each field), preset names that share a file, the object's
rotation and the surface's size, the estimate of a run with large images, and
the messages of settings that cannot work.  Each test compares snapshots of
the whole file (``blender_state``) and the exact message the user sees.
"""

import os

import numpy as np
import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from blender_scenes import halves, image_material, sphere  # noqa: E402
from blender_state import assert_unchanged, snapshot  # noqa: E402
from cp_stylize.parameters import FILTERS  # noqa: E402

pytestmark = pytest.mark.blender


@pytest.fixture
def presets(addon, tmp_path, monkeypatch):
    """The add-on with its user preset folder in ``tmp_path / "presets"``; returns that folder."""
    from cp_stylize.blender import operators

    folder = tmp_path / "presets"
    monkeypatch.setattr(operators, "user_preset_dir", lambda create=False: str(folder) if not create or
                        folder.mkdir(exist_ok=True) is None else None)
    return folder


def error(operator, **kwargs):
    """The exact message of a refused operator (scripts get it as RuntimeError)."""
    with pytest.raises(RuntimeError) as info:
        operator(**kwargs)
    text = str(info.value)
    assert text.startswith("Error: ") and text.endswith("\n"), repr(text)
    return text[len("Error: "):-1]


def panel_state(settings):
    """Every property of the panel and its palette, as plain values."""
    return settings._filter_state(), {name: getattr(settings, name) for name in ("image_size", "image_name")}


def preset_state(settings):
    """The properties a preset sets: the current mode's filter, the direction, the noise and the strokes."""
    values, palette = settings._filter_state()
    other_modes = [m for m in FILTERS if m != settings.mode]
    return {k: v for k, v in values.items() if not k.startswith(tuple(f"{m}_" for m in other_modes))}, palette


def set_panel(settings):
    """Panel settings that differ from the defaults in every field a preset holds."""
    settings.mode, settings.time, settings.quality, settings.spacing = "ced", 3.3e-4, "CUSTOM", 0.011
    settings.ced_sigma, settings.ced_rho, settings.ced_alpha, settings.ced_b_rel = 2e-4, 1e-3, 0.01, 1e-5
    settings.direction, settings.axis, settings.direction_attribute = "axis", (1.0, -0.5, 0.25), "comb"
    settings.noise_mapping, settings.noise_fraction, settings.noise_spread, settings.seed = "random", 0.0, 0.3, 42
    settings.strokes, settings.stroke_length, settings.stroke_width, settings.detail = 0.6, 0.2, 0.02, 0.4
    for colour, weight in (((0.1, 0.1, 0.5), 2.0), ((0.3, 0.302, 0.9), 0.5)):
        item = settings.palette.add()
        item.colour, item.weight = colour, weight


# -- 8. a preset loads back as it was saved ---------------------------------------------------------------


def test_a_preset_with_strokes_and_no_noise_loads_back_as_it_was(presets, addon):
    set_panel(addon)
    assert bpy.ops.cp_stylize.preset_add(name="Strokes without noise") == {"FINISHED"}
    saved = preset_state(addon)
    assert (addon.preset_name, addon.preset_key) == ("Strokes without noise", "strokes_without_noise")
    assert os.listdir(presets) == ["strokes_without_noise.toml"]
    bpy.ops.cp_stylize.preset_load(name="denoise_eed")
    assert preset_state(addon) != saved
    before = snapshot()
    assert bpy.ops.cp_stylize.preset_load(name="strokes_without_noise") == {"FINISHED"}
    assert preset_state(addon) == saved          # every field, the palette's colours exact
    assert_unchanged(before, snapshot())


# -- 9. a bad preset is refused whole ---------------------------------------------------------------------

ENTRY = '"#rrggbb", [r, g, b] or ["#rrggbb", weight] (r, g, b in [0, 1], a weight of at least 0)'
BAD_PRESETS = [
    ('name = "Big Seed"\nmode = "eed"\nT = 3e-4\nspacing = 0.012\ndetail = 0.25\n'
     '[noise]\nfraction = 0.1\nseed = 99999999999\npalette = ["#ff0000"]\n',
     "[noise] seed must be a whole number in [0, 2147483647], got 99999999999"),
    ('mode = "ced"\n[noise]\nfraction = 0.5\npalette = [[1, 2]]\n',
     f"[noise] palette entry 1 must be {ENTRY}, got [1, 2]"),
    ('mode = "ced"\nnoise = 5\n',
     "noise must be a table ([noise] with mapping, seed, fraction, spread, fidelity, keep_values, keep_darks, hue_snap, palette), got 5"),
    ('mode = "ced"\nstrokes = [1]\n', "strokes must be a table ([strokes] with strength, length, width, layers, chain, broad, jitter, swirl, stars, relief, sheen), got [1]"),
    ('mode = "ced"\ndirection = "axis"\naxis = 5\n', "axis must be three finite numbers, not all zero, got 5"),
    ('name = 5\nmode = "eed"\n', "name must be text, got 5"),
    ('mode = "eed"\nparams = "x"\n', "params must be a table ([params] with sigma, rho, alpha, b_rel, beta, contrast, "
                                     "ink, lambda_rel), got 'x'"),
    ('mode = "ced"\nT = 1e-4\nspacing = 0.016\n[noise]\nfraction = 0.5\n'
     'palette = [["#ff0000", 0], ["#0000ff", 0]]\n',
     "the palette's weights are all 0, so no colour could be drawn: give at least one colour a weight above 0"),
]


@pytest.mark.parametrize("text, message", BAD_PRESETS)
def test_a_bad_preset_changes_nothing_on_load_and_names_the_file_and_field(presets, addon, text, message):
    presets.mkdir()
    path = presets / "bad.toml"
    path.write_text(text)
    set_panel(addon)
    state, before = panel_state(addon), snapshot()
    assert error(bpy.ops.cp_stylize.preset_load, name="bad") == f"{path}: {message}"
    assert panel_state(addon) == state
    assert_unchanged(before, snapshot())


@pytest.mark.parametrize("text, message", BAD_PRESETS)
def test_a_bad_preset_is_refused_by_stylize_before_the_run(presets, addon, monkeypatch, text, message):
    from cp_stylize.blender import stylize

    presets.mkdir()
    path = presets / "bad.toml"
    path.write_text(text)
    sphere(material=image_material("Painted", halves("source")))
    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before = snapshot()
    assert error(bpy.ops.object.cp_stylize, preset="bad") == f"{path}: {message}"
    assert error(bpy.ops.object.cp_stylize, preset=str(path)) == f"{path}: {message}"
    assert_unchanged(before, snapshot())


def test_loading_is_all_or_nothing_even_if_a_property_refuses_its_value(presets, addon):
    from cp_stylize.presets import load_preset

    class Refused:
        """A preset whose seed the panel cannot take, after it set the mode, time and filter."""

        def __init__(self, settings):
            self._settings = settings

        def __getattr__(self, name):
            if name == "seed":
                raise ValueError("seed refused")
            return getattr(self._settings, name)

    set_panel(addon)
    state = panel_state(addon)
    with pytest.raises(ValueError, match="seed refused"):
        addon.from_settings(Refused(load_preset("starry_night")), key="starry_night")
    assert panel_state(addon) == state and addon.mode == "ced" and addon.preset_key == ""


def test_palette_weights_all_zero_are_refused_before_the_run(addon, monkeypatch):
    from cp_stylize.blender import stylize

    sphere(material=image_material("Painted", halves("source")))
    addon.mode, addon.noise_fraction = "ced", 0.3
    addon.palette.add().weight = 0.0
    monkeypatch.setattr(stylize, "prepare", lambda *a, **k: pytest.fail("the run was prepared"))
    before = snapshot()
    assert error(bpy.ops.object.cp_stylize) == ("the palette's weights are all 0, so no colour could be drawn: give "
                                                "at least one colour a weight above 0")
    assert_unchanged(before, snapshot())


# -- 10. preset names: one file a key, and saving never over another ---------------------------------------


def test_names_that_share_a_file_name_are_saved_apart(presets, addon):
    addon.mode, addon.time = "eed", 3e-4
    assert bpy.ops.cp_stylize.preset_add(name="Wood grain") == {"FINISHED"}
    addon.mode, addon.time = "gaussian", 5e-4
    assert bpy.ops.cp_stylize.preset_add(name="wood/grain") == {"FINISHED"}
    assert sorted(os.listdir(presets)) == ["wood_grain.toml", "wood_grain_2.toml"]
    assert addon.preset_key == "wood_grain_2"
    from cp_stylize.blender import operators
    from cp_stylize.presets import preset_menu

    menu = dict(preset_menu(operators.user_folders()))
    assert (menu["wood_grain"], menu["wood_grain_2"]) == ("Wood grain", "wood/grain")
    assert bpy.ops.cp_stylize.preset_load(name="wood_grain") == {"FINISHED"}
    assert (addon.mode, addon.time, addon.preset_name) == ("eed", pytest.approx(3e-4), "Wood grain")
    assert bpy.ops.cp_stylize.preset_load(name="wood_grain_2") == {"FINISHED"}
    assert (addon.mode, addon.preset_name, addon.preset_key) == ("gaussian", "wood/grain", "wood_grain_2")
    # the panel's remove button removes the preset shown, not the one its name once mapped to
    assert bpy.ops.cp_stylize.preset_remove(name=addon.preset_key) == {"FINISHED"}
    assert os.listdir(presets) == ["wood_grain.toml"]


def test_a_shipped_presets_name_is_refused_and_a_key_means_one_file_everywhere(presets, addon, monkeypatch):
    from cp_stylize.blender import operators, stylize
    from cp_stylize.presets import StylizeSettings, preset_menu, save_preset

    addon.mode = "gaussian"
    assert error(bpy.ops.cp_stylize.preset_add, name="Starry Night") == (
        "'Starry Night' is the name of a shipped preset: choose another name")
    assert not presets.exists() or os.listdir(presets) == []
    # a user file with a shipped key (made by hand, or by an older version) hides nothing
    presets.mkdir(exist_ok=True)
    user = presets / "starry_night.toml"
    save_preset(StylizeSettings(mode="eed", T=5e-4, name="Starry Night"), user)
    assert bpy.ops.cp_stylize.preset_load(name="starry_night") == {"FINISHED"}
    assert addon.mode == "gaussian"                         # the shipped one, as the operator's preset= reads it
    menu = preset_menu(operators.user_folders())
    assert ("starry_night", "Starry Night") in menu and (str(user), "Starry Night (starry_night.toml)") in menu
    assert bpy.ops.cp_stylize.preset_load(name=str(user)) == {"FINISHED"}
    assert (addon.mode, addon.preset_key) == ("eed", str(user))
    assert error(bpy.ops.cp_stylize.preset_remove, name="starry_night") == (
        "'starry_night' is a shipped preset, not a user preset: it cannot be removed")
    sphere(material=image_material("Painted", halves("source")))
    read = []
    real = stylize.prepare
    monkeypatch.setattr(stylize, "prepare", lambda obj, settings, *a, **k: read.append(settings) or
                        real(obj, settings, *a, **k))
    assert bpy.ops.object.cp_stylize(preset="starry_night", quality="PREVIEW") == {"FINISHED"}
    assert (read[0].mode, read[0].name, read[0].strokes) == ("gaussian", "Starry Night", 1.0)


def test_a_preset_name_of_300_characters_is_refused_with_a_message(presets, addon):
    before = snapshot()
    assert error(bpy.ops.cp_stylize.preset_add, name="x" * 300) == (
        "a preset's name may be 64 characters long, and this one has 300: choose a shorter name")
    assert not presets.exists() or os.listdir(presets) == []
    assert_unchanged(before, snapshot())


# -- 11. the object's rotation, and the size of its surface ------------------------------------------------


def stylized_pixels(obj):
    image = obj.material_slots[0].material.node_tree.nodes["cp_stylize"].image
    w, h = image.size
    buf = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf.reshape(h, w, 4)[..., :3]


def striped_box(name="Box"):
    """A cube 2 units a side wearing red and blue halves through its own UV map."""
    bpy.ops.mesh.primitive_cube_add(size=2.0)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(image_material(f"{name} Paint", halves(f"{name} source")))
    return obj


def run_report(capfd, **kwargs):
    capfd.readouterr()
    assert bpy.ops.object.cp_stylize(**kwargs) == {"FINISHED"}
    return capfd.readouterr().out


def band_of(report):
    """'N band points, grid spacing h' of a run's report."""
    line = next(line for line in report.splitlines() if line.startswith("Info: stylized"))
    return line[line.rindex("(") + 1:line.rindex(")")].split(", the last")[0]


@pytest.mark.parametrize("direction", ["texture", "axis"])
def test_turning_the_object_or_its_parent_changes_nothing(addon, capfd, direction):
    import math

    addon.mode, addon.time, addon.direction, addon.axis = "ced", 2e-4, direction, (1.0, 0.0, 0.0)
    addon.keep = False
    obj = striped_box()
    obj.scale = (1.0, 0.5, 1.5)
    first = run_report(capfd)
    plain = stylized_pixels(obj).copy()
    # the same object turned onto a corner, under a turned and mirrored parent
    obj.rotation_euler = (math.radians(45), math.radians(35.264), math.radians(10))
    bpy.ops.object.empty_add()
    parent = bpy.context.active_object
    parent.rotation_euler, parent.scale = (0.3, -1.1, 2.0), (-1.0, 1.0, 1.0)
    obj.parent = parent
    bpy.context.view_layer.objects.active = obj
    bpy.context.view_layer.update()
    before = snapshot()
    second = run_report(capfd)
    assert band_of(second) == band_of(first)                     # the same band points and grid spacing
    np.testing.assert_array_equal(stylized_pixels(obj), plain)   # the core saw the same vertices
    after = snapshot()
    assert after["materials"]["Box Paint"] == before["materials"]["Box Paint"]


def test_the_size_is_the_surfaces_diameter_whatever_way_the_mesh_is_turned(addon):
    from cp_stylize.blender.operators import estimate

    obj = striped_box()
    h, n, _, _ = estimate(obj, addon.to_settings())
    assert h == pytest.approx(0.016 * np.sqrt(12) / 2)            # the cube's diameter, its space diagonal
    obj.data.transform(_turn(0.7, 0.4))                          # the mesh itself turned, not the object
    obj.data.update()
    h_turned, n_turned, _, _ = estimate(obj, addon.to_settings())
    assert h_turned == pytest.approx(h, rel=1e-5) and abs(n_turned - n) < 0.03 * n


def _turn(a, b):
    import mathutils

    return mathutils.Matrix.Rotation(a, 4, "X") @ mathutils.Matrix.Rotation(b, 4, "Z")


# -- 12. only what the surface has counts ----------------------------------------------------------------


def test_a_face_without_area_far_away_changes_nothing(addon, capfd):
    import bmesh

    from cp_stylize.blender.operators import estimate

    obj = sphere(material=image_material("Painted", halves("source")))
    h, n, _, _ = estimate(obj, addon.to_settings())
    first = run_report(capfd)
    plain = stylized_pixels(obj).copy()
    mesh = bmesh.new()
    mesh.from_mesh(obj.data)
    corners = [mesh.verts.new((100.0 + k, 0.0, 0.0)) for k in range(3)]   # on a line: no area, no surface
    mesh.faces.new(corners)
    mesh.to_mesh(obj.data)
    mesh.free()
    assert estimate(obj, addon.to_settings())[:2] == (h, n)
    second = run_report(capfd)
    assert band_of(second) == band_of(first)
    image = stylized_pixels(obj)
    assert image.std() > 0.3 and image.std() == pytest.approx(plain.std(), abs=0.02)


# -- messages ----------------------------------------------------------------------------------------------


def test_an_axis_the_objects_scale_flattens_is_refused_by_name(addon):
    addon.mode, addon.direction, addon.axis = "ced", "axis", (0.0, 0.0, 1.0)
    obj = sphere(material=image_material("Painted", halves("source")))
    obj.scale = (1.0, 1.0, 0.0)
    before = snapshot()
    assert error(bpy.ops.object.cp_stylize) == (
        "'Ball' is flattened along the stroke direction's axis (0, 0, 1): its scale is 0 there, so the axis has no "
        "direction on its surface; choose another axis, or give the object a scale along it")
    assert_unchanged(before, snapshot())


@pytest.mark.parametrize("flattened", [False, True])
def test_a_mesh_of_faces_without_area_is_refused_by_name(addon, flattened):
    mesh = bpy.data.meshes.new("Lines")
    if flattened:   # a square standing in the xz-plane, which a scale of 0 along z makes a line
        mesh.from_pydata([(0, 0, 0), (1, 0, 0), (1, 0, 1), (0, 0, 1)], [], [(0, 1, 2, 3)])
    else:
        mesh.from_pydata([(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)], [], [(0, 1, 2), (1, 2, 3)])
    obj = bpy.data.objects.new("Strokes", mesh)
    bpy.context.collection.objects.link(obj)
    if flattened:
        obj.scale = (1.0, 1.0, 0.0)
    bpy.context.view_layer.objects.active = obj
    before = snapshot()
    why = ", as the object's scale flattens it" if flattened else ""
    assert error(bpy.ops.object.cp_stylize) == (
        "the mesh of 'Strokes' has no surface to stylize: the corners of every face lie on a line or at one "
        f"point{why}")
    assert_unchanged(before, snapshot())


# -- 13. the estimate counts the input images, and follows the computer -----------------------------------


def test_a_large_input_image_counts_in_the_estimate_and_the_limit_stops_the_run_before_it_is_read(addon,
                                                                                                   monkeypatch):
    from cp_stylize.blender import images, operators, stylize
    from cp_stylize.estimate import BYTES_PER_IMAGE_PIXEL

    obj = sphere(material=image_material("Painted", halves("source", size=2048)))
    settings = addon.to_settings()
    h, n, with_image, seconds = operators.estimate(obj, settings)
    obj.material_slots[0].material = bpy.data.materials.new("Flat")
    _, _, plain, plain_seconds = operators.estimate(obj, settings)
    assert with_image - plain == BYTES_PER_IMAGE_PIXEL * 2048**2 and seconds > plain_seconds
    obj.material_slots[0].material = bpy.data.materials["Painted"]
    addon.memory_limit = (plain + with_image) / 2 / 2**30       # room for the run, not for the image
    monkeypatch.setattr(images, "display_colours", lambda *a: pytest.fail("the image was read"))
    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before = snapshot()
    assert error(bpy.ops.object.cp_stylize) == (
        f"this run needs about {with_image / 2**30:.1f} GiB (about {n:,} band points), above the memory limit of "
        f"{addon.memory_limit:.1f} GiB: lower the quality or the image size, or raise Max RAM (under Output)")
    assert_unchanged(before, snapshot())


def test_an_8192_image_is_offered_and_counted_and_the_memory_limit_refuses_it_before_the_run(addon, monkeypatch):
    from cp_stylize.blender import operators, stylize

    sizes = [item.identifier for item in addon.bl_rna.properties["image_size"].enum_items]
    assert sizes[-1] == "8192"
    obj = sphere(material=image_material("Painted", halves("source")))
    _, n, small, _ = operators.estimate(obj, addon.to_settings())
    addon.image_size = "8192"
    _, _, large, _ = operators.estimate(obj, addon.to_settings())
    assert large - small > 48 * (8192**2 - 512**2)        # its texels count (a plain filter: 128 bytes each)
    addon.memory_limit = (small + large) / 2 / 2**30      # room for the run at 512, not at 8192
    monkeypatch.setattr(stylize, "run_core", lambda *a, **k: pytest.fail("the core ran"))
    before = snapshot()
    assert error(bpy.ops.object.cp_stylize) == (
        f"this run needs about {large / 2**30:.1f} GiB (about {n:,} band points), above the memory limit of "
        f"{addon.memory_limit:.1f} GiB: lower the quality or the image size, or raise Max RAM (under Output)")
    assert_unchanged(before, snapshot())


def test_the_time_estimate_follows_the_computers_speed(addon, monkeypatch):
    from cp_stylize import calibration
    from cp_stylize.blender import operators

    obj = sphere(material=image_material("Painted", halves("source")))
    assert addon.output().speed == calibration.machine_speed()    # measured once, kept for the session
    monkeypatch.setattr(operators, "machine_speed", lambda: 1.0)
    _, _, nbytes, seconds = operators.estimate(obj, addon.to_settings())
    monkeypatch.setattr(operators, "machine_speed", lambda: 3.0)   # a computer three times slower
    assert operators.estimate(obj, addon.to_settings())[2:] == (nbytes, pytest.approx(3 * seconds))
    assert addon.output().speed == 3.0
