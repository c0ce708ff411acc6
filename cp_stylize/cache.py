"""What a run builds before its filter, kept for the next run on the same mesh.

A run spends its first seconds on things that depend on the mesh, the grid
and the atlas only: the normalised mesh and its closest point search, the UV
atlas (an xatlas unwrap can take a minute), the band with its extension and
stencil matrices, and the surface points of the atlas's texels.  A user who
tries another preset or moves a slider changes none of them.  A
:class:`RunCache` passed to :func:`cp_stylize.pipeline.stylize` hands them
to the next run when they were built from the same inputs, compared by a
digest of the arrays' bytes, so an edited mesh or a new grid spacing is
never served stale parts.

It keeps one version of each part: a part built from other inputs replaces
it, and the old one is dropped before the new one is built.  A run on
another mesh drops every part first (:meth:`RunCache.start`), so it never
holds two bands at once.
"""

from __future__ import annotations

import hashlib
import threading

import numpy as np

__all__ = ["RunCache", "digest"]

#: The package's own name (``cp_stylize``, or longer inside Blender's extensions): its objects are
#: searched for arrays by :meth:`RunCache.nbytes`.
_PACKAGE = __name__.rpartition(".")[0]


def digest(*items):
    """A short digest of arrays (by dtype, shape and bytes), numbers, strings and None."""
    h = hashlib.blake2b(digest_size=16)
    for item in items:
        if item is None or isinstance(item, (bool, int, float, str)):
            h.update(repr(item).encode())
        else:
            array = np.ascontiguousarray(item)
            h.update(f"{array.dtype.str}{array.shape}".encode())
            h.update(array.view(np.uint8).reshape(-1).data if array.size else b"")
        h.update(b"|")
    return h.hexdigest()


class RunCache:
    """Parts of a run, each kept with the key of the inputs it was built from.

    :meth:`get` gives the kept part if its key matches, and otherwise drops
    it and builds a new one.  :attr:`reused` names the parts the last
    :meth:`start`-ed run took from the cache.
    """

    def __init__(self):
        self._parts = {}
        self._lock = threading.Lock()
        self.reused = []
        self.owner = None

    def start(self, owner=None):
        """Begin a run on the mesh ``owner`` (a digest): every part kept for another mesh is dropped,
        and :attr:`reused` starts empty."""
        if owner != self.owner:
            self.clear()
        self.owner = owner
        self.reused = []

    def get(self, name, key, build):
        """The part ``name`` built from inputs ``key``: kept, or ``build()`` (then kept).

        An exception from ``build`` leaves nothing kept under ``name``.
        """
        with self._lock:
            kept = self._parts.get(name)
            if kept is not None and kept[0] == key:
                self.reused.append(name)
                return kept[1]
            self._parts.pop(name, None)         # free it before the new one is built
        value = build()
        with self._lock:
            self._parts[name] = (key, value)
        return value

    def part(self, name):
        """The part kept under ``name``, or None."""
        with self._lock:
            kept = self._parts.get(name)
        return None if kept is None else kept[1]

    def clear(self):
        """Drop every part."""
        with self._lock:
            self._parts.clear()

    def nbytes(self):
        """Bytes of the arrays and sparse matrices the kept parts hold (each counted once)."""
        with self._lock:
            parts = [value for _, value in self._parts.values()]
        return _nbytes(parts, set())

    def __contains__(self, name):
        return name in self._parts

    def __len__(self):
        return len(self._parts)


def _nbytes(item, seen):
    """Bytes of the arrays within ``item``: NumPy arrays, SciPy sparse matrices, and the containers and
    cp_stylize objects that hold them."""
    if id(item) in seen or item is None or isinstance(item, (bool, int, float, str, bytes, type)):
        return 0
    seen.add(id(item))
    if isinstance(item, np.ndarray):
        base = item
        while isinstance(base.base, np.ndarray):
            base = base.base
        if base is not item:
            return _nbytes(base, seen)
        return item.nbytes
    if isinstance(item, dict):
        return sum(_nbytes(v, seen) for v in item.values())
    if isinstance(item, (list, tuple, set)):
        return sum(_nbytes(v, seen) for v in item)
    fields = getattr(item, "__dict__", None)
    if fields is None or not type(item).__module__.startswith((_PACKAGE + ".", "scipy.sparse")):
        return 0
    return sum(_nbytes(v, seen) for v in fields.values())
