"""Where a material's surface colour comes from, and where the stylized image goes.

The colour a material shows is the colour input of the shader connected to
its Material Output: the Principled BSDF's Base Color, or the Color of a
Diffuse, Emission or other shader (or of a node group with such an input).
:func:`colour_input` finds that socket, or names the node that has none.

:func:`colour_source` says how to read what feeds it, as the renderer does
(through reroutes, and past muted nodes and links as the renderer leaves them
out):

- :class:`Flat`: nothing is linked, the socket's own colour;
- :class:`ImageSource`: an Image Texture with flat projection, read through a
  UV map (the render UV map unless a UV Map node names one), optionally
  through a constant Mapping node, with its extension (repeat, extend,
  mirror, clip) and colour space;
- :class:`AttributeSource`: a Color Attribute node;
- :class:`BakeSource`: anything else (procedural textures, other coordinates,
  colour adjustments, other colour spaces), baked with Cycles.

The result goes into an Image Texture node named :data:`NODE` linked to that
same socket (:func:`wire`), or, for a result in a colour attribute, into a
Color Attribute node named :data:`ATTRIBUTE_NODE` (:func:`wire_attribute`);
the node remembers what fed the socket before, so a second run reads the
original colours again, not its own result.
"""

from __future__ import annotations

import dataclasses

import bpy
import numpy as np

from .errors import StylizeError

#: Name of the Image Texture node that holds the stylized image, and of its UV Map node.
NODE = "cp_stylize"
UV_NODE = "cp_stylize UV"
#: Name of the Color Attribute node that shows a result written into a colour attribute.
ATTRIBUTE_NODE = "cp_stylize attribute"
#: The Image Texture node that holds the relief (the strokes' height), and the Bump node it feeds.
RELIEF_NODE = "cp_stylize relief"
BUMP_NODE = "cp_stylize bump"
#: Custom property of :data:`NODE` and :data:`ATTRIBUTE_NODE`: ``"<node name>/<output identifier>"`` of what
#: fed the colour input before the result did ("" if nothing was linked).
SOURCE = "cp_stylize_source"
#: Custom property of a material copy: the material it was copied from (keeps it alive).
ORIGINAL = "cp_stylize_original"

#: Image colour spaces whose pixels cp_stylize reads itself: byte pixels as stored are sRGB-encoded
#: for "sRGB" and linear for the others (float images are linear whatever their colour space).
SRGB_SPACES = ("sRGB",)
LINEAR_SPACES = ("Non-Color", "Linear Rec.709", "Linear", "Raw", "Linear CIE-XYZ E")

#: Blender's image extensions as cp_stylize.texture wraps.
WRAPS = {"REPEAT": "repeat", "EXTEND": "clamp", "MIRROR": "mirror", "CLIP": "clip"}

#: The colour Blender renders a face without a material with (sRGB-encoded grey 0.8).
DEFAULT_SURFACE = (0.906, 0.906, 0.906)


@dataclasses.dataclass(frozen=True)
class Flat:
    colour: tuple            # sRGB-encoded (r, g, b)


@dataclasses.dataclass(frozen=True)
class ImageSource:
    node: object             # the Image Texture node
    image: object
    uv_name: str | None      # None: the render UV map
    transform: tuple | None  # (A (2, 2), b (2,)) applied to the UVs
    wrap: str
    mapping: str | None = None   # the name of the Mapping node that applies it


@dataclasses.dataclass(frozen=True)
class AttributeSource:
    name: str | None         # None: the mesh's render colour attribute


@dataclasses.dataclass(frozen=True)
class BakeSource:
    socket: object           # the output socket whose colour Cycles bakes


def _linked(socket):
    """The output socket linked to input ``socket``, through reroutes (None if unlinked, or through a muted link)."""
    while socket.is_linked:
        link = socket.links[0]
        if not link.is_valid or link.is_muted:
            return None
        if link.from_node.type != "REROUTE":
            return link.from_socket
        socket = link.from_node.inputs[0]
    return None


