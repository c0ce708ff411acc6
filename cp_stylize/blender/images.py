"""Pixels between Blender images and NumPy arrays (row 0 at the bottom, as Blender stores them)."""

import os
import tempfile

import bpy
import numpy as np

from .errors import StylizeError


def image_to_array(image):
    """RGBA pixels of a Blender image as a float32 array (H, W, 4)."""
    w, h = image.size
    if w == 0 or h == 0:
        raise StylizeError(f"image {image.name!r} has no pixels (is its file missing?)")
    channels = image.channels
    buf = np.empty(w * h * channels, dtype=np.float32)
    image.pixels.foreach_get(buf)
    buf = buf.reshape(h, w, channels)
    if channels == 4:
        return buf
    rgba = np.ones((h, w, 4), dtype=np.float32)
    rgba[..., :3] = buf[..., :1] if channels < 3 else buf[..., :3]
    return rgba


def array_to_image(name, array, *, colorspace="sRGB", float_buffer=False):
    """A new Blender image named ``name`` holding ``array`` (H, W, C) with C in {1, 3, 4}."""
    array = np.asarray(array, dtype=np.float32)
    h, w, c = array.shape
    rgba = np.ones((h, w, 4), dtype=np.float32)
    if c == 1:
        rgba[..., :3] = array
    else:
        rgba[..., :c] = array[..., :4]
    image = bpy.data.images.new(name, width=w, height=h, alpha=True, float_buffer=float_buffer)
    image.colorspace_settings.name = colorspace
    image.pixels.foreach_set(rgba.ravel())
    image.update()
    return image


def tile_offset(number):
    """The UV square of UDIM tile ``number``: (u, v) of its lower left corner (1001: (0, 0), 1012: (1, 1))."""
    return (number - 1001) % 10, (number - 1001) // 10


def _tile_path(image, number):
    """The file of a tiled image's tile ``number``: its path with the ``<UDIM>`` (1001) or ``<UVTILE>`` (u1_v1)
    token filled in."""
    u, v = tile_offset(number)
    path = bpy.path.abspath(image.filepath_raw, library=image.library)
    return path.replace("<UDIM>", str(number)).replace("<UVTILE>", f"u{u + 1}_v{v + 1}")


def _check_tiles(image):
    """Raise StylizeError if a tiled (UDIM) image's tiles cannot each be read from its files or packed data."""
    fix = "save it (Image > Save in the Image Editor) and press Stylize again"
    if image.is_dirty:
        raise StylizeError(f"image {image.name!r} is a tiled (UDIM) image with changes that are not saved (its "
                           f"tiles are read from their files or packed data): {fix}")
    packed = {p.tile_number for p in image.packed_files}
    if packed:
        missing = [t.number for t in image.tiles if t.number not in packed]
        if missing:
            raise StylizeError(f"image {image.name!r}: its tile {missing[0]} is not packed with the others: pack "
                               "them all (Image > Pack in the Image Editor), or unpack them all, and press Stylize "
                               "again")
        return
    if not image.filepath_raw:
        raise StylizeError(f"image {image.name!r} is a tiled (UDIM) image with no files (its tiles are read from "
                           f"their files or packed data): {fix}")
    for tile in image.tiles:
        path = _tile_path(image, tile.number)
        if not os.path.isfile(path):
            raise StylizeError(f"image {image.name!r}: the file {path!r} of its tile {tile.number} is missing: find "
                               "it again (File > External Data > Find Missing Files), or choose another image")


