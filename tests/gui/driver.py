"""Drive a real Blender window through one scenario; run by ``tests/gui/test_window.py``.

    blender --factory-startup --python-use-system-env --python tests/gui/driver.py -- SCENARIO OUT ZIP

The driver works through ``bpy.app.timers``, as a user's clicks would arrive:
it closes the splash screen, installs the extension zip with Blender's own
installer, builds a textured sphere, opens the sidebar's Stylize tab, presses
Stylize through the operator's INVOKE path, and does what the scenario says
(Esc with xdotool, undo and redo, deleting the object or entering Edit Mode
while the run works).  It records facts (snapshots of the file, the progress it
saw, the reports) in ``OUT/result.json`` and screenshots (``import -window
root``, ImageMagick) in OUT, then quits.
"""

import json
import os
import subprocess
import sys
import time
import traceback

import bpy

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))   # tests/: blender_state, blender_scenes

from blender_scenes import halves, image_material, sphere, spread_over_tiles, udim_image  # noqa: E402
from cp_stylize_dev.scene import attribute_material  # noqa: E402
from blender_state import differences, snapshot  # noqa: E402

ADDON = "bl_ext.user_default.cp_stylize"
SCENARIO, OUT, ZIP = sys.argv[sys.argv.index("--") + 1:][:3]
facts = {"scenario": SCENARIO, "blender": bpy.app.version_string, "screenshots": {}, "steps": []}


def log(text):
    facts["steps"].append(f"{time.perf_counter() - START:6.1f} s  {text}")


# -- the window ----------------------------------------------------------------------------------


def view3d():
    """``(window, area, region, sidebar)`` of the 3D viewport."""
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    sidebar = next(r for r in area.regions if r.type == "UI")
    return window, area, region, sidebar


def in_view3d(operator, *args, **kwargs):
    window, area, region, _ = view3d()
    with bpy.context.temp_override(window=window, area=area, region=region):
        return operator(*args, **kwargs)


def screenshot(name, region=None):
    """A screenshot of the whole screen, and of ``region`` (cropped) if given; returns the file's path."""
    path = os.path.join(OUT, f"{name}.png")
    subprocess.run(["import", "-window", "root", path], check=True, capture_output=True)
    if region is not None:
        window = view3d()[0]
        top = window.height - (region.y + region.height)
        crop = os.path.join(OUT, f"{name}_crop.png")
        subprocess.run(["convert", path, "-crop", f"{region.width}x{region.height}+{region.x}+{top}", "+repage",
                        crop], check=True, capture_output=True)
        facts["screenshots"][name + "_crop"] = crop
    facts["screenshots"][name] = path
    return path


def key(name):
    """Press a key in the Blender window, as the user would (focus it first: the virtual screen has no
    window manager to do it)."""
    found = subprocess.run(["xdotool", "search", "--name", "Blender"], capture_output=True, text=True, timeout=20)
    for window in found.stdout.split()[:1]:
        subprocess.run(["xdotool", "windowfocus", "--sync", window, "key", name], check=True, capture_output=True,
                       timeout=20)
    log(f"pressed {name}")


def reports():
    """The messages of the window manager's reports, oldest first (through an Info editor and the clipboard)."""
    window = view3d()[0]
    area = next(a for a in window.screen.areas if a.type != "VIEW_3D")
    kind = area.type
    area.type = "INFO"
    try:
        with bpy.context.temp_override(window=window, area=area, region=area.regions[-1]):
            bpy.ops.info.select_all(action="SELECT")
            bpy.ops.info.report_copy()
    finally:
        area.type = kind
    return [line for line in bpy.context.window_manager.clipboard.splitlines() if line.strip()]


def running():
    """The add-on's interactive run in progress, or None."""
    return sys.modules[f"{ADDON}.cp_stylize.blender.operators"]._running


# -- set-up --------------------------------------------------------------------------------------


