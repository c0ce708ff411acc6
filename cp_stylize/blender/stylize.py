"""Stylize a Blender object: read its surface colour, run the core, write the result back.

A run has three steps, and only the last one changes the file:

1. :func:`prepare` checks everything that can be checked before the long
   part (the object, its materials, the save target, the estimated time and
   memory), reads the mesh and its colours into a :class:`Job` of plain data
   and, for procedural colours, bakes them with Cycles into a temporary image
   (:mod:`.bake`, which restores everything it touches).
2. :func:`run_core` runs the NumPy/SciPy core on the job; it touches no
   Blender data, so it may run in a worker thread (:class:`BackgroundRun`).
3. :func:`.writing.apply` checks that the object is still there and unchanged, then
   creates the image (and a UV map if the mesh needs one), saves or packs it
   and wires it into the materials as one transaction: if anything fails,
   every change is undone (:mod:`.changes`) and the file is as it was.

What a run writes: by default a copy of each material (``<material>_stylized``,
which remembers its original, so a second run starts again from the original
colours and updates the same copy, as long as no other object shows that copy);
with ``target="APPLY"`` the object's own materials.  Where a mesh shares its
data with other objects, the copy is assigned to this object only.  A saved
image never overwrites a file: it takes the first free name (``wood.png``,
``wood.001.png``, ...).  The images a result replaces are removed only if
nothing uses them and nobody edited them (:mod:`.results`).

What a run keeps: the parts it built before its filter (the band and its
operators, the atlas, the surface points of the texels; see
:mod:`cp_stylize.cache`), in memory only, so that the next run on the same
mesh at the same grid spacing starts at the filter.  They are keyed by the
mesh's own numbers, so an edited mesh, an undo or another object never
reads stale parts; :func:`release` frees them, and so do loading a file and
disabling the add-on.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import threading

import bpy
import numpy as np

from ..parameters import AXIS_DIRECTIONS
from . import bake, images, materials, meshdata
from .errors import Cancelled, StylizeError
from .writing import ATLAS_UV_NAME, MODE_NAMES, UV_LIMIT, file_stem, result_names, save_folder

#: Blender's limit of UV maps a mesh can have.
MAX_UV_MAPS = 8

OBJECT_TYPES = {
    "EMPTY": "an empty", "CAMERA": "a camera", "LIGHT": "a light", "LIGHT_PROBE": "a light probe",
    "SPEAKER": "a speaker", "ARMATURE": "an armature", "LATTICE": "a lattice", "CURVES": "a hair curves object",
    "POINTCLOUD": "a point cloud", "VOLUME": "a volume", "GPENCIL": "a Grease Pencil object",
    "GREASEPENCIL": "a Grease Pencil object",
}
#: Objects Blender converts to meshes (Object > Convert > Mesh).
CONVERTIBLE = {"CURVE": "a curve", "SURFACE": "a surface", "META": "a metaball", "FONT": "a text object"}


@dataclasses.dataclass(frozen=True)
class Output:
    """What to do with the result, and the limits a run must stay within."""

    image_name: str = ""              # empty: "<object>_stylized"
    target: str = "NEW_MATERIAL"      # or "APPLY"
    storage: str = "PACK"             # or "SAVE" (a PNG next to the .blend)
    memory_limit: float = 8 * 2**30   # bytes
    time_limit: float = 15 * 60       # seconds
    keep: bool = True                 # keep what the run builds before its filter for the next run
    speed: float = 1.0                # the estimate's time factor for this computer (cp_stylize.calibration)
    kind: str = "IMAGE"               # or "ATTRIBUTE": a new colour attribute (see :func:`prepare_attribute`)


@dataclasses.dataclass
class Job:
    """Everything a run needs, as plain data: the hand-off between Blender and the core."""

    object_name: str
    settings: object                  # StylizeSettings
    output: Output
    mesh: meshdata.MeshData
    colours: object                   # pipeline.ColourInput
    uvs: np.ndarray | None            # (F, 3, 2) the UVs the core tries for the output atlas, if it decides
    uv_name: str | None               # the UV map the result is read through, unless it is a new one
    atlas: object                     # an Atlas decided before the run, or None
    new_atlas: bool                   # a new UV map may be written if the mesh's own are not usable
    no_atlas: str | None              # why not, if not
    slots: list                       # material slot indices the faces use
    fingerprint: str
    slots_state: list
    estimate: object                  # estimate.RunEstimate
    result: object = None
    reused: list = dataclasses.field(default_factory=list)   # the parts the run took from the last one


@dataclasses.dataclass
class AttributeJob:
    """A run whose result goes into a colour attribute (:func:`prepare_attribute`), as plain data."""

    object_name: str
    settings: object                  # StylizeSettings
    output: Output
    vertices: np.ndarray              # (V, 3) world units without the rotation (:class:`.meshdata.MeshData`)
    triangles: np.ndarray             # (F, 3)
    colours: np.ndarray               # (V, 4) sRGB-encoded, the source attribute's at the vertices
    source: str                       # the colour attribute read
    domain: str                       # its domain ("POINT" or "CORNER") and type, which the result takes
    data_type: str
    slots: list
    fingerprint: str
    slots_state: list
    method: str                       # "mesh" or "band" (cp_stylize.vertex_colours.choose_method), and why
    reason: str
    estimate: object
    shown: tuple = ()                 # the earlier results of this source the materials show
    result: object = None             # a cp_stylize.vertex_colours.VertexResult
    reused: list = dataclasses.field(default_factory=list)


# -- what runs keep for the next ---------------------------------------------------------------

_cache = None            # a cp_stylize.cache.RunCache, made by the first run
_cache_bytes = 0         # what it held after the last run


def run_cache():
    """The :class:`~cp_stylize.cache.RunCache` runs share (made on first use)."""
    global _cache
    if _cache is None:
        from ..cache import RunCache

        _cache = RunCache()
    return _cache


def kept_bytes():
    """Bytes the parts kept for re-runs held after the last run (0 when nothing is kept)."""
    return _cache_bytes if _cache is not None and len(_cache) else 0


def release():
    """Free everything kept for re-runs."""
    global _cache_bytes
    if _cache is not None:
        _cache.clear()
    _cache_bytes = 0


# -- checks ----------------------------------------------------------------------------------


def check_object(obj):
    """Raise StylizeError unless ``obj`` is a local mesh object in Object Mode."""
    if obj is None:
        raise StylizeError("no active object: select a mesh object")
    if obj.type in CONVERTIBLE:
        raise StylizeError(f"{obj.name!r} is {CONVERTIBLE[obj.type]}, not a mesh: convert it first "
                           "(Object > Convert > Mesh)")
    if obj.type != "MESH":
        raise StylizeError(f"{obj.name!r} is {OBJECT_TYPES.get(obj.type, obj.type.lower())}, not a mesh")
    if obj.library is not None:
        raise StylizeError(f"{obj.name!r} is linked from the library {obj.library.name!r} and cannot be changed "
                           "here: make it local first (Object > Relations > Make Local)")
    if obj.mode != "OBJECT":
        mode = MODE_NAMES.get(obj.mode, obj.mode.title())
        raise StylizeError(f"{obj.name!r} is in {mode}: leave {mode} first")


def physical_memory():
    """This computer's memory in bytes, or None if it cannot be told."""
    try:
        if sys.platform == "win32":
            import ctypes

            class Status(ctypes.Structure):
                _fields_ = [("length", ctypes.c_ulong), ("load", ctypes.c_ulong), ("total", ctypes.c_ulonglong),
                            ("free", ctypes.c_ulonglong), ("pagefile", ctypes.c_ulonglong),
                            ("free_pagefile", ctypes.c_ulonglong), ("virtual", ctypes.c_ulonglong),
                            ("free_virtual", ctypes.c_ulonglong), ("extended", ctypes.c_ulonglong)]
            status = Status(length=ctypes.sizeof(Status))
            ctypes.windll.kernel32.GlobalMemoryStatusEx(ctypes.byref(status))
            return int(status.total)
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, OSError, ValueError):
        return None


