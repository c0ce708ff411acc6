"""Fixtures of the Blender tests: the add-on registered in a factory-fresh empty scene."""

import pytest


@pytest.fixture
def registered():
    """The add-on registered from the repository; yields the scene's settings."""
    import bpy

    import cp_stylize.blender as addon

    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon.register()
    yield bpy.context.scene.cp_stylize
    addon.unregister()


@pytest.fixture
def addon(registered):
    """The registered add-on's settings, at the quick preview quality and a 512 x 512 image."""
    registered.quality = "PREVIEW"
    registered.image_size = "512"
    return registered