def set_up():
    key("Escape")   # the splash screen
    yield 0.5
    screenshot("started")
    result = bpy.ops.extensions.package_install_files(filepath=ZIP, repo="user_default", enable_on_install=True)
    log(f"installed {os.path.basename(ZIP)}: {result}")
    for obj in list(bpy.data.objects):
        if obj.type == "MESH":
            bpy.data.objects.remove(obj)
    obj = sphere(material=image_material("Painted", halves("source")), segments=48, rings=24)
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    settings = bpy.context.scene.cp_stylize
    settings.quality, settings.image_size = "PREVIEW", "512"
    settings.mode, settings.time = "ced", 6e-4   # long enough to act on the run while it works
    _, area, _, sidebar = view3d()
    area.spaces.active.show_region_ui = True
    yield 0.3
    sidebar.active_panel_category = "Stylize"
    in_view3d(bpy.ops.ed.undo_push, message="scene ready")
    yield 0.5


def stylize_and_watch(act_at=None, action=None):
    """Press Stylize (INVOKE) and follow the run; call ``action`` once the progress passes ``act_at``."""
    result = in_view3d(bpy.ops.object.cp_stylize, "INVOKE_DEFAULT")
    log(f"Stylize pressed: {sorted(result)}")
    facts["invoke"] = sorted(result)
    seen, acted, shot = [], False, False
    start = time.perf_counter()
    while running() is not None:
        fraction = running().fraction
        seen.append(round(fraction, 3))
        if not shot and fraction > 0.3:
            _, _, _, sidebar = view3d()
            screenshot("running")
            shot = True
        if action is not None and not acted and fraction > act_at:
            log(f"acting at {100 * fraction:.0f} %")
            action()
            acted = True
        if time.perf_counter() - start > 600:
            raise RuntimeError("the run did not end within 10 minutes")
        yield 0.1
    facts["progress"] = seen
    facts["acted"] = acted
    log(f"run ended; progress seen {len(seen)} times")
    yield 0.5


def undo_and_redo(before, done):
    """Undo the run and redo it; the differences from the states ``before`` and ``done`` go into the facts,
    with the reports."""
    in_view3d(bpy.ops.ed.undo)
    yield 0.5
    facts["after_undo"] = differences(before, snapshot())
    in_view3d(bpy.ops.ed.redo)
    yield 0.5
    facts["after_redo"] = differences(done, snapshot())
    facts["reports"] = reports()


# -- scenarios ---------------------------------------------------------------------------------------


def _shown(preset, aside, shot, area, sidebar):
    """The preset ``preset`` loaded (unless None) and the sub-panel ``aside`` put out of the way, then the sidebar
    drawn and its screenshot taken as ``shot`` (a step of a scenario: ``yield from``)."""
    if preset is not None:
        in_view3d(bpy.ops.cp_stylize.preset_load, name=preset)
    bpy.utils.unregister_class(aside)
    area.tag_redraw()
    yield 1.5
    screenshot(shot, sidebar)


