"""The Blender add-on: settings, operators and the sidebar panel.

Only this sub-package imports ``bpy``.  The numerical core is imported inside
the operators' methods, so enabling the add-on stays cheap.
"""

import bpy

from . import operators, panel, properties

_classes = properties.classes + operators.classes + panel.classes


@bpy.app.handlers.persistent
def _release_on_load(*_):
    """A file is loaded: free what the last run kept for re-runs."""
    operators.release_kept()


def register():
    for cls in _classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.cp_stylize = bpy.props.PointerProperty(type=properties.CPStylizeSettings)
    bpy.app.handlers.load_pre.append(_release_on_load)


def unregister():
    if _release_on_load in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_release_on_load)
    operators.release_kept()
    panel.release_previews()
    del bpy.types.Scene.cp_stylize
    for cls in reversed(_classes):
        bpy.utils.unregister_class(cls)
