"""The add-on's settings, stored on the scene as ``scene.cp_stylize``.

Lengths are relative to the object's size: the object is normalised so that
its longest side is 2 (as in the paper), so a setting looks the same on a
2 cm object and on a 20 m one.
"""

import bpy

#: Grid spacing relative to an object whose longest side is 2, by quality.
QUALITY_SPACING = {"PREVIEW": 0.02, "STANDARD": 0.01, "HIGH": 0.008}


class CPStylizeSettings(bpy.types.PropertyGroup):
    quality: bpy.props.EnumProperty(
        name="Quality",
        description="Grid spacing of the computational band, relative to the object's size",
        items=[
            ("PREVIEW", "Preview", "Coarse grid (h = 0.02 for an object 2 units long): quick"),
            ("STANDARD", "Standard", "h = 0.01 for an object 2 units long"),
            ("HIGH", "High", "h = 0.008 for an object 2 units long: fine strokes, slow"),
            ("CUSTOM", "Custom", "Set the relative grid spacing yourself"),
        ],
        default="PREVIEW",
    )
    spacing: bpy.props.FloatProperty(
        name="Grid Spacing",
        description="Relative grid spacing h for an object whose longest side is 2",
        default=0.01, min=0.002, max=0.1, precision=4, step=0.1,
    )

    def relative_spacing(self):
        return self.spacing if self.quality == "CUSTOM" else QUALITY_SPACING[self.quality]


classes = (CPStylizeSettings,)
