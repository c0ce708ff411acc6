"""Speed benchmark: ``python -m cp_stylize bench [--quick] [--json FILE]``.

Two cases, each run with both diffusion schemes in a process of its own (so
that its peak memory is its own):

1. ``torus``: edge-enhancing diffusion of noisy grey stripes on a torus with
   the paper's Fig. 4 parameters, h = 0.0125, 30 steps;
2. ``suzanne``: the Starry Night (Paper) preset on Suzanne with two subdivision
   levels (the demo's textured object, read through Blender's Python module),
   normalised to length 2, h = 0.008, RGB, a 1024 x 1024 atlas.

For each it reports band points, the seconds of each stage (closest points
and band with E, and of that E alone; the Laplacian L; bake-in; diffusion;
bake-out), peak memory,
and the PSNR of the fast result against the reference one.  The "limit" is
the time of one closest point extension of the state, ``band.extend`` on
(N, C), times the number of steps: the work no scheme of the closest point
method can skip.  A table of single heat steps on the unit sphere follows.

``--quick`` runs coarse grids in well under a minute.  Speed targets are
checked here, never in the tests.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

from cp_stylize.band import Band
from cp_stylize.heat_flow import heat
from cp_stylize.sparse import workers
from cp_stylize.surfaces import Sphere, Torus

SCHEMES = ("reference", "fast")

#: Grid spacing, steps and atlas size of each case, full and quick.
SIZES = {
    "torus": {"full": {"h": 0.0125, "steps": 30}, "quick": {"h": 0.05, "steps": 10}},
    "suzanne": {"full": {"h": 0.008, "size": 1024}, "quick": {"h": 0.04, "size": 256}},
}


def _best(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def _peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # kB on Linux


def _e_seconds(band):
    """Seconds to build the band's extension matrix E (the part of the band's build that interpolates)."""
    start = time.perf_counter()
    band.interpolation_matrix(band.cp)
    return time.perf_counter() - start


def _extend_seconds(band, channels):
    state = np.random.default_rng(0).random((band.size, channels)).astype(np.float32)
    band.extend(state)  # warm: the split matrix is made once
    return _best(lambda: band.extend(state), 3)


# -- one case and scheme, in a process of its own ------------------------------------------


def run_torus(scheme, quick):
    from cp_stylize.diffusion import PAPER_CFL, diffuse
    from cp_stylize.baking import bake_map

    from .paper import FIG4, torus_stripes

    size = SIZES["torus"]["quick" if quick else "full"]
    h, steps = size["h"], size["steps"]
    times = {}
    start = time.perf_counter()
    torus = Torus(1.0, 0.4)
    band = Band.build(torus, h, stencil="anisotropic")
    times["band"] = time.perf_counter() - start
    times["band_E"] = _e_seconds(band)
    start = time.perf_counter()
    band.laplacian_matrix()
    times["L"] = time.perf_counter() - start
    start = time.perf_counter()
    _, noisy = torus_stripes(band)
    times["bake_in"] = time.perf_counter() - start
    scale = (h / 0.0125) ** 2  # the paper's times are for h = 0.0125
    start = time.perf_counter()
    out = diffuse(band, noisy, mode="eed", T=steps * PAPER_CFL * h * h, scheme=scheme,
                  **{k: v * scale if k != "lambda_rel" else v for k, v in FIG4["eed"].items()})
    times["diffusion"] = time.perf_counter() - start
    start = time.perf_counter()
    image = bake_map(band, out, 320, 800)
    times["bake_out"] = time.perf_counter() - start
    limit = _extend_seconds(band, 1) if scheme == "fast" else None
    return band.size, steps, times, np.clip(image, 0, 1), limit


def run_suzanne(scheme, quick, data):
    from cp_stylize.diffusion import PAPER_CFL
    from cp_stylize.heat_flow import time_steps
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize.pipeline import ColourInput, normalisation, stencil_for, stylize
    from cp_stylize.presets import load_preset

    size = SIZES["suzanne"]["quick" if quick else "full"]
    arrays = np.load(data)
    settings = load_preset("starry_night_paper")
    if size["h"] != settings.spacing:  # the same number of steps, and the same kernels in grid spacings
        scale = (size["h"] / settings.spacing) ** 2
        settings = settings.replace(T=settings.T * scale, sigma=settings.sigma * scale, rho=settings.rho * scale)
    settings = settings.replace(spacing=size["h"], image_size=size["size"])
    colours = ColourInput(textures=[(arrays["image"], arrays["uvs"], np.ones(len(arrays["faces"]), bool))])
    result = stylize(arrays["vertices"], arrays["faces"], colours, settings, uvs=arrays["uvs"], scheme=scheme)
    steps, _ = time_steps(settings.T, PAPER_CFL * settings.spacing**2)
    covered = result.image.reshape(-1, result.image.shape[-1])[result.atlas.texels]
    times = dict(result.timings)
    times["bake_out"] += times.pop("atlas")   # the atlas is part of the bake-out, as in the torus case
    # the same band once more, after the run: its E alone, and the limit (one extension of the state)
    centre, scale = normalisation(arrays["vertices"], arrays["faces"])
    band = Band.build(TriangleMesh((arrays["vertices"] - centre) * scale, arrays["faces"]), settings.spacing,
                      stencil=stencil_for(settings.mode))
    times["band_E"] = _e_seconds(band)
    limit = _extend_seconds(band, 3) if scheme == "fast" else None
    return result.band_size, steps, times, covered, limit


def worker(case, scheme, quick, data, out):
    """Run one case with one scheme; print its figures as JSON and save its image to ``out``."""
    if case == "torus":
        points, steps, times, image, extend = run_torus(scheme, quick)
    else:
        points, steps, times, image, extend = run_suzanne(scheme, quick, data)
    np.save(out, image.astype(np.float32))
    print(json.dumps({"case": case, "scheme": scheme, "points": int(points), "steps": int(steps),
                      "seconds": times, "peak_mb": _peak_mb(), "extend_seconds": extend}))


# -- the driver ---------------------------------------------------------------------------


def suzanne_arrays(folder, log):
    """The demo's Suzanne as ``folder/suzanne.npz`` (see :func:`cp_stylize_dev.demo.save_mesh_arrays`),
    made in a process of its own; None, logged, where Blender's Python module cannot make it."""
    path = os.path.join(folder, "suzanne.npz")
    code = f"from cp_stylize_dev.demo import save_mesh_arrays; save_mesh_arrays({path!r})"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=_root())
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        log(f"suzanne: skipped, Blender's Python module could not make the mesh ({last})")
        return None
    return path


