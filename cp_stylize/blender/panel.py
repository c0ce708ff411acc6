"""The sidebar panel: View3D > Sidebar > Stylize."""

import os

import bpy

from ..parameters import AXIS_DIRECTIONS, FILTERS, paints_shading, takes_direction
from . import operators
from .properties import SIZE_VIEWS, filter_property, object_scale, size_property

_estimate_cache = {}


def _images(obj):
    """The materials of ``obj`` and the sizes of their images: what the estimate's image cost depends on."""
    found = []
    for slot in obj.material_slots:
        tree = slot.material.node_tree if slot.material else None
        nodes = tree.nodes if tree else ()
        found.append((slot.material and slot.material.name,
                      tuple(tuple(n.image.size) for n in nodes if n.type == "TEX_IMAGE" and n.image)))
    return tuple(found)


def length_text(length):
    """A length in world units as the scene shows lengths (its unit system and scale: "8.94 mm")."""
    units = bpy.context.scene.unit_settings
    return bpy.utils.units.to_string(units.system, "LENGTH", length * units.scale_length, precision=3).strip()


def _estimate_text(obj, settings):
    """Lines describing the run's size, cached on what changes them."""
    try:
        core = settings.to_settings()
    except ValueError as err:
        return [str(err)]
    attribute = settings.result_kind == "ATTRIBUTE"
    key = (obj.name, tuple(round(c, 6) for c in obj.dimensions), core, len(obj.data.polygons), _images(obj),
           attribute)
    if key not in _estimate_cache:
        try:
            h, n, nbytes, seconds = operators.estimate(obj, core, attribute=attribute)
            _estimate_cache.clear()
            where = f"About {n:,} band points" if n else "On the mesh's own vertices"
            _estimate_cache[key] = [f"Grid spacing {length_text(h)}",
                                    f"{where}, {nbytes / 2**20:,.0f} MiB",
                                    f"Roughly {max(seconds, 1):,.0f} s"]
        except ValueError as err:
            return [str(err)]
    return _estimate_cache[key]


class VIEW3D_PT_cp_stylize_presets(bpy.types.Panel):
    """The preset picker: a picture of each preset over its name (a popover of the Stylize panel)."""
    bl_idname = "VIEW3D_PT_cp_stylize_presets"
    bl_label = "Presets"
    bl_space_type = "VIEW_3D"
    bl_region_type = "HEADER"
    bl_ui_units_x = 22

    def draw(self, context):
        from ..presets import preset_menu, preset_paths

        folders = operators.user_folders()
        paths = preset_paths(folders)
        grid = self.layout.grid_flow(row_major=True, columns=MENU_COLUMNS, even_columns=True, even_rows=True)
        for key, label in preset_menu(folders):
            col = grid.column(align=True)
            icon = preset_icon(paths[key])
            if icon:
                col.template_icon(icon_value=icon, scale=THUMBNAIL_SCALE)
            col.operator("cp_stylize.preset_load", text=label).name = key


#: The preset picker's columns, and its pictures' size in multiples of a line's height.
MENU_COLUMNS = 3
THUMBNAIL_SCALE = 6.0
_previews = None


def thumbnail_path(preset_path):
    """The picture of the preset file ``preset_path``: the PNG next to it with its name."""
    return os.path.splitext(preset_path)[0] + ".png"


def preset_preview(preset_path):
    """The preview (Blender's ``bpy.utils.previews``) of the preset file ``preset_path``, from its
    :func:`thumbnail_path`; None where it has none.  The pictures load when the menu is first drawn, not when
    the add-on is enabled, and again when a file changes."""
    global _previews
    path = thumbnail_path(preset_path)
    try:
        stamp = os.path.getmtime(path)
    except OSError:
        return None
    if _previews is None:
        import bpy.utils.previews

        _previews = bpy.utils.previews.new()
    name = f"{path}@{stamp}"
    if name not in _previews:
        _previews.load(name, path, "IMAGE")
    return _previews[name]


def preset_icon(preset_path):
    """The icon of the preset file's picture (:func:`preset_preview`); 0 where it has none, or where Blender
    draws no icons (``blender -b``)."""
    preview = preset_preview(preset_path)
    return 0 if preview is None else preview.icon_id


def release_previews():
    """Free the preview icons (when the add-on is disabled)."""
    global _previews
    if _previews is not None:
        import bpy.utils.previews

        bpy.utils.previews.remove(_previews)
        _previews = None