def duration(seconds):
    """``'45 s'``, ``'12 min'`` or ``'3 h 20 min'``."""
    if seconds < 90:
        return f"{max(seconds, 1):.0f} s"
    minutes = round(seconds / 60)
    return f"{minutes} min" if minutes < 60 else f"{minutes // 60} h {minutes % 60} min"


def check_limits(estimate, output):
    """Raise StylizeError if a run's estimated memory or time is above the limits or this computer's memory."""
    where = f"about {estimate.band_points:,} band points" if estimate.band_points else "on the mesh's own vertices"
    need = f"this run needs about {estimate.bytes / 2**30:.1f} GiB ({where})"
    costs = ["the quality", "the image size"] if output.kind == "IMAGE" else ["the quality"]    # what sets them

    def lower(*more):
        said = costs + list(more)
        return "lower " + (said[0] if len(said) == 1 else ", ".join(said[:-1]) + " or " + said[-1])

    memory = physical_memory()
    if memory is not None and estimate.bytes > memory:
        raise StylizeError(f"{need}, more than this computer's {memory / 2**30:.1f} GiB of memory: {lower()}")
    if estimate.bytes > output.memory_limit:
        raise StylizeError(f"{need}, above the memory limit of {output.memory_limit / 2**30:.1f} GiB: "
                           f"{lower()}, or raise Max RAM (under Output)")
    if estimate.seconds > output.time_limit:
        raise StylizeError(f"this run would take roughly {duration(estimate.seconds)}, above the time limit of "
                           f"{duration(output.time_limit)}: {lower('the time')}, or raise Max Time "
                           "(under Output)")


