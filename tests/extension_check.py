"""Install a built cp_stylize zip with Blender's own installer, enable it and stylize two objects.

    python tests/extension_check.py ZIP                       # with the bpy module
    blender -b --factory-startup --python tests/extension_check.py -- ZIP

Run it with a throw-away user configuration (``HOME=$(mktemp -d)``): the
extension is installed into the user repository.  SciPy, xatlas and libigl
must come from the zip's wheels: copies elsewhere on the path (a virtual
environment's, the system's) are hidden.  It checks that enabling the add-on imports no SciPy,
then runs Starry Night on an image-textured sphere and a Gaussian blur on a
procedural (checker) sphere, checks both results, filters the sphere's vertices
with the mesh filter (libigl), finds the sphere's band through libigl's AABB
tree as for a large mesh, and prints one line that
starts with ``EXTENSION CHECK PASSED``.  Any failure raises.
"""

import importlib
import importlib.abc
import importlib.machinery
import os
import sys

import bpy
import numpy as np

ADDON = "bl_ext.user_default.cp_stylize"
SHIPPED = ("scipy", "xatlas", "igl")


class OnlyFromExtensions(importlib.abc.MetaPathFinder):
    """Find SciPy, xatlas and libigl only in this user's extensions' site-packages, where the zip's wheels go."""

    def find_spec(self, name, path=None, target=None):
        if path is not None or name not in SHIPPED:
            return None
        places = [p for p in sys.path if os.path.realpath(p).startswith(user_extensions())]
        spec = importlib.machinery.PathFinder.find_spec(name, places)
        if spec is None:
            raise ImportError(f"{name} is not installed from the extension's wheels (searched {places})")
        return spec


def user_extensions():
    """The folder of this user's extensions (and of the wheels they install)."""
    return os.path.realpath(bpy.utils.user_resource("EXTENSIONS"))


#: The Starry Night preset's palette.
STARRY_NIGHT = ("#0b1a3a", "#13294f", "#1d3b72", "#2a4f9a", "#3c5fc0", "#6d8fd0", "#e6b12f", "#a9c3dd", "#f3d54e",
                "#f8ecaa")


def _hue(rgb):
    """The hue angle (degrees) of sRGB colours, in the opponent plane of a rough perceptual space."""
    rgb = np.asarray(rgb, dtype=np.float64)
    return np.degrees(np.arctan2(np.sqrt(3) * (rgb[:, 1] - rgb[:, 2]), 2 * rgb[:, 0] - rgb[:, 1] - rgb[:, 2]))


def _hue_off_palette(rgb, palette):
    """How far (degrees) each colour's hue lies from the nearest hue of the palette."""
    d = np.abs(_hue(rgb)[:, None] - _hue(palette)[None, :]) % 360
    return np.min(np.minimum(d, 360 - d), axis=1)


def _source_pixels():
    return np.asarray(bpy.data.images["Source"].pixels[:], np.float32).reshape(-1, 4)[:, :3]


def _image(size=64):
    v, u = np.meshgrid(np.linspace(0, 1, size), np.linspace(0, 1, size), indexing="ij")
    rgba = np.ones((size, size, 4), np.float32)
    rgba[..., 0], rgba[..., 1], rgba[..., 2] = 0.4 + 0.5 * u, 0.3 + 0.4 * v, 0.3
    image = bpy.data.images.new("Source", size, size)
    image.pixels.foreach_set(rgba.ravel())
    image.pack()
    return image


def _material(name, colour_node):
    material = bpy.data.materials.new(name)
    if material.node_tree is None:
        material.use_nodes = True
    tree = material.node_tree
    node = tree.nodes.new(colour_node)
    bsdf = next(n for n in tree.nodes if n.type == "BSDF_PRINCIPLED")
    tree.links.new(node.outputs["Color"], bsdf.inputs["Base Color"])
    return material, node


def _sphere(name, material, x):
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1.0, location=(x, 0.0, 0.0), segments=32, ring_count=16)
    obj = bpy.context.active_object
    obj.name = name
    obj.data.materials.append(material)
    return obj