def _split(layout):
    """``layout`` with labels left of the values and no animation decorators."""
    layout.use_property_split = True
    layout.use_property_decorate = False
    return layout


class _Sidebar:
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Stylize"


class _Closed(_Sidebar):
    """A sub-panel of the Stylize panel, closed until the user opens it."""
    bl_parent_id = "VIEW3D_PT_cp_stylize"
    bl_options = {"DEFAULT_CLOSED"}


class VIEW3D_PT_cp_stylize(_Sidebar, bpy.types.Panel):
    bl_idname = "VIEW3D_PT_cp_stylize"
    bl_label = "Stylize"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = self.layout
        row = layout.row(align=True)
        row.popover("VIEW3D_PT_cp_stylize_presets", text=settings.preset_name or "Presets")
        row.operator("cp_stylize.preset_add", text="", icon="ADD")
        remove = row.operator("cp_stylize.preset_remove", text="", icon="REMOVE")
        remove.name = settings.preset_key

        layout = _split(self.layout)
        layout.prop(settings, "mode")
        obj = context.active_object
        if takes_direction(settings.mode, settings.strokes, settings.hatch_spacing):
            layout.prop(settings, "direction")
            if settings.direction in AXIS_DIRECTIONS:
                layout.prop(settings, "axis")
            elif settings.direction == "attribute":
                if obj is not None and obj.type == "MESH":
                    layout.prop_search(settings, "direction_attribute", obj.data, "attributes")
                else:
                    layout.prop(settings, "direction_attribute")
        layout.prop(settings, "quality")
        if settings.quality == "CUSTOM":
            _prop(layout, settings, "spacing")
        box = layout.box()
        if obj is not None and obj.type == "MESH":
            for line in _estimate_text(obj, settings):
                box.label(text=line)
        else:
            box.label(text="Select a mesh object", icon="INFO")

        _prop(layout, settings, "time")
        layout.prop(settings, "detail")
        if object_scale() is None:
            layout.label(text="Sizes for an object 2 units across", icon="INFO")


def _prop(layout, settings, name, text=None):
    """The property ``name``, as a size in the scene's units for the active object where it is a length or
    a time (:mod:`cp_stylize.blender.properties`), else as it is."""
    view = size_property(name)
    shown = view if view in SIZE_VIEWS and object_scale() is not None else name
    layout.prop(settings, shown, **({} if text is None else {"text": text}))


def _switched(layout, settings, switch, props, text=None):
    """``switch`` (a strength or size, 0: off) and under it the ``props`` it governs, greyed while it is 0;
    each of ``props`` is a property's name or ``(name, label)``."""
    _prop(layout, settings, switch, text)
    col = layout.column()
    col.active = getattr(settings, switch) > 0
    for prop in props:
        name, label = (prop, None) if isinstance(prop, str) else prop
        _prop(col, settings, name, label)


class VIEW3D_PT_cp_stylize_paint(_Sidebar, bpy.types.Panel):
    bl_label = "Paint"
    bl_parent_id = "VIEW3D_PT_cp_stylize"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = _split(self.layout)
        _switched(layout, settings, "strokes", [("stroke_width", "Width"), ("stroke_length", "Length"),
                                                "stroke_layers", "stroke_chain", "broad_paint", "stroke_jitter",
                                                "swirl", "stars", "relief", "sheen"])
        layout.prop(settings, "contours")


class VIEW3D_PT_cp_stylize_oil(_Closed, bpy.types.Panel):
    bl_label = "Oil Paint"

    def draw(self, context):
        _switched(_split(self.layout), context.scene.cp_stylize, "oil_size", ["oil_sharpness", "oil_eccentricity"],
                  text="Size")


class VIEW3D_PT_cp_stylize_toon(_Closed, bpy.types.Panel):
    bl_label = "Toon"

    def draw(self, context):
        layout = _split(self.layout)
        _switched(layout, context.scene.cp_stylize, "toon_levels", ["toon_softness", "toon_outlines"], text="Levels")
        _switched(layout, context.scene.cp_stylize, "line_width", ["line_detail"], text="Line Width")


class VIEW3D_PT_cp_stylize_watercolour(_Closed, bpy.types.Panel):
    bl_label = "Watercolour"

    def draw(self, context):
        layout = _split(self.layout)
        _switched(layout, context.scene.cp_stylize, "wash_levels", ["wash_edges", "wash_granulation", "wash_bleed",
                                                                    "wash_wobble"])
        _switched(layout, context.scene.cp_stylize, "line_width", ["line_detail"], text="Pen Lines")


