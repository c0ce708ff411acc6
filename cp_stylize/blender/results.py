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
    """Whether ``image`` is a result a run made."""
    return bool(image.get(MADE_BY))


def edited(image):
    """Whether a result image differs from what its run wrote: True, False, or None where that cannot be told
    (a result made before results remembered their pixels)."""
    if image.is_dirty:
        return True
    recorded = image.get(DIGEST)
    if not recorded:
        return None
    w, h = image.size
    if w == 0 or h == 0:        # its file is gone: it holds no pixels to lose
        return False
    return pixel_digest(image) != recorded


def _in_use(image):
    """Whether the user keeps ``image`` (a fake user) or anything in the file still uses it: what refers to
    it, not its user count, which Blender 4.2 leaves one too high after a material copy's image node is
    pointed elsewhere."""
    return image.use_fake_user or (bool(image.users) and bool(bpy.data.user_map(subset={image}).get(image)))


class Replaced:
    """The images the nodes a run rewires showed before it, each once."""

    def __init__(self):
        self._images = {}

    def add(self, image):
        if image is not None:
            self._images.setdefault(image.as_pointer(), image)

    def retire(self, new_images, changes):
        """Decide what becomes of the replaced images once the new ones are wired.

        Gives the earlier results that nothing uses any more and that were
        edited, or may have been, a fake user (recorded in ``changes``).
        Returns ``(unused, kept)``: the images to remove once the run's
        changes are final, and ``(name, edited)`` of those kept (``edited``
        None where it cannot be told).
        """
        new = {image.as_pointer() for image in new_images}
        unused, kept = [], []
        for pointer, image in self._images.items():
            if pointer in new or not made_by_a_run(image) or _in_use(image):
                continue
            changed = edited(image)
            if changed is False:
                unused.append(image)
            else:
                changes.set(image, "use_fake_user", True)
                kept.append((image.name, changed))
        return unused, kept


#: How the report says why earlier results were kept: by whether they were edited (None: cannot be told),
#: for one result and for several.
_WHY_KEPT = {True: ("the earlier result {} was edited after its run",
                    "the earlier results {} were edited after their runs"),
             None: ("the earlier result {} may have been edited (it was made before results remembered their "
                    "pixels)",
                    "the earlier results {} may have been edited (they were made before results remembered their "
                    "pixels)")}


def kept_note(kept):
    """What the report says about the earlier results a run kept, ``(name, edited)`` each ("" if none)."""
    notes = []
    for known, (one, several) in _WHY_KEPT.items():
        names = [repr(name) for name, edited in kept if edited is known]
        if names:
            listed = names[0] if len(names) == 1 else ", ".join(names[:-1]) + f" and {names[-1]}"
            notes.append((one if len(names) == 1 else several).format(listed))
    if not notes:
        return ""
    if len(kept) == 1:
        return f"; {notes[0]}, so it is kept, with a fake user so that saving keeps it"
    return f"; {'; '.join(notes)}, so they are kept, with fake users so that saving keeps them"


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