def scenario_panel():
    """The sidebar's Stylize tab, with every panel open, for every mode."""
    panels = sys.modules[f"{ADDON}.cp_stylize.blender.panel"]
    # open the Oil Paint, Toon and Palette sub-panels, which start closed; the order stays
    after = [panels.VIEW3D_PT_cp_stylize_oil, panels.VIEW3D_PT_cp_stylize_toon, panels.VIEW3D_PT_cp_stylize_watercolour,
             panels.VIEW3D_PT_cp_stylize_hatching, panels.VIEW3D_PT_cp_stylize_shading,
             panels.VIEW3D_PT_cp_stylize_palette, panels.VIEW3D_PT_cp_stylize_output]
    for cls in reversed(after):
        bpy.utils.unregister_class(cls)
    for cls in after:
        cls.bl_options = set()
        bpy.utils.register_class(cls)
    in_view3d(bpy.ops.cp_stylize.preset_load, name="starry_night")
    _, area, _, sidebar = view3d()
    facts["sidebar"] = {"category": sidebar.active_panel_category, "width": sidebar.width,
                        "height": sidebar.height}
    modes = [item.identifier for item in bpy.context.scene.cp_stylize.bl_rna.properties["mode"].enum_items]
    for mode in modes:
        bpy.context.scene.cp_stylize.mode = mode
        area.tag_redraw()
        yield 1.5   # the panels slide into place
        screenshot(f"panel_{mode}", sidebar)
    facts["modes"] = modes
    settings = bpy.context.scene.cp_stylize
    settings.mode = "ced"
    for direction in ("axis", "attribute"):   # the settings each stroke direction adds
        settings.direction = direction
        area.tag_redraw()
        yield 1.5
        screenshot(f"panel_direction_{direction}", sidebar)
    facts["directions"] = ["axis", "attribute"]
    # oil paint and toon bands on: their settings come alive
    settings.direction = "texture"
    settings.oil_size, settings.toon_levels = 0.03, 4
    area.tag_redraw()
    yield 1.5
    screenshot("panel_oil_toon", sidebar)
    # the Toon preset, with the Paint and Oil Paint sub-panels out of the way so that the Toon sub-panel's
    # bands, outlines and lines show in the window
    in_view3d(bpy.ops.cp_stylize.preset_load, name="toon")
    aside = [panels.VIEW3D_PT_cp_stylize_paint, panels.VIEW3D_PT_cp_stylize_oil]
    for cls in aside:
        bpy.utils.unregister_class(cls)
    area.tag_redraw()
    yield 1.5
    screenshot("panel_toon", sidebar)
    facts["toon"] = {"toon_levels": settings.toon_levels, "toon_outlines": settings.toon_outlines,
                     "line_width": settings.line_width}
    # the Watercolour preset, with the Toon sub-panel out of the way too
    yield from _shown("watercolour", panels.VIEW3D_PT_cp_stylize_toon, "panel_watercolour", area, sidebar)
    facts["watercolour"] = {"wash_levels": settings.wash_levels, "oil_size": settings.oil_size,
                            "labels": [settings.bl_rna.properties[name].name for name in
                                       ("wash_edges", "wash_granulation", "wash_bleed", "wash_wobble")]}
    # the Ink Hatching preset, with the Watercolour sub-panel out of the way too
    yield from _shown("hatching", panels.VIEW3D_PT_cp_stylize_watercolour, "panel_hatching", area, sidebar)
    facts["hatching"] = {"hatch_spacing": settings.hatch_spacing, "hatch_layers": settings.hatch_layers,
                         "line_width": settings.line_width}
    # the Hand-Painted preset, with the Ink Hatching sub-panel out of the way too: its light, edges and warmth
    yield from _shown("hand_painted", panels.VIEW3D_PT_cp_stylize_hatching, "panel_hand_painted", area, sidebar)
    facts["hand_painted"] = {name: getattr(settings, name) for name in ("shade_light", "shade_edges", "shade_warmth")}
    # the Sunflower Vase preset, with the Hand-Painted Light sub-panel out of the way too: the Palette
    # sub-panel's mapping by tone and hue, its Fidelity and the Palette Hues under it
    yield from _shown("sunflower_vase", panels.VIEW3D_PT_cp_stylize_shading, "panel_palette", area, sidebar)
    facts["palette"] = {"fidelity": settings.fidelity, "hue_snap": settings.hue_snap,
                        "label": settings.bl_rna.properties["hue_snap"].name}
    # the Output sub-panel, with the Palette sub-panel out of the way too: its limits' labels whole at the
    # sidebar's width
    yield from _shown(None, panels.VIEW3D_PT_cp_stylize_palette, "panel_output", area, sidebar)
    facts["output_labels"] = [settings.bl_rna.properties[name].name for name in ("memory_limit", "time_limit")]
    bpy.utils.unregister_class(panels.VIEW3D_PT_cp_stylize_output)      # back in their order
    aside += [panels.VIEW3D_PT_cp_stylize_toon, panels.VIEW3D_PT_cp_stylize_watercolour,
              panels.VIEW3D_PT_cp_stylize_hatching, panels.VIEW3D_PT_cp_stylize_shading,
              panels.VIEW3D_PT_cp_stylize_palette, panels.VIEW3D_PT_cp_stylize_output]
    for cls in aside:
        bpy.utils.register_class(cls)
    # the preset menu, a picture of each preset over its name
    presets = sys.modules[f"{ADDON}.cp_stylize.presets"]
    user = sys.modules[f"{ADDON}.cp_stylize.blender.operators"].user_folders()
    facts["preset_icons"] = {key: panels.preset_icon(path) for key, path in presets.preset_paths(user).items()}
    in_view3d(bpy.ops.wm.call_panel, name="VIEW3D_PT_cp_stylize_presets", keep_open=True)
    yield 1.5
    screenshot("preset_menu")
    key("Escape")
    yield 0.5
    # the Advanced sub-panel opened, with the others out of the way: the filter's own parameters
    in_view3d(bpy.ops.cp_stylize.preset_load, name="denoise_eed")
    aside = [panels.VIEW3D_PT_cp_stylize_paint, panels.VIEW3D_PT_cp_stylize_oil, panels.VIEW3D_PT_cp_stylize_toon,
             panels.VIEW3D_PT_cp_stylize_watercolour, panels.VIEW3D_PT_cp_stylize_hatching,
             panels.VIEW3D_PT_cp_stylize_shading, panels.VIEW3D_PT_cp_stylize_palette,
             panels.VIEW3D_PT_cp_stylize_output]
    for cls in aside:
        bpy.utils.unregister_class(cls)
    # the sub-panel stays closed once drawn closed: the same panel under a name of its own starts open
    bpy.utils.unregister_class(panels.VIEW3D_PT_cp_stylize_advanced)
    shown = type("VIEW3D_PT_cp_stylize_advanced_shown", (panels.VIEW3D_PT_cp_stylize_advanced,),
                 {"bl_idname": "VIEW3D_PT_cp_stylize_advanced_shown", "bl_options": set()})
    bpy.utils.register_class(shown)
    area.tag_redraw()
    yield 1.5
    screenshot("panel_advanced", sidebar)
    bpy.utils.unregister_class(shown)
    bpy.utils.register_class(panels.VIEW3D_PT_cp_stylize_advanced)
    facts["sizes"] = {"time_size": settings.time_size, "time": settings.time,
                      "radius": bpy.context.active_object.dimensions[0] / 2}
    for cls in aside:
        bpy.utils.register_class(cls)


