"""The sidebar panel: View3D > Sidebar > Stylize."""

import bpy


class VIEW3D_PT_cp_stylize(bpy.types.Panel):
    bl_idname = "VIEW3D_PT_cp_stylize"
    bl_label = "Stylize"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Stylize"

    def draw(self, context):
        settings = context.scene.cp_stylize
        layout = self.layout
        layout.use_property_split = True
        layout.prop(settings, "quality")
        if settings.quality == "CUSTOM":
            layout.prop(settings, "spacing")
        layout.operator("object.cp_stylize_estimate", icon="INFO")


classes = (VIEW3D_PT_cp_stylize,)