def _check_writable(material, output):
    """Raise StylizeError if the result cannot go into (a copy of) ``material``."""
    if output.target == "APPLY" and material.library is not None:
        raise StylizeError(f"material {material.name!r} is linked from the library {material.library.name!r} and "
                           "cannot be changed here: choose New Material Copy, or make it local first")
    if materials.uses_nodes(material):
        materials.colour_input(material)   # the result needs a colour input to go into


# -- reading -----------------------------------------------------------------------------------


#: The colour Cycles shows where a tiled image has no tile under a face's UVs (magenta, as for a missing image).
MISSING_TILE = (1.0, 0.0, 1.0)


def _image_texture(source, mesh, faces, material, owner):
    from ..pipeline import Texture

    image = source.image
    images.check_readable(image)
    name = source.uv_name or mesh.render_uv
    if name is None:
        raise StylizeError(f"material {material.name!r} reads the image {image.name!r} through UVs, but the mesh "
                           f"of {owner!r} has no UV map")
    uvs = mesh.uv_maps[name]
    bad = ~(np.isfinite(uvs[faces]) & (np.abs(uvs[faces]) < UV_LIMIT)).all(axis=-1)   # Blender keeps inf as 3.4e38
    if bad.any():
        count = len(np.unique(mesh.loops[faces][bad]))
        corners = "1 corner whose UV is" if count == 1 else f"{count} corners whose UVs are"
        raise StylizeError(f"the UV map {name!r} of {owner!r} has {corners} not a finite number, and material "
                           f"{material.name!r} reads the image {image.name!r} through it: unwrap it again (UV > Unwrap "
                           "in Edit Mode), or fix those corners, and press Stylize again")
    if source.transform is not None:
        A, b = source.transform
        uvs = uvs @ A.T + b
        if not np.isfinite(uvs[faces]).all():
            raise StylizeError(f"the Mapping node {source.mapping!r} in material {material.name!r} maps the UVs "
                               "beyond finite numbers: lower its scale")
    if image.source != "TILED":
        return [Texture(_display_colours(image), uvs, faces, (source.wrap, source.wrap))]
    # a tiled (UDIM) image: each tile colours the faces whose UVs centre on its square, read there as an image
    # of its own with the node's extension at its edges, as Cycles reads a tile
    centre = np.floor(uvs[faces].mean(axis=1))
    number = np.where((centre[:, 0] >= 0) & (centre[:, 0] < 10) & (centre[:, 1] >= 0),
                      1001 + centre[:, 0] + 10 * centre[:, 1], 0)
    textures = []
    for tile, pixels in images.read_tiles(image, _display_colours, set(np.unique(number).astype(int).tolist())):
        on = np.zeros_like(faces)
        on[faces] = number == tile
        textures.append(Texture(pixels, uvs - np.float32(images.tile_offset(tile)), on, (source.wrap, source.wrap)))
    missing = faces.copy()
    for texture in textures:
        missing &= ~texture.faces
    if missing.any():       # faces on no tile: Cycles shows them in its colour of a missing image
        textures.append(Texture(np.array([[MISSING_TILE]], np.float32), uvs, missing, ("clamp", "clamp")))
    return textures


