"""The demo's scene: a photograph as texture, its material, the camera, light and render."""

import os
import tempfile

import bpy
import numpy as np
from mathutils import Vector

from cp_stylize.blender import images


def reset():
    """An empty scene with Blender's factory settings."""
    bpy.ops.wm.read_factory_settings(use_empty=True)


def studio_photo_path(name="forest"):
    """Path of one of the equirectangular photographs that ship with Blender."""
    path = os.path.join(bpy.utils.system_resource("DATAFILES"), "studiolights", "world", f"{name}.exr")
    if not os.path.isfile(path):
        raise FileNotFoundError(f"Blender's studio light {name!r} is not at {path}")
    return path


def photo_texture(name="forest"):
    """A Blender studio-light panorama, tone-mapped to sRGB values in [0, 1]: (H, W, 3) float32."""
    from cp_stylize.texture import linear_to_srgb

    image = bpy.data.images.load(studio_photo_path(name), check_existing=False)
    try:
        rgb = images.image_to_array(image)[..., :3].astype(np.float64)
    finally:
        bpy.data.images.remove(image)
    luminance = rgb @ np.array([0.2126, 0.7152, 0.0722])
    rgb = rgb / max(np.percentile(luminance, 99.0), 1e-6)
    return linear_to_srgb(rgb).astype(np.float32)


def _colour_from(name, kind):
    """A new material whose Principled BSDF takes its Base Color from a new node of type ``kind``; returns
    the material, the node and the BSDF."""
    material = bpy.data.materials.new(name)
    if material.node_tree is None:  # Blender 4.x creates the node tree on request
        material.use_nodes = True
    tree = material.node_tree
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    node = tree.nodes.new(kind)
    node.location = (bsdf.location.x - 350, bsdf.location.y)
    tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    return material, node, bsdf


def new_material(name, image):
    """A material whose Principled BSDF takes its Base Color from an Image Texture of ``image``."""
    material, tex, bsdf = _colour_from(name, "ShaderNodeTexImage")
    tex.image = image
    bsdf.inputs["Roughness"].default_value = 0.8
    return material


def attribute_material(name, layer="Col"):
    """A material whose Principled BSDF takes its Base Color from the colour attribute ``layer`` (a Color
    Attribute node; "" for the render colour attribute)."""
    material, node, _ = _colour_from(name, "ShaderNodeVertexColor")
    node.layer_name = layer
    return material


def setup_render(resolution=(480, 360), samples=16):
    """Cycles on the CPU, a camera, a key light and a grey world, framing the origin."""
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
    scene.cycles.use_denoising = False
    scene.render.resolution_x, scene.render.resolution_y = resolution
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "PNG"
    scene.view_settings.view_transform = "Standard"
    if scene.world is None:
        scene.world = bpy.data.worlds.new("World")
    scene.world.color = (0.25, 0.25, 0.27)
    if scene.camera is None:
        cam = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
        scene.collection.objects.link(cam)
        scene.camera = cam
        light = bpy.data.objects.new("Key", bpy.data.lights.new("Key", type="SUN"))
        light.data.energy = 3.0
        scene.collection.objects.link(light)
        light.rotation_euler = (0.9, 0.0, 0.6)
    return scene


def frame_objects(objects, margin=1.15):
    """Point the scene camera at the objects' bounding sphere from the front and slightly above."""
    corners = np.array([tuple(o.matrix_world @ Vector(c)) for o in objects for c in o.bound_box])
    centre = 0.5 * (corners.min(axis=0) + corners.max(axis=0))
    radius = 0.5 * np.linalg.norm(corners.max(axis=0) - corners.min(axis=0))
    cam = bpy.context.scene.camera
    direction = Vector((0.0, -1.0, 0.35)).normalized()
    distance = float(margin * radius / np.sin(0.5 * cam.data.angle))
    cam.location = Vector(centre) + distance * direction
    cam.rotation_euler = (-direction).to_track_quat("-Z", "Y").to_euler()


def render(path):
    scene = bpy.context.scene
    scene.render.filepath = os.path.abspath(path)
    bpy.ops.render.render(write_still=True)
    return path


def stylize(obj, preset, quality="STANDARD", image_size=None):
    """Run the Stylize operator on ``obj`` with ``preset`` loaded, as a user would (the add-on registered
    for the run only), at ``quality`` (None: the preset's own grid); raises if it does not finish."""
    from cp_stylize.blender import register, unregister

    register()
    try:
        settings = bpy.context.scene.cp_stylize
        bpy.ops.cp_stylize.preset_load(name=preset)
        if quality is not None:
            settings.quality = quality.upper()
        if image_size is not None:
            settings.image_size = str(image_size)
        bpy.context.view_layer.objects.active = obj
        result = bpy.ops.object.cp_stylize()
        if result != {"FINISHED"}:
            raise RuntimeError(f"{preset} on {obj.name}: the Stylize operator returned {result}")
    finally:
        unregister()


def read_image(path):
    """An image file as a float array (H, W, 3), row 0 at the top."""
    image = bpy.data.images.load(path, check_existing=False)
    try:
        return images.image_to_array(image)[::-1, :, :3].astype(np.float64)
    finally:
        bpy.data.images.remove(image)


#: Blender's Kuwahara node as the oil paint comparisons set it: anisotropic, its default sharpness and
#: eccentricity, a size that gives strokes about as wide as the Oil Paint preset's on a 1024-pixel photograph.
KUWAHARA_NODE = {"Type": "Anisotropic", "Size": 12.0, "Sharpness": 0.5, "Eccentricity": 1.0}


def kuwahara_node(pixels):
    """``pixels`` (H, W, 3, sRGB values, row 0 at the bottom) through Blender's Kuwahara compositor node."""
    h, w, _ = pixels.shape
    source = images.array_to_image("kuwahara_in", pixels)
    group = bpy.data.node_groups.new("kuwahara", "CompositorNodeTree")
    group.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    read = group.nodes.new("CompositorNodeImage")
    read.image = source
    kuwahara = group.nodes.new("CompositorNodeKuwahara")
    for name, value in KUWAHARA_NODE.items():
        kuwahara.inputs[name].default_value = value
    out = group.nodes.new("NodeGroupOutput")
    group.links.new(read.outputs["Image"], kuwahara.inputs["Image"])
    group.links.new(kuwahara.outputs["Image"], out.inputs[0])
    s = bpy.context.scene
    s.compositing_node_group = group
    s.render.use_compositing = True
    s.render.engine = "BLENDER_WORKBENCH"
    s.render.resolution_x, s.render.resolution_y, s.render.resolution_percentage = w, h, 100
    s.view_settings.view_transform = "Standard"
    s.render.image_settings.file_format = "PNG"
    s.render.image_settings.color_depth = "8"          # a byte image: its pixels read back as sRGB values
    try:
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "kuwahara.png")
            s.render.filepath = path
            bpy.ops.render.render(write_still=True)
            return read_image(path)[::-1].astype(np.float32)
    finally:
        s.compositing_node_group = None
        bpy.data.node_groups.remove(group)
        bpy.data.images.remove(source)
