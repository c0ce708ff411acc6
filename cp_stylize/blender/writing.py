"""Write a run's result into the file: the image (and relief), a UV map where one is needed, the materials.

:func:`apply` is the last step of a run (:mod:`.stylize`): it checks that the
object is still there and unchanged, then creates the image (and a UV map if
the mesh needs one), saves or packs it and wires it into the materials as one
transaction: if anything fails, every change is undone (:mod:`.changes`) and
the file is as it was.  A saved image never overwrites a file: it takes the
first free name (``wood.png``, ``wood.001.png``, ...).  The images a result
replaces are removed only if nothing uses them and nobody edited them
(:mod:`.results`).
"""

from __future__ import annotations

import dataclasses
import os

import bpy
import numpy as np

from . import images, materials, meshdata, results
from .changes import Changes
from .errors import StylizeError

#: Name of the UV map added to meshes that have no usable UVs of their own.
ATLAS_UV_NAME = "cp_stylize_atlas"
#: How the report names the modes in which an object cannot be stylized.
MODE_NAMES = {"EDIT": "Edit Mode", "SCULPT": "Sculpt Mode", "VERTEX_PAINT": "Vertex Paint Mode",
              "WEIGHT_PAINT": "Weight Paint Mode", "TEXTURE_PAINT": "Texture Paint Mode"}


@dataclasses.dataclass(frozen=True)
class Applied:
    image: str                        # the new image's name
    path: str | None                  # the file it was saved as
    materials: tuple                  # names of the materials that show it
    kept: tuple = ()                  # (name, edited) of the earlier results it replaced and kept (see results)
    relief: str | None = None         # the relief image's name, where the run made one


def save_folder():
    """The folder a saved image goes to (next to the .blend); StylizeError if it cannot be written."""
    if not bpy.data.filepath:
        raise StylizeError("save the .blend file first to save the image next to it, or choose Pack")
    folder = os.path.dirname(os.path.abspath(bpy.data.filepath))
    if not os.path.isdir(folder) or not os.access(folder, os.W_OK):
        raise StylizeError(f"cannot save the image next to the .blend file: the folder {folder!r} is not writable; "
                           "choose Pack, or save the .blend elsewhere")
    return folder


def _current_object(job):
    """The job's object, still there and unchanged since :func:`prepare`, or StylizeError."""
    name = job.object_name
    obj = bpy.data.objects.get(name)
    if obj is None or obj.library is not None or obj.type != "MESH":
        raise StylizeError(f"{name!r} was deleted or renamed while it was being stylized; nothing was changed")
    if obj.mode != "OBJECT":
        mode = MODE_NAMES.get(obj.mode, obj.mode.title())
        raise StylizeError(f"{name!r} is in {mode}; nothing was changed: leave {mode} and press Stylize again")
    if meshdata.fingerprint(obj) != job.fingerprint:
        raise StylizeError(f"the mesh of {name!r} changed while it was being stylized; nothing was changed: "
                           "press Stylize again")
    if meshdata.slots_state(obj) != job.slots_state:
        raise StylizeError(f"the materials of {name!r} changed while it was being stylized; nothing was changed: "
                           "press Stylize again")
    return obj


def _write_atlas_uvs(obj, loops, uvs, changes):
    """Write the new atlas ``uvs`` (F, 3, 2) at the triangle corners ``loops`` into the UV map :data:`ATLAS_UV_NAME`."""
    mesh = obj.data
    if ATLAS_UV_NAME in mesh.uv_layers:
        old = np.empty(2 * len(mesh.loops), dtype=np.float32)
        mesh.uv_layers[ATLAS_UV_NAME].data.foreach_get("uv", old)
        changes.record(lambda: mesh.uv_layers[ATLAS_UV_NAME].data.foreach_set("uv", old))
    elif changes.new_uv_map(mesh, ATLAS_UV_NAME) is None:
        raise StylizeError(f"the mesh of {obj.name!r} has {len(mesh.uv_layers)} UV maps, Blender's limit, and the "
                           "result needs a new one; nothing was changed: remove a UV map it does not need "
                           "(Object Data properties > UV Maps) and press Stylize again")
    written = meshdata.write_corner_uvs(mesh.uv_layers[ATLAS_UV_NAME], loops, uvs)
    meshdata.check_written_uvs(obj, ATLAS_UV_NAME, written, after_run=True)
    return ATLAS_UV_NAME