def _display_colours(image):
    linear = image.is_float or image.colorspace_settings.name in materials.LINEAR_SPACES
    return images.display_colours(image, linear)


def _read_colours(obj, mesh, slots):
    """The ColourInput of the faces, and what to bake: ``{slot index: (material, output socket)}``."""
    from ..pipeline import ColourInput

    n = len(mesh.triangles)
    fallback = mesh.colours.get(mesh.render_colour)
    corner = np.empty((n, 3, 3), dtype=np.float32)
    corner[:] = materials.DEFAULT_SURFACE if fallback is None else fallback
    colours = ColourInput(corner_colours=corner)
    to_bake = {}
    for index in slots:
        faces = mesh.material_index == index if len(obj.material_slots) else np.ones(n, dtype=bool)
        if index == len(obj.material_slots) - 1:
            faces = mesh.material_index >= index   # Blender renders indices past the last slot with it
        material = obj.material_slots[index].material if len(obj.material_slots) else None
        if material is None:
            continue
        material = materials.source_material(material)
        source = materials.colour_source(material, mesh.uv_maps.keys(), obj.name)
        if isinstance(source, materials.Flat):
            corner[faces] = source.colour
        elif isinstance(source, materials.ImageSource):
            colours.textures += _image_texture(source, mesh, faces, material, obj.name)
        elif isinstance(source, materials.AttributeSource) and (source.name or mesh.render_colour) in mesh.colours:
            corner[faces] = mesh.colours[source.name or mesh.render_colour][faces]
        else:
            socket = source.socket if isinstance(source, materials.BakeSource) else None
            to_bake[index] = material, socket or materials.original_origin(materials.colour_input(material))
    return colours, to_bake


def input_pixels(obj, uv_names, slots, settings):
    """The pixels of the images a run on ``obj`` reads (material ``slots`` used): every image a material
    reads directly, once for each material, and the bake's image where a colour must be baked."""
    pixels, baked = 0, False
    for index in slots:
        material = obj.material_slots[index].material if len(obj.material_slots) else None
        if material is None:
            continue
        source = materials.colour_source(materials.source_material(material), uv_names, obj.name)
        if isinstance(source, materials.ImageSource):
            tiles = source.image.tiles if source.image.source == "TILED" else [source.image]
            pixels += sum(t.size[0] * t.size[1] for t in tiles)
        elif not isinstance(source, (materials.Flat, materials.AttributeSource)):
            baked = True
    return pixels + (settings.image_size ** 2 if baked else 0)


def _atlas(mesh, settings, keep, uvs, allow_new):
    """The output atlas for the UVs ``uvs`` (or a new one), kept for the run and re-runs like the core's own parts."""
    from ..pipeline import decide_atlas

    return decide_atlas(mesh.vertices, mesh.triangles, settings.image_size, uvs, new_atlas=allow_new,
                        cache=run_cache() if keep else None)


def _no_atlas_message(name, err):
    why = err.why or ("fix the UV map, or apply the modifiers that change its topology (or make its mesh local) "
                      "first")
    return f"{name!r} has no usable UV map for the result ({err.problems}) and cannot get a new one: {why}"


def _listed(names):
    """``'A'``, ``'A' and 'B'``, ``'A', 'B', 'C' and 2 more``."""
    shown = [repr(n) for n in names[:3]]
    if len(names) > 3:
        return ", ".join(shown) + f" and {len(names) - 3} more"
    return shown[0] if len(shown) == 1 else ", ".join(shown[:-1]) + f" and {shown[-1]}"


