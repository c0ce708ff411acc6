"""The images a run makes, and what becomes of the images they replace.

A result image remembers the object it was made for (:data:`MADE_BY`) and a
digest of the pixels the run wrote (:data:`DIGEST`).  Both are custom
properties, so they survive packing, saving and reopening the file.

When a run wires its new images into the nodes that showed earlier results,
:class:`Replaced` collects what those nodes showed, once each however many
materials shared it.  After the wiring, :meth:`Replaced.retire` decides each
one's fate, whatever its role (colour now, other maps later):

- an earlier result that nothing uses any more and that is exactly as its run
  left it (not dirty, pixels equal to its digest) is removed: it holds nothing
  a new run cannot make again;
- one that was painted on or otherwise edited since (its pixels differ from
  its digest, or it is dirty, or it is from a version without a digest), and
  that nothing uses any more, is kept: it gets a fake user, so that saving the
  file keeps it, and the run's report names it;
- anything else (an image still used elsewhere, an image no run made) is left
  alone.
"""

from __future__ import annotations

import hashlib

import bpy
import numpy as np

#: Custom property of a result image: the name of the object it was made for.
MADE_BY = "cp_stylize"
#: Custom property of a result image: the digest of the pixels its run wrote.
DIGEST = "cp_stylize_digest"


def pixel_digest(image):
    """A digest of an image's size and pixels (as Blender hands them out), or None if it has none."""
    w, h = image.size
    if w == 0 or h == 0:
        return None
    buf = np.empty(w * h * image.channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    digest = hashlib.blake2b(digest_size=16)
    digest.update(np.array([w, h, image.channels], dtype=np.int64).tobytes())
    digest.update(buf.tobytes())
    return digest.hexdigest()


def mark(image, obj):
    """Mark ``image`` (new in this run, its pixels final) as a result made for ``obj``."""
    image[MADE_BY] = obj.name
    image[DIGEST] = pixel_digest(image) or ""


def made_by_a_run(image):
    return bool(image.get(MADE_BY))


def edited(image):
    """Whether a result image differs from what its run wrote (or cannot be told apart from an edited one)."""
    if image.is_dirty:
        return True
    recorded = image.get(DIGEST)
    if not recorded:
        return True
    w, h = image.size
    if w == 0 or h == 0:        # its file is gone: it holds no pixels to lose
        return False
    return pixel_digest(image) != recorded


class Replaced:
    """The images the nodes a run rewires showed before it, each once."""

    def __init__(self):
        self._images = {}

    def add(self, image):
        if image is not None:
            self._images.setdefault(image.as_pointer(), image)

    def retire(self, new_images, changes):
        """Decide what becomes of the replaced images once the new ones are wired.

        Gives the edited earlier results that nothing uses any more a fake
        user (recorded in ``changes``).  Returns ``(unused, kept)``: the
        images to remove once the run's changes are final, and the names of
        those kept.
        """
        new = {image.as_pointer() for image in new_images}
        unused, kept = [], []
        for pointer, image in self._images.items():
            if pointer in new or not made_by_a_run(image) or image.users > 0:
                continue
            if edited(image):
                changes.set(image, "use_fake_user", True)
                kept.append(image.name)
            else:
                unused.append(image)
        return unused, kept


def kept_note(names):
    """What the report says about the edited earlier results a run kept ("" if none)."""
    if not names:
        return ""
    if len(names) == 1:
        return (f"; the earlier result {names[0]!r} was edited after its run, so it is kept, with a fake user so "
                "that saving keeps it")
    listed = ", ".join(repr(n) for n in names[:-1]) + f" and {names[-1]!r}"
    return (f"; the earlier results {listed} were edited after their runs, so they are kept, with fake users so "
            "that saving keeps them")


def remove(images, wanted):
    """Remove the unused earlier results ``images``; a new image takes back a name one of them held.

    ``wanted`` holds ``(new image, the name it was meant to have)``.
    """
    freed = {image.name for image in images}
    for image in images:
        bpy.data.images.remove(image)
    for image, name in wanted:
        if name in freed and image.name != name:
            image.name = name