def _unmuted(output):
    """What the renderer takes for ``output`` (None: the input that reads it keeps its own value).

    The renderer leaves muted nodes out: a muted node passes on what feeds
    the input its internal link joins to ``output``; where it has no such
    link, or that input is unlinked, the reading input keeps its own value.
    """
    while output is not None and output.node.mute:
        through = next((l.from_socket for l in output.node.internal_links if l.to_socket == output), None)
        output = None if through is None else _linked(through)
    return output


def _upstream(socket):
    """The output socket whose value input ``socket`` reads, as the renderer sees it (None: its own value)."""
    return _unmuted(_linked(socket))


def material_output(tree):
    """The Material Output node Cycles renders (None if there is none)."""
    outputs = [n for n in tree.nodes if n.type == "OUTPUT_MATERIAL" and n.target in ("ALL", "CYCLES")]
    return next((n for n in outputs if n.is_active_output), outputs[0] if outputs else None)


def uses_nodes(material):
    """Whether the renderer shades ``material`` with its nodes (always, from Blender 5.0 on)."""
    return material.node_tree is not None and (bpy.app.version >= (5, 0, 0) or material.use_nodes)


def colour_input(material):
    """The input socket that sets ``material``'s surface colour; StylizeError naming what is wrong."""
    tree = material.node_tree
    out = material_output(tree)
    if out is None:
        if any(n.type == "OUTPUT_MATERIAL" for n in tree.nodes):
            raise StylizeError(f"material {material.name!r} has a Material Output node for EEVEE only, and the "
                               "result is read as Cycles renders it: set the node's Target to All (the node's "
                               "sidebar, Node tab > Properties), or add an output for Cycles")
        raise StylizeError(f"material {material.name!r} has no Material Output node: add one (Add > Output > "
                           "Material Output in the Shader Editor) and connect its Surface to the shader")
    surface = _upstream(out.inputs["Surface"])
    if surface is None:
        muted = getattr(_linked(out.inputs["Surface"]), "node", None)
        if muted is not None:
            raise StylizeError(f"material {material.name!r}: its surface comes from the muted node {muted.name!r} "
                               f"({muted.bl_label}), so it renders no surface: unmute it (M in the Shader Editor)")
        raise StylizeError(f"material {material.name!r}: nothing is connected to its Material Output's Surface")
    shader = surface.node
    for name in ("Base Color", "Color"):
        socket = shader.inputs.get(name)
        if socket is not None and socket.type == "RGBA" and socket.enabled:
            return socket
    raise StylizeError(f"material {material.name!r}: its surface comes from the node {shader.name!r} "
                       f"({shader.bl_label}), which has no colour input; cp_stylize reads and writes the Base Color "
                       "or Color input of the shader connected to the Material Output")


def _remembered(node):
    """What fed the colour input before :data:`NODE` did: ``(True, socket or None)``, or ``(False, None)``."""
    if SOURCE not in node:
        return False, None
    ref = node[SOURCE]
    if not ref:
        return True, None
    name, _, identifier = ref.rpartition("/")
    source = node.id_data.nodes.get(name)
    if source is None:
        return False, None
    socket = next((s for s in source.outputs if s.identifier == identifier), None)
    return socket is not None, socket


def _ours(output):
    """Whether ``output`` is the Color of the Image Texture node :data:`NODE` a run wired in."""
    return output is not None and output.node.name == NODE and output.node.type == "TEX_IMAGE"


def _ours_attribute(output):
    """Whether ``output`` is the Color of the Color Attribute node :data:`ATTRIBUTE_NODE` a run wired in."""
    return output is not None and output.node.name == ATTRIBUTE_NODE and output.node.type == "VERTEX_COLOR"


def original_origin(socket):
    """The output socket whose colour ``socket`` shows, before any result was wired in (None: unlinked)."""
    origin = _linked(socket)
    if _ours(origin) or _ours_attribute(origin):
        found, remembered = _remembered(origin.node)
        if found:
            return _unmuted(remembered)
    return _unmuted(origin)