def _shared_uv_map(obj, mesh):
    """Why a new atlas cannot be written because other objects share ``obj``'s mesh (None if it can): it
    would become their render UV map (a mesh without UV maps), or rewrite the ``cp_stylize_atlas`` map
    they may render through."""
    sharing = [o.name for o in bpy.data.objects if o.data == obj.data and o != obj]
    if not sharing:
        return None
    renders = "it renders" if len(sharing) == 1 else "they render"
    if not mesh.uv_maps:
        return (f"its mesh {obj.data.name!r} is shared with {_listed(sharing)}, and a new UV map would become the "
                f"render UV map there too, changing how {renders}: give {obj.name!r} its own mesh first (Object > "
                "Relations > Make Single User > Object & Data), or add a UV map to the mesh")
    if ATLAS_UV_NAME in obj.data.uv_layers:
        return (f"its mesh {obj.data.name!r} is shared with {_listed(sharing)}, and rewriting its UV map "
                f"{ATLAS_UV_NAME!r} could change how {renders}: give {obj.name!r} its own mesh first (Object > "
                "Relations > Make Single User > Object & Data)")
    return None


def _no_new_uv_map(obj, mesh):
    """Why no new UV map can be written onto ``obj``'s mesh for any result (None if one can)."""
    data = obj.data
    if data.library is not None:
        return (f"its mesh {data.name!r} is linked from the library {data.library.name!r}: make it local first "
                "(Object > Relations > Make Local), or give it a usable UV map in the library")
    if not mesh.same_topology:
        return "its modifiers change its faces or the order of their corners: apply them first, or give the mesh a " \
               "usable UV map"
    return None


@dataclasses.dataclass(frozen=True)
class AtlasPlan:
    """How the result's UV layout is decided before the run."""

    atlas: object                     # the Atlas, when decided here (else the core decides)
    uvs: object                       # (F, 3, 2) the UVs the core tries, when it decides
    uv_name: str | None               # the UV map the result is read through, when not a new one
    new_atlas: bool                   # the core may make a new atlas
    why: str | None                   # why no new UV map can be written (the core's refusal)


def _atlas_plan(obj, mesh, settings, keep, bake_needed):
    """Decide, as far as can be decided before the run, which UV map the result goes on.

    The render UV map where it is usable; else the ``cp_stylize_atlas`` map an
    earlier run wrote, where usable; else a new atlas.  Whether the render map
    is usable is left to the core (it costs a raster of the UVs) unless it
    matters now: for a procedural bake, which needs the atlas, and where a new
    UV map might not be possible or allowed (Blender's limit of
    :data:`MAX_UV_MAPS`, a mesh shared with other objects, an earlier atlas to
    try).  Raises StylizeError where a new UV map is needed and cannot be written.
    """
    from ..atlas import UnusableUVs

    layers = obj.data.uv_layers
    render = mesh.render_uv
    stored = ATLAS_UV_NAME if ATLAS_UV_NAME in mesh.uv_maps and ATLAS_UV_NAME != render else None
    why = _no_new_uv_map(obj, mesh) or _shared_uv_map(obj, mesh)
    if mesh.uv_maps and not (bake_needed or stored or len(layers) >= MAX_UV_MAPS):
        return AtlasPlan(None, mesh.uv_maps[render], render, why is None, why)
    problems = "it has none"
    for name in (render, stored) if mesh.uv_maps else ():
        if name is None:
            continue
        try:
            return AtlasPlan(_atlas(mesh, settings, keep, mesh.uv_maps[name], False), None, name, False, None)
        except UnusableUVs as err:
            problems = err.problems if name == render else problems
    # a new UV map it must be
    if why is None and len(layers) >= MAX_UV_MAPS and (ATLAS_UV_NAME not in layers or bake_needed):
        why = (f"its mesh {obj.data.name!r} already has {len(layers)} UV maps, Blender's limit: remove one it does "
               "not need (Object Data properties > UV Maps) and press Stylize again")
    if why is not None:
        raise StylizeError(_no_atlas_message(obj.name, UnusableUVs(problems, why)))
    if not bake_needed:
        return AtlasPlan(None, None, None, True, None)   # the core makes the new atlas, in the run
    try:
        return AtlasPlan(_atlas(mesh, settings, keep, None, True), None, None, True, None)
    except UnusableUVs as err:
        raise StylizeError(_no_atlas_message(obj.name, err)) from None