def _result(obj):
    image = obj.material_slots[0].material.node_tree.nodes["cp_stylize"].image
    out = np.empty(image.size[0] * image.size[1] * 4, np.float32)
    image.pixels.foreach_get(out)
    return out.reshape(-1, 4)[:, :3]


def main(zip_path):
    import addon_utils

    result = bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default",
                                                      enable_on_install=True)
    assert result == {"FINISHED"}, result
    assert addon_utils.check(ADDON)[1], "the add-on is not enabled"
    assert "scipy" not in sys.modules, "enabling the add-on imported SciPy"
    sys.meta_path.insert(0, OnlyFromExtensions())

    settings = bpy.context.scene.cp_stylize
    settings.image_size = "512"
    image_material, tex = _material("Photo", "ShaderNodeTexImage")
    tex.image = _image()
    photo = _sphere("Photo", image_material, -2.5)
    assert bpy.ops.object.cp_stylize(preset="starry_night", quality="PREVIEW") == {"FINISHED"}
    painted = _result(photo)
    palette = np.array([[int(c[i:i + 2], 16) / 255 for i in (1, 3, 5)] for c in STARRY_NIGHT])
    covered = painted.max(axis=1) > 0
    off = _hue_off_palette(painted[covered], palette)
    assert np.median(off) < 20 and np.median(_hue_off_palette(_source_pixels(), palette)) > 20, \
        "Starry Night did not bring the painting's hues"

    checker_material, checker = _material("Checker", "ShaderNodeTexChecker")
    checker.inputs["Scale"].default_value = 6.0
    procedural = _sphere("Checker", checker_material, 2.5)
    settings.mode, settings.time, settings.quality = "gaussian", 1e-5, "PREVIEW"
    assert bpy.ops.object.cp_stylize() == {"FINISHED"}
    grey = _result(procedural).mean(axis=1)
    covered = grey > 0.01
    assert grey[covered].max() - grey[covered].min() > 0.3, "the baked checker lost its two tones"
    assert "cp_stylize bake" not in bpy.data.images and "Checker" in bpy.data.materials

    import igl
    import scipy
    import xatlas

    # the mesh filters' libigl, from the zip's wheel, on the sphere's triangles as the add-on reads them
    mesh_diffuse = importlib.import_module(ADDON + ".cp_stylize.mesh_diffusion").mesh_diffuse
    data = importlib.import_module(ADDON + ".cp_stylize.blender.meshdata").read(procedural, corners=False)
    height = data.vertices[:, 2]
    blurred = mesh_diffuse(data.vertices, data.triangles, height, mode="gaussian", T=0.05)
    assert np.ptp(blurred) < 0.99 * np.ptp(height), "the mesh filter did not smooth"
    # the band of a large mesh, found through libigl's AABB tree: the same grid points as the blocks' search
    core = importlib.import_module(ADDON + ".cp_stylize")
    band_search = importlib.import_module(ADDON + ".cp_stylize.band_search")
    mesh = core.TriangleMesh(data.vertices, data.triangles)
    chosen, bands = band_search.use_aabb, []
    try:
        for tree in (False, True):          # the blocks' search, then the tree's
            band_search.use_aabb = lambda triangles, points, tree=tree: tree
            bands.append(set(map(tuple, core.Band.build(mesh, 0.05).ijk.tolist())))
    finally:
        band_search.use_aabb = chosen
    assert bands[0] == bands[1], "the AABB tree's band differs from the blocks'"
    for module in (scipy, xatlas, igl):
        assert os.path.realpath(module.__file__).startswith(user_extensions()), module.__file__
    print(f"EXTENSION CHECK PASSED blender={bpy.app.version_string} python={sys.version.split()[0]} "
          f"numpy={np.__version__} scipy={scipy.__version__} from {os.path.dirname(scipy.__file__)}", flush=True)


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    main(args[0])
    if not bpy.app.binary_path and bpy.app.version < (4, 4, 3):
        os._exit(0)   # Blender 4.2-4.4.2 as a module crash at exit (see tests/blender_support.py)
