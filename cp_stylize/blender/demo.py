"""The main job: ``python -m cp_stylize demo --out DIR``.

Builds a scene with a textured object from Blender's own data, stylizes its
texture on the surface and writes ``demo.blend``, ``before.png``,
``after.png`` (Cycles renders) and ``texture.png`` (the stylized texture).
"""

import os
import time

import bpy

from . import images, scene


def run(out_dir, *, spacing=0.02, smoothing_time=0.0005, resolution=(480, 360), samples=16, log=print):
    """Run the demo and write its four files into ``out_dir``; returns their paths."""
    from .. import Band, Sphere, heat
    from ..texture import bake_map, sample_map, write_png

    os.makedirs(out_dir, exist_ok=True)
    scene.reset()
    texture = scene.photo_texture("forest")
    source = images.array_to_image("demo_texture", texture)
    material = scene.new_material("Demo", source)
    obj = scene.add_uv_sphere("Globe", radius=1.0, material=material)
    scene.setup_render(resolution, samples)
    scene.frame_objects([obj])
    paths = {name: os.path.join(out_dir, name) for name in ("before.png", "after.png", "texture.png", "demo.blend")}
    scene.render(paths["before.png"])

    start = time.perf_counter()
    band = Band.build(Sphere(1.0), spacing)
    values = sample_map(band, texture)
    smoothed = heat(band, values, smoothing_time)
    result = bake_map(band, smoothed, *texture.shape[:2]).clip(0.0, 1.0)
    log(f"surface heat smoothing: {band.size:,} band points at h = {spacing}, "
        f"t = {smoothing_time}, {time.perf_counter() - start:.1f} s")

    stylized = images.array_to_image(f"{obj.name}_stylized", result)
    stylized.filepath_raw = paths["texture.png"]
    stylized.file_format = "PNG"
    copy = material.copy()
    copy.name = f"{material.name}_stylized"
    tex = next(n for n in copy.node_tree.nodes if n.type == "TEX_IMAGE")
    tex.image = stylized
    obj.data.materials[0] = copy
    material.use_fake_user = True  # the original stays in the file, to switch back to
    scene.render(paths["after.png"])
    write_png(paths["texture.png"], result)
    stylized.pack()
    source.pack()
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(paths["demo.blend"]))
    for name, path in paths.items():
        log(f"wrote {path}")
    return paths