def _result_node(material, name, kind, above, changes):
    """The result node ``name`` (of type ``kind``: :data:`NODE` or :data:`ATTRIBUTE_NODE`) feeding
    ``material``'s colour input, unmuted, and whether it was made now; ``above``: how far above the shader
    a new one goes.  A node of an earlier run is reused, also where a run of the other kind (an image after
    a colour attribute, or the reverse) took the colour input from it; a node that newly feeds the input
    remembers what fed it before (:data:`SOURCE`).  Every change is recorded in ``changes``."""
    if not uses_nodes(material):
        changes.set(material, "use_nodes", True)
    tree = material.node_tree
    socket = colour_input(material)
    current = _linked(socket)
    node = tree.nodes.get(name)
    if node is not None and node.bl_idname != kind:
        node = None
    if node is not None and current is not None and current.node == node:
        changes.set(node, "mute", False)
        return node, False
    made = node is None
    if made:
        shader = socket.node
        node = changes.new_node(tree, kind)
        node.name = node.label = name
        node.location = (shader.location.x - 400, shader.location.y + above)
    else:
        changes.set(node, "mute", False)
    changes.set_item(node, SOURCE, _source_reference(current))
    changes.link(tree, node.outputs["Color"], socket)
    return node, made


def _source_reference(current):
    """What a new result node remembers as having fed the colour input, now fed by ``current``: the
    reference a result node of the other kind remembered (an image run after an attribute run, or the
    reverse), else ``current`` itself ("" if nothing)."""
    if (_ours(current) or _ours_attribute(current)) and SOURCE in current.node:
        return current.node[SOURCE]
    return f"{current.node.name}/{current.identifier}" if current is not None else ""


def _linear_to_srgb(rgb):
    from ..texture import linear_to_srgb

    return tuple(float(c) for c in linear_to_srgb(np.clip(np.asarray(rgb[:3], dtype=np.float64), 0.0, None)))


def _mapping_transform(node, material):
    """2-D affine map ``(A, b)`` a Mapping node applies to UVs (z = 0), exactly as the renderer does, or None."""
    from mathutils import Euler

    kind = node.vector_type
    if kind not in ("POINT", "TEXTURE", "VECTOR"):
        return None
    if any(_upstream(s) is not None for s in node.inputs[1:] if s.enabled):
        return None
    scale = np.array(node.inputs["Scale"].default_value[:], dtype=np.float64)
    rotation = np.array(Euler(node.inputs["Rotation"].default_value[:], "XYZ").to_matrix(), dtype=np.float64)
    location = np.array(node.inputs["Location"].default_value[:], dtype=np.float64) if kind != "VECTOR" \
        else np.zeros(3)
    if kind == "TEXTURE":  # safe_divide(R^T (x - L), S), as Cycles and EEVEE compute it
        if np.any(scale[:2] == 0):
            raise StylizeError(f"the Mapping node {node.name!r} in material {material.name!r} has a zero scale, "
                               "which maps the whole texture to one line or point")
        inv = np.diag(1.0 / scale) @ rotation.T
        return inv[:2, :2], -(inv @ location)[:2]
    full = rotation @ np.diag(scale)   # R (S x) + L
    return full[:2, :2], location[:2]


def _image_source(output, material, uv_names, owner):
    """An :class:`ImageSource` for an Image Texture's Color output, or None where only a bake reads it."""
    node = output.node
    if output.identifier != "Color" or node.projection != "FLAT" or node.image is None:
        return None
    image = node.image
    if image.source in ("FILE", "GENERATED") and not (image.is_float or image.colorspace_settings.name
                                                      in SRGB_SPACES + LINEAR_SPACES):
        return None
    transform, uv_name, mapping = None, None, None
    vector = _upstream(node.inputs["Vector"])
    if vector is not None and vector.node.type == "MAPPING":
        mapping = vector.node.name
        transform = _mapping_transform(vector.node, material)
        vector = _upstream(vector.node.inputs["Vector"])
        if transform is None or vector is None:   # an unlinked Mapping input is a constant, not the UVs
            return None
    if vector is not None:
        kind = vector.node.type
        if kind == "UVMAP" and not getattr(vector.node, "from_instancer", False):
            uv_name = vector.node.uv_map or None
            if uv_name is not None and uv_name not in uv_names:
                raise StylizeError(f"the UV Map node {vector.node.name!r} in material {material.name!r} names the "
                                   f"UV map {uv_name!r}, which the mesh of {owner!r} does not have")
        elif not (kind == "TEX_COORD" and vector.identifier == "UV"
                  and not getattr(vector.node, "from_instancer", False)):
            return None
    return ImageSource(node=node, image=image, uv_name=uv_name, transform=transform,
                       wrap=WRAPS.get(node.extension, "repeat"), mapping=mapping)


