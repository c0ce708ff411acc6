"""The run estimate against measured runs: Suzanne at several subdivision levels, atlas sizes and grids.

Usage (the Python with the ``bpy`` module, from the checkout)::

    python tools/estimate_cases.py                      # about 9 minutes, peaks near 4.5 GB
    python tools/estimate_cases.py --preset denoise_eed --cases 2:1024:0.008 4:1024:0.008

Each case is the demo's photograph-textured Suzanne with the given subdivision
levels, run through :func:`cp_stylize.pipeline.stylize` with the preset at the
given atlas size and grid spacing, in a process of its own so that its peak
memory is its own.  Prints a Markdown table of the measured wall time and peak
resident memory beside :func:`cp_stylize.estimate.estimate`'s figures, which the
add-on uses to refuse runs above its limits; the time estimate is scaled by this
computer's factor (``x``, :mod:`cp_stylize.calibration`).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

#: level:size:spacing of each case.
CASES = ("2:1024:0.008", "3:1024:0.008", "4:1024:0.008", "5:1024:0.008", "3:4096:0.008", "2:1024:0.005")


def make_meshes(levels, folder):
    """Suzanne at each subdivision level as ``folder/suzanne<level>.npz`` (see ``save_mesh_arrays``)."""
    from cp_stylize_dev.demo import save_mesh_arrays

    for level in sorted(set(levels)):
        save_mesh_arrays(os.path.join(folder, f"suzanne{level}.npz"), levels=level)


def run_case(path, size, spacing, preset):
    """One run in this process: its figures as a dict."""
    import numpy as np

    from cp_stylize.estimate import estimate
    from cp_stylize.pipeline import ColourInput, Texture, stylize
    from cp_stylize.presets import load_preset

    arrays = np.load(path)
    colours = ColourInput(textures=[Texture(arrays["image"], arrays["uvs"], np.ones(len(arrays["faces"]), bool))])
    settings = load_preset(preset).replace(spacing=spacing, image_size=size)
    guess = estimate(arrays["vertices"], arrays["faces"], settings, image_pixels=colours.image_pixels)
    start = time.perf_counter()
    result = stylize(arrays["vertices"], arrays["faces"], colours, settings, uvs=arrays["uvs"])
    seconds = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    from cp_stylize.calibration import machine_speed

    return {"triangles": len(arrays["faces"]), "points": result.band_size, "seconds": seconds,
            "peak": peak, "est_seconds": guess.seconds, "est_bytes": guess.bytes,
            "timings": result.timings, "speed": machine_speed()}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--preset", default="starry_night")
    parser.add_argument("--cases", nargs="+", default=list(CASES), help="level:size:spacing ...")
    parser.add_argument("--worker", nargs=3, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        path, size, spacing = args.worker
        print(json.dumps(run_case(path, int(size), float(spacing), args.preset)))
        return 0
    cases = [(int(level), int(size), float(spacing)) for level, size, spacing in
             (case.split(":") for case in args.cases)]
    gib = 2.0 ** 30
    with tempfile.TemporaryDirectory() as folder:
        make_meshes([c[0] for c in cases], folder)
        print(f"| case ({args.preset}) | triangles | band points | time | estimate | peak | estimate |")
        print("|---|---|---|---|---|---|---|")
        for level, size, spacing in cases:
            path = os.path.join(folder, f"suzanne{level}.npz")
            done = subprocess.run([sys.executable, __file__, "--preset", args.preset, "--worker", path, str(size),
                                   str(spacing)], capture_output=True, text=True, cwd=ROOT)
            if done.returncode != 0:
                raise RuntimeError(f"case {level}:{size}:{spacing} failed:\n{done.stderr}")
            r = json.loads(done.stdout.strip().splitlines()[-1])
            print(f"| subdivision {level}, {size}², h = {spacing} | {r['triangles']:,} | {r['points']:,} "
                  f"| {r['seconds']:.1f} s | {r['est_seconds']:.1f} s ({100 * (r['est_seconds'] / r['seconds'] - 1):+.0f} %, "
                  f"x {r['speed']:.2f}) "
                  f"| {r['peak'] / gib:.2f} GiB | {r['est_bytes'] / gib:.2f} GiB "
                  f"({100 * (r['est_bytes'] / r['peak'] - 1):+.0f} %) |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