def _root():
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run_worker(case, scheme, quick, data, out):
    cmd = [sys.executable, "-m", "cp_stylize_dev.bench", "--worker", case, scheme, out]
    if quick:
        cmd.append("--quick")
    if data:
        cmd += ["--data", data]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=_root())
    if done.returncode != 0:
        raise RuntimeError(f"the {case} {scheme} run failed:\n{done.stderr}")
    return json.loads(done.stdout.strip().splitlines()[-1])


def psnr(a, b):
    """PSNR in dB of ``a`` against ``b``, values in [0, 1]."""
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def heat_steps(spacings=(0.05, 0.025), steps=20, repeat=3, log=print):
    """Rows (h, band points, build s, s/step grey, s/step RGB) on the unit sphere."""
    rows = []
    log(f"{'h':>7} {'band points':>12} {'build s':>8} {'step ms (1 ch)':>15} {'step ms (3 ch)':>15}")
    for h in spacings:
        start = time.perf_counter()
        band = Band.build(Sphere(), h)
        build = time.perf_counter() - start
        grey = band.cp[:, 2].astype(np.float32)
        rgb = np.repeat(grey[:, None], 3, axis=1)
        dt = 0.1 * h * h
        t1 = _best(lambda: heat(band, grey, steps * dt, dt=dt), repeat) / steps
        t3 = _best(lambda: heat(band, rgb, steps * dt, dt=dt), repeat) / steps
        rows.append((h, band.size, build, t1, t3))
        log(f"{h:7.4f} {band.size:12,d} {build:8.2f} {1e3 * t1:15.2f} {1e3 * t3:15.2f}")
    return rows