class VIEW3D_PT_cp_stylize_hatching(_Closed, bpy.types.Panel):
    bl_label = "Ink Hatching"

    def draw(self, context):
        layout = _split(self.layout)
        _switched(layout, context.scene.cp_stylize, "hatch_spacing", ["hatch_layers", "hatch_angle", "hatch_ink",
                                                                      "hatch_swell", "hatch_light", "hatch_smooth"],
                  text="Spacing")
        _switched(layout, context.scene.cp_stylize, "line_width", ["line_detail"], text="Outlines")


class VIEW3D_PT_cp_stylize_shading(_Closed, bpy.types.Panel):
    bl_label = "Hand-Painted Light"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = _split(self.layout)
        _prop(layout, settings, "shade_light")
        _prop(layout, settings, "shade_edges")
        col = layout.column()
        col.active = paints_shading(settings.shade_light, settings.shade_edges)
        _prop(col, settings, "shade_warmth")


class VIEW3D_PT_cp_stylize_palette(_Closed, bpy.types.Panel):
    bl_label = "Palette"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = _split(self.layout)
        layout.prop(settings, "noise_mapping")
        if settings.noise_mapping == "tone":
            _switched(layout, settings, "fidelity", ["hue_snap"])
            layout.prop(settings, "keep_values")
            layout.prop(settings, "keep_darks")
        layout.prop(settings, "noise_fraction")
        if settings.noise_mapping == "tone":
            layout.prop(settings, "noise_spread")
        layout.prop(settings, "seed")
        for index, item in enumerate(settings.palette):
            row = layout.row(align=True)
            row.prop(item, "colour", text="")
            row.prop(item, "weight", text="Weight")
            row.operator("cp_stylize.palette_remove", text="", icon="X").index = index
        layout.operator("cp_stylize.palette_add", icon="ADD")


class VIEW3D_PT_cp_stylize_output(_Sidebar, bpy.types.Panel):
    bl_label = "Output"
    bl_parent_id = "VIEW3D_PT_cp_stylize"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = _split(self.layout)
        layout.prop(settings, "result_kind")
        if settings.result_kind == "IMAGE":
            layout.prop(settings, "image_size")
            layout.prop(settings, "image_name")
        else:
            where, why = operators.attribute_method(context.active_object, settings)
            col = layout.column(align=True)
            col.label(text=where, icon="INFO")
            col.label(text=why, icon="BLANK1")
        layout.prop(settings, "target")
        if settings.result_kind == "IMAGE":
            layout.prop(settings, "storage")
        layout.prop(settings, "memory_limit")
        layout.prop(settings, "time_limit")
        if settings.result_kind == "IMAGE":        # what a colour attribute's run builds is not kept
            layout.prop(settings, "keep")
        layout.separator()
        layout.operator("object.cp_stylize", icon="BRUSH_DATA")
        if operators.hides_textures(context):        # a result would not show: offer the view that shows it
            layout.operator("view3d.toggle_shading", text="Show in Material Preview", icon="MATERIAL").type = "MATERIAL"
        layout.operator("object.cp_stylize_estimate", icon="INFO")
        held = operators.kept_bytes()
        if held:
            row = layout.row(align=True)
            row.label(text=f"Kept for re-runs: {held / 2**20:,.0f} MiB")
            row.operator("cp_stylize.release", text="", icon="TRASH")


class VIEW3D_PT_cp_stylize_advanced(_Closed, bpy.types.Panel):
    """The filter's own parameters, as the methods name them: the diffusion time and the mode's parameters."""
    bl_label = "Advanced"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = _split(self.layout)
        col = layout.column(heading="Filter")
        col.prop(settings, "time")
        for parameter in FILTERS[settings.mode].parameters:
            _prop(col, settings, filter_property(settings.mode, parameter.name))


classes = (VIEW3D_PT_cp_stylize_presets, VIEW3D_PT_cp_stylize, VIEW3D_PT_cp_stylize_paint, VIEW3D_PT_cp_stylize_oil,
           VIEW3D_PT_cp_stylize_toon, VIEW3D_PT_cp_stylize_watercolour, VIEW3D_PT_cp_stylize_hatching,
           VIEW3D_PT_cp_stylize_shading, VIEW3D_PT_cp_stylize_palette,
           VIEW3D_PT_cp_stylize_output, VIEW3D_PT_cp_stylize_advanced)