def read_tiles(image, read, numbers=None):
    """``[(tile number, read(tile))]`` for each tile of a tiled (UDIM) image (of those ``numbers``, if given),
    each ``tile`` a temporary single image in the tiled image's colour space, removed once read.

    A tiled image's ``pixels`` are those of its first tile alone, so each tile is
    loaded again from its own file, or from its packed data through a
    temporary file (:func:`check_readable` first), one at a time.
    """
    packed = {p.tile_number: p for p in image.packed_files}
    found = []
    with tempfile.TemporaryDirectory(prefix="cp_stylize_tiles_") as folder:
        for tile in image.tiles:
            if numbers is not None and tile.number not in numbers:
                continue
            path = _tile_path(image, tile.number)
            if tile.number in packed:
                path = os.path.join(folder, f"{tile.number}_{os.path.basename(packed[tile.number].filepath)}")
                with open(path, "wb") as file:
                    file.write(packed[tile.number].packed_file.data)
            one = bpy.data.images.load(path, check_existing=False)
            try:
                one.colorspace_settings.name = image.colorspace_settings.name
                if one.size[0] == 0 or one.size[1] == 0:
                    raise StylizeError(f"image {image.name!r}: its tile {tile.number} could not be read (it is "
                                       "damaged, or not an image Blender can open): replace it, or choose another "
                                       "image")
                found.append((tile.number, read(one)))
            finally:
                bpy.data.images.remove(one)
    return found


def check_readable(image):
    """Raise StylizeError for images cp_stylize cannot read."""
    if image.source == "TILED":
        _check_tiles(image)
        return
    if image.source not in ("FILE", "GENERATED"):
        kind = {"SEQUENCE": "an image sequence", "MOVIE": "a movie", "VIEWER": "a viewer image"}.get(
            image.source, f"an image of source {image.source.lower()}")
        raise StylizeError(f"image {image.name!r} is {kind}, which cp_stylize cannot read: use a still image "
                           "(in the Image Editor's sidebar, Image tab: Source Single Image; or open one frame as "
                           "an image)")
    path = None
    if image.source == "FILE" and image.packed_file is None:
        path = bpy.path.abspath(image.filepath, library=image.library)
        if not os.path.isfile(path):
            raise StylizeError(f"image {image.name!r}: its file {path!r} is missing: find it again (File > External "
                               "Data > Find Missing Files), replace it (Image > Replace), or choose another image")
    if image.size[0] == 0 or image.size[1] == 0:
        if path is not None:
            raise StylizeError(f"image {image.name!r}: its file {path!r} could not be read (it is damaged, or not an "
                               "image Blender can open): replace the file, or choose another image")
        if image.packed_file is not None:
            raise StylizeError(f"image {image.name!r}: its packed file could not be read (it is damaged, or not an "
                               "image Blender can open): replace it (Image > Replace), or choose another image")
        raise StylizeError(f"image {image.name!r} has no pixels")


#: Rows of pixels checked and encoded at once: the image's own array is the only copy of its pixels.
_ROWS = 256


def display_colours(image, linear):
    """An image's RGB as display (sRGB-encoded) values (H, W, 3); ``linear``: its pixels are linear.

    Works in place on the one array of the image's pixels, a band of rows at a
    time, so that reading an image costs its float RGBA pixels (16 bytes a
    pixel) and little more.  Raises StylizeError if pixels are not finite numbers.
    """
    from ..texture import linear_to_srgb

    rgb = image_to_array(image)[..., :3]
    count = 0
    for start in range(0, rgb.shape[0], _ROWS):
        rows = rgb[start:start + _ROWS]
        count += int(np.count_nonzero(~np.isfinite(rows).all(axis=2)))
        if linear and not count:
            rows[...] = linear_to_srgb(np.clip(rows, 0.0, None))
    if count:
        noun = "pixel that is not a finite number" if count == 1 else "pixels that are not finite numbers"
        raise StylizeError(f"image {image.name!r} has {count} {noun}")
    return rgb


def free_path(folder, stem, ext=".png"):
    """``folder/stem.png``, or ``stem.001.png``, ``stem.002.png``, ... : the first name nothing uses."""
    path = os.path.join(folder, stem + ext)
    number = 0
    while os.path.lexists(path):
        number += 1
        path = os.path.join(folder, f"{stem}.{number:03d}{ext}")
    return path


def write_file(image, path, file_format="PNG"):
    """Save ``image`` as the file ``path`` (``file_format``: PNG or OPEN_EXR) and point the image at it (relative
    to the .blend)."""
    image.filepath_raw = path
    image.file_format = file_format
    image.save()
    image.filepath_raw = bpy.path.relpath(path)