#: The longest file name most file systems take, in bytes.
FILE_NAME_BYTES = 255
#: File name endings of the formats results are saved in.
EXTENSIONS = {"PNG": ".png", "OPEN_EXR": ".exr"}


def result_names(obj, output):
    """The names of a run's colour image and relief image on ``obj``."""
    name = output.image_name or f"{obj.name}_stylized"
    return name, f"{name}_relief"


def file_stem(name, file_format):
    """The file name (without its ending) an image ``name`` is saved under; raises StylizeError where it
    is too long for a file system, with a numbered ending."""
    stem = bpy.path.clean_name(name)
    if len((stem + ".000" + EXTENSIONS[file_format]).encode("utf-8")) > FILE_NAME_BYTES:
        raise StylizeError(f"the image name {name!r} is too long for a file name ({len(stem.encode('utf-8'))} bytes; "
                           f"files may have {FILE_NAME_BYTES}): choose a shorter Image Name, or choose Pack; "
                           "nothing was changed")
    return stem


def _store(image, output, name, changes, file_format="PNG"):
    """Pack the image, or save it (as a PNG, or an OpenEXR for heights) next to the .blend under a name no
    file has."""
    if output.storage != "SAVE":
        image.file_format = file_format         # what the packed file holds: a float relief stays float
        image.pack()
        return None
    stem = file_stem(name, file_format)
    path = images.free_path(save_folder(), stem, EXTENSIONS[file_format])
    try:
        images.write_file(image, path, file_format)
    except (OSError, RuntimeError) as err:
        if os.path.exists(path):
            os.remove(path)
        reason = err.strerror if isinstance(err, OSError) and err.strerror else str(err).strip()
        raise StylizeError(f"could not save the image {image.name!r} as {path!r}: {reason}; "
                           "nothing was changed") from None
    changes.new_file(path)
    return path


#: The datablock collections whose items hold materials in slots of their own.
_MATERIAL_HOLDERS = ("meshes", "curves", "metaballs", "volumes", "pointclouds", "hair_curves", "grease_pencils",
                     "grease_pencils_v3")


def _shown_by_others(material, obj):
    """Whether anything other than ``obj`` may show ``material``.

    True where another object's slot shows it, and where it has users the
    slots do not account for (a Geometry Nodes Set Material node, say).
    """
    if any(other != obj and any(slot.material == material for slot in other.material_slots)
           for other in bpy.data.objects):
        return True
    known = int(material.use_fake_user)
    for holders in _MATERIAL_HOLDERS:
        known += sum(list(data.materials).count(material) for data in getattr(bpy.data, holders, ()))
    known += sum(slot.link == "OBJECT" and slot.material == material
                 for other in bpy.data.objects for slot in other.material_slots)
    return material.users > known


def _own_copy(material, obj):
    """Whether ``material`` is a copy an earlier run made that only ``obj`` shows, so this run may rewire it."""
    return (material.get(materials.ORIGINAL) is not None and material.library is None
            and not _shown_by_others(material, obj))


def _material_for(obj, index, output, changes, copies):
    """The material slot ``index``'s result goes into, creating or copying one as needed.

    ``copies`` maps each material to its copy made in this run, so that slots
    sharing a material share its copy.  A copy an earlier run made is reused
    only while no other object shows it (a duplicate of the object, or an
    object the material was linked to, keeps its look): otherwise it is
    copied in turn, with the user's changes to it, and the new copy points to
    the same original.
    """
    slot = obj.material_slots[index] if index < len(obj.material_slots) else None
    material = slot.material if slot is not None else None
    if material is not None and (output.target == "APPLY" or _own_copy(material, obj)):
        return material     # the user's own, or this object's copy from an earlier run
    if material is None:
        new = changes.new_id(bpy.data.materials, bpy.data.materials.new(f"{obj.name}_stylized"))
        if new.node_tree is None:
            changes.set(new, "use_nodes", True)
    elif material in copies:
        new = copies[material]
    else:
        original = material.get(materials.ORIGINAL) or material
        new = copies[material] = changes.new_id(bpy.data.materials, material.copy())
        new.name = f"{original.name}_stylized"
        changes.set_item(new, materials.ORIGINAL, original)
    mesh = obj.data
    if slot is None:   # no slots: add one to the mesh, empty at mesh level
        mesh.materials.append(None)
        changes.record(lambda: mesh.materials.pop(index=len(mesh.materials) - 1))
        slot = obj.material_slots[len(obj.material_slots) - 1]
    if mesh.library is not None or mesh.users - mesh.use_fake_user > 1 or slot.link == "OBJECT":
        changes.set(slot, "link", "OBJECT")   # this object only: the mesh's other users keep their look
    changes.set(slot, "material", new)
    return new