def _direction_attribute(obj, settings):
    """The vector attribute the strokes follow, or None; StylizeError if one is asked for but not named."""
    if settings.stroke_direction != "attribute":
        return None
    if not settings.attribute:
        raise StylizeError(f"the stroke direction is a mesh attribute, but none is chosen: pick one of "
                           f"{obj.name!r}'s vector attributes")
    return settings.attribute


def prepare(obj, settings, output=Output(), depsgraph=None):
    """Check and read everything a run on ``obj`` needs; returns a :class:`Job` (an :class:`AttributeJob` where
    ``output.kind`` is ``"ATTRIBUTE"``: :func:`prepare_attribute`). Changes nothing in the file.

    Raises StylizeError for problems with the object, its materials, the
    save target or the limits.
    """
    from ..estimate import estimate

    if output.kind == "ATTRIBUTE":
        return prepare_attribute(obj, settings, output, depsgraph)
    check_object(obj)
    if output.storage == "SAVE":
        save_folder()
        name, relief_name = result_names(obj, output)
        file_stem(name, "PNG")
        if settings.relief > 0 and settings.strokes > 0:
            file_stem(relief_name, "OPEN_EXR")
    mesh = meshdata.read(obj, depsgraph, vectors=_direction_attribute(obj, settings))
    if settings.stroke_direction in AXIS_DIRECTIONS:
        # the axis is the object's; the core sees the mesh in world units without its rotation
        settings = settings.replace(axis=meshdata.axis_in_frame(obj, settings.axis))
    if not output.keep:
        release()
    slot_count = len(obj.material_slots)
    used = np.unique(np.minimum(mesh.material_index, max(slot_count - 1, 0)))
    slots = [int(i) for i in used]
    guess = estimate(mesh.vertices, mesh.triangles, settings, keep=output.keep, unwrap=not mesh.uv_maps,
                     image_pixels=input_pixels(obj, mesh.uv_maps.keys(), slots, settings), speed=output.speed)
    check_limits(guess, output)
    for index in slots:
        if slot_count and obj.material_slots[index].material is not None:
            _check_writable(obj.material_slots[index].material, output)
    colours, to_bake = _read_colours(obj, mesh, slots)
    if to_bake:
        bake.check_bakeable(obj)
    plan = _atlas_plan(obj, mesh, settings, output.keep, bool(to_bake))
    if to_bake:
        from ..pipeline import Texture

        atlas = plan.atlas
        baked = bake.bake(obj, to_bake, settings.image_size, uv_name=None if atlas.generated else plan.uv_name,
                          uvs=atlas.uvs if atlas.generated else None, loops=mesh.loops)
        faces = np.isin(np.minimum(mesh.material_index, max(slot_count - 1, 0)), list(to_bake))
        colours.textures.append(Texture(baked, atlas.uvs, faces, ("clamp", "clamp")))
    return Job(object_name=obj.name, settings=settings, output=output, mesh=mesh, colours=colours,
               uvs=plan.uvs, uv_name=plan.uv_name, atlas=plan.atlas, new_atlas=plan.new_atlas, no_atlas=plan.why,
               slots=slots, fingerprint=meshdata.fingerprint(obj), slots_state=meshdata.slots_state(obj),
               estimate=guess)


def _attribute_shown(obj, index, mesh):
    """The colour attribute material slot ``index`` of ``obj`` shows, traced back to the attribute an earlier
    run read if it shows that run's result; StylizeError if it shows no colour attribute."""
    from . import writing

    material = obj.material_slots[index].material if len(obj.material_slots) else None
    if material is None:        # faces without a material read the render colour attribute
        return writing.attribute_origin(obj.data, mesh.render_colour, obj.name)
    shown = materials.result_attribute(material)
    if shown is not None:
        return writing.attribute_origin(obj.data, shown or mesh.render_colour, obj.name)
    source = materials.colour_source(materials.source_material(material), mesh.uv_maps.keys(), obj.name)
    if not isinstance(source, materials.AttributeSource):
        what = {materials.Flat: "a flat colour", materials.ImageSource: "an image"}.get(type(source), "colours "
                                                                                       "made by its nodes")
        raise StylizeError(f"material {material.name!r} of {obj.name!r} shows {what}, not a colour attribute: the "
                           "Colour Attribute result filters a colour attribute; choose Result: Image")
    return writing.attribute_origin(obj.data, source.name or mesh.render_colour, obj.name)


