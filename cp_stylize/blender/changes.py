"""Changes to Blender data that can all be undone: one run's result is applied all or nothing.

Every change goes through a :class:`Changes` (a new datablock, node, link, UV
map or file, a property set) and records how to undo itself.  ``undo()``
reverts them in reverse order, so that after a failure the file is exactly as
it was.  The procedural bake uses the same mechanism for its temporary
changes, which it always undoes.
"""

import os
import sys
import traceback

_MISSING = object()


class Changes:
    def __init__(self):
        self._undo = []

    def __enter__(self):
        return self

    def __exit__(self, kind, error, tb):
        if kind is not None:
            self.undo()
        return False

    def record(self, undo):
        """Add a callable that reverts one change."""
        self._undo.append(undo)

    def undo(self):
        """Revert every recorded change, newest first (a revert that fails is reported and skipped)."""
        while self._undo:
            step = self._undo.pop()
            try:
                step()
            except Exception:  # keep reverting the rest
                print("cp_stylize: could not revert a change:", file=sys.stderr)
                traceback.print_exc()

    # -- properties ------------------------------------------------------------------------------

    def set(self, owner, attr, value):
        old = getattr(owner, attr)
        if old == value:
            return
        setattr(owner, attr, value)
        self.record(lambda: setattr(owner, attr, old))

    def set_item(self, owner, key, value):
        """Set the custom property ``owner[key]``."""
        old = owner.get(key, _MISSING)
        owner[key] = value
        self.record(lambda: owner.pop(key, None) if old is _MISSING else owner.__setitem__(key, old))

    # -- datablocks --------------------------------------------------------------------------------

    def new_id(self, collection, block):
        """Record ``block``, just added to ``collection`` (e.g. ``bpy.data.images``), for removal."""
        self.record(lambda: collection.remove(block))
        return block

    def new_uv_map(self, mesh, name):
        """A new UV map ``name`` on ``mesh``, recorded for removal (by name: adding a UV map moves the others).

        Returns None if the mesh has as many UV maps as Blender allows.
        """
        layer = mesh.uv_layers.new(name=name, do_init=False)
        if layer is not None:
            added = layer.name
            self.record(lambda: mesh.uv_layers.remove(mesh.uv_layers[added]) if added in mesh.uv_layers else None)
        return layer

    def new_colour_attribute(self, mesh, name, data_type, domain):
        """A new colour attribute ``name`` on ``mesh``, recorded for removal (by name); the mesh's active and
        render colour attributes stay as they were."""
        attributes = mesh.color_attributes
        active, render = attributes.active_color_name, attributes.default_color_name
        attribute = attributes.new(name, data_type, domain)
        added = attribute.name
        if attributes.active_color_name != active:
            attributes.active_color_name = active
        if attributes.default_color_name != render:
            attributes.default_color_name = render

        def undo():
            if added in attributes:
                attributes.remove(attributes[added])
            if attributes.active_color_name != active:
                attributes.active_color_name = active
            if attributes.default_color_name != render:
                attributes.default_color_name = render
        self.record(undo)
        return attributes[added]

    def new_file(self, path):
        """Record a file this run wrote, for removal."""
        self.record(lambda: os.path.exists(path) and os.remove(path))
        return path

    # -- node trees ----------------------------------------------------------------------------------

    def new_node(self, tree, kind):
        node = tree.nodes.new(kind)
        name = node.name
        self.record(lambda: tree.nodes.remove(tree.nodes[name]) if name in tree.nodes else None)
        return node

    def link(self, tree, from_socket, to_socket):
        """Link two sockets; undo restores what fed ``to_socket`` before."""
        before = [l.from_socket for l in to_socket.links]
        tree.links.new(from_socket, to_socket)

        def undo():
            for l in list(to_socket.links):
                if l.from_socket == from_socket:
                    tree.links.remove(l)
            for s in before:
                tree.links.new(s, to_socket)
        self.record(undo)

    def unlink(self, tree, link):
        from_socket, to_socket = link.from_socket, link.to_socket
        tree.links.remove(link)
        self.record(lambda: tree.links.new(from_socket, to_socket))
