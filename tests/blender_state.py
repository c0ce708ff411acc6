"""What a Blender file holds, as plain data, to show that a run changed only what it should.

:func:`snapshot` records the datablock counts, every image's pixels (a hash)
and dirty flag, every material's nodes, links and custom properties, every
object's material slots and mode, every mesh's UV maps, colour attributes
(their values too, and which are active) and custom properties, the render and
bake settings a procedural bake touches, and the bytes of the files in a
folder.  Two snapshots compare with ``==``; :func:`differences`
names what changed.
"""

import hashlib
import os

import bpy
import numpy as np

COLLECTIONS = ("images", "materials", "meshes", "objects", "node_groups", "textures", "collections", "libraries")


def pixel_hash(image):
    """SHA-256 of an image's float pixels (None for an image without pixels)."""
    w, h = image.size
    if not image.has_data and (w == 0 or h == 0):
        return None
    buf = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    return hashlib.sha256(buf.tobytes()).hexdigest()


def _socket(s):
    return f"{s.node.name}:{s.identifier}"


def _value(v):
    try:
        return tuple(round(float(x), 6) for x in v)
    except TypeError:
        return round(float(v), 6) if isinstance(v, float) else v


def material_state(material):
    state = {"fake_user": material.use_fake_user, "library": material.library is not None,
             "props": sorted(material.keys())}
    tree = material.node_tree
    if tree is not None:
        state["nodes"] = sorted((n.name, n.bl_idname, getattr(getattr(n, "image", None), "name", None),
                                 getattr(n, "uv_map", None), tuple(sorted(n.keys())))
                                for n in tree.nodes)
        state["links"] = sorted((_socket(l.from_socket), _socket(l.to_socket)) for l in tree.links)
        state["values"] = sorted((n.name, s.identifier, _value(s.default_value)) for n in tree.nodes
                                 for s in n.inputs if hasattr(s, "default_value") and not s.is_linked)
    return state


def _values_hash(attribute):
    """SHA-256 of a colour attribute's values."""
    values = np.empty(4 * len(attribute.data), dtype=np.float32)
    attribute.data.foreach_get("color", values)
    return hashlib.sha256(values.tobytes()).hexdigest()


def mesh_state(mesh):
    uv = mesh.uv_layers
    colours = mesh.color_attributes
    return {
        "uv_maps": [l.name for l in uv],
        "uv_active": uv.active.name if uv.active else None,
        "uv_render": next((l.name for l in uv if l.active_render), None),
        "colour_attributes": [(a.name, a.domain, a.data_type, _values_hash(a)) for a in colours],
        "colour_active": (colours.active_color_name, colours.default_color_name),
        "props": sorted(mesh.keys()),
        "materials": [m.name if m else None for m in mesh.materials],
        "counts": (len(mesh.vertices), len(mesh.loops), len(mesh.polygons)),
    }


def files(folder):
    """``{name: sha256}`` of the files directly in ``folder`` (names of folders map to 'dir')."""
    out = {}
    for name in sorted(os.listdir(folder)):
        path = os.path.join(folder, name)
        if os.path.isdir(path):
            out[name] = "dir"
        else:
            with open(path, "rb") as fh:
                out[name] = hashlib.sha256(fh.read()).hexdigest()
    return out


def snapshot(folder=None):
    data = bpy.data
    scene = bpy.context.scene
    bake = scene.render.bake
    state = {
        "counts": {k: len(getattr(data, k)) for k in COLLECTIONS},
        "images": {im.name: (pixel_hash(im), im.is_dirty, im.filepath, im.packed_file is not None,
                             im.use_fake_user, im.colorspace_settings.name) for im in data.images},
        "materials": {m.name: material_state(m) for m in data.materials},
        "objects": {o.name: ([(s.link, s.material.name if s.material else None) for s in o.material_slots],
                             o.mode, o.data.name if o.data else None, o.select_get())
                    for o in scene.objects},
        "active": bpy.context.view_layer.objects.active.name if bpy.context.view_layer.objects.active else None,
        "meshes": {m.name: mesh_state(m) for m in data.meshes},
        "render": (scene.render.engine, scene.cycles.samples, scene.cycles.device, bake.target, bake.use_clear,
                   bake.margin, bake.use_selected_to_active),
        "filepath": data.filepath,
    }
    if folder is not None:
        state["files"] = files(folder)
    return state


def differences(before, after, prefix=""):
    """Paths of what differs between two snapshots, for assertion messages."""
    if isinstance(before, dict) and isinstance(after, dict):
        out = []
        for key in sorted(set(before) | set(after), key=str):
            if key not in before:
                out.append(f"{prefix}{key}: added")
            elif key not in after:
                out.append(f"{prefix}{key}: removed")
            else:
                out += differences(before[key], after[key], f"{prefix}{key}.")
        return out
    return [] if before == after else [f"{prefix[:-1]}: {before!r} -> {after!r}"]


def assert_unchanged(before, after):
    diff = differences(before, after)
    assert not diff, "the run changed the file:\n" + "\n".join(diff)
