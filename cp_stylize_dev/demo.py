"""The main job: ``python -m cp_stylize demo --out DIR``.

Builds a scene with Suzanne (two subdivision levels) textured with a
photograph that ships with Blender (wrapped around her: :func:`wrapped_photo`),
runs the Starry Night preset on it with the Stylize operator and writes ``demo.blend``, ``before.png``, ``after.png``
(Cycles renders) and ``texture.png`` (the stylized texture).
"""

import os
import time

import bpy

from cp_stylize.blender import images

from . import scene


#: Texels a side of the demo's texture, and the panorama's longitude that faces the front view (degrees).
TEXTURE_SIZE = 2048
FACING = 90.0


def build_scene(texture_name="forest", levels=2):
    """Suzanne with a Subdivision modifier (``levels``) and a material reading, through her UVs, a photograph
    wrapped around her (:func:`wrapped_photo`)."""
    scene.reset()
    bpy.ops.mesh.primitive_monkey_add(size=2.0)
    obj = bpy.context.active_object
    obj.name = "Suzanne"
    modifier = obj.modifiers.new("Subdivision", "SUBSURF")
    modifier.levels = modifier.render_levels = levels
    bpy.ops.object.shade_smooth()
    obj.rotation_euler = (0.0, 0.0, 0.0)
    source = images.array_to_image("demo_texture", wrapped_photo(obj, scene.photo_texture(texture_name)))
    material = scene.new_material("Demo", source)
    obj.data.materials.append(material)
    return obj, material, source


def wrapped_photo(obj, panorama, size=TEXTURE_SIZE, facing=FACING):
    """A texture (size, size, 3) in ``obj``'s UVs showing at each point of its surface the equirectangular
    ``panorama`` (H, W, 3) in that point's direction from the object's centre, as if the photograph were
    projected onto it from inside: one continuous picture over the surface, whatever its UV seams (Suzanne's
    own texture coordinates cut her head in two, so the photograph read through them breaks down her brow).
    Texels outside the UV islands take their nearest island texel's colour."""
    import numpy as np

    from cp_stylize import raster
    from cp_stylize.blender import meshdata
    from cp_stylize.texture import bilinear

    data = meshdata.read(obj)
    uv = data.uv_maps[data.render_uv]
    texels, triangles, bary, _ = raster.rasterise(uv, size)
    corners = data.vertices[data.triangles[triangles]]
    points = np.einsum("mk,mkd->md", bary.astype(np.float64), corners)
    low, high = data.vertices.min(axis=0), data.vertices.max(axis=0)
    d = points - (low + high) / 2
    longitude = np.arctan2(d[:, 1], -d[:, 0]) / (2 * np.pi) + 0.5 + facing / 360.0
    latitude = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1])) / np.pi + 0.5
    colours = bilinear(panorama[..., :3], np.column_stack([longitude, latitude]), wrap=("repeat", "clamp"))
    nearest = raster.nearest_texels(texels, size)
    return np.stack([raster.nearest_filled(colours[:, c], texels, size, nearest) for c in range(3)],
                    axis=-1).astype(np.float32)


def run(out_dir, *, preset="starry_night", quality="STANDARD", image_size="1024", resolution=(480, 400),
        samples=16, log=print):
    """Run the demo and write its four files into ``out_dir``; returns their paths."""
    from cp_stylize.blender import register, unregister
    from cp_stylize.texture import write_png

    os.makedirs(out_dir, exist_ok=True)
    obj, material, source = build_scene()
    scene.setup_render(resolution, samples)
    scene.frame_objects([obj], margin=1.05)
    paths = {name: os.path.join(out_dir, name) for name in ("before.png", "after.png", "texture.png", "demo.blend")}
    scene.render(paths["before.png"])

    registered = hasattr(bpy.types, "OBJECT_OT_cp_stylize")  # the add-on may be enabled already
    if not registered:
        register()
    try:
        settings = bpy.context.scene.cp_stylize
        bpy.ops.cp_stylize.preset_load(name=preset)
        settings.quality = quality
        settings.image_size = image_size
        start = time.perf_counter()
        bpy.context.view_layer.objects.active = obj
        result = bpy.ops.object.cp_stylize()
        if result != {"FINISHED"}:
            raise RuntimeError(f"the Stylize operator returned {result}")
        log(f"{preset} on {obj.name}: {time.perf_counter() - start:.1f} s")
        stylized = bpy.data.images[f"{obj.name}_stylized"]
        write_png(paths["texture.png"], images.image_to_array(stylized))
        scene.render(paths["after.png"])
        source.pack()
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(paths["demo.blend"]))
    finally:
        if not registered:
            unregister()
    for path in paths.values():
        log(f"wrote {path}")
    return paths


def save_mesh_arrays(path, texture_name="forest", levels=2):
    """Write the demo's textured Suzanne (``levels`` of subdivision) as plain arrays (``.npz``) for runs
    without Blender.

    Keys: ``vertices`` (V, 3) in world units, ``faces`` (F, 3), ``uvs`` (F, 3, 2)
    and ``image`` (H, W, 3), the sRGB texture read through ``uvs`` on every face.
    """
    import numpy as np

    from cp_stylize.blender.stylize import prepare
    from cp_stylize.presets import StylizeSettings

    obj, _, _ = build_scene(texture_name, levels)
    job = prepare(obj, StylizeSettings())
    (texture,) = job.colours.textures
    if not np.all(texture.faces):
        raise RuntimeError("the demo texture should cover every face")
    np.savez(path, vertices=job.mesh.vertices, faces=job.mesh.triangles, uvs=texture.uvs, image=texture.image)
    scene.reset()
    return path
