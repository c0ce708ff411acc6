"""Operators of the add-on."""

import bpy

from . import meshdata

#: Rough memory a band point takes during a run: E (64 float32 weights and
#: int32 indices), L, closest points and the work arrays of a colour run.
BYTES_PER_BAND_POINT = 1200


def band_estimate(obj, settings, depsgraph=None):
    """Grid spacing (world units), expected band points and bytes for ``obj`` at ``settings``."""
    from ..band import estimate_band_size

    verts, tris = meshdata.evaluated_triangles(obj, depsgraph)
    if len(tris) == 0:
        raise ValueError(f"the mesh {obj.name!r} has no faces")
    longest = float((verts.max(axis=0) - verts.min(axis=0)).max())
    h = settings.relative_spacing() * longest / 2.0
    n = estimate_band_size(meshdata.surface_area(verts, tris), h)
    return h, n, n * BYTES_PER_BAND_POINT


class OBJECT_OT_cp_stylize_estimate(bpy.types.Operator):
    """Estimate the grid spacing, band size and memory a run on the active object needs"""

    bl_idname = "object.cp_stylize_estimate"
    bl_label = "Estimate Band"
    bl_options = {"REGISTER"}

    band_points: bpy.props.IntProperty(name="Band Points", options={"SKIP_SAVE"})
    spacing: bpy.props.FloatProperty(name="Grid Spacing", options={"SKIP_SAVE"})

    @classmethod
    def poll(cls, context):
        return context.active_object is not None

    def execute(self, context):
        try:
            h, n, nbytes = band_estimate(context.active_object, context.scene.cp_stylize)
        except ValueError as err:
            self.report({"ERROR"}, str(err))
            return {"CANCELLED"}
        self.spacing, self.band_points = h, n
        self.report({"INFO"}, f"grid spacing {h:.4g}, about {n:,} band points, {nbytes / 2**20:.0f} MiB")
        return {"FINISHED"}


classes = (OBJECT_OT_cp_stylize_estimate,)
