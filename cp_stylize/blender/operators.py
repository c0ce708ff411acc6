"""Operators of the add-on: Stylize, the band estimate, presets and the noise palette."""

import os
import time

import bpy

from . import meshdata
from .properties import QUALITY_SPACING


def estimate(obj, settings, depsgraph=None):
    """``(h, points, bytes, seconds)`` of a run on ``obj`` with the core's StylizeSettings.

    ``h`` is the grid spacing in world units; raises ValueError for unusable objects.
    """
    from ..band import estimate_band_size
    from ..pipeline import estimate_run

    verts, tris = meshdata.evaluated_triangles(obj, depsgraph)
    if len(tris) == 0:
        raise ValueError(f"the mesh {obj.name!r} has no faces")
    longest = float((verts.max(axis=0) - verts.min(axis=0)).max())
    if longest <= 0:
        raise ValueError(f"the mesh {obj.name!r} has no extent")
    scale = 2.0 / longest
    stencil = "laplacian" if settings.mode == "gaussian" else "anisotropic"
    n = estimate_band_size(meshdata.surface_area(verts, tris) * scale**2, settings.spacing, stencil=stencil)
    seconds, nbytes = estimate_run(n, settings)
    return settings.spacing / scale, n, nbytes, seconds


class OBJECT_OT_cp_stylize_estimate(bpy.types.Operator):
    """Estimate the grid spacing, band size and memory a run on the active object needs"""

    bl_idname = "object.cp_stylize_estimate"
    bl_label = "Estimate Band"
    bl_options = {"REGISTER"}

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def execute(self, context):
        try:
            h, n, nbytes, seconds = estimate(context.active_object, context.scene.cp_stylize.to_settings())
        except ValueError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        self.report({"INFO"}, f"grid spacing {h:.4g}, about {n:,} band points, {nbytes / 2**20:.0f} MiB, "
                              f"roughly {seconds:.0f} s")
        return {"FINISHED"}


