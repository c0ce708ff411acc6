"""The sidebar panels draw without errors and name only real properties and operators."""

import types

import numpy as np

import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from cp_stylize.parameters import AXIS_DIRECTIONS, DIRECTED_MODES, DIRECTIONS, FILTERS, MODES  # noqa: E402

pytestmark = pytest.mark.blender


class FakeLayout:
    """Records what a panel draws and checks every property and operator it names."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = self.use_property_decorate = False

    def _child(self, *args, **kwargs):
        return FakeLayout(self.log)

    row = column = box = grid_flow = _child

    def template_icon(self, icon_value=0, **kwargs):
        assert icon_value > 0
        self.log.append(("icon", icon_value))

    def prop(self, data, name, **kwargs):
        assert name in data.bl_rna.properties, f"no property {name!r} on {data!r}"
        self.log.append(("prop", name))

    def prop_search(self, data, name, search_data, search_name, **kwargs):
        assert name in data.bl_rna.properties, f"no property {name!r} on {data!r}"
        assert search_name in search_data.bl_rna.properties, f"no collection {search_name!r} on {search_data!r}"
        self.log.append(("prop", name))

    def operator(self, idname, **kwargs):
        module, name = idname.split(".")
        assert hasattr(getattr(bpy.ops, module), name) and getattr(getattr(bpy.ops, module), name).poll is not None
        getattr(getattr(bpy.ops, module), name).get_rna_type()  # raises if not registered
        self.log.append(("operator", idname))
        return types.SimpleNamespace()

    def popover(self, panel, **kwargs):
        assert hasattr(bpy.types, panel), panel
        self.log.append(("popover", panel))

    def label(self, text="", **kwargs):
        self.log.append(("label", text))

    def separator(self, **kwargs):
        pass


@pytest.mark.parametrize("mode", list(FILTERS))
def test_every_panel_draws_for_every_mode(registered, mode):
    from cp_stylize.blender import panel

    bpy.ops.mesh.primitive_uv_sphere_add()
    registered.mode = mode
    registered.palette.add()
    context = bpy.context
    log = []
    for cls in (panel.VIEW3D_PT_cp_stylize, panel.VIEW3D_PT_cp_stylize_paint, panel.VIEW3D_PT_cp_stylize_oil,
                panel.VIEW3D_PT_cp_stylize_toon, panel.VIEW3D_PT_cp_stylize_watercolour,
                panel.VIEW3D_PT_cp_stylize_palette, panel.VIEW3D_PT_cp_stylize_output,
                panel.VIEW3D_PT_cp_stylize_advanced, panel.VIEW3D_PT_cp_stylize_presets):
        cls.draw(types.SimpleNamespace(layout=FakeLayout(log)), context)
    # the mode's own parameters, and the size views of lengths and times by the name of what they show
    props = {name.removeprefix(mode + "_").removesuffix("_size") for kind, name in log if kind == "prop"}
    assert {"mode", "quality", "time", "strokes", "stroke_width", "stroke_layers", "stroke_jitter", "swirl", "relief",
            "contours", "noise_mapping", "wash_levels", "wash_edges", "wash_granulation", "wash_bleed",
            "wash_wobble"} <= props
    assert ("rho" in props) == (mode in ("eed", "ced")) and ("alpha" in props) == (mode in ("ced", "flow"))
    assert {p.name for p in FILTERS[mode].parameters} <= props
    assert ("operator", "object.cp_stylize") in log
    # the estimate box shows the spacing, the band size and a time
    labels = [text for kind, text in log if kind == "label"]
    assert any("band points" in t for t in labels) and any(t.startswith("Roughly") for t in labels)
    # the preset menu lists the shipped presets
    assert sum(1 for kind, name in log if kind == "operator" and name == "cp_stylize.preset_load") >= 6


@pytest.mark.parametrize("direction", list(DIRECTIONS))
def test_the_stroke_direction_shows_what_it_needs(registered, direction):
    from cp_stylize.blender import panel

    bpy.ops.mesh.primitive_uv_sphere_add()
    for mode in FILTERS:
        registered.mode = mode
        registered.direction = direction
        log = []
        panel.VIEW3D_PT_cp_stylize.draw(types.SimpleNamespace(layout=FakeLayout(log)), bpy.context)
        props = {name for kind, name in log if kind == "prop"}
        assert ("direction" in props) == (mode in DIRECTED_MODES)
        assert ("axis" in props) == (mode in DIRECTED_MODES and direction in AXIS_DIRECTIONS)
        assert ("direction_attribute" in props) == (mode in DIRECTED_MODES and direction == "attribute")
        settings = registered.to_settings() if (mode, direction) != ("flow", "texture") else None
        if settings is not None:
            assert settings.stroke_direction == (direction if mode in DIRECTED_MODES else "texture")


def test_choosing_flow_leaves_the_textures_direction_for_the_minimum_curvature(registered):
    registered.mode, registered.direction = "ced", "texture"
    registered.mode = "flow"
    assert registered.direction == "min" and registered.to_settings().stroke_direction == "min"
    registered.mode, registered.direction = "ced", "axis"
    registered.mode = "flow"
    assert registered.direction == "axis"        # a field chosen stays
    registered.direction = "texture"             # chosen by hand anyway: the run says why not
    with pytest.raises(ValueError, match="mode 'flow' draws along a direction field"):
        registered.to_settings()
    # an axis is checked only where it is used: zeroed, it stops an axis run, not an attribute run
    registered.direction, registered.axis, registered.direction_attribute = "axis", (0, 0, 0), "comb"
    with pytest.raises(ValueError, match="axis must be three finite numbers, not all zero"):
        registered.to_settings()
    registered.direction = "attribute"
    assert registered.to_settings().attribute == "comb"


def test_presets_load_save_and_remove_through_the_operators(registered, tmp_path, monkeypatch):
    from cp_stylize.blender import operators

    monkeypatch.setattr(operators, "user_preset_dir", lambda create=False: str(tmp_path))
    assert bpy.ops.cp_stylize.preset_load(name="starry_night") == {"FINISHED"}
    from cp_stylize.presets import load_preset

    assert registered.mode == "gaussian" and len(registered.palette) == len(load_preset("starry_night").palette) == 12
    assert (registered.noise_mapping, round(registered.detail, 6)) == ("tone", load_preset("starry_night").detail)
    assert (registered.strokes, registered.stroke_length, registered.stroke_layers) == (1.0, pytest.approx(0.12), 3)
    assert (registered.swirl, registered.relief, registered.contours) == pytest.approx((0.6, 0.6, 0.6))
    assert registered.quality == "STANDARD"  # the preset's spacing, 0.008
    registered.time = 3e-4
    assert bpy.ops.cp_stylize.preset_add(name="My Look") == {"FINISHED"}
    assert (tmp_path / "my_look.toml").exists() and "my_look" in operators.all_presets()
    assert bpy.ops.cp_stylize.preset_load(name="denoise_eed") == {"FINISHED"}
    assert bpy.ops.cp_stylize.preset_load(name="my_look") == {"FINISHED"}
    assert registered.time == pytest.approx(3e-4) and registered.mode == "gaussian"
    assert (registered.noise_mapping, round(registered.detail, 6)) == ("tone", load_preset("starry_night").detail)     # saved and loaded back
    assert registered.to_settings().stroke_width == pytest.approx(0.03)
    assert (registered.to_settings().swirl, registered.to_settings().stroke_layers) == (pytest.approx(0.6), 3)
    with pytest.raises(RuntimeError, match="not a user preset"):
        bpy.ops.cp_stylize.preset_remove(name="starry_night")
    assert bpy.ops.cp_stylize.preset_remove(name="my_look") == {"FINISHED"}
    assert not (tmp_path / "my_look.toml").exists()


def test_the_ink_hatching_preset_keeps_its_direction_and_lines_through_the_panel(registered):
    """Hatching takes a direction in any mode: the panel's settings give the preset's lines around the form."""
    from cp_stylize.presets import load_preset

    assert bpy.ops.cp_stylize.preset_load(name="hatching") == {"FINISHED"}
    shipped, settings = load_preset("hatching"), registered.to_settings()
    assert (settings.mode, settings.stroke_direction) == (shipped.mode, "max") == ("eed", "max")
    assert (settings.hatch_layers, settings.hatch_angle) == (shipped.hatch_layers, shipped.hatch_angle)
    assert (settings.hatch_spacing, settings.hatch_ink, settings.line_width) == pytest.approx(
        (shipped.hatch_spacing, shipped.hatch_ink, shipped.line_width))
    registered.hatch_spacing = 0.0            # without hatching (and strokes), EED takes no direction
    assert registered.to_settings().stroke_direction == "texture"


def test_lengths_in_the_estimate_read_in_the_scenes_units():
    from cp_stylize.blender.panel import length_text

    units = bpy.context.scene.unit_settings
    kept = (units.system, units.scale_length)
    try:
        units.system, units.scale_length = "METRIC", 1.0
        assert length_text(0.00894) == "8.94 mm"
        units.system = "IMPERIAL"
        assert length_text(0.00894) == "352 thou"
        units.system = "NONE"
        assert length_text(0.00894) == "0.00894"
    finally:
        units.system, units.scale_length = kept


def _png_size(path):
    with open(path, "rb") as fh:
        head = fh.read(24)
    assert head[:8] == b"\x89PNG\r\n\x1a\n", path
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")


def test_the_preset_menu_shows_a_picture_of_each_preset_and_a_saved_preset_takes_its_runs(registered, tmp_path,
                                                                                          monkeypatch):
    from cp_stylize.blender import images, operators, panel
    from cp_stylize.presets import builtin_presets

    for key, path in builtin_presets().items():       # the shipped pictures (tools/thumbnails.py)
        assert _png_size(panel.thumbnail_path(path)) == (160, 160), key
    monkeypatch.setattr(operators, "user_preset_dir", lambda create=False: str(tmp_path))
    result = images.array_to_image("Ball_stylized", np.full((512, 512, 3), (0.2, 0.4, 0.9), np.float32))
    monkeypatch.setattr(operators, "_last_image", result.name)
    images_before = set(bpy.data.images)
    assert bpy.ops.cp_stylize.preset_add(name="Blue Look") == {"FINISHED"}
    assert _png_size(tmp_path / "blue_look.png") == (128, 128)     # the run's image, a quarter across
    assert set(bpy.data.images) == images_before           # no image left behind by the picture
    log = []
    panel.VIEW3D_PT_cp_stylize_presets.draw(types.SimpleNamespace(layout=FakeLayout(log)), bpy.context)
    assert len([name for kind, name in log if kind == "operator"]) == len(builtin_presets()) + 1
    # the pictures load as Blender's previews (their icons are drawn in a window: tests/gui)
    for path in list(builtin_presets().values()) + [str(tmp_path / "blue_look.toml")]:
        assert tuple(panel.preset_preview(path).image_size) == _png_size(panel.thumbnail_path(path)), path
    assert bpy.ops.cp_stylize.preset_remove(name="blue_look") == {"FINISHED"}
    assert not (tmp_path / "blue_look.png").exists() and not (tmp_path / "blue_look.toml").exists()
    # saved again with no run to show: no picture, and an old one of that name does not stay
    (tmp_path / "blue_look.png").write_bytes(b"old")
    monkeypatch.setattr(operators, "_last_image", None)
    assert bpy.ops.cp_stylize.preset_add(name="Blue Look") == {"FINISHED"}
    assert (tmp_path / "blue_look.toml").exists() and not (tmp_path / "blue_look.png").exists()


def test_the_properties_take_their_limits_from_the_parameter_table(registered):
    from cp_stylize.blender.properties import PROPERTY_NAMES, filter_property
    from cp_stylize.parameters import FILTERS, RUN

    rna = registered.bl_rna.properties
    table = [(PROPERTY_NAMES.get(p.name, p.name), p, p.default) for p in RUN.values()]
    table += [(filter_property(mode, p.name), p, f.defaults[p.name]) for mode, f in FILTERS.items() for p in f.parameters]
    for name, parameter, default in table:
        prop = rna[name]
        assert (prop.hard_min, prop.hard_max) == pytest.approx((parameter.minimum, parameter.maximum)), name
        assert prop.name == parameter.label and prop.description == parameter.description
        assert prop.default == pytest.approx(default, rel=1e-6), name
    assert [item.identifier for item in rna["mode"].enum_items] == list(FILTERS)


def test_lengths_and_times_show_as_sizes_in_the_scene_units_of_the_active_object(registered):
    from cp_stylize.blender.properties import SIZE_VIEWS

    bpy.ops.mesh.primitive_uv_sphere_add(radius=5.0)       # its surface's diameter: 10, poles apart
    obj = bpy.context.active_object
    registered.stroke_width, registered.time, registered.eed_rho = 0.03, 2e-4, 8e-4
    assert registered.stroke_width_size == pytest.approx(0.15, rel=1e-4)
    assert registered.time_size == pytest.approx(5.0 * (2 * 2e-4) ** 0.5, rel=1e-4)   # the blur's radius
    assert registered.eed_rho_size == pytest.approx(5.0 * (2 * 8e-4) ** 0.5, rel=1e-4)
    registered.stroke_width_size, registered.time_size = 0.5, 0.05      # set in the scene's units
    assert registered.stroke_width == pytest.approx(0.1, rel=1e-4)
    assert registered.time == pytest.approx(0.5 * 0.01**2, rel=1e-3)
    registered.stroke_width_size = 1e6                                   # held to the table's limits
    assert registered.stroke_width == pytest.approx(0.2)
    registered.stroke_width = 0.03
    stored = registered.to_settings()
    obj.scale = (2.0, 2.0, 2.0)                  # the object doubles: its sizes do, the stored values not
    bpy.context.view_layer.update()
    assert registered.stroke_width_size == pytest.approx(0.3, rel=1e-4)
    assert registered.to_settings() == stored
    bpy.context.view_layer.objects.active = None  # no object: sizes for one 2 units across
    assert registered.stroke_width_size == pytest.approx(0.03, rel=1e-4)
    # every length and time has its view, and nothing else
    from cp_stylize.parameters import FILTERS, RUN
    sized = {p.name for p in RUN.values() if p.sized} | {f"{m}_{p.name}" for m, f in FILTERS.items()
                                                          for p in f.parameters if p.sized}
    assert SIZE_VIEWS == {f"{'time' if n == 'T' else n}_size" for n in sized}


def test_the_main_panel_shows_sizes_and_the_advanced_one_the_filters_own_parameters(registered):
    from cp_stylize.blender import panel

    bpy.ops.mesh.primitive_uv_sphere_add()
    registered.mode = "ced"
    main, advanced = [], []
    panel.VIEW3D_PT_cp_stylize.draw(types.SimpleNamespace(layout=FakeLayout(main)), bpy.context)
    panel.VIEW3D_PT_cp_stylize_advanced.draw(types.SimpleNamespace(layout=FakeLayout(advanced)), bpy.context)
    main = {name for kind, name in main if kind == "prop"}
    advanced = {name for kind, name in advanced if kind == "prop"}
    assert "time_size" in main and "time" not in main and not any(n.startswith("ced_") for n in main)
    assert {"time", "ced_sigma_size", "ced_rho_size", "ced_alpha", "ced_b_rel"} <= advanced
    assert panel.VIEW3D_PT_cp_stylize_advanced.bl_options == {"DEFAULT_CLOSED"}
    # no field shows more than four decimals but the filter's own, which only the Advanced panel shows, and
    # none there six (Blender shows more only for a value below 10^-precision, at most three digits of it)
    rna = registered.bl_rna.properties
    wide = {name for name in main if rna[name].type == "FLOAT" and rna[name].precision > 4}
    assert not wide, wide
    for mode in MODES:
        registered.mode = mode
        shown = []
        panel.VIEW3D_PT_cp_stylize_advanced.draw(types.SimpleNamespace(layout=FakeLayout(shown)), bpy.context)
        wide = {name for kind, name in shown if kind == "prop" and rna[name].type == "FLOAT" and rna[name].precision > 5}
        assert not wide, (mode, wide)


def test_each_mode_keeps_its_own_parameters(registered):
    registered.mode = "eed"
    registered.lambda_rel = 2e-3
    registered.mode = "perona_malik"
    assert registered.lambda_rel == pytest.approx(1.0 / 13.0)  # Perona-Malik's own default, not EED's value
    assert registered.to_settings().lambda_rel == pytest.approx(1.0 / 13.0)
    registered.mode = "eed"
    assert registered.lambda_rel == pytest.approx(2e-3) and registered.to_settings().lambda_rel == pytest.approx(2e-3)
    registered.mode = "gaussian"
    with pytest.raises(AttributeError, match="mode 'gaussian' has no parameter 'rho'"):
        registered.rho


def _viewport(shading, colour="MATERIAL"):
    return types.SimpleNamespace(scene=bpy.context.scene, space_data=types.SimpleNamespace(
        type="VIEW_3D", shading=types.SimpleNamespace(type=shading, color_type=colour)))


def test_where_the_viewport_shows_no_textures_the_panel_and_the_report_say_how_to_see_the_result(registered):
    from cp_stylize.blender import operators, panel

    for shading, colour in (("SOLID", "MATERIAL"), ("SOLID", "OBJECT"), ("WIREFRAME", "MATERIAL")):
        assert operators.hides_textures(_viewport(shading, colour)), (shading, colour)
        assert "switch to Material Preview (Z)" in operators._how_to_see(_viewport(shading, colour))
    for shading, colour in (("MATERIAL", "MATERIAL"), ("RENDERED", "MATERIAL"), ("SOLID", "TEXTURE")):
        assert not operators.hides_textures(_viewport(shading, colour)), (shading, colour)
        assert operators._how_to_see(_viewport(shading, colour)) == ""
    assert not operators.hides_textures(None)           # a script or blender -b: no viewport, nothing to add
    assert not operators.hides_textures(types.SimpleNamespace(space_data=None))
    for shading, shown in (("SOLID", True), ("MATERIAL", False)):
        log = []
        panel.VIEW3D_PT_cp_stylize_output.draw(types.SimpleNamespace(layout=FakeLayout(log)), _viewport(shading))
        assert (("operator", "view3d.toggle_shading") in log) == shown
