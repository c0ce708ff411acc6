"""Scene building blocks of the Blender tests: images, materials and objects."""

import os

import bpy
import numpy as np

RED, BLUE, GREEN = (0.9, 0.1, 0.1), (0.1, 0.2, 0.9), (0.1, 0.8, 0.2)


def new_image(name, rgb, *, colorspace="sRGB", float_buffer=False, pack=True):
    """An image holding the colours ``rgb`` (H, W, 3), row 0 at the bottom."""
    h, w, _ = rgb.shape
    image = bpy.data.images.new(name, w, h, float_buffer=float_buffer)
    if image.colorspace_settings.name != colorspace:
        image.colorspace_settings.name = colorspace  # before the pixels: changing it reloads the image
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[..., :3] = rgb
    image.pixels.foreach_set(rgba.ravel())
    if pack:
        image.pack()
    return image


def halves(name, left=RED, right=BLUE, *, size=64, axis="u", **options):
    """An image whose left (u < 1/2) or bottom (v < 1/2) half is ``left`` and the rest ``right``."""
    first = (np.arange(size) < size // 2)
    mask = first[None, :] if axis == "u" else first[:, None]
    return new_image(name, np.where(mask[..., None], left, right) * np.ones((size, size, 1)), **options)


def node_material(name):
    """A new material with its node tree (Blender 4.x makes the tree on request)."""
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    return material


def surface_from(material, node):
    """Connect ``node``'s first output to the material's Material Output Surface; returns ``node``."""
    out = next(n for n in material.node_tree.nodes if n.type == "OUTPUT_MATERIAL")
    material.node_tree.links.new(node.outputs[0], out.inputs["Surface"])
    return node


def image_material(name, image, *, shader="ShaderNodeBsdfPrincipled"):
    """A material whose surface shader takes its colour from an Image Texture of ``image``."""
    material = node_material(name)
    tree = material.node_tree
    surface = next((n for n in tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if shader != "ShaderNodeBsdfPrincipled":
        tree.nodes.remove(surface)
        surface = surface_from(material, tree.nodes.new(shader))
    tex = tree.nodes.new("ShaderNodeTexImage")
    tex.image = image
    colour = surface.inputs["Base Color"] if "Base Color" in surface.inputs else surface.inputs["Color"]
    tree.links.new(tex.outputs["Color"], colour)
    tree.nodes.active = tex
    return material


def procedural_material(name="Checker"):
    """A Principled BSDF whose Base Color is a checker texture (Cycles must bake it)."""
    material = node_material(name)
    tree = material.node_tree
    checker = tree.nodes.new("ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 6.0
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    tree.links.new(checker.outputs["Color"], bsdf.inputs["Base Color"])
    return material


def sphere(name="Ball", material=None, *, segments=32, rings=16, location=(0.0, 0.0, 0.0)):
    """A smooth-shaded UV sphere of radius 1 (with its UV map) wearing ``material``."""
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=rings, radius=1.0, location=location)
    obj = bpy.context.active_object
    obj.name = name
    bpy.ops.object.shade_smooth()
    if material is not None:
        obj.data.materials.append(material)
    return obj


def smooth_colours(size):
    """Smooth, colourful pixels (size, size, 3): no edge a bake's resolution would blur."""
    v, u = np.meshgrid((np.arange(size) + 0.5) / size, (np.arange(size) + 0.5) / size, indexing="ij")
    return np.stack([0.5 + 0.4 * np.sin(2 * np.pi * u), 0.5 + 0.4 * np.cos(2 * np.pi * v), 0.3 + 0.3 * u * v],
                    axis=-1)


def smooth_image(name, *, size=64, **options):
    """A smooth, colourful image (:func:`smooth_colours`)."""
    return new_image(name, smooth_colours(size), **options)


def udim_image(folder, *, packed):
    """A tiled (UDIM) image of three tiles of different sizes and colours (1001, 1002 and 1011), from files in
    ``folder`` (``Tiles.<UDIM>.png``), packed or not."""
    folder = str(folder)
    for number, size, order in ((1001, 64, [0, 1, 2]), (1002, 32, [2, 0, 1]), (1011, 48, [1, 2, 0])):
        image = new_image(f"tile {number}", smooth_colours(size)[..., order], pack=False)
        image.filepath_raw, image.file_format = os.path.join(folder, f"Tiles.{number}.png"), "PNG"
        image.save()
        bpy.data.images.remove(image)
    image = bpy.data.images.load(os.path.join(folder, "Tiles.1001.png"))
    image.source = "TILED"          # Blender finds the other tiles beside the first
    assert sorted(t.number for t in image.tiles) == [1001, 1002, 1011]
    if packed:
        image.pack()
        for number in (1001, 1002, 1011):
            os.remove(os.path.join(folder, f"Tiles.{number}.png"))
    return image


def spread_over_tiles(obj, off_tiles=False):
    """Move the faces of ``obj``'s UV map onto the tiles 1001, 1002 and 1011 by where they are (and with
    ``off_tiles``, those at the bottom onto the square of 1005, which the image does not have)."""
    mesh = obj.data
    layer = mesh.uv_layers[0]
    uv = np.empty(2 * len(mesh.loops))
    layer.data.foreach_get("uv", uv)
    uv = uv.reshape(-1, 2)
    for poly in mesh.polygons:
        loops = list(poly.loop_indices)
        if off_tiles and poly.center.z < -0.6:
            uv[loops] += (4.0, 0.0)                                         # no tile
        elif poly.center.z > 0.3:
            uv[loops] += (0.0, 1.0)                                         # tile 1011
        elif poly.center.x < 0:
            uv[loops] += (1.0, 0.0)                                         # tile 1002
    layer.data.foreach_set("uv", uv.ravel())
