"""Operators of the add-on: Stylize, the band estimate, presets and the noise palette.

Every operator is a boundary: whatever goes wrong reaches the user as one
message (``self.report``), never as a traceback, and leaves the file as it was.
"""

import os
import sys
import time
import traceback

import bpy

from .errors import Cancelled
from ..parameters import FILTERS
from .properties import QUALITY_SPACING

#: The interactive run in progress (one at a time), or None.
_running = None


def estimate(obj, settings, depsgraph=None, attribute=False):
    """``(h, points, bytes, seconds)`` of a run on ``obj`` with the core's StylizeSettings (``attribute``: into
    a colour attribute, ``points`` 0 where the mesh filter serves it).

    ``h`` is the grid spacing in world units; raises StylizeError (a ValueError) for unusable objects.
    """
    from ..estimate import estimate as estimate_run
    from . import meshdata, stylize

    stylize.check_object(obj)
    mesh = meshdata.read(obj, depsgraph, corners=False)
    if attribute:
        from ..estimate import estimate_vertices
        from ..vertex_colours import choose_method, mean_edge

        edge = mean_edge(mesh.vertices, mesh.triangles)
        method, _ = choose_method(mesh.vertices, mesh.triangles, settings, edge=edge)
        guess = estimate_vertices(mesh.vertices, mesh.triangles, settings, method, speed=machine_speed(), edge=edge)
        return guess.spacing, guess.band_points, guess.bytes, guess.seconds
    import numpy as np

    index = np.zeros(len(obj.data.polygons), dtype=np.int32)
    obj.data.polygons.foreach_get("material_index", index)
    slots = np.unique(np.minimum(index, max(len(obj.material_slots) - 1, 0))).tolist()
    guess = estimate_run(mesh.vertices, mesh.triangles, settings, keep=True, unwrap=not obj.data.uv_layers,
                         image_pixels=stylize.input_pixels(obj, obj.data.uv_layers.keys(), slots, settings),
                         speed=machine_speed())
    return guess.spacing, guess.band_points, guess.bytes, guess.seconds


#: The last :func:`attribute_method` answer: ``(key, lines)``.
_method_shown = (None, ())


def attribute_method(obj, panel):
    """Two short lines for the panel: where a Colour Attribute run on ``obj`` with the panel's settings would
    filter (the mesh's vertices or the band) and why; remembered for the same mesh, mode and grid."""
    global _method_shown
    if obj is None or obj.type != "MESH" or not len(obj.data.polygons):
        return ("Select a mesh object", "")
    data = obj.data
    key = (data.as_pointer(), len(data.vertices), len(data.polygons), panel.mode, panel.relative_spacing())
    if _method_shown[0] == key:
        return _method_shown[1]
    from ..mesh_diffusion import MESH_MODES, available
    from ..vertex_colours import MESH_EDGE, mean_edge
    from . import meshdata

    try:
        mesh = meshdata.read(obj, corners=False)
        edge = mean_edge(mesh.vertices, mesh.triangles)
    except (ValueError, RuntimeError):
        return ("Filters on the mesh's vertices", "or on the band")
    if panel.mode not in MESH_MODES:
        label = ("Filters on the band", f"({FILTERS[panel.mode].label} runs there only)")
    elif edge > MESH_EDGE * panel.relative_spacing():
        label = ("Filters on the band", "(the vertices lie farther apart)")
    elif not available():
        label = ("Filters on the band", "(libigl is missing)")
    else:
        label = ("Filters on the mesh's vertices", "(they lie closer than the grid)")
    _method_shown = (key, label)
    return label


def hides_textures(context):
    """Whether the context's 3D viewport is shaded so that it shows no textures (Solid shading by material or
    object colour, Wireframe); False without a 3D viewport."""
    space = getattr(context, "space_data", None) if context is not None else None
    shading = getattr(space, "shading", None) if getattr(space, "type", None) == "VIEW_3D" else None
    return shading is not None and shading.type not in ("MATERIAL", "RENDERED") and not (
        shading.type == "SOLID" and shading.color_type == "TEXTURE")


def _how_to_see(context):
    """What the report adds where the 3D viewport the run was started from shows no textures: how to see
    the result ("" where it does, or without a viewport)."""
    if not hides_textures(context):
        return ""
    return "; the viewport's Solid shading does not show it: switch to Material Preview (Z), or press Show in Material Preview under Stylize"