def scenario_undo():
    """A run to the end, then undo and redo."""
    before = snapshot()
    yield from stylize_and_watch()
    facts["reports"] = []
    done = snapshot()
    facts["changed_by_run"] = differences(before, done)
    screenshot("finished")
    yield from undo_and_redo(before, done)
    facts["shading"] = view3d()[1].spaces.active.shading.type
    in_view3d(bpy.ops.view3d.toggle_shading, type="MATERIAL")     # what Show in Material Preview does
    yield 3.0
    screenshot("finished_material_preview")


def scenario_attribute():
    """A scan's colour attribute filtered into a new colour attribute (Result: Colour Attribute), its Output
    sub-panel drawn, then undo and redo."""
    import numpy as np

    obj = sphere("Scan", segments=96, rings=48, location=(0.0, 0.0, 0.0))
    bpy.data.objects.remove(bpy.data.objects["Ball"])
    mesh = obj.data
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    rgb = np.clip(np.where(co[:, :1] > 0, 0.8, 0.2) + 0.1 * np.random.default_rng(0).standard_normal((len(co), 3)),
                  0, 1)
    attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    attribute.data.foreach_set("color_srgb", np.concatenate([rgb, np.ones((len(co), 1))], 1).astype("f4").ravel())
    mesh.color_attributes.active_color = attribute
    mesh.materials.append(attribute_material("Scanned", "Col"))
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    settings = bpy.context.scene.cp_stylize
    settings.result_kind = "ATTRIBUTE"
    settings.mode, settings.time = "eed", 2e-3
    settings.quality, settings.spacing = "CUSTOM", 0.08
    in_view3d(bpy.ops.ed.undo_push, message="scan ready")
    _, area, _, sidebar = view3d()
    panels = sys.modules[f"{ADDON}.cp_stylize.blender.panel"]
    bpy.utils.unregister_class(panels.VIEW3D_PT_cp_stylize_paint)     # out of the way of the Output sub-panel
    area.tag_redraw()
    yield 1.5
    screenshot("attribute_output", sidebar)
    bpy.utils.register_class(panels.VIEW3D_PT_cp_stylize_paint)
    facts["method_label"] = sys.modules[f"{ADDON}.cp_stylize.blender.operators"].attribute_method(obj, settings)
    before = snapshot()
    yield from stylize_and_watch()
    done = snapshot()
    facts["changed_by_run"] = differences(before, done)
    in_view3d(bpy.ops.view3d.view_selected)
    yield from undo_and_redo(before, done)
    # the result as Solid shading shows the active colour attribute (no shaders to compile, unlike Material
    # Preview's); the facts are in, so the active attribute may change now
    bpy.data.objects["Scan"].data.color_attributes.active_color_name = "Col_stylized"   # found again after undo
    shading = view3d()[1].spaces.active.shading
    shading.type, shading.color_type = "SOLID", "VERTEX"
    yield 1.5
    screenshot("attribute_result")


