"""``python -m cp_stylize paper --out DIR``: the paper's experiments, redrawn.

- ``fig4_torus.png``: noisy stripes on the torus R = 1, r = 0.4 filtered by
  Gaussian, Perona-Malik and edge-enhancing diffusion with the paper's
  parameters (Fig. 4: sigma = 1.2e-4, rho = 3.5e-4, lambda = 1e-3, Perona-Malik
  lambda = 1/13, T = 7e-4), as flattened (phi, theta) maps, with profiles across
  the stripes and PSNR against the clean stripes;
- ``flow_torus.png``: Diewald and Rumpf's Fig. 1 as flattened maps: smoothed white
  noise drawn into a flow texture along the maximum (around the tube) and the
  minimum (around the axis) curvature directions, computed from the band;
- ``fig5_sphere.png``: a fingerprint-like ridge pattern with noise on the unit
  sphere under coherence-enhancing diffusion with the parameters of eq. (55),
  as equirectangular maps;
- ``starry_sphere.png``: the paper's own "Starry Night" recipe (section 5.2.3,
  :data:`STARRY_NIGHT`): two thirds of the band points take random colours of
  the painting's palette, mostly dark blues, and coherence-enhancing diffusion
  draws them out into strokes.

The paper uses h = 0.0125; ``--h`` sets another spacing with the same
parameters (coarser grids take fewer, longer steps).
"""

from __future__ import annotations

import os
import tempfile
import time

import numpy as np

from cp_stylize.band import Band
from cp_stylize.curvature import principal_curvatures
from cp_stylize.diffusion import diffuse, flow_noise
from cp_stylize.parameters import DEFAULTS
from cp_stylize.surfaces import Sphere, Torus
from cp_stylize.baking import bake_map

from . import figures
from .bench import suzanne_arrays

#: The modes' defaults are the paper's (cp_stylize/parameters.py): Fig. 4's for
#: Gaussian, Perona-Malik and EED, eq. (55)'s for CED.
FIG4 = {mode: DEFAULTS[mode] for mode in ("gaussian", "perona_malik", "eed")}
FIG4_T = 7e-4
FIG5 = DEFAULTS["ced"]
FIG5_T = 1.2e-3
NAMES = {"noisy": "NOISY", "gaussian": "GAUSSIAN", "perona_malik": "PERONA-MALIK", "eed": "EED"}


def torus_stripes(band, noise=0.3, seed=0):
    """Clean stripes (0/1) and their noisy version on the torus band, both closest point extensions."""
    s, t = band.surface.parameters(band.cp)
    clean = (np.sin(2 * np.pi * (6 * s + t)) > 0).astype(np.float32)
    noisy = clean + np.random.default_rng(seed).normal(0.0, noise, band.size).astype(np.float32)
    return clean, band.extend(noisy)


def flat_map(band, values, height, width):
    """Band values on the surface parametrisation ``point(s, t)``, top row ``t = 1``: (height, width, C)."""
    return bake_map(band, values, height, width)[::-1]