def prepare_attribute(obj, settings, output, depsgraph=None):
    """Check and read everything a run into a colour attribute needs; returns an :class:`AttributeJob`.

    The colour attribute the object shows (through its materials' Color
    Attribute nodes, or the render colour attribute where a face has no
    material) is filtered at the mesh's vertices
    (:func:`cp_stylize.vertex_colours.stylize_vertices`: the mesh's own finite
    elements where its vertices are finer than the grid, else the band), and
    the result goes into a new colour attribute of the same domain and type.
    Changes nothing in the file.  Raises StylizeError for a look that paints
    (it needs an image), a mesh shared with other objects or linked from a
    library, modifiers that change the vertices, materials that show no
    colour attribute or different ones, and the limits.
    """
    from ..estimate import estimate_vertices
    from ..vertex_colours import choose_method, corner_to_vertex, mean_edge

    check_object(obj)
    if settings.stylised:
        look = f"the preset {settings.name!r}" if settings.name else "these settings"
        raise StylizeError(f"{look} paints a look (palette, strokes, lines, oil paint, toon, watercolour, "
                           "hatching or painted light) whose marks are finer than a vertex apart: choose Result: "
                           "Image, or a filter (Denoise, Gaussian Blur, Perona-Malik) for a colour attribute")
    data = obj.data
    if data.library is not None:
        raise StylizeError(f"the mesh of {obj.name!r} is linked from the library {data.library.name!r} and cannot "
                           "get a colour attribute here: make it local first (Object > Relations > Make Local)")
    sharing = [o.name for o in bpy.data.objects if o.data == data and o != obj]
    if sharing:
        raise StylizeError(f"the mesh {data.name!r} of {obj.name!r} is shared with {_listed(sharing)}, which would "
                           f"get the new colour attribute too: give {obj.name!r} its own mesh first (Object > "
                           "Relations > Make Single User > Object & Data), or choose Result: Image")
    mesh = meshdata.read(obj, depsgraph)
    if not mesh.same_topology or len(mesh.vertices) != len(data.vertices):
        raise StylizeError(f"the modifiers of {obj.name!r} change its vertices or faces, so a colour at its "
                           "vertices cannot be written back: apply them first, or choose Result: Image")
    slot_count = len(obj.material_slots)
    slots = [int(i) for i in np.unique(np.minimum(mesh.material_index, max(slot_count - 1, 0)))]
    sources = sorted({_attribute_shown(obj, index, mesh) for index in slots}, key=str)
    if None in sources:
        raise StylizeError(f"the mesh of {obj.name!r} has no colour attribute to filter: paint one (Vertex Paint "
                           "Mode) or import it with the scan, or choose Result: Image")
    if len(sources) > 1:
        raise StylizeError(f"the materials of {obj.name!r} show different colour attributes ({_listed(sources)}): "
                           "the Colour Attribute result filters one; choose Result: Image")
    source = sources[0]
    attribute = data.color_attributes.get(source)
    if attribute is None or attribute.domain not in ("POINT", "CORNER"):
        raise StylizeError(f"the mesh of {obj.name!r} has no colour attribute {source!r} on its points or face "
                           "corners: choose one its materials show, or Result: Image")
    from .writing import _shown_by_others

    shown = []
    for index in slots:
        material = obj.material_slots[index].material if slot_count else None
        if material is None:
            continue
        _check_writable(material, output)
        if output.target == "APPLY" and _shown_by_others(material, obj):
            raise StylizeError(f"material {material.name!r} is shown by other objects too, whose meshes have no "
                               f"result attribute: wired into it, the result would render black there; choose "
                               "New Material Copy")
        earlier = materials.result_attribute(material)
        if earlier:
            shown.append(earlier)
    rgba = np.empty(4 * len(attribute.data), dtype=np.float32)
    attribute.data.foreach_get("color_srgb", rgba)
    rgba = rgba.reshape(-1, 4)
    if attribute.domain == "CORNER":
        rgba = corner_to_vertex(mesh.triangles, rgba[mesh.loops], mesh.vertices)
    used = np.zeros(len(rgba), dtype=bool)
    used[mesh.triangles.ravel()] = True
    bad = ~np.isfinite(rgba).all(axis=1)
    if (bad & used).any():
        count = int((bad & used).sum())
        raise StylizeError(f"the colour attribute {source!r} of {obj.name!r} holds colours that are not finite "
                           f"numbers at {count:,} {'vertex' if count == 1 else 'vertices'}: repaint them (Vertex "
                           "Paint Mode) or import the scan again")
    rgba[bad] = 0.0                         # loose vertices: nothing filters them
    if not output.keep:
        release()
    edge = mean_edge(mesh.vertices, mesh.triangles)
    method, reason = choose_method(mesh.vertices, mesh.triangles, settings, edge=edge)
    guess = estimate_vertices(mesh.vertices, mesh.triangles, settings, method, speed=output.speed, edge=edge)
    check_limits(guess, output)
    return AttributeJob(object_name=obj.name, settings=settings, output=output, vertices=mesh.vertices,
                        triangles=mesh.triangles, colours=rgba, source=source, domain=attribute.domain,
                        data_type=attribute.data_type, slots=slots, fingerprint=meshdata.fingerprint(obj),
                        slots_state=meshdata.slots_state(obj), method=method, reason=reason, estimate=guess,
                        shown=tuple(shown))


