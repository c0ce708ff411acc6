"""Blender extension entry point: the add-on lives in cp_stylize.blender."""

from .cp_stylize.blender import register, unregister  # noqa: F401
