"""The shipped presets' thumbnails: each preset run on the photo sphere and rendered small, as ``presets/<key>.png``.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/thumbnails.py [--presets KEY ...]

Each preset in ``presets/`` is loaded and run with the Stylize operator at
Preview quality into a 512 x 512 image, on a UV sphere wearing Blender's
forest photograph (as in the gallery, :mod:`tools.gallery`), and rendered
with Cycles at :data:`SIZE` pixels.  The add-on's preset menu shows the PNG
next to each preset file as its picture (``cp_stylize.blender.panel``).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from cp_stylize.presets import builtin_presets  # noqa: E402
from cp_stylize_dev import scene  # noqa: E402

import gallery  # noqa: E402  (tools/, next to this file)

#: The thumbnails' size in pixels: enough for a preview icon drawn five times the text's height.
SIZE = 160


def run(keys=None, log=print):
    """Render the thumbnail of each shipped preset (or of ``keys``); returns their paths."""
    shipped = builtin_presets()
    written = []
    for key in keys or sorted(shipped):
        obj, _ = gallery.build("sphere")
        scene.setup_render((SIZE, SIZE), 16)
        gallery.frame("sphere", obj)
        start = time.perf_counter()
        scene.stylize(obj, key, "PREVIEW", 512)
        path = os.path.splitext(shipped[key])[0] + ".png"
        scene.render(path)
        log(f"{key:16s} {time.perf_counter() - start:6.1f} s  {path}")
        written.append(path)
    return written


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--presets", nargs="+", metavar="KEY", help="only these presets (default: every shipped one)")
    args = parser.parse_args(argv)
    run(args.presets)


if __name__ == "__main__":
    main()
