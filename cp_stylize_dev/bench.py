"""Speed benchmark: ``python -m cp_stylize bench [--quick] [--json FILE]``.

Two cases, each run with both diffusion schemes in a process of its own (so
that its peak memory is its own):

1. ``torus``: edge-enhancing diffusion of noisy grey stripes on a torus with
   the paper's Fig. 4 parameters, h = 0.0125, 30 steps;
2. ``suzanne``: the paper's Starry Night recipe (:data:`cp_stylize_dev.paper.STARRY_NIGHT`)
   on Suzanne with two subdivision levels (the demo's textured object, read through Blender's Python module),
   normalised to a diameter of 2, h = 0.008, RGB, a 1024 x 1024 atlas.

For each it reports band points, the seconds of each stage (closest points
and band with E, and of that E alone; the Laplacian L; bake-in; diffusion;
bake-out), peak memory,
and the PSNR of the fast result against the reference one.  The "limit" is
the time of one closest point extension of the state, ``band.extend`` on
(N, C), times the number of steps: the work no scheme of the closest point
method can skip.  A table of single heat steps on the unit sphere follows.

Then the scale cases, fast scheme only, each in a process of its own, with
the demo's Suzanne at several subdivision levels (normalised to a diameter of 2,
h = 0.008 unless said):

- ``starry``: subdivision 2 (the demo's object), the Starry Night preset with
  its strokes, contours and relief, as the demo runs it;
- ``scan``: 1,007,616 triangles (subdivision 5), Starry Night; its closest
  point search is timed against the same search on 15,744 triangles;
- ``high``: subdivision 2 at the High grid (h = 0.005), Starry Night;
- ``atlas4096``: subdivision 3, Gaussian Blur into a 4096 x 4096 atlas;
- ``atlas8192``: the same into an 8192 x 8192 atlas (about 8 GiB at its peak: run only when named, with
  ``--cases atlas8192``);
- ``rerun``: subdivision 2, Denoise (EED), then the same with twice the time
  and then Starry Night, each with the first run's :class:`~cp_stylize.cache.RunCache`;
- ``no_uvs``: a scan-like sphere of 501,264 triangles without UVs (a UV
  sphere whose vertices move along the radius by a tenth of an edge, at
  random), so that a new atlas is made (charts projected along the axes).
- ``mesh``: colour on a mesh's own vertices (a scan's colour attribute):
  Denoise (EED) into colours at the vertices with
  :func:`cp_stylize.vertex_colours.stylize_vertices` (which chooses the mesh
  filter, :func:`cp_stylize.mesh_diffusion.mesh_diffuse`) on a torus of
  1,003,680 vertices, 2 across, RGB (no band, no atlas).

Each reports its stages, peak memory and the run estimate the add-on uses
for its limits; a table of the targets follows.

``--quick`` runs coarse grids in well under a minute, without the scale
cases.  Speed targets are checked here, never in the tests.
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

    from .paper import STARRY_NIGHT

    size = SIZES["suzanne"]["quick" if quick else "full"]
    arrays = np.load(data)
    settings = STARRY_NIGHT
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


# -- the scale cases ----------------------------------------------------------------------

#: Subdivision levels of Suzanne, preset, grid spacing and atlas size of each scale case.
SCALE = {
    "starry": {"levels": 2, "preset": "starry_night", "h": 0.008, "size": 1024},
    "scan": {"levels": 5, "preset": "starry_night", "h": 0.008, "size": 1024},
    "high": {"levels": 2, "preset": "starry_night", "h": 0.005, "size": 1024},
    "atlas4096": {"levels": 3, "preset": "gaussian_blur", "h": 0.008, "size": 4096},
    "atlas8192": {"levels": 3, "preset": "gaussian_blur", "h": 0.008, "size": 8192},
    "rerun": {"levels": 2, "preset": "denoise_eed", "h": 0.008, "size": 1024},
    "no_uvs": {"levels": None, "preset": "denoise_eed", "h": 0.008, "size": 1024},
    "mesh": {"levels": None, "preset": "denoise_eed", "around": 1530},
}
#: The scale cases run only when named: they need more memory than a small machine has.
ON_REQUEST = ("atlas8192",)


def _closest_points_seconds(vertices, faces, h, stencil):
    """Seconds of the closest point search alone (the band's grid points and their closest points)."""
    from cp_stylize.band import band_width
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize.pipeline import normalisation

    centre, scale = normalisation(vertices, faces)
    mesh = TriangleMesh((vertices - centre) * scale, faces)
    start = time.perf_counter()
    for _ in mesh.band_points(h, band_width(h, stencil=stencil) * 1.01):
        pass
    return time.perf_counter() - start


def _scale_inputs(case, data):
    from cp_stylize.mesh import parametric_mesh
    from cp_stylize.pipeline import ColourInput, Texture
    from cp_stylize.surfaces import Sphere

    if case == "no_uvs":
        n_u = 708
        vertices, faces, _ = parametric_mesh(Sphere().point, n_u, n_u // 2)
        rng = np.random.default_rng(0)
        vertices = vertices * (1 + 0.1 * (2 * np.pi / n_u) * rng.standard_normal(len(vertices)))[:, None]
        corners = rng.random((len(faces), 3, 3)).astype(np.float32)
        return vertices, faces, None, ColourInput(corner_colours=corners)
    arrays = np.load(data)
    colours = ColourInput(textures=[Texture(arrays["image"], arrays["uvs"], np.ones(len(arrays["faces"]), bool))])
    return arrays["vertices"], arrays["faces"], arrays["uvs"], colours


def run_mesh_case():
    """The ``mesh`` scale case: a million vertices' colours filtered into colours at the vertices
    (:func:`cp_stylize.vertex_colours.stylize_vertices`, which chooses the mesh filter here); its figures as a
    dict."""
    from cp_stylize.presets import load_preset
    from cp_stylize.vertex_colours import stylize_vertices

    from .crosscheck import torus_mesh

    vertices, faces = torus_mesh(SCALE["mesh"]["around"])
    rng = np.random.default_rng(0)
    colours = np.clip(0.5 + 0.3 * np.sin(8.0 * vertices[:, :1] + np.arange(3)) + 0.1 * rng.standard_normal(
        (len(vertices), 3)), 0.0, 1.0).astype(np.float32)
    result = stylize_vertices(vertices, faces, colours, load_preset(SCALE["mesh"]["preset"]))
    return {"case": "mesh", "vertices": int(len(vertices)), "triangles": int(len(faces)), "points": 0,
            "method": result.method, "seconds": {"total": result.seconds}, "peak_mb": _peak_mb()}


def run_scale(case, data, base=None):
    """One scale case in this process: its figures as a dict."""
    if case == "mesh":
        return run_mesh_case()
    from cp_stylize.cache import RunCache
    from cp_stylize.diffusion import PAPER_CFL
    from cp_stylize.heat_flow import time_steps
    from cp_stylize.estimate import estimate
    from cp_stylize.pipeline import stencil_for, stylize
    from cp_stylize.presets import load_preset

    spec = SCALE[case]
    vertices, faces, uvs, colours = _scale_inputs(case, data)
    settings = load_preset(spec["preset"]).replace(spacing=spec["h"], image_size=spec["size"])
    cache = RunCache() if case == "rerun" else None
    guess = estimate(vertices, faces, settings, keep=cache is not None, unwrap=uvs is None,
                     image_pixels=colours.image_pixels)
    start = time.perf_counter()
    result = stylize(vertices, faces, colours, settings, uvs=uvs, cache=cache)
    figures = {"case": case, "triangles": int(len(faces)), "points": int(result.band_size),
               "seconds": dict(result.timings, total=time.perf_counter() - start), "peak_mb": _peak_mb(),
               "estimate_seconds": guess.seconds, "estimate_mb": guess.bytes / 2**20,
               "covered": float(result.atlas.coverage.mean()), "generated_atlas": bool(result.atlas.generated),
               "atlas_reason": result.atlas.reason}
    if case == "scan":
        figures["closest_points"] = _closest_points_seconds(vertices, faces, spec["h"], stencil_for(settings.mode))
        if base is not None:
            small = np.load(base)
            figures["closest_points_16k"] = _closest_points_seconds(small["vertices"], small["faces"], spec["h"],
                                                                    stencil_for(settings.mode))
    if case == "rerun":
        again = []
        for label, changed in (
                (f"{spec['preset']}, twice the time", settings.replace(T=2 * settings.T)),
                ("starry_night", load_preset("starry_night").replace(spacing=spec["h"], image_size=spec["size"]))):
            start = time.perf_counter()
            rerun = stylize(vertices, faces, colours, changed, uvs=uvs, cache=cache)
            total = time.perf_counter() - start
            again.append({"preset": label, "seconds": total,
                          "timings": rerun.timings, "reused": list(cache.reused),
                          "overhead": total - rerun.timings["diffusion"]})
        figures["reruns"] = again
        figures["kept_mb"] = cache.nbytes() / 2**20
        # the first re-run's diffusion against the limit: its operators were kept, so it is its steps
        steps, _ = time_steps(2 * settings.T, PAPER_CFL * settings.spacing**2)
        figures["rerun_limit"] = _extend_seconds(cache.part("band"), 3) * steps
        figures["rerun_fast_over_limit"] = again[0]["timings"]["diffusion"] / figures["rerun_limit"]
    return figures


def worker(case, scheme, quick, data, out, base=None):
    """Run one case with one scheme; print its figures as JSON and save its image to ``out``."""
    if case in SCALE:
        print(json.dumps(run_scale(case, data, base)))
        return
    if case == "torus":
        points, steps, times, image, extend = run_torus(scheme, quick)
    else:
        points, steps, times, image, extend = run_suzanne(scheme, quick, data)
    np.save(out, image.astype(np.float32))
    print(json.dumps({"case": case, "scheme": scheme, "points": int(points), "steps": int(steps),
                      "seconds": times, "peak_mb": _peak_mb(), "extend_seconds": extend}))


# -- the driver ---------------------------------------------------------------------------


def suzanne_arrays(folder, log, levels=2):
    """The demo's Suzanne with ``levels`` of subdivision as ``folder/suzanne<levels>.npz`` (see
    :func:`cp_stylize_dev.demo.save_mesh_arrays`), made in a process of its own; None, logged, where
    Blender's Python module cannot make it."""
    path = os.path.join(folder, f"suzanne{levels}.npz")
    if os.path.exists(path):
        return path
    code = f"from cp_stylize_dev.demo import save_mesh_arrays; save_mesh_arrays({path!r}, levels={levels})"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=_root())
    if done.returncode != 0:
        last = (done.stderr.strip().splitlines() or ["no message"])[-1]
        log(f"suzanne: skipped, Blender's Python module could not make the mesh ({last})")
        return None
    return path


def _root():
    return os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run_worker(case, scheme, quick, data, out, base=None):
    cmd = [sys.executable, "-m", "cp_stylize_dev.bench", "--worker", case, scheme, out]
    if quick:
        cmd.append("--quick")
    if data:
        cmd += ["--data", data]
    if base:
        cmd += ["--base", base]
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
        t1 = _best(lambda: heat(band, grey, steps * dt, tau=dt), repeat) / steps
        t3 = _best(lambda: heat(band, rgb, steps * dt, tau=dt), repeat) / steps
        rows.append((h, band.size, build, t1, t3))
        log(f"{h:7.4f} {band.size:12,d} {build:8.2f} {1e3 * t1:15.2f} {1e3 * t3:15.2f}")
    return rows


def run(quick=False, json_path=None, cases=("torus", "suzanne") + tuple(c for c in SCALE if c not in ON_REQUEST),
        log=print):
    """Run the benchmark; returns its figures (also written to ``json_path`` if given)."""
    report = {"cores": workers(), "quick": bool(quick), "runs": [], "cases": {}, "scale": {}}
    log(f"cp_stylize bench{' --quick' if quick else ''}: {workers()} core(s)")
    with tempfile.TemporaryDirectory() as folder:
        data = suzanne_arrays(folder, log) if "suzanne" in cases or not quick else None
        for case in cases:
            if case not in ("torus", "suzanne") or (case == "suzanne" and data is None):
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
        for case in cases if not quick else ():
            if case not in SCALE:
                continue
            levels = SCALE[case]["levels"]
            mesh = suzanne_arrays(folder, log, levels) if levels is not None else None
            if levels is not None and mesh is None:
                continue
            log(f"  scale case {case} ...")
            report["scale"][case] = _run_worker(case, "fast", False, mesh, os.devnull,
                                                base=data if case == "scan" else None)
        _scale_table(report, log)
    log("\nclosest point heat step on the unit sphere (tricubic E, 7-point L, float32)")
    report["heat_steps"] = [dict(zip(("h", "points", "build_s", "step_s_grey", "step_s_rgb"), row))
                            for row in heat_steps((0.1, 0.05) if quick else (0.05, 0.025),
                                                  steps=5 if quick else 20, repeat=1 if quick else 3, log=log)]
    if json_path:
        with open(json_path, "w") as f:
            json.dump(report, f, indent=2)
        log(f"\nwrote {json_path}")
    return report


#: The scale targets: (what, figure from the report, target, unit).
def _targets(report):
    scale, cases = report["scale"], report["cases"]
    rows = []
    if "scan" in scale and "closest_points_16k" in scale["scan"]:
        s = scale["scan"]
        rows.append(("closest points, 1M over 16k triangles", s["closest_points"] / s["closest_points_16k"], 2.0, "x"))
    if "starry" in scale:
        rows.append(("Starry Night on the demo's Suzanne, with relief", scale["starry"]["seconds"]["total"], 22.0, "s"))
    if "scan" in scale:
        rows.append(("1M-triangle scan, end to end", scale["scan"]["seconds"]["total"], 15.0, "s"))
        rows.append(("1M-triangle scan, peak", scale["scan"]["peak_mb"] / 1024, 2.0, "GiB"))
    if "high" in scale:
        rows.append(("High on Suzanne, peak", scale["high"]["peak_mb"] / 1024, 2.0, "GiB"))
    if "no_uvs" in scale:
        rows.append((f"atlas of {scale['no_uvs']['triangles']:,} triangles without UVs (target: 500k)",
                     scale["no_uvs"]["seconds"]["atlas"], 30.0, "s"))
    if "atlas4096" in scale:
        rows.append(("4096 x 4096 bake-out", scale["atlas4096"]["seconds"]["bake_out"], 4.0, "s"))
    if "mesh" in scale:
        rows.append((f"mesh filter (EED) on {scale['mesh']['vertices']:,} vertices", scale["mesh"]["seconds"]["total"],
                     15.0, "s"))
        rows.append(("mesh filter on a million vertices, peak", scale["mesh"]["peak_mb"] / 1024, 2.0, "GiB"))
    if "rerun" in scale:
        for r in scale["rerun"]["reruns"]:
            rows.append((f"re-run ({r['preset']}) beyond its diffusion", r["overhead"], 1.5, "s"))
    for name, s in scale.items():
        if "estimate_seconds" not in s:
            continue
        for what, measured, guess in (("time", s["seconds"]["total"], s["estimate_seconds"]),
                                      ("peak", s["peak_mb"], s["estimate_mb"])):
            rows.append((f"estimate of {name}'s {what}, off by", 100 * abs(guess / measured - 1), 30.0, "%"))
    for name, c in cases.items():
        rows.append((f"{name}: fast diffusion over the limit", c["fast_over_limit"], 2.0, "x"))
    if "rerun" in scale:
        rows.append(("rerun: the re-run's diffusion over the limit", scale["rerun"]["rerun_fast_over_limit"], 2.0, "x"))
    return rows


def _scale_table(report, log):
    if not report["scale"]:
        return
    stages = ("atlas", "band", "bake_in", "diffusion", "painting", "bake_out", "total")
    log(f"\n{'case':<10} {'triangles':>10} {'points':>10} " + " ".join(f"{s + ' s':>11}" for s in stages)
        + f" {'peak MB':>8} {'est. s':>7} {'est. MB':>8}")
    for name, s in report["scale"].items():
        cells = " ".join(f"{s['seconds'].get(k, 0.0):11.2f}" for k in stages)
        guess = (f"{s['estimate_seconds']:7.1f} {s['estimate_mb']:8.0f}" if "estimate_seconds" in s
                 else f"{'-':>7} {'-':>8}")
        log(f"{name:<10} {s['triangles']:10,d} {s['points']:10,d} {cells} {s['peak_mb']:8.0f} {guess}")
    s = report["scale"]
    if "scan" in s:
        log(f"\nscan: closest points {s['scan']['closest_points']:.2f} s"
            + (f" (15,744 triangles: {s['scan']['closest_points_16k']:.2f} s)" if "closest_points_16k" in s["scan"]
               else ""))
    if "no_uvs" in s:
        log(f"no_uvs: the new atlas covers {100 * s['no_uvs']['covered']:.1f} % of the texels "
            f"({s['no_uvs']['atlas_reason']})")
    if "rerun" in s:
        log(f"rerun: first run {s['rerun']['seconds']['total']:.2f} s; kept for re-runs {s['rerun']['kept_mb']:.0f} MB")
        for r in s["rerun"]["reruns"]:
            log(f"  {r['preset']}: {r['seconds']:.2f} s, of it diffusion {r['timings']['diffusion']:.2f} s, "
                f"bake-out {r['timings']['bake_out']:.2f} s; reused {', '.join(r['reused'])}")
    rows = _targets(report)
    report["targets"] = [{"what": w, "measured": m, "target": t, "unit": u, "met": m <= t} for w, m, t, u in rows]
    log(f"\n{'target':<58} {'measured':>10} {'target':>8}  met")
    for w, m, t, u in rows:
        log(f"{w:<58} {m:10.2f} {t:8.1f} {u:<3} {'yes' if m <= t else 'no'}")


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
    parser.add_argument("--base")
    args = parser.parse_args(argv)
    worker(*args.worker[:2], args.quick, args.data, args.worker[2], args.base)


if __name__ == "__main__":
    main()