# -- running -----------------------------------------------------------------------------


def run_core(job, progress=None, log=None):
    """Run the core on a prepared job (no Blender data is touched: safe in a worker thread)."""
    from ..atlas import UnusableUVs
    from ..pipeline import stylize

    global _cache_bytes
    if isinstance(job, AttributeJob):
        from ..vertex_colours import stylize_vertices

        job.result = stylize_vertices(job.vertices, job.triangles, job.colours[:, :3], job.settings,
                                      method=job.method, progress=progress, log=log)
        return job.result
    cache = run_cache() if job.output.keep else None
    try:
        job.result = stylize(job.mesh.vertices, job.mesh.triangles, job.colours, job.settings, uvs=job.uvs,
                             atlas=job.atlas, new_atlas=job.new_atlas, directions=job.mesh.directions,
                             progress=progress, log=log, cache=cache)
    except UnusableUVs as err:
        raise StylizeError(_no_atlas_message(job.object_name, UnusableUVs(err.problems, err.why or job.no_atlas))) \
            from None
    finally:
        _cache_bytes = 0 if cache is None else cache.nbytes()
    job.reused = [] if cache is None else list(cache.reused)
    return job.result


class BackgroundRun:
    """:func:`run_core` in a worker thread, with its progress, cancel and outcome.

    The main thread polls :attr:`fraction` and :attr:`done`; :meth:`cancel`
    makes the worker stop at its next progress report with :class:`Cancelled`
    as its :attr:`error`.  Nothing here touches Blender data.
    """

    def __init__(self, job):
        self.job = job
        self.fraction = 0.0
        self.error = None
        self._cancel = threading.Event()
        self._thread = threading.Thread(target=self._work, daemon=True)

    def _progress(self, fraction):
        self.fraction = fraction
        if self._cancel.is_set():
            raise Cancelled

    def _work(self):
        try:
            run_core(self.job, progress=self._progress)
        except BaseException as err:  # handed to the main thread
            self.error = err

    def start(self):
        self._thread.start()
        return self

    def cancel(self):
        self._cancel.set()

    @property
    def cancelling(self):
        return self._cancel.is_set()

    @property
    def done(self):
        return self._thread.ident is not None and not self._thread.is_alive()

    @property
    def cancelled(self):
        return isinstance(self.error, Cancelled)

    def wait(self, timeout=None):
        self._thread.join(timeout)
        return self.done