def fig4(out_dir, h=0.0125, log=print, scheme="fast"):
    torus = Torus(1.0, 0.4)
    start = time.perf_counter()
    band = Band.build(torus, h, stencil="anisotropic")
    log(f"fig. 4: torus band at h = {h}: {band.size:,} points ({time.perf_counter() - start:.1f} s)")
    _, noisy = torus_stripes(band)
    results = {"noisy": noisy}
    for mode, params in FIG4.items():
        start = time.perf_counter()
        results[mode] = diffuse(band, noisy, mode=mode, T=FIG4_T, scheme=scheme, **params)
        log(f"  {mode:13s} {time.perf_counter() - start:7.1f} s")
    height, width = 200, 500
    maps = {k: flat_map(band, v, height, width)[..., 0] for k, v in results.items()}
    t_rows, s_cols = np.meshgrid((np.arange(height) + 0.5) / height, (np.arange(width) + 0.5) / width, indexing="ij")
    truth = (np.sin(2 * np.pi * (6 * s_cols + t_rows[::-1])) > 0).astype(float)
    psnr = {k: 10 * np.log10(1.0 / np.mean((np.clip(m, 0, 1) - truth) ** 2)) for k, m in maps.items()}
    for k, v in psnr.items():
        log(f"  PSNR {k:13s} {v:6.2f} dB")
    panels = [figures.panel(maps[k], f"{NAMES[k]} {psnr[k]:.1f} DB") for k in maps]
    colours = {"noisy": (0.45, 0.45, 0.45), "gaussian": (0.3, 0.6, 1.0), "perona_malik": (1.0, 0.7, 0.2),
               "eed": (0.3, 1.0, 0.4)}
    curves = [np.clip(maps[k][height // 2], -0.2, 1.2) for k in colours]
    plot = figures.profile_plot(curves, list(colours.values()), ylim=(-0.2, 1.2))
    legend = figures.text("NOISY GREY, GAUSSIAN BLUE, PERONA-MALIK ORANGE, EED GREEN", scale=1)
    image = figures.stack([figures.grid(panels, 2), figures.grid([figures.panel(plot, "PROFILE ACROSS THE STRIPES")], 1),
                           np.pad(legend, ((0, 6), (6, 0), (0, 0)))])
    path = os.path.join(out_dir, "fig4_torus.png")
    figures.save(path, image)
    return path, psnr, band.size


def fingerprint(band, noise=0.3, seed=1):
    """A fingerprint-like pattern of curved ridges with noise on the unit sphere band."""
    p = band.cp
    centre = np.array([0.25, -0.3, 0.92])
    centre /= np.linalg.norm(centre)
    angle = np.arccos(np.clip(p @ centre, -1, 1))  # geodesic distance from a whorl centre
    ridges = 0.5 + 0.5 * np.sin(70 * angle + 2.5 * np.sin(3 * p[:, 0] + 2 * p[:, 2]))
    rng = np.random.default_rng(seed)
    u = ridges + rng.normal(0.0, noise, band.size)
    return band.extend(np.clip(u, 0, 1).astype(np.float32))


def fig5(out_dir, h=0.0125, log=print, scheme="fast"):
    sphere = Sphere(1.0)
    start = time.perf_counter()
    band = Band.build(sphere, h, stencil="anisotropic")
    log(f"fig. 5: sphere band at h = {h}: {band.size:,} points ({time.perf_counter() - start:.1f} s)")
    u0 = fingerprint(band)
    start = time.perf_counter()
    result = diffuse(band, u0, mode="ced", T=FIG5_T, scheme=scheme, **FIG5)
    log(f"  ced           {time.perf_counter() - start:7.1f} s")
    maps = [flat_map(band, v, 250, 500)[..., 0] for v in (u0, result)]
    captions = ["RIDGES WITH NOISE", f"CED (55), T = {FIG5_T:.1E}"]
    image = figures.grid([figures.panel(m, c) for m, c in zip(maps, captions)], 1)
    path = os.path.join(out_dir, "fig5_sphere.png")
    figures.save(path, image)
    return path


def _starry_night():
    from cp_stylize.presets import StylizeSettings

    palette = {"#0b1a3a": 6, "#13294f": 6, "#1d3b72": 5, "#2a4f9a": 4, "#3c5fc0": 3, "#6d8fd0": 2, "#a9c3dd": 1,
               "#f3d54e": 1, "#e6b12f": 1, "#f8ecaa": 1, "#1e3a2a": 1, "#35553c": 1}
    return StylizeSettings(mode="ced", T=1.1e-4, spacing=0.008, detail=0.0, noise_fraction=0.67, seed=1889,
                           palette=tuple(tuple(int(c[i:i + 2], 16) / 255 for i in (1, 3, 5)) for c in palette),
                           palette_weights=tuple(float(w) for w in palette.values()),
                           params={"sigma": 1e-4, "rho": 5e-4, "alpha": 1e-3, "b_rel": 1e-6},
                           name="Starry Night (paper)")


#: The paper's "Starry Night" recipe (section 5.2.3; its Fig. 7 at iteration 10, about 10 steps at
#: h = 0.008): two thirds of the band points take random colours of the painting's palette, mostly
#: dark blues, and coherence-enhancing diffusion draws them out into strokes that follow the
#: texture's structure.  For surfaces already painted in the palette's colours: on a photograph the
#: random colours cover the picture (the shipped "Starry Night" preset paints it instead).
STARRY_NIGHT = _starry_night()


def fig_starry(out_dir, h=0.0125, log=print, scheme="fast"):
    """The paper's Starry Night recipe on the unit sphere, from a mid-blue, as an equirectangular map."""
    from cp_stylize.noise import inject_noise

    settings = STARRY_NIGHT
    band = Band.build(Sphere(1.0), h, stencil="anisotropic")
    u0 = np.tile(np.float32([0.16, 0.25, 0.45]), (band.size, 1))
    noisy = inject_noise(u0, settings.noise_fraction, settings.palette, weights=settings.palette_weights,
                         seed=settings.seed)
    scale = (h / settings.spacing) ** 2            # the same number of steps and kernels in grid spacings
    params = {k: v * scale if k in ("sigma", "rho") else v for k, v in settings.params.items()}
    start = time.perf_counter()
    result = diffuse(band, band.extend(noisy), mode="ced", T=settings.T * scale, scheme=scheme, **params)
    log(f"starry night (paper): sphere band at h = {h}: {time.perf_counter() - start:.1f} s")
    maps = [np.clip(flat_map(band, v, 250, 500), 0, 1) for v in (noisy, result)]
    captions = ["PALETTE NOISE, 67 PERCENT", "CED, PAPER 5.2.3"]
    path = os.path.join(out_dir, "starry_sphere.png")
    figures.save(path, figures.grid([figures.panel(m, c) for m, c in zip(maps, captions)], 1))
    return path


#: Diewald and Rumpf, "Visualization of principal curvature directions by anisotropic diffusion" (2000),
#: Fig. 1: flow textures along both principal curvature directions of the torus.
FLOW = {"T": 60, "contrast": 2.0, "beta": 0.05}    # T in units of h^2: streaks some ten spacings long


def fig_flow(out_dir, h=0.0125, log=print, scheme="fast"):
    torus = Torus(1.0, 0.4)
    start = time.perf_counter()
    band = Band.build(torus, h, stencil="anisotropic")
    curvature = principal_curvatures(band)
    log(f"flow: torus band at h = {h}: {band.size:,} points, principal directions "
        f"({time.perf_counter() - start:.1f} s)")
    noise = flow_noise(band)          # Diewald and Rumpf's initial data: white noise, briefly smoothed
    values, captions = [noise], ["NOISE"]
    for which, name in (("max", "MAXIMUM"), ("min", "MINIMUM")):
        start = time.perf_counter()
        values.append(diffuse(band, noise, mode="flow", T=FLOW["T"] * h * h, field=curvature.direction(which),
                              contrast=FLOW["contrast"], beta=FLOW["beta"], scheme=scheme))
        log(f"  flow along {which} curvature {time.perf_counter() - start:7.1f} s")
        captions.append(f"ALONG THE {name} CURVATURE")
    values = [(v - v.min()) / (v.max() - v.min()) for v in values]
    # Diewald and Rumpf's Fig. 1: the torus seen from above, and its parameter domain (angle around the axis across)
    views = [figures.surface_view(band, v, size=(330, 500), extent=1.5) for v in values]
    maps = [flat_map(band, v, 200, 500)[..., 0] for v in values]
    image = figures.grid([figures.panel(m, c) for m, c in zip(views, captions)]
                         + [figures.panel(m, c + ", FLAT") for m, c in zip(maps, captions)], 3)
    path = os.path.join(out_dir, "flow_torus.png")
    figures.save(path, image)
    return path


def fig_flow_mesh(out_dir, vertices, faces, h=0.008, log=print, scheme="fast", name="suzanne", size=440):
    """The flow texture along both principal directions of a triangle mesh (normalised to a diameter of 2)."""
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize.pipeline import CURVATURE_SMOOTHING, normalisation

    centre, scale = normalisation(vertices, faces)
    start = time.perf_counter()
    band = Band.build(TriangleMesh((np.asarray(vertices) - centre) * scale, faces), h, stencil="anisotropic")
    curvature = principal_curvatures(band, smooth=CURVATURE_SMOOTHING * h * h)
    log(f"flow: {name} band at h = {h}: {band.size:,} points, principal directions "
        f"({time.perf_counter() - start:.1f} s)")
    noise = flow_noise(band)
    panels = []
    for which, label in (("max", "MAXIMUM"), ("min", "MINIMUM")):
        field = curvature.direction(which) * curvature.confidence[:, None]
        start = time.perf_counter()
        u = diffuse(band, noise, mode="flow", T=FLOW["T"] * h * h, field=field, contrast=FLOW["contrast"],
                    beta=FLOW["beta"], scheme=scheme)
        log(f"  flow along {which} curvature {time.perf_counter() - start:7.1f} s")
        lo, hi = np.percentile(u, [2, 98])          # a few extreme points (the eyes) would grey the rest
        u = np.clip((u - lo) / (hi - lo), 0.0, 1.0)
        view = figures.surface_view(band, u, size=(size, size), elevation=5.0, azimuth=-80.0, extent=1.15)
        panels.append(figures.panel(view, f"ALONG THE {label} CURVATURE"))
    confidence = figures.surface_view(band, curvature.confidence, size=(size, size), elevation=5.0, azimuth=-80.0,
                                      extent=1.15)
    panels.append(figures.panel(confidence, "CONFIDENCE"))
    path = os.path.join(out_dir, f"flow_{name}.png")
    figures.save(path, figures.grid(panels, 3))
    return path


def run(out_dir, h=0.0125, log=print, scheme="fast"):
    os.makedirs(out_dir, exist_ok=True)
    log(f"diffusion scheme: {scheme}")
    path4, psnr, n = fig4(out_dir, h, log, scheme)
    path5 = fig5(out_dir, h, log, scheme)
    paths = [path4, path5, fig_flow(out_dir, h, log, scheme), fig_starry(out_dir, h, log, scheme)]
    with tempfile.TemporaryDirectory() as folder:
        data = suzanne_arrays(folder, log)       # needs Blender's Python module
        if data is not None:
            arrays = np.load(data)
            paths.append(fig_flow_mesh(out_dir, arrays["vertices"], arrays["faces"], h, log, scheme))
    for path in paths:
        log(f"wrote {path}")
    return tuple(paths)