def machine_speed():
    """The estimate's time factor for this computer (:func:`cp_stylize.calibration.machine_speed`).

    Measured at the first estimate (well under a second, never when the
    add-on is enabled) and kept in the extension's user folder, so that later
    sessions read it; run from a checkout, not installed, it is kept in memory.
    """
    from ..calibration import machine_speed as speed

    parts = __package__.split(".")
    if parts[0] == "bl_ext" and len(parts) >= 3:
        return speed(os.path.join(bpy.utils.extension_path_user(".".join(parts[:3]), create=True),
                                  "calibration.json"))
    return speed()


def guarded(operator, work):
    """Run ``work()`` and turn any exception into one report; returns the operator's result."""
    try:
        return work()
    except Cancelled:
        operator.report({"WARNING"}, "stylize cancelled; nothing was changed")
    except ValueError as err:   # StylizeError, and the core's messages about bad input
        operator.report({"ERROR"}, str(err))
    except MemoryError:
        operator.report({"ERROR"}, "there was not enough memory for this run; nothing was changed: "
                                   "lower the quality")
    except Exception as err:
        traceback.print_exc(file=sys.stderr)
        operator.report({"ERROR"}, f"cp_stylize failed unexpectedly ({type(err).__name__}: {err}); nothing was "
                                   "changed. The system console has the details")
    return {"CANCELLED"}


class OBJECT_OT_cp_stylize_estimate(bpy.types.Operator):
    """Estimate the grid spacing, band size and memory a run on the active object needs"""

    bl_idname = "object.cp_stylize_estimate"
    bl_label = "Estimate Band"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def execute(self, context):
        def work():
            panel = context.scene.cp_stylize
            if panel.result_kind == "ATTRIBUTE":
                from . import stylize

                job = stylize.prepare_attribute(context.active_object, panel.to_settings(), panel.output())
                guess = job.estimate
                self.report({"INFO"}, f"{job.reason}; {guess.bytes / 2**20:.0f} MiB, roughly {guess.seconds:.0f} s")
                return {"FINISHED"}
            h, n, nbytes, seconds = estimate(context.active_object, panel.to_settings())
            self.report({"INFO"}, f"grid spacing {h:.4g}, about {n:,} band points, {nbytes / 2**20:.0f} MiB, "
                                  f"roughly {seconds:.0f} s")
            return {"FINISHED"}
        return guarded(self, work)