def scenario_rerun():
    """A run, then the same object again with a longer time: the second run reuses the first's band."""
    yield from stylize_and_watch()
    settings = bpy.context.scene.cp_stylize
    settings.time *= 1.5
    yield from stylize_and_watch()
    addon = sys.modules[f"{ADDON}.cp_stylize.blender.operators"]
    facts["kept_mib"] = addon.kept_bytes() / 2**20
    _, area, _, sidebar = view3d()
    area.tag_redraw()
    yield 1.0
    screenshot("rerun_sidebar", sidebar)
    in_view3d(bpy.ops.cp_stylize.release)
    facts["kept_after_free"] = addon.kept_bytes()
    facts["reports"] = reports()


def scenario_udim():
    """A UDIM asset: the sphere wearing a tiled image of three tiles (its files saved beside the screenshots),
    its faces spread over them, stylized to the end; then undo and redo, and the result in Material Preview."""
    obj = bpy.context.active_object
    folder = os.path.join(OUT, "tiles")
    os.makedirs(folder, exist_ok=True)
    image = udim_image(folder, packed=False)
    obj.material_slots[0].material = image_material("Tiled", image)
    spread_over_tiles(obj)
    settings = bpy.context.scene.cp_stylize
    settings.mode, settings.time = "eed", 2e-4
    in_view3d(bpy.ops.view3d.toggle_shading, type="MATERIAL")
    in_view3d(bpy.ops.view3d.view_selected)            # the asset filling the view
    in_view3d(bpy.ops.ed.undo_push, message="tiled asset ready")
    yield 10.0                                          # EEVEE compiles the material's shaders first
    screenshot("udim_before", view3d()[2])
    facts["tiles"] = sorted(t.number for t in image.tiles)
    before = snapshot()
    files = sorted(os.listdir(folder))
    yield from stylize_and_watch()
    done = snapshot()
    facts["changed_by_run"] = differences(before, done)
    facts["tile_files_unchanged"] = sorted(os.listdir(folder)) == files
    yield 10.0
    screenshot("udim_after", view3d()[2])
    yield from undo_and_redo(before, done)


def scenario_escape():
    """Esc while the run works."""
    before = snapshot()
    yield from stylize_and_watch(0.2, lambda: key("Escape"))
    facts["changed"] = differences(before, snapshot())
    facts["reports"] = reports()


def scenario_delete():
    """The object deleted while the run works."""
    state = {}

    def delete():
        in_view3d(bpy.ops.object.delete)
        state["deleted"] = snapshot()

    yield from stylize_and_watch(0.2, delete)
    facts["changed"] = differences(state["deleted"], snapshot())
    facts["ball_exists"] = "Ball" in bpy.data.objects
    facts["reports"] = reports()


def scenario_edit_mode():
    """Edit Mode entered while the run works."""
    state = {}

    def edit():
        in_view3d(bpy.ops.object.mode_set, mode="EDIT")
        state["editing"] = snapshot()

    yield from stylize_and_watch(0.2, edit)
    facts["mode"] = bpy.context.active_object.mode
    facts["changed"] = differences(state["editing"], snapshot())
    screenshot("edit_mode_refused")
    facts["reports"] = reports()
    in_view3d(bpy.ops.object.mode_set, mode="OBJECT")


# -- the timer loop ------------------------------------------------------------------------------------


def steps():
    yield from set_up()
    yield from globals()[f"scenario_{SCENARIO}"]()


def finish():
    with open(os.path.join(OUT, "result.json"), "w", encoding="utf-8") as fh:
        json.dump(facts, fh, indent=1)
    bpy.ops.wm.quit_blender()


def tick():
    try:
        return next(STEPS)
    except StopIteration:
        finish()
    except Exception:
        facts["error"] = traceback.format_exc()
        finish()
    return None


START = time.perf_counter()
os.makedirs(OUT, exist_ok=True)
STEPS = steps()
bpy.app.timers.register(tick, first_interval=1.0)
