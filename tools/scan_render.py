"""A scan's colour attribute denoised into a new colour attribute, rendered before and after with Cycles.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/scan_render.py --out docs/gallery

The scan is a sphere of 320,000 vertices whose surface is rough at a tenth of
an edge (as a photogrammetry mesh is) and which has no UV map: its colour is
a point colour attribute, Blender's forest photograph read at each vertex with
noise of standard deviation 0.08 added, as a scan's colour is noisy.  The
Denoise (EED) preset runs with *Result: Colour Attribute*, as a user would:
its vertices lie closer than the grid, so the filter runs on the mesh's own
finite elements, and the result is a new colour attribute.  Writes
``scan_before.jpg`` and ``scan_after.jpg`` (1024 x 1024) with their 100 %
crops (``*_crop.jpg``), and prints the run's report with the PSNR of the colours against the
photograph's before and after.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from cp_stylize_dev import scene  # noqa: E402

SIZE = 1024
#: The 100 % crop: CROP x CROP pixels with this top-left corner (shares of the render's height and width).
CROP, CORNER = 384, (0.3, 0.3)
NOISE = 0.08


def build():
    """The scan: a rough sphere without UVs, its colour the forest photograph with noise in a point attribute,
    shown by a Color Attribute node."""
    scene.reset()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=800, ring_count=400, radius=1.0)
    obj = bpy.context.active_object
    obj.name = "Scan"
    bpy.ops.object.shade_smooth()
    mesh = obj.data
    while mesh.uv_layers:
        mesh.uv_layers.remove(mesh.uv_layers[0])
    co = np.empty(3 * len(mesh.vertices))
    mesh.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    rng = np.random.default_rng(0)
    edge = 2 * np.pi / 800
    co *= (1.0 + 0.1 * edge * rng.standard_normal(len(co)))[:, None]
    mesh.vertices.foreach_set("co", co.ravel())
    photo = scene.photo_texture("forest")[..., :3]
    h, w, _ = photo.shape
    x, y, z = (co / np.linalg.norm(co, axis=1, keepdims=True)).T
    u = (np.arctan2(y, x) / (2 * np.pi) + 0.5) % 1.0
    v = np.arccos(np.clip(-z, -1, 1)) / np.pi          # row 0 at the bottom, as Blender stores images
    clean = photo[np.minimum((v * h).astype(int), h - 1), np.minimum((u * w).astype(int), w - 1)]
    rgb = np.clip(clean + NOISE * rng.standard_normal(clean.shape), 0.0, 1.0)
    attribute = mesh.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    attribute.data.foreach_set("color_srgb", np.concatenate([rgb, np.ones((len(co), 1))], 1).astype("f4").ravel())
    mesh.color_attributes.active_color = attribute
    mesh.materials.append(scene.attribute_material("Scan", "Col"))
    return obj, clean


def psnr(obj, name, clean):
    """The PSNR (dB) of the colour attribute ``name`` against the clean colours."""
    attribute = obj.data.color_attributes[name]
    values = np.empty(4 * len(attribute.data), dtype=np.float32)
    attribute.data.foreach_get("color_srgb", values)
    return 10 * np.log10(1.0 / np.mean((values.reshape(-1, 4)[:, :3] - clean) ** 2))


def crop(path):
    pixels = scene.read_image(path)
    r, c = (int(share * n) for share, n in zip(CORNER, pixels.shape[:2]))
    out = pixels[r:r + CROP, c:c + CROP]
    image = bpy.data.images.new("crop", CROP, CROP)
    rgba = np.ones((CROP, CROP, 4), np.float32)
    rgba[..., :3] = np.clip(out[::-1], 0, 1)
    image.pixels.foreach_set(rgba.ravel())
    image.filepath_raw, image.file_format = path.replace(".jpg", "_crop.jpg"), "JPEG"
    image.save()
    bpy.data.images.remove(image)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--out", default="docs/gallery")
    parser.add_argument("--samples", type=int, default=24)
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    obj, clean = build()
    scene.setup_render((SIZE, SIZE), args.samples)
    scene.frame_objects([obj], margin=0.62)
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.quality = "JPEG", 92
    before = os.path.join(args.out, "scan_before.jpg")
    scene.render(before)
    crop(before)
    from cp_stylize.blender import register, unregister

    register()
    try:
        bpy.context.scene.cp_stylize.result_kind = "ATTRIBUTE"
        bpy.context.view_layer.objects.active = obj
        start = time.perf_counter()
        result = bpy.ops.object.cp_stylize(preset="denoise_eed")
        print(f"{result}, {time.perf_counter() - start:.1f} s; attributes: "
              f"{[a.name for a in obj.data.color_attributes]}, UV maps: {len(obj.data.uv_layers)}, images: "
              f"{[i.name for i in bpy.data.images]}; PSNR against the clean colours {psnr(obj, 'Col', clean):.1f} dB "
              f"before, {psnr(obj, 'Col_stylized', clean):.1f} dB after")
    finally:
        unregister()
    after = os.path.join(args.out, "scan_after.jpg")
    scene.render(after)
    crop(after)


if __name__ == "__main__":
    main()