class OBJECT_OT_cp_stylize(bpy.types.Operator):
    """Stylize the active object's texture on its surface and wire the result into its material"""

    bl_idname = "object.cp_stylize"
    bl_label = "Stylize"
    bl_options = {"REGISTER", "UNDO"}

    preset: bpy.props.StringProperty(
        name="Preset", description="Run with this preset (a shipped preset's name or a TOML file) "
                                   "instead of the panel's filter settings", default="", options={"SKIP_SAVE"})
    quality: bpy.props.EnumProperty(
        name="Quality", description="With a preset: its own grid spacing, or one of the quality levels",
        items=[("PRESET", "Preset", "The preset's own grid spacing")]
        + [(k, k.title(), f"Relative grid spacing {v}") for k, v in QUALITY_SPACING.items()],
        default="PRESET", options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        return context.mode == "OBJECT"

    # -- shared steps ------------------------------------------------------------------------

    def _prepare(self, context):
        from ..presets import load_preset
        from . import stylize

        panel = context.scene.cp_stylize
        obj = context.active_object
        if obj is None:
            raise stylize.StylizeError("no active object")
        if obj.type != "MESH":
            raise stylize.StylizeError(f"{obj.name!r} is a {obj.type.lower()}, not a mesh")
        settings = load_preset(self.preset) if self.preset else panel.to_settings()
        if self.preset and self.quality != "PRESET":
            settings = settings.replace(spacing=QUALITY_SPACING[self.quality])
        settings = settings.replace(image_size=int(panel.image_size))
        _, n, nbytes, _ = estimate(obj, settings)
        if nbytes > panel.memory_limit * 2**30:
            raise stylize.StylizeError(
                f"this run needs about {nbytes / 2**30:.1f} GiB (about {n:,} band points), above the memory limit "
                f"of {panel.memory_limit:.1f} GiB: lower the quality or raise the limit")
        return stylize.prepare(obj, settings)

    def _finish(self, context, job):
        from . import stylize

        panel = context.scene.cp_stylize
        image = stylize.apply(job, image_name=panel.image_name, target=panel.target, storage=panel.storage)
        result = job.result
        self.report({"INFO"}, f"stylized {job.obj.name!r} into {image.name!r} in {result.seconds:.1f} s "
                              f"({result.band_size:,} band points, grid spacing {result.spacing:.4g})")

    def execute(self, context):
        from . import stylize

        try:
            job = self._prepare(context)
            stylize.run_core(job, log=print if bpy.app.background else None)
            self._finish(context, job)
        except (ValueError, RuntimeError, FloatingPointError, MemoryError) as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        return {"FINISHED"}

    # -- interactive: a worker thread, progress and Esc ---------------------------------------

    def invoke(self, context, event):
        from . import stylize

        if bpy.app.background:
            return self.execute(context)
        try:
            self._job = self._prepare(context)
        except (ValueError, RuntimeError) as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        self._run = stylize.BackgroundRun(self._job).start()
        self._start = time.perf_counter()
        wm = context.window_manager
        self._timer = wm.event_timer_add(0.2, window=context.window)
        wm.progress_begin(0, 100)
        wm.modal_handler_add(self)
        return {"RUNNING_MODAL"}

    def modal(self, context, event):
        run = self._run
        if event.type == "ESC" and event.value == "PRESS":
            run.cancel()
        if event.type != "TIMER":
            return {"PASS_THROUGH"}
        wm = context.window_manager
        wm.progress_update(int(100 * run.fraction))
        context.workspace.status_text_set(
            f"Stylizing {self._job.obj.name}: {100 * run.fraction:.0f} % "
            f"({time.perf_counter() - self._start:.0f} s), Esc to cancel")
        if not run.done:
            return {"RUNNING_MODAL"}
        wm.event_timer_remove(self._timer)
        wm.progress_end()
        context.workspace.status_text_set(None)
        if run.cancelled:
            self.report({"WARNING"}, "stylize cancelled; nothing was changed")
            return {"CANCELLED"}
        try:
            if run.error is not None:
                raise run.error
            self._finish(context, self._job)
        except (ValueError, RuntimeError, FloatingPointError, MemoryError, ReferenceError) as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        return {"FINISHED"}


# -- presets -------------------------------------------------------------------------------------


def user_preset_dir(create=False):
    """Folder of the user's presets in Blender's user config."""
    parts = __package__.split(".")
    if parts[0] == "bl_ext" and len(parts) >= 3:
        return bpy.utils.extension_path_user(".".join(parts[:3]), path="presets", create=create)
    return bpy.utils.user_resource("SCRIPTS", path=os.path.join("presets", "cp_stylize"), create=create)


def all_presets():
    """``{label: path}`` of shipped and user presets (user presets win on equal names)."""
    from ..presets import builtin_presets

    found = dict(builtin_presets())
    folder = user_preset_dir()
    if folder and os.path.isdir(folder):
        found.update({f[:-5]: os.path.join(folder, f) for f in sorted(os.listdir(folder)) if f.endswith(".toml")})
    return found


class CP_STYLIZE_OT_preset_load(bpy.types.Operator):
    """Load a preset into the panel's settings"""

    bl_idname = "cp_stylize.preset_load"
    bl_label = "Load Preset"
    bl_options = {"REGISTER", "UNDO", "INTERNAL"}

    name: bpy.props.StringProperty(name="Preset")

    def execute(self, context):
        from ..presets import load_preset

        path = all_presets().get(self.name, self.name)
        try:
            settings = load_preset(path)
        except ValueError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        context.scene.cp_stylize.from_settings(settings.replace(name=settings.name or self.name))
        return {"FINISHED"}


class CP_STYLIZE_OT_preset_add(bpy.types.Operator):
    """Save the panel's settings as a user preset"""

    bl_idname = "cp_stylize.preset_add"
    bl_label = "Add Preset"
    bl_options = {"REGISTER", "INTERNAL"}

    name: bpy.props.StringProperty(name="Name", default="My Preset")

    def invoke(self, context, event):
        return context.window_manager.invoke_props_dialog(self)

    def execute(self, context):
        from ..presets import save_preset

        file_name = bpy.path.clean_name(self.name).lower()
        if not self.name.strip() or not file_name.strip("_"):
            self.report({"ERROR"}, "a preset needs a name")
            return {"CANCELLED"}
        try:
            settings = context.scene.cp_stylize.to_settings().replace(name=self.name, description="user preset")
        except ValueError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        path = os.path.join(user_preset_dir(create=True), file_name + ".toml")
        save_preset(settings, path)
        context.scene.cp_stylize.preset_name = self.name
        self.report({"INFO"}, f"saved preset {self.name!r} to {path}")
        return {"FINISHED"}


class CP_STYLIZE_OT_preset_remove(bpy.types.Operator):
    """Remove a user preset (shipped presets cannot be removed)"""

    bl_idname = "cp_stylize.preset_remove"
    bl_label = "Remove Preset"
    bl_options = {"REGISTER", "INTERNAL"}

    name: bpy.props.StringProperty(name="Preset")

    def execute(self, context):
        folder = user_preset_dir()
        path = all_presets().get(self.name)
        if not path or not folder or os.path.dirname(path) != os.path.normpath(folder):
            self.report({"ERROR"}, f"{self.name!r} is not a user preset")
            return {"CANCELLED"}
        os.remove(path)
        self.report({"INFO"}, f"removed preset {self.name!r}")
        return {"FINISHED"}


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
    CP_STYLIZE_OT_preset_load,
    CP_STYLIZE_OT_preset_add,
    CP_STYLIZE_OT_preset_remove,
    CP_STYLIZE_OT_palette_add,
    CP_STYLIZE_OT_palette_remove,
)
