"""Blender extension entry point: the add-on lives in cp_stylize.blender (loaded when it is registered)."""


def register():
    from .cp_stylize.blender import register as register_addon

    register_addon()


def unregister():
    from .cp_stylize.blender import unregister as unregister_addon

    unregister_addon()
