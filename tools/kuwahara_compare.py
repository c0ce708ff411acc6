"""Oil paint on the surface beside Blender's own Kuwahara node: across a UV seam and at a sphere's pole.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/kuwahara_compare.py --out docs/gallery

A UV sphere wears Blender's forest photograph.  Once its texture goes through
Blender's Kuwahara compositor node as an image (anisotropic; the settings of
:data:`cp_stylize_dev.scene.KUWAHARA_NODE`), as an artist would filter it
today; once the sphere is stylized with the Oil Paint preset, whose
anisotropic Kuwahara filter works on the surface.  Each is rendered from two
sides: facing the meridian where the UV map's two edges meet (``*_seam.jpg``)
and looking down on the north pole (``*_pole.jpg``); ``kuwahara_compare.jpg``
puts the four side by side.

The image filter cannot see across the seam, so the strokes break there, and
at the pole the image's rows are squeezed into a point, so its strokes turn
into a pinwheel; the surface filter has neither.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402

from cp_stylize_dev import figures, scene  # noqa: E402
from tools.gallery import build, save_jpeg  # noqa: E402

SIZE = 768
IMAGE_SIZE = 2048
PRESET = "oil_paint"


def seam_direction(obj):
    """The unit direction from the centre to the meridian where the sphere's UV map is cut."""
    uv = obj.data.uv_layers.active.data
    points = [obj.data.vertices[loop.vertex_index].co for loop in obj.data.loops
              if uv[loop.index].uv.x < 1e-4 and abs(obj.data.vertices[loop.vertex_index].co.z) < 0.5]
    direction = sum(points, Vector()) / max(len(points), 1)
    direction.z = 0.0
    return direction.normalized()


def view(obj, side, path, samples=24):
    """Render ``obj`` looking at its UV seam (``side`` "seam") or down on its north pole ("pole")."""
    scene.setup_render((SIZE, SIZE), samples)
    cam = bpy.context.scene.camera
    direction = Vector((0.0, 0.0, 1.0)) if side == "pole" else seam_direction(obj)
    cam.location = direction * 3.2
    cam.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 50
    key = bpy.data.objects["Key"]             # the key light from over the camera's shoulder
    key.rotation_euler = (-(direction + Vector((0.3, -0.3, 0.4)))).to_track_quat("-Z", "Y").to_euler()
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.quality = "JPEG", 92
    scene.render(path)
    return path


def run(out_dir, log=print):
    os.makedirs(out_dir, exist_ok=True)
    scene.reset()
    photo = scene.photo_texture("forest")
    start = time.perf_counter()
    filtered = scene.kuwahara_node(photo)
    log(f"Blender's Kuwahara node on the {photo.shape[1]} x {photo.shape[0]} photograph: "
        f"{time.perf_counter() - start:.1f} s")
    paths = []
    for side in ("seam", "pole"):
        node, _ = build("sphere", filtered)
        paths.append(view(node, side, os.path.join(out_dir, f"kuwahara_node_{side}.jpg")))
        obj, _ = build("sphere", photo)
        start = time.perf_counter()
        scene.stylize(obj, PRESET, None, IMAGE_SIZE)
        log(f"Oil Paint on the sphere: {time.perf_counter() - start:.1f} s")
        paths.append(view(obj, side, os.path.join(out_dir, f"kuwahara_surface_{side}.jpg")))
    labels = ["BLENDER NODE, SEAM", "ON THE SURFACE, SEAM", "BLENDER NODE, POLE", "ON THE SURFACE, POLE"]
    cells = [figures.panel(scene.read_image(p)[::2, ::2], label) for p, label in zip(paths, labels)]
    path = save_jpeg(os.path.join(out_dir, "kuwahara_compare.jpg"), figures.grid(cells, columns=2))
    log(f"wrote {path}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="gallery_out", help="output folder (default: gallery_out)")
    run(parser.parse_args(argv).out)


if __name__ == "__main__":
    main()