#: A UV coordinate this large is no place on a texture: Blender stores an infinite UV as the largest float.
UV_LIMIT = 1e9

def relief_distance(obj, job):
    """The Bump node's distance for ``job``'s relief on ``obj``: the height 1 in the object's own units
    (:data:`cp_stylize.canvas.THICKNESS` of the strokes' width at Relief 1)."""
    from ..canvas import THICKNESS

    settings = job.settings
    world_per_unit = job.result.spacing / settings.spacing          # world length of a unit of the core's frame
    scale = abs(float(np.linalg.det(np.array(obj.matrix_world)[:3, :3]))) ** (1.0 / 3.0) or 1.0
    return settings.relief * THICKNESS * settings.stroke_width * world_per_unit / scale


#: Custom property of a mesh: ``{result attribute: {"source": the attribute it was filtered from, "digest":
#: its values as written}}``, so that a re-run reads the source again and updates an unedited result in place.
ATTRIBUTES = "cp_stylize_attributes"


@dataclasses.dataclass(frozen=True)
class AppliedAttribute:
    attribute: str                    # the colour attribute the result went into
    materials: tuple                  # names of the materials that show it
    kept: str | None = None           # an earlier result the user has painted since, kept as it is
    kept_images: tuple = ()           # (name, edited) of earlier relief images kept (see results)


def attribute_origin(mesh, name, owner):
    """The colour attribute a run's result ``name`` on ``mesh`` was filtered from, where it is one; else
    ``name``.  StylizeError where it is a result whose source is gone (renamed or removed): a run would
    filter the result again."""
    record = mesh.get(ATTRIBUTES, {}).get(name) if name else None
    if record is None:
        return name
    source = record.get("source")
    if source not in mesh.color_attributes:
        raise StylizeError(f"the colour attribute {name!r} of {owner!r} is an earlier result, and the attribute it "
                           f"was filtered from, {source!r}, is gone (renamed or removed): point the material's Color "
                           "Attribute node at the attribute to filter, or choose Result: Image")
    return source


#: Blender keeps attribute names to this many bytes (63 in the oldest Blender the add-on supports).
NAME_BYTES = 63


def result_attribute_name(source, number=0):
    """``<source>_stylized`` (``.001`` ... for ``number``), the source's part cut so that the whole fits in
    :data:`NAME_BYTES` bytes of UTF-8."""
    suffix = "_stylized" + (f".{number:03d}" if number else "")
    room = NAME_BYTES - len(suffix.encode("utf-8"))
    return source.encode("utf-8")[:room].decode("utf-8", "ignore") + suffix


def _colour_values(attribute):
    """An attribute's values as Blender stores them (float colours; byte colours as floats)."""
    values = np.empty(4 * len(attribute.data), dtype=np.float32)
    attribute.data.foreach_get("color", values)
    return values


def _values_digest(values):
    import hashlib

    return hashlib.blake2b(values.tobytes(), digest_size=16).hexdigest()


def _result_attribute(mesh, job, changes):
    """The colour attribute the job's result goes into, and the name of an earlier result kept because it was
    painted since (or None).  An earlier result of the same source, domain and type that is exactly as its
    run wrote it is updated in place: the one the materials show, else ``<source>_stylized``; otherwise the
    result goes into a new attribute ``<source>_stylized`` (``.001`` ... where the name is taken)."""
    attributes = mesh.color_attributes
    base = result_attribute_name(job.source)
    records = mesh.get(ATTRIBUTES, {})
    kept = None
    for name in dict.fromkeys([*job.shown, base]):
        existing = attributes.get(name)
        record = records.get(name)
        if existing is None or record is None or record.get("source") != job.source \
                or (existing.domain, existing.data_type) != (job.domain, job.data_type):
            continue
        old = _colour_values(existing)
        if _values_digest(old) == record.get("digest"):
            changes.record(lambda: attributes[name].data.foreach_set("color", old))
            return existing, None
        kept = kept or name                   # painted since its run: kept, and the result goes beside it
    name, number = base, 0
    while name in mesh.attributes:
        number += 1
        name = result_attribute_name(job.source, number)
    return changes.new_colour_attribute(mesh, name, job.data_type, job.domain), kept