def source_material(material):
    """The material whose colours a run on ``material`` reads.

    ``material`` itself, except for a copy an earlier run made whose
    :data:`NODE` no longer finds the node it replaced (deleted since): then
    its original, which still has it, so that a run starts again from the
    original colours rather than from the last result.
    """
    original = material.get(ORIGINAL)
    if original is None or not uses_nodes(material):
        return material
    try:
        origin = _linked(colour_input(material))
    except StylizeError:
        return material
    forgotten = (_ours(origin) or _ours_attribute(origin)) and not _remembered(origin.node)[0]
    return original if forgotten else material


def colour_source(material, uv_names, owner):
    """How to read ``material``'s surface colour: Flat, ImageSource, AttributeSource or BakeSource.

    ``uv_names`` are the UV maps of the mesh it colours, ``owner`` the name of
    that mesh's object (for messages).
    """
    if not uses_nodes(material):
        return Flat(_linear_to_srgb(material.diffuse_color))
    socket = colour_input(material)
    origin = original_origin(socket)
    if origin is None:
        return Flat(_linear_to_srgb(socket.default_value))
    node = origin.node
    if node.type == "TEX_IMAGE":
        found = _image_source(origin, material, uv_names, owner)
        if found is not None:
            return found
        return BakeSource(origin)
    if node.type == "VERTEX_COLOR" and origin.identifier == "Color":
        return AttributeSource(node.layer_name or None)
    return BakeSource(origin)


# -- writing -----------------------------------------------------------------------------------------


def wire(material, image, uv_name, changes):
    """Show ``image`` (through the UV map ``uv_name``) as ``material``'s surface colour.

    The image goes into the Image Texture node :data:`NODE`, linked to the
    shader's colour input; a node from an earlier run is reused.  Nothing
    else in the material changes: the shader, and the nodes that fed the
    colour before (now unlinked, remembered by the node).  A node of an
    earlier run that the user muted is unmuted, so that the result shows.
    Every change is recorded in ``changes`` so that it can be undone.
    Returns the image the node showed before (None for a new node).
    """
    tex, made = _result_node(material, NODE, "ShaderNodeTexImage", 200, changes)
    tree = material.node_tree
    previous = None if made else tex.image
    changes.set(tex, "image", image)
    changes.set(tex, "interpolation", "Cubic")       # smooth where the render magnifies the texture
    changes.set(tex, "extension", "EXTEND")          # the atlas lies in [0, 1]: no wrap to the far side
    uv = tree.nodes.get(UV_NODE)
    uv_linked = tex.inputs["Vector"].is_linked and tex.inputs["Vector"].links[0].from_node == uv
    if uv_name:
        if uv is None or uv.type != "UVMAP":
            uv = changes.new_node(tree, "ShaderNodeUVMap")
            uv.name = uv.label = UV_NODE
            uv.location = (tex.location.x - 250, tex.location.y)
            uv_linked = False
        changes.set(uv, "uv_map", uv_name)
        changes.set(uv, "mute", False)
        if not uv_linked:
            changes.link(tree, uv.outputs["UV"], tex.inputs["Vector"])
    elif uv_linked:
        changes.unlink(tree, tex.inputs["Vector"].links[0])
    return previous


def result_attribute(material):
    """The colour attribute an earlier run's :data:`ATTRIBUTE_NODE` shows as ``material``'s colour ("" for the
    render colour attribute), or None where the colour does not come from that node (or it is muted)."""
    if not uses_nodes(material):
        return None
    try:
        current = _linked(colour_input(material))
    except StylizeError:
        return None
    if not _ours_attribute(current) or current.node.mute:
        return None
    return current.node.layer_name


def wire_attribute(material, name, changes):
    """Show the colour attribute ``name`` as ``material``'s surface colour, as :func:`wire` shows an image.

    The attribute goes into the Color Attribute node :data:`ATTRIBUTE_NODE`,
    linked to the shader's colour input; a node from an earlier run is reused
    (and unmuted).  Nothing else in the material changes; what fed the colour
    before is remembered by the node.  Returns the attribute the node showed
    before (None for a new node).
    """
    node, made = _result_node(material, ATTRIBUTE_NODE, "ShaderNodeVertexColor", -100, changes)
    previous = None if made else node.layer_name
    changes.set(node, "layer_name", name)
    return previous


