"""Command line: ``python -m cp_stylize {demo,paper,bench,looks,crosscheck,docs} ...`` (from a checkout: the tools live in
``cp_stylize_dev``, which the extension does not ship)."""

from __future__ import annotations

import argparse
import importlib
import sys

from .parameters import IMAGE_SIZE_CHOICES


def _tool(name):
    """A development tool of ``cp_stylize_dev`` (in a checkout only)."""
    try:
        return importlib.import_module(f"cp_stylize_dev.{name}")
    except ImportError as err:
        sys.exit(f"`{name}` needs a checkout of cp_stylize with its requirements installed "
                 f"(pip install -r requirements.txt): {err}")


def _demo(args):
    _tool("demo").run(args.out, preset=args.preset, quality=args.quality.upper(), image_size=args.size)


def _paper(args):
    _tool("paper").run(args.out, h=args.h, scheme=args.scheme)


def _bench(args):
    bench = _tool("bench")
    bench.run(quick=args.quick, json_path=args.json, **({"cases": tuple(args.cases)} if args.cases else {}))


def _looks(args):
    _tool("looks").run(args.out)


def _crosscheck(args):
    _tool("crosscheck").run(quick=args.quick, **({"cases": tuple(args.cases)} if args.cases else {}))


def _docs(args):
    _tool("docs").run()


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m cp_stylize", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("demo", help="stylize a textured object in a Blender scene and render it")
    p.add_argument("--out", default="demo_out", help="output folder (default: demo_out)")
    p.add_argument("--preset", default="starry_night", help="preset to run (default: starry_night)")
    p.add_argument("--quality", default="standard", choices=["preview", "standard", "high"],
                   help="grid spacing relative to the object (default: standard)")
    p.add_argument("--size", default="1024", choices=[str(s) for s in IMAGE_SIZE_CHOICES], help="texture size")
    p.set_defaults(func=_demo)
    p = sub.add_parser("paper", help="redraw the paper's experiments (Fig. 4 and a Fig. 5-like CED) as PNGs")
    p.add_argument("--out", default="paper_out", help="output folder (default: paper_out)")
    p.add_argument("--h", type=float, default=0.0125, help="grid spacing (default: the paper's 0.0125)")
    p.add_argument("--scheme", default="fast", choices=["fast", "reference"],
                   help="diffusion scheme (default: fast; reference is the paper's Algorithm 1, minutes)")
    p.set_defaults(func=_paper)
    p = sub.add_parser("bench", help="time both diffusion schemes on the torus and on Suzanne")
    p.add_argument("--quick", action="store_true", help="coarse grids, for a smoke run (under a minute)")
    p.add_argument("--json", metavar="FILE", help="also write the figures as JSON to FILE")
    p.add_argument("--cases", nargs="+", metavar="CASE",
                   help="only these cases: torus, suzanne, scan, high, atlas4096, rerun, no_uvs, mesh, and atlas8192 "
                        "(about 8 GiB; default: all but atlas8192)")
    p.set_defaults(func=_bench)
    p = sub.add_parser("looks", help="measure the presets' looks on the photo sphere, Suzanne and a city photograph (minutes)")
    p.add_argument("--out", default="looks_out", help="output folder for the atlases (default: looks_out)")
    p.set_defaults(func=_looks)
    p = sub.add_parser("crosscheck", help="filter on the band and on the mesh's own vertices and compare them, "
                                          "refining both (minutes)")
    p.add_argument("--quick", action="store_true", help="two coarse refinements (seconds)")
    p.add_argument("--cases", nargs="+", metavar="CASE", choices=["sphere", "torus", "suzanne"],
                   help="only these cases (default: all)")
    p.set_defaults(func=_crosscheck)
    p = sub.add_parser("docs", help="write the user guide's parameter tables (docs/blender.md) from "
                                    "cp_stylize/parameters.py")
    p.set_defaults(func=_docs)
    args = parser.parse_args(argv)
    args.func(args)


if __name__ == "__main__":
    main()
