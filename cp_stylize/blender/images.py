"""Pixels between Blender images and NumPy arrays (row 0 at the bottom, as Blender stores them)."""

import bpy
import numpy as np


def image_to_array(image):
    """RGBA pixels of a Blender image as a float32 array (H, W, 4)."""
    w, h = image.size
    if w == 0 or h == 0:
        raise ValueError(f"image {image.name!r} has no pixels (is its file missing?)")
    buf = np.empty(w * h * 4, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return buf.reshape(h, w, 4)


def array_to_image(name, array, *, colorspace="sRGB", float_buffer=False):
    """A new Blender image named ``name`` holding ``array`` (H, W, C) with C in {1, 3, 4}."""
    array = np.asarray(array, dtype=np.float32)
    h, w, c = array.shape
    rgba = np.ones((h, w, 4), dtype=np.float32)
    if c == 1:
        rgba[..., :3] = array
    else:
        rgba[..., :c] = array[..., :4]
    image = bpy.data.images.new(name, width=w, height=h, alpha=True, float_buffer=float_buffer)
    image.colorspace_settings.name = colorspace
    image.pixels.foreach_set(rgba.ravel())
    image.update()
    return image