def _node(tree, name, kind, changes, location):
    """The node ``name`` of type ``kind`` a run made before, or a new one (recorded in ``changes``)."""
    node = tree.nodes.get(name)
    if node is not None and node.bl_idname == kind:
        return node, False
    node = changes.new_node(tree, kind)
    node.name = node.label = name
    node.location = location
    return node, True


def _normal_input(material):
    """The Normal input of the shader whose colour a run sets, or None (a shader without one shows no relief)."""
    socket = colour_input(material).node.inputs.get("Normal")
    return socket if socket is not None and socket.enabled else None


def wire_relief(material, image, uv_name, distance, changes):
    """Show the relief ``image`` (a height, through the UV map ``uv_name``) as bumps of ``material``'s shader.

    The image goes into the Image Texture node :data:`RELIEF_NODE`, whose
    height feeds the Bump node :data:`BUMP_NODE` (``distance``: the height 1
    in the object's units), whose normal feeds the shader's Normal input.
    Whatever fed that input before (a normal map) now feeds the Bump node's
    Normal, so it keeps working under the relief.  Nodes of an earlier run
    are reused.  Every change is recorded in ``changes``.  Returns the image
    the relief node showed before (None for a new node, or where the shader
    has no Normal input and nothing is wired).
    """
    normal = _normal_input(material)
    if normal is None:
        return None
    tree = material.node_tree
    shader = normal.node
    tex, made = _node(tree, RELIEF_NODE, "ShaderNodeTexImage", changes,
                      (shader.location.x - 700, shader.location.y - 250))
    previous = None if made else tex.image
    changes.set(tex, "image", image)
    changes.set(tex, "mute", False)
    changes.set(tex, "interpolation", "Cubic")       # smooth slopes between texels: no stair-stepped bumps
    changes.set(tex, "extension", "EXTEND")          # a repeat would slope the relief to the far side's height
    uv = tree.nodes.get(UV_NODE)
    vector = tex.inputs["Vector"]
    if uv_name and uv is not None and uv.type == "UVMAP":
        if not (vector.is_linked and vector.links[0].from_node == uv):
            changes.link(tree, uv.outputs["UV"], vector)
    elif vector.is_linked:
        changes.unlink(tree, vector.links[0])
    bump, _ = _node(tree, BUMP_NODE, "ShaderNodeBump", changes, (shader.location.x - 350, shader.location.y - 250))
    changes.set(bump, "mute", False)
    changes.set(bump.inputs["Strength"], "default_value", 1.0)
    changes.set(bump.inputs["Distance"], "default_value", float(distance))
    if not (bump.inputs["Height"].is_linked and bump.inputs["Height"].links[0].from_node == tex):
        changes.link(tree, tex.outputs["Color"], bump.inputs["Height"])
    feeding = normal.links[0].from_socket if normal.is_linked else None
    if feeding is None or feeding.node != bump:
        if feeding is not None:
            changes.link(tree, feeding, bump.inputs["Normal"])
        changes.link(tree, bump.outputs["Normal"], normal)
    return previous


def unwire_relief(material, changes):
    """Take an earlier run's relief out of ``material``: what fed the Bump node's Normal feeds the shader's
    Normal again, and the relief node shows no image.  Returns the image it showed (None if none)."""
    tree = material.node_tree
    tex = tree.nodes.get(RELIEF_NODE) if tree is not None else None
    if tex is None or tex.type != "TEX_IMAGE":
        return None
    bump = tree.nodes.get(BUMP_NODE)
    normal = _normal_input(material)
    if bump is not None and normal is not None and normal.is_linked and normal.links[0].from_node == bump:
        under = bump.inputs["Normal"]
        if under.is_linked:
            changes.link(tree, under.links[0].from_socket, normal)
        else:
            changes.unlink(tree, normal.links[0])
    previous = tex.image
    changes.set(tex, "image", None)
    return previous
