"""Every preset on Suzanne and on the photo sphere, rendered with Cycles: one contact sheet.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/contact_sheet.py --out sheet_out
    python tools/contact_sheet.py --out sheet_out --quality standard --docs docs/presets.png

Each cell is its own scene: Suzanne (the demo's, two subdivision levels) or a
UV sphere, both wearing Blender's forest photograph (the sphere through its
UVs, Suzanne wrapped around her, :func:`cp_stylize_dev.demo.wrapped_photo`); the
preset is loaded and run with the Stylize operator, as a user would, and the
object rendered.  The first cell of each object is the photograph itself.  Writes each
render (``<object>_<preset>.png``) and the sheet (``contact_sheet.png``) into
``--out``, and with ``--docs`` a copy of the sheet at half size.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bpy  # noqa: E402
import numpy as np  # noqa: E402

from cp_stylize.blender import images  # noqa: E402
from cp_stylize.presets import builtin_presets, load_preset  # noqa: E402
from cp_stylize_dev import demo, figures, scene  # noqa: E402

OBJECTS = ("suzanne", "sphere")


def build(kind):
    """A fresh scene with the object, textured with the forest photograph; returns the object."""
    if kind == "suzanne":
        obj, _, _ = demo.build_scene()
        return obj
    scene.reset()
    source = images.array_to_image("sheet_texture", scene.photo_texture("forest"))
    material = scene.new_material("Sheet", source)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=1.0)
    obj = bpy.context.active_object
    obj.name = "Sphere"
    bpy.ops.object.shade_smooth()
    obj.data.materials.append(material)
    return obj


def render_cell(kind, preset, path, quality, resolution, samples):
    """Render ``kind`` after ``preset`` (None: the photograph itself) to ``path``; returns seconds."""
    obj = build(kind)
    scene.setup_render(resolution, samples)
    scene.frame_objects([obj], margin=0.62)   # the box's diagonal: the object fills the frame
    start = time.perf_counter()
    if preset is not None:
        scene.stylize(obj, preset, quality)
    seconds = time.perf_counter() - start
    scene.render(path)
    return seconds


def run(out_dir, *, quality="preview", resolution=(320, 280), samples=8, docs=None, columns=5, log=print):
    os.makedirs(out_dir, exist_ok=True)
    presets = [None] + list(builtin_presets())
    cells = []
    for kind in OBJECTS:
        for preset in presets:
            path = os.path.join(out_dir, f"{kind}_{preset or 'photo'}.png")
            seconds = render_cell(kind, preset, path, quality, resolution, samples)
            label = "PHOTOGRAPH" if preset is None else load_preset(preset).name.upper()
            log(f"{kind:8s} {preset or 'photograph':22s} {seconds:6.1f} s  {path}")
            cells.append(figures.panel(scene.read_image(path), label))
        cells += [np.zeros((1, 1, 3))] * (-len(cells) % columns)      # each object starts a row
    sheet = figures.grid(cells, columns=columns)
    path = os.path.join(out_dir, "contact_sheet.png")
    figures.save(path, sheet)
    log(f"wrote {path}")
    if docs:
        half = sheet[: sheet.shape[0] // 2 * 2, : sheet.shape[1] // 2 * 2]
        half = 0.25 * (half[0::2, 0::2] + half[1::2, 0::2] + half[0::2, 1::2] + half[1::2, 1::2])
        figures.save(docs, half)
        log(f"wrote {docs}")
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="sheet_out", help="output folder (default: sheet_out)")
    parser.add_argument("--quality", default="preview", choices=["preview", "standard", "high"],
                        help="grid spacing of every run (default: preview, a few minutes in all)")
    parser.add_argument("--samples", type=int, default=8, help="Cycles samples a render (default: 8)")
    parser.add_argument("--docs", help="also write the sheet at half size to this PNG")
    args = parser.parse_args(argv)
    run(args.out, quality=args.quality, samples=args.samples, docs=args.docs)


if __name__ == "__main__":
    main()
