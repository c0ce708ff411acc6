"""The sidebar panels draw without errors and name only real properties and operators."""

import types

import pytest

bpy = pytest.importorskip("bpy", reason="needs Blender's Python module (pip install -r requirements.txt)")

from cp_stylize.parameters import DIRECTED_MODES, DIRECTIONS, FILTERS  # noqa: E402

pytestmark = pytest.mark.blender


class FakeLayout:
    """Records what a panel draws and checks every property and operator it names."""

    def __init__(self, log):
        self.log = log
        self.use_property_split = self.use_property_decorate = False

    def _child(self, *args, **kwargs):
        return FakeLayout(self.log)

    row = column = box = _child

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

    def menu(self, idname, **kwargs):
        assert hasattr(bpy.types, idname), idname
        self.log.append(("menu", idname))

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
    for cls in (panel.VIEW3D_PT_cp_stylize, panel.VIEW3D_PT_cp_stylize_paint, panel.VIEW3D_PT_cp_stylize_palette,
                panel.VIEW3D_PT_cp_stylize_output, panel.CP_STYLIZE_MT_presets):
        cls.draw(types.SimpleNamespace(layout=FakeLayout(log)), context)
    props = {name.removeprefix(mode + "_") for kind, name in log if kind == "prop"}  # the mode's own parameters
    assert {"mode", "quality", "time", "strokes", "stroke_width", "stroke_layers", "stroke_jitter", "swirl", "relief",
            "contours", "noise_mapping"} <= props
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
        assert ("axis" in props) == (mode in DIRECTED_MODES and direction == "axis")
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

    assert registered.mode == "gaussian" and len(registered.palette) == len(load_preset("starry_night").palette) == 11
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
