"""The Blender add-on: settings, operators and the sidebar panel.

Only this sub-package imports ``bpy``.  The numerical core is imported inside
the operators' methods, so enabling the add-on stays cheap.
"""

import bpy

from . import operators, panel, properties

_classes = properties.classes + operators.classes + panel.classes


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.cp_stylize = bpy.props.PointerProperty(type=properties.CPStylizeSettings)


def unregister():
    del bpy.types.Scene.cp_stylize
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