def run(quick=False, json_path=None, cases=("torus", "suzanne"), log=print):
    """Run the benchmark; returns its figures (also written to ``json_path`` if given)."""
    report = {"cores": workers(), "quick": bool(quick), "runs": [], "cases": {}}
    log(f"cp_stylize bench{' --quick' if quick else ''}: {workers()} core(s)")
    with tempfile.TemporaryDirectory() as folder:
        data = suzanne_arrays(folder, log) if "suzanne" in cases else None
        for case in cases:
            if case == "suzanne" and data is None:
                continue
            images = {}
            for scheme in SCHEMES:
                out = os.path.join(folder, f"{case}_{scheme}.npy")
                figures = _run_worker(case, scheme, quick, data, out)
                figures["seconds"]["total"] = sum(v for k, v in figures["seconds"].items() if k != "band_E")
                images[scheme] = np.load(out)
                report["runs"].append(figures)
            fast, ref = (next(r for r in report["runs"] if r["case"] == case and r["scheme"] == s)
                         for s in ("fast", "reference"))
            report["cases"][case] = {
                "points": fast["points"], "steps": fast["steps"],
                "psnr_fast_vs_reference": psnr(images["fast"], images["reference"]),
                "diffusion_speedup": ref["seconds"]["diffusion"] / fast["seconds"]["diffusion"],
                "limit_seconds": fast["extend_seconds"] * fast["steps"],
                "fast_over_limit": fast["seconds"]["diffusion"] / (fast["extend_seconds"] * fast["steps"]),
            }
    _table(report, log)
    log("\nclosest point heat step on the unit sphere (tricubic E, 7-point L, float32)")
    report["heat_steps"] = [dict(zip(("h", "points", "build_s", "step_s_grey", "step_s_rgb"), row))
                            for row in heat_steps((0.1, 0.05) if quick else (0.05, 0.025),
                                                  steps=5 if quick else 20, repeat=1 if quick else 3, log=log)]
    if json_path:
        with open(json_path, "w") as f:
            json.dump(report, f, indent=2)
        log(f"\nwrote {json_path}")
    return report


def _table(report, log):
    stages = ("band", "band_E", "L", "bake_in", "diffusion", "bake_out", "total")
    head = (f"{'case':<8} {'scheme':<9} {'points':>9} " + " ".join(f"{s + ' s':>11}" for s in stages)
            + f" {'peak MB':>8}")
    log("\n" + head)
    for r in report["runs"]:
        cells = " ".join(f"{r['seconds'].get(s, 0.0):11.2f}" if s in r["seconds"] else f"{'-':>11}"
                         for s in stages)
        log(f"{r['case']:<8} {r['scheme']:<9} {r['points']:9,d} {cells} {r['peak_mb']:8.0f}")
    for case, c in report["cases"].items():
        log(f"\n{case}: {c['points']:,} band points, {c['steps']} steps")
        log(f"  diffusion, fast vs reference: {c['diffusion_speedup']:.1f}x faster, "
            f"PSNR {c['psnr_fast_vs_reference']:.1f} dB")
        log(f"  limit: one band.extend of the state x {c['steps']} steps = {c['limit_seconds']:.2f} s; "
            f"fast diffusion = {c['fast_over_limit']:.1f} x limit")


def main(argv=None):
    import argparse

    parser = argparse.ArgumentParser(prog="python -m cp_stylize_dev.bench")
    parser.add_argument("--worker", nargs=3, metavar=("CASE", "SCHEME", "OUT"))
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--data")
    args = parser.parse_args(argv)
    worker(*args.worker[:2], args.quick, args.data, args.worker[2])


if __name__ == "__main__":
    main()
