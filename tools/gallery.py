"""The painterly presets' gallery: each on Suzanne, the photo sphere and a city photograph, rendered with Cycles.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/gallery.py --out docs/gallery

Each preset is loaded and run with the Stylize operator at Standard quality
into a 2048 x 2048 image (:data:`IMAGE_SIZE`), as a user would, and the
object rendered at 1024 pixels: Suzanne (the demo's, two subdivision levels, Blender's forest photograph
wrapped around her) and a UV sphere wearing that photograph through its UVs, and a 2 x 1 frame wearing
Blender's city photograph (buildings, a crane, road markings), seen straight
on; and each subject wearing its photograph (``<subject>_photo.jpg``).  For
each stylized render a 100 % crop (``*_crop.jpg``, 384 x 384 pixels of the
render) shows the strokes as they are; one more render of Suzanne under a
raking light shows the relief, and Van Gogh Along the Form is rendered on
a torus too (``torus_van_gogh_form.jpg``), a form whose curvature has a
direction for its strokes to follow.  The sphere is rendered again from straight above its north
pole (``sphere_*_pole.jpg``), where a UV map pinches its picture and a filter in texture space pinches
with it.  ``gallery.jpg`` puts them side by
side at a third of their size, a row a preset.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import bpy  # noqa: E402
import numpy as np  # noqa: E402
from mathutils import Vector  # noqa: E402

from cp_stylize.blender import images  # noqa: E402
from cp_stylize_dev import demo, figures, scene  # noqa: E402

PRESETS = ("starry_night", "van_gogh_form", "sunflower_vase")
SUBJECTS = ("suzanne", "sphere", "city")
SIZE = 1024
#: The stylized image's size: a 1024-pixel render of an object shows about half of its texture, so a
#: 2048-pixel image gives each pixel of Suzanne's render about a texel of its own (the texel density a
#: studio sets for a hero asset seen at that size); the sphere's UV map spreads its image over the whole
#: of its parallels, so at its equator, seen face on, a texel spans about 1.4 pixels of the render.
IMAGE_SIZE = 2048
#: The crop of each render at full size: (row, column) of its top left corner, as shares of the render.
CROPS = {"suzanne": (0.22, 0.3), "sphere": (0.32, 0.32), "city": (0.05, 0.35), "torus": (0.25, 0.12)}
#: Cycles's pixel filter width (pixels; its default is 1.5): one pixel, so that a 100 % crop shows the strokes'
#: edges as sharp as the texture has them, not softened again by the render.
PIXEL_FILTER = 1.0
#: Cycles samples of the raking-light render (the others take 24).
RAKING_SAMPLES = 128
#: The preset shown on a torus as well, and the torus's photograph.
FORM_PRESET = "van_gogh_form"
CROP = 384


def build(kind, texture=None):
    """A fresh scene with the subject wearing its photograph (or ``texture``, an image array, for the sphere,
    the torus and the frame); returns the object and the render's size."""
    if kind == "suzanne":
        obj, _, _ = demo.build_scene()
        return obj, (SIZE, SIZE)
    scene.reset()
    if texture is None:
        texture = scene.photo_texture("city" if kind == "city" else "forest")
    material = scene.new_material("Gallery", images.array_to_image("gallery_photo", texture))
    if kind == "sphere":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=128, ring_count=64, radius=1.0)
        obj = bpy.context.active_object
        bpy.ops.object.shade_smooth()
        size = (SIZE, SIZE)
    elif kind == "torus":
        bpy.ops.mesh.primitive_torus_add(major_segments=96, minor_segments=48, major_radius=1.0, minor_radius=0.4)
        obj = bpy.context.active_object
        obj.rotation_euler = (math.radians(55), 0.0, 0.0)
        bpy.ops.object.shade_smooth()
        size = (SIZE, SIZE)
    else:
        bpy.ops.mesh.primitive_plane_add(size=1.0)
        obj = bpy.context.active_object
        obj.scale = (2.0, 1.0, 1.0)
        size = (SIZE, SIZE // 2)
        # a framed photograph, not a tiling texture: its top edge is not blended with its bottom row's road
        next(n for n in material.node_tree.nodes if n.type == "TEX_IMAGE").extension = "EXTEND"
    obj.name = kind.title()
    obj.data.materials.append(material)
    return obj, size


def frame(kind, obj, raking=False):
    """The camera and light for ``kind``: front views of the objects, the frame seen straight on."""
    cam = bpy.context.scene.camera
    key = bpy.data.objects["Key"]
    if kind == "city":
        cam.data.type = "ORTHO"
        cam.data.ortho_scale = 2.0
        cam.location = Vector((0.0, 0.0, 3.0))
        cam.rotation_euler = (0.0, 0.0, 0.0)
        key.rotation_euler = (math.radians(35), 0.0, math.radians(30))
    else:
        scene.frame_objects([obj], margin=0.62 if kind == "sphere" else 0.75)
    if raking:   # a low light from the side: the paint's ridges cast their shading
        key.rotation_euler = (math.radians(78), 0.0, math.radians(75))
        key.data.energy = 4.0


def unlit(obj):
    """Show the object's textures as they are, lit by nothing, as an unlit game shader shows them: each
    material's surface becomes an emission of what feeds its Principled BSDF's Base Color (the scene's
    view transform is Standard, so the render shows its colours as they are)."""
    for slot in obj.material_slots:
        tree = slot.material.node_tree
        output = next(n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.is_active_output)
        bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
        emission = tree.nodes.new("ShaderNodeEmission")
        tree.links.new(bsdf.inputs["Base Color"].links[0].from_socket, emission.inputs["Color"])
        tree.links.new(emission.outputs["Emission"], output.inputs["Surface"])


def from_above(obj):
    """The camera straight above the object's north pole, as far from its centre as before, looking down: the
    pole, where a UV sphere's map pinches its picture, seen face on."""
    cam = bpy.context.scene.camera
    centre = obj.matrix_world.translation
    cam.location = centre + Vector((0.0, 0.0, (cam.location - centre).length))
    cam.rotation_euler = (0.0, 0.0, 0.0)


def render(kind, preset, path, *, raking=False, samples=24, quality="STANDARD", shown_unlit=False, pole=None,
           log=print):
    """Run ``preset`` on ``kind`` with the Stylize operator and render it to ``path`` (JPEG); returns seconds.
    ``preset`` None renders the photograph itself; ``shown_unlit``: as an unlit shader shows it (:func:`unlit`);
    ``pole``: the same object rendered again from straight above (:func:`from_above`) to this path."""
    obj, size = build(kind)
    scene.setup_render(size, samples)
    bpy.context.scene.cycles.filter_width = PIXEL_FILTER
    frame(kind, obj, raking)
    start = time.perf_counter()
    if preset is not None:
        scene.stylize(obj, preset, quality, IMAGE_SIZE)
    seconds = time.perf_counter() - start
    if shown_unlit:
        unlit(obj)
    settings = bpy.context.scene.render.image_settings
    settings.file_format, settings.quality = "JPEG", 92
    scene.render(path)
    if pole is not None:
        from_above(obj)
        scene.render(pole)
    log(f"{kind:8s} {preset or 'photograph':15s} {seconds:6.1f} s  {path}")
    return seconds


def save_jpeg(path, pixels):
    """Write a float image (H, W, 3), row 0 at the top, as a JPEG."""
    h, w, _ = pixels.shape
    image = bpy.data.images.new("gallery_out", w, h)
    try:
        rgba = np.ones((h, w, 4), np.float32)
        rgba[..., :3] = np.clip(pixels[::-1], 0, 1)
        image.pixels.foreach_set(rgba.ravel())
        image.filepath_raw, image.file_format = path, "JPEG"
        bpy.context.scene.render.image_settings.quality = 92
        image.save()
    finally:
        bpy.data.images.remove(image)
    return path


def crop(path, kind):
    """The 100 % crop of a render: CROP x CROP pixels at :data:`CROPS` of the render."""
    pixels = scene.read_image(path)
    r, c = (int(share * n) for share, n in zip(CROPS[kind], pixels.shape[:2]))
    return save_jpeg(path.replace(".jpg", "_crop.jpg"), pixels[r:r + CROP, c:c + CROP])


def run(out_dir, *, presets=PRESETS, subjects=SUBJECTS, quality="STANDARD", relief=True, unlit_too=False, log=print):
    os.makedirs(out_dir, exist_ok=True)
    for kind in subjects:            # the photographs themselves, to compare against
        render(kind, None, os.path.join(out_dir, f"{kind}_photo.jpg"), log=log,
               pole=os.path.join(out_dir, f"{kind}_photo_pole.jpg") if kind == "sphere" else None)
    if unlit_too:                    # and each render again as an unlit shader shows it
        for kind in subjects:
            render(kind, None, os.path.join(out_dir, f"{kind}_photo_unlit.jpg"), shown_unlit=True, log=log)
            for preset in presets:
                path = os.path.join(out_dir, f"{kind}_{preset}_unlit.jpg")
                render(kind, preset, path, quality=quality, shown_unlit=True, log=log)
                crop(path, kind)
    rows = []
    for preset in presets:
        cells = []
        for kind in subjects:
            path = os.path.join(out_dir, f"{kind}_{preset}.jpg")
            pole = os.path.join(out_dir, f"{kind}_{preset}_pole.jpg") if kind == "sphere" else None
            render(kind, preset, path, quality=quality, pole=pole, log=log)
            crop(path, kind)
            if pole is not None:          # a UV map's pole, where a texture-space filter pinches
                crop(pole, kind)
            cells.append(figures.panel(scene.read_image(path)[::3, ::3], f"{preset.replace('_', ' ').upper()}, {kind.upper()}"))
        rows.append(cells)
    if FORM_PRESET in presets:
        render("torus", None, os.path.join(out_dir, "torus_photo.jpg"), log=log)
        path = os.path.join(out_dir, f"torus_{FORM_PRESET}.jpg")
        render("torus", FORM_PRESET, path, log=log)
        crop(path, "torus")
    if relief:
        _relief(out_dir, log)
    sheet = figures.grid([cell for row in rows for cell in row], columns=len(subjects))
    path = save_jpeg(os.path.join(out_dir, "gallery.jpg"), sheet)
    log(f"wrote {path}")
    return path


def _relief(out_dir, log):
    """Suzanne in Sunflower Vase under a raking light, and its 100 % crop."""
    raking = os.path.join(out_dir, "relief_raking.jpg")
    # the raking light leaves much of the head in shadow, lit only by the world: more samples, or its path
    # tracing noise reads as a grain in the paint
    render("suzanne", "sunflower_vase", raking, raking=True, samples=RAKING_SAMPLES, log=log)
    crop(raking, "suzanne")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="gallery_out", help="output folder (default: gallery_out)")
    parser.add_argument("--presets", nargs="+", default=list(PRESETS))
    parser.add_argument("--subjects", nargs="+", default=list(SUBJECTS))
    parser.add_argument("--quality", default="STANDARD", choices=["PREVIEW", "STANDARD", "HIGH", "PRESET"],
                        help="the grid (default: STANDARD); PRESET: each preset's own")
    parser.add_argument("--no-relief", action="store_true", help="leave out the render under a raking light")
    parser.add_argument("--unlit", action="store_true",
                        help="render each also as an unlit shader shows it (<subject>_<preset>_unlit.jpg)")
    args = parser.parse_args(argv)
    run(args.out, presets=args.presets, subjects=args.subjects,
        quality=None if args.quality == "PRESET" else args.quality, relief=not args.no_relief, unlit_too=args.unlit)


if __name__ == "__main__":
    main()