class OBJECT_OT_cp_stylize(bpy.types.Operator):
    """Stylize the active object's texture on its surface and wire the result into its material"""

    bl_idname = "object.cp_stylize"
    bl_label = "Stylize"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.StringProperty(
        name="Preset", description="Run with this preset (a shipped preset's name or a TOML file) "
                                   "instead of the panel's filter settings", default="", options={"SKIP_SAVE"})
    quality: bpy.props.EnumProperty(
        name="Quality", description="The grid spacing: the preset's or the panel's own, or one of the quality levels",
        items=[("DEFAULT", "As Set", "The preset's or the panel's own grid spacing")]
        + [(k, k.title(), f"Relative grid spacing {v}") for k, v in QUALITY_SPACING.items()],
        default="DEFAULT", options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        if context.mode != "OBJECT":
            cls.poll_message_set("cp_stylize works in Object Mode: leave Edit Mode first"
                                 if context.mode.startswith("EDIT") else "cp_stylize works in Object Mode")
            return False
        if _running is not None:
            cls.poll_message_set("a Stylize run is in progress (Esc cancels it)")
            return False
        return True

    def _prepare(self, context):
        from ..presets import load_preset
        from . import stylize

        panel = context.scene.cp_stylize
        settings = load_preset(self.preset, user_folders()) if self.preset else panel.to_settings()
        if self.quality != "DEFAULT":
            settings = settings.replace(spacing=QUALITY_SPACING[self.quality])
        settings = settings.replace(image_size=int(panel.image_size))
        return stylize.prepare(context.active_object, settings, panel.output())

    def _finish(self, job, context=None):
        from . import results, stylize, writing

        if isinstance(job, stylize.AttributeJob):
            return self._finish_attribute(job, context)
        applied = writing.apply(job)
        global _last_image
        _last_image = applied.image
        result = job.result
        where = f", saved as {os.path.basename(applied.path)}" if applied.path else ""
        reused = ", the last run's band reused" if "band" in job.reused else ""
        self.report({"WARNING"} if applied.kept else {"INFO"},
                    f"stylized {job.object_name!r} into {applied.image!r}{where}"
                    f"{f', its relief in {applied.relief!r}' if applied.relief else ''} in {result.seconds:.1f} s "
                    f"({result.band_size:,} band points, grid spacing {result.spacing:.4g}{reused})"
                    f"{results.kept_note(applied.kept)}{_how_to_see(context)}")
        return {"FINISHED"}

    def _finish_attribute(self, job, context):
        from . import results, writing

        applied = writing.apply_attribute(job)
        result = job.result
        where = "on the mesh's own vertices" if result.method == "mesh" else f"on the band ({result.points:,} points)"
        kept = (f"; the earlier result {applied.kept!r} was painted after its run, so it is kept as it is"
                if applied.kept else "")
        self.report({"WARNING"} if applied.kept or applied.kept_images else {"INFO"},
                    f"stylized {job.object_name!r} into the colour attribute {applied.attribute!r} {where} in "
                    f"{result.seconds:.1f} s ({job.reason}){kept}{results.kept_note(applied.kept_images)}"
                    f"{_how_to_see(context)}")
        return {"FINISHED"}

    def execute(self, context):
        from . import stylize

        def work():
            job = self._prepare(context)
            stylize.run_core(job, log=print if bpy.app.background else None)
            return self._finish(job, context)
        return guarded(self, work)

    # -- interactive: a worker thread, progress and Esc ---------------------------------------

    def invoke(self, context, event):
        if bpy.app.background:
            return self.execute(context)
        return guarded(self, lambda: self._start(context))

    def _start(self, context):
        from . import stylize

        global _running
        self._job = self._prepare(context)
        self._run = _running = stylize.BackgroundRun(self._job).start()
        self._start_time = time.perf_counter()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def _stop(self, context):
        global _running
        _running = None
        wm = context.window_manager
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        if context.workspace is not None:
            context.workspace.status_text_set(None)

    def modal(self, context, event):
        run = self._run
        if event.type == "ESC" and event.value == "PRESS":
            run.cancel()
            return {"RUNNING_MODAL"}
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        if not run.done:
            context.window_manager.progress_update(int(100 * run.fraction))
            what = "cancelling" if run.cancelling else "Esc to cancel"
            if context.workspace is not None:
                context.workspace.status_text_set(
                    f"Stylizing {self._job.object_name}: {100 * run.fraction:.0f} % "
                    f"({time.perf_counter() - self._start_time:.0f} s), {what}")
            return {"RUNNING_MODAL"}
        self._stop(context)

        def finish():
            if run.error is not None:
                raise run.error
            return self._finish(self._job, context)
        return guarded(self, finish)

    def cancel(self, context):
        self._run.cancel()
        self._stop(context)


def kept_bytes():
    """Bytes the last run kept for re-runs (nothing is imported when no run has been made)."""
    module = sys.modules.get(f"{__package__}.stylize")
    return 0 if module is None else module.kept_bytes()


def release_kept():
    module = sys.modules.get(f"{__package__}.stylize")
    if module is not None:
        module.release()


class CP_STYLIZE_OT_release(bpy.types.Operator):
    """Free the memory the last run kept so that the next run on the same mesh and grid starts at the filter"""

    bl_idname = "cp_stylize.release"
    bl_label = "Free Kept Data"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        if _running is not None:
            cls.poll_message_set("a Stylize run is in progress")
            return False
        return kept_bytes() > 0

    def execute(self, context):
        freed = kept_bytes()
        release_kept()
        self.report({"INFO"}, f"freed {freed / 2**20:,.0f} MiB kept for re-runs")
        return {"FINISHED"}


# -- presets -------------------------------------------------------------------------------------


def user_preset_dir(create=False):
    """Folder of the user's presets in Blender's user config."""
    parts = __package__.split(".")
    if parts[0] == "bl_ext" and len(parts) >= 3:
        return bpy.utils.extension_path_user(".".join(parts[:3]), path="presets", create=create)
    return bpy.utils.user_resource("SCRIPTS", path=os.path.join("presets", "cp_stylize"), create=create)


def user_folders():
    """The folders the add-on looks for presets in after the shipped ones: the user's preset folder."""
    folder = user_preset_dir()
    return [folder] if folder else []


def all_presets():
    """``{key: path}`` of the shipped and the user's presets (see :func:`cp_stylize.presets.preset_paths`)."""
    from ..presets import preset_paths

    return preset_paths(user_folders())


class CP_STYLIZE_OT_preset_load(bpy.types.Operator):
    """Load a preset into the panel's settings"""

    bl_idname = "cp_stylize.preset_load"
    bl_label = "Load Preset"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    name: bpy.props.StringProperty(name="Preset", description="The preset's key, or its file's path")

    def execute(self, context):
        from ..presets import load_preset

        def work():   # on any error the panel is as it was: a preset is checked whole, then set whole
            settings = load_preset(self.name, user_folders())
            context.scene.cp_stylize.from_settings(settings.replace(name=settings.name or self.name), key=self.name)
            return {"FINISHED"}
        return guarded(self, work)


#: The name of the image the last run in this session made: a preset saved after it takes its picture.
_last_image = None
#: A user preset's picture is at most this many pixels across (the shipped ones' size, tools/thumbnails.py).
THUMBNAIL_SIZE = 160


def save_thumbnail(preset_path, image):
    """Write ``image`` (the last run's result), made small, as the picture of the user preset file
    ``preset_path`` (the PNG next to it), or remove an older picture of that preset where there is no image;
    returns what the report adds ("" when all went well)."""
    from . import images
    from .panel import thumbnail_path

    path = thumbnail_path(preset_path)
    if image is None:
        return remove_thumbnail(preset_path)
    try:
        pixels = images.image_to_array(image)[..., :3]
        step = max(1, -(-max(pixels.shape[:2]) // THUMBNAIL_SIZE))         # at most THUMBNAIL_SIZE across
        h, w = (n // step * step for n in pixels.shape[:2])
        small = pixels[:h, :w].reshape(h // step, step, w // step, step, 3).mean(axis=(1, 3))
        temporary = images.array_to_image("cp_stylize_thumbnail", small)
        try:
            partial = path + ".part"
            images.write_file(temporary, partial, "PNG")
            os.replace(partial, path)
        finally:
            bpy.data.images.remove(temporary)
    except (OSError, RuntimeError, ValueError) as err:
        return f" (without a picture: {err})"
    return f", with a picture of {image.name!r}"


def remove_thumbnail(preset_path):
    """Remove the picture of the user preset file ``preset_path``, if it has one; returns what the report adds
    ("" when all went well)."""
    from .panel import thumbnail_path

    path = thumbnail_path(preset_path)
    try:
        os.remove(path)
    except FileNotFoundError:
        pass
    except OSError as err:
        return f" (its picture {path!r} stays: {err.strerror or err})"
    return ""


class CP_STYLIZE_OT_preset_add(bpy.types.Operator):
    """Save the panel's settings as a user preset (never over another preset)"""

    bl_idname = "cp_stylize.preset_add"
    bl_label = "Add Preset"
    bl_options = {"REGISTER", "INTERNAL"}

    name: bpy.props.StringProperty(name="Name", default="My Preset")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        from ..presets import save_user_preset

        panel = context.scene.cp_stylize

        def work():
            settings = panel.to_settings().replace(description="user preset")
            key, path, replaced = save_user_preset(settings, user_preset_dir(create=True), self.name)
            panel.preset_name, panel.preset_key = self.name.strip(), key
            picture = save_thumbnail(path, bpy.data.images.get(_last_image) if _last_image else None)
            self.report({"INFO"}, f"{'replaced' if replaced else 'saved'} the preset {self.name.strip()!r} in {path}"
                                  f"{picture}")
            return {"FINISHED"}
        return guarded(self, work)


class CP_STYLIZE_OT_preset_remove(bpy.types.Operator):
    """Remove a user preset (shipped presets cannot be removed)"""

    bl_idname = "cp_stylize.preset_remove"
    bl_label = "Remove Preset"
    bl_options = {"REGISTER", "INTERNAL"}

    name: bpy.props.StringProperty(name="Preset", description="The preset's key, or its file's path")

    def execute(self, context):
        from ..presets import remove_user_preset

        def work():
            path = remove_user_preset(self.name, user_preset_dir())
            picture = remove_thumbnail(path)
            self.report({"INFO"}, f"removed the preset {self.name!r} ({path}){picture}")
            return {"FINISHED"}
        return guarded(self, work)


class CP_STYLIZE_OT_palette_add(bpy.types.Operator):
    """Add a colour to the noise palette"""

    bl_idname = "cp_stylize.palette_add"
    bl_label = "Add Colour"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    def execute(self, context):
        context.scene.cp_stylize.palette.add()
        return {"FINISHED"}


class CP_STYLIZE_OT_palette_remove(bpy.types.Operator):
    """Remove a colour from the noise palette"""

    bl_idname = "cp_stylize.palette_remove"
    bl_label = "Remove Colour"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    index: bpy.props.IntProperty()

    def execute(self, context):
        palette = context.scene.cp_stylize.palette
        if 0 <= self.index < len(palette):
            palette.remove(self.index)
        return {"FINISHED"}


classes = (
    OBJECT_OT_cp_stylize_estimate,
    OBJECT_OT_cp_stylize,
    CP_STYLIZE_OT_release,
    CP_STYLIZE_OT_preset_load,
    CP_STYLIZE_OT_preset_add,
    CP_STYLIZE_OT_preset_remove,
    CP_STYLIZE_OT_palette_add,
    CP_STYLIZE_OT_palette_remove,
)