def apply_attribute(job):
    """Write an :class:`~.stylize.AttributeJob`'s result into a colour attribute as one transaction; returns
    :class:`AppliedAttribute`.

    The result goes into ``<source>_stylized`` (:func:`_result_attribute`), of
    the source's domain and type, with the source's alpha; the materials (or
    their copies, as for an image) show it through a Color Attribute node
    (:func:`.materials.wire_attribute`), and any relief an earlier image run
    wired is taken out.  The source attribute and the mesh's active and render
    colour attributes stay as they were.  Raises StylizeError (with nothing
    changed) as :func:`apply` does.
    """
    obj = _current_object(job)
    mesh = obj.data
    sharing = [o.name for o in bpy.data.objects if o.data == mesh and o != obj]
    if sharing:
        raise StylizeError(f"the mesh of {obj.name!r} came to be shared with {sharing[0]!r} while it was being "
                           "stylized; nothing was changed: give it its own mesh (Object > Relations > Make Single "
                           "User > Object & Data) and press Stylize again")
    colours = np.empty((len(job.colours), 4), dtype=np.float32)
    colours[:, :3] = np.clip(job.result.colours[:, :3], 0.0, 1.0)
    colours[:, 3] = job.colours[:, 3]
    replaced = results.Replaced()
    with Changes() as changes:
        attribute, kept = _result_attribute(mesh, job, changes)
        if job.domain == "CORNER":
            loops = np.empty(len(mesh.loops), dtype=np.int32)
            mesh.loops.foreach_get("vertex_index", loops)
            colours = colours[loops]
        attribute.data.foreach_set("color_srgb", colours.ravel())
        name = attribute.name
        records = {key: dict(value) for key, value in mesh.get(ATTRIBUTES, {}).items()}
        records[name] = {"source": job.source, "digest": _values_digest(_colour_values(attribute))}
        changes.set_item(mesh, ATTRIBUTES, records)
        wired, copies = [], {}
        for index in job.slots:
            material = _material_for(obj, index, job.output, changes, copies)
            if material in wired:
                continue
            materials.wire_attribute(material, name, changes)
            replaced.add(materials.unwire_relief(material, changes))
            wired.append(material)
        unused, kept_images = replaced.retire([], changes)
    results.remove(unused, [])
    return AppliedAttribute(attribute=name, materials=tuple(m.name for m in wired), kept=kept,
                            kept_images=tuple(kept_images))


def apply(job):
    """Write the result into the file as one transaction; returns :class:`Applied`.

    Raises StylizeError (with nothing changed) if the object was deleted,
    entered Edit Mode or changed during the run, or if saving fails.  The
    images the result replaces are removed or kept as :mod:`.results` says.
    With a relief (the strokes' height), a second image ``<name>_relief``
    feeds a Bump node under the shader (:func:`.materials.wire_relief`); a
    run without one takes an earlier run's relief out again.
    """
    obj = _current_object(job)
    result, output = job.result, job.output
    name, relief_name = result_names(obj, output)
    replaced = results.Replaced()
    with Changes() as changes:
        uv_name = job.uv_name
        if result.atlas.generated:
            uv_name = _write_atlas_uvs(obj, job.mesh.loops, result.atlas.uvs, changes)
        image = changes.new_id(bpy.data.images, images.array_to_image(name, result.image))
        path = _store(image, output, name, changes)
        results.mark(image, obj)
        relief = None
        if result.height is not None:
            relief = changes.new_id(bpy.data.images, images.array_to_image(
                relief_name, result.height[..., None], colorspace="Non-Color", float_buffer=True))
            _store(relief, output, relief_name, changes, file_format="OPEN_EXR")
            results.mark(relief, obj)
        wired, copies = [], {}
        for index in job.slots:
            material = _material_for(obj, index, output, changes, copies)
            if material in wired:
                continue
            replaced.add(materials.wire(material, image, uv_name, changes))
            if relief is not None:
                replaced.add(materials.wire_relief(material, relief, uv_name, relief_distance(obj, job), changes))
            else:
                replaced.add(materials.unwire_relief(material, changes))
            wired.append(material)
        unused, kept = replaced.retire([image] + ([relief] if relief is not None else []), changes)
    results.remove(unused, [(image, name)] + ([(relief, relief_name)] if relief is not None else []))
    return Applied(image=image.name, path=path, materials=tuple(m.name for m in wired), kept=tuple(kept),
                   relief=None if relief is None else relief.name)
