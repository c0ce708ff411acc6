"""What a look delivers, measured: the photo sphere and the figures of each preset's promise.

- :func:`photo_sphere`: a UV sphere (diameter 2) wearing an equirectangular
  photograph through its own UVs, as plain arrays;
- :func:`psnr`, :func:`edge_sharpness`: a denoiser against the clean picture;
- :func:`coherence`, :func:`stroke_aspect`, :func:`star_yellows`,
  :func:`luminance_correlation`: what a painterly look draws;
- :func:`hull_excess`: how far colours lie outside the input colours' hull.

The images measured are equirectangular (the sphere's own UVs): a texel is
``2 pi / width`` units wide at the equator, and the measures keep to the band
within 45 degrees of it, where a texel's width shrinks by at most 1/sqrt(2).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull

__all__ = ["photo_sphere", "psnr", "edge_sharpness", "coherence", "stroke_aspect", "star_yellows",
           "luminance_correlation", "hull_excess", "luminance", "equator_rows"]

_LUMA = np.array([0.2126, 0.7152, 0.0722])


def photo_sphere(segments=128, rings=64):
    """``(vertices, faces, uvs)`` of a unit UV sphere with equirectangular per-corner UVs."""
    theta = np.linspace(0.0, np.pi, rings + 1)[1:-1]           # inner rings, from the north pole
    phi = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    ring_vertices = np.column_stack([(np.sin(t) * np.cos(p)).ravel(), (np.sin(t) * np.sin(p)).ravel(),
                                     np.cos(t).ravel()])
    vertices = np.vstack([[0.0, 0.0, 1.0], ring_vertices, [0.0, 0.0, -1.0]])
    south = len(vertices) - 1

    def index(r, s):
        return 1 + r * segments + s % segments

    def uv(r, s):                                      # r: ring number 0..rings (0 the north pole)
        return (s / segments, 1.0 - r / rings)

    faces, uvs = [], []
    for s in range(segments):
        faces.append([0, index(0, s), index(0, s + 1)])
        uvs.append([((s + 0.5) / segments, 1.0), uv(1, s), uv(1, s + 1)])
        faces.append([south, index(rings - 2, s + 1), index(rings - 2, s)])
        uvs.append([((s + 0.5) / segments, 0.0), uv(rings - 1, s + 1), uv(rings - 1, s)])
        for r in range(rings - 2):
            a, b, c, d = index(r, s), index(r, s + 1), index(r + 1, s + 1), index(r + 1, s)
            faces += [[a, d, c], [a, c, b]]
            uvs += [[uv(r + 1, s), uv(r + 2, s), uv(r + 2, s + 1)], [uv(r + 1, s), uv(r + 2, s + 1), uv(r + 1, s + 1)]]
    return vertices, np.array(faces), np.array(uvs, dtype=np.float64)


def luminance(image):
    return np.asarray(image, dtype=np.float64)[..., :3] @ _LUMA


def equator_rows(height, degrees=45.0):
    """Rows (a slice) of an equirectangular image within ``degrees`` of the equator."""
    half = int(round(height * degrees / 180.0))
    return slice(height // 2 - half, height // 2 + half)


def psnr(a, b):
    """PSNR in dB of ``a`` against ``b`` (values in [0, 1])."""
    mse = float(np.mean((np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def _gradient(image, sigma=1.0):
    gy = ndimage.gaussian_filter(image, sigma, order=(1, 0), mode=("nearest", "wrap"))
    gx = ndimage.gaussian_filter(image, sigma, order=(0, 1), mode=("nearest", "wrap"))
    return gx, gy


def edge_sharpness(result, clean, share=0.02):
    """How much of the clean picture's strongest edges a result keeps: in [0, 1] for a blur.

    The median, over the ``share`` of texels with the largest clean
    luminance gradient (Gaussian derivative, sigma 1 texel), of the result's
    gradient along the clean gradient's direction over the clean gradient's
    length: noise across the edge averages out, a blurred edge scores its
    loss of slope.
    """
    cx, cy = _gradient(luminance(clean))
    rx, ry = _gradient(luminance(result))
    strength = np.hypot(cx, cy)
    strong = strength >= np.quantile(strength, 1.0 - share)
    along = (rx * cx + ry * cy)[strong] / strength[strong] ** 2
    return float(np.median(along))


def _tensor(image, scale_px):
    gx, gy = _gradient(luminance(image))
    smooth = (lambda a: ndimage.gaussian_filter(a, scale_px, mode=("nearest", "wrap")))
    return smooth(gx * gx), smooth(gx * gy), smooth(gy * gy)


def coherence(image, scale_px, mask=None):
    """Mean orientation coherence ``|J|_aniso / tr J`` of the structure tensor integrated at ``scale_px``
    (over the texels of ``mask``, where given)."""
    jxx, jxy, jyy = _tensor(image, scale_px)
    c = np.sqrt((jxx - jyy) ** 2 + 4 * jxy ** 2) / np.maximum(jxx + jyy, 1e-12)
    return float(np.mean(c if mask is None else c[mask]))


def stroke_aspect(image, scale_px=2.0, reach=40, mask=None):
    """Mean stroke length over width: correlation lengths along and across the local orientation.

    The luminance, less its blur at ``reach / 2`` texels, is correlated
    with itself shifted by ``d`` texels along each texel's own stroke
    direction (the structure tensor's smaller eigenvector, integrated over
    ``scale_px``), so that strokes that swirl are followed, and across it.
    The distances where the correlation over all texels falls to one half
    are the strokes' length and width; returns their ratio.  With ``mask``,
    only pairs of texels both in it count (an atlas's islands).
    """
    lum = luminance(image)
    lum = lum - ndimage.gaussian_filter(lum, reach / 2, mode=("nearest", "wrap"))
    jxx, jxy, jyy = _tensor(image, scale_px)
    angle = 0.5 * np.arctan2(2 * jxy, jxx - jyy) + np.pi / 2      # along the strokes (x = columns)
    rows, cols = np.mgrid[0:lum.shape[0], 0:lum.shape[1]].astype(np.float64)
    inner = (slice(reach, -reach), slice(None))
    base = lum[inner].ravel()
    inside = np.ones(base.shape, bool) if mask is None else mask[inner].ravel()
    lengths = []
    for a in (angle, angle + np.pi / 2):
        dr, dc = np.sin(a), np.cos(a)
        corr = [1.0]
        steps = np.arange(0.5, reach, 0.5)
        for d in steps:
            at = [rows + d * dr, cols + d * dc]
            moved = ndimage.map_coordinates(lum, at, order=1, mode="grid-wrap")[inner].ravel()
            both = inside
            if mask is not None:
                both = inside & (ndimage.map_coordinates(mask.astype(float), at, order=0, mode="grid-wrap")[inner].ravel() > 0)
            corr.append(float(np.corrcoef(base[both], moved[both])[0, 1]))
            if corr[-1] < 0.5:
                break
        corr = np.array(corr)
        steps = np.concatenate([[0.0], steps[:len(corr) - 1]])
        if corr[-1] >= 0.5:
            lengths.append(steps[-1])
        else:
            k = len(corr) - 1
            lengths.append(steps[k - 1] + (corr[k - 1] - 0.5) / (corr[k - 1] - corr[k]) * (steps[k] - steps[k - 1]))
    return float(lengths[0] / lengths[1])


def star_yellows(image):
    """Share of texels that are star yellows: hue 35-70 degrees, saturation >= 0.35, value >= 0.6."""
    rgb = np.asarray(image, dtype=np.float64)[..., :3].reshape(-1, 3)
    high, low = rgb.max(axis=1), rgb.min(axis=1)
    sat = np.where(high > 0, (high - low) / np.maximum(high, 1e-12), 0.0)
    r, g, b = rgb.T
    hue = np.degrees(np.arctan2(np.sqrt(3) * (g - b), 2 * r - g - b)) % 360
    return float(np.mean((hue >= 35) & (hue <= 70) & (sat >= 0.35) & (high >= 0.6)))


def luminance_correlation(result, source, sigma_px, mask=None):
    """Pearson correlation of the two luminances, each blurred by a Gaussian of ``sigma_px`` texels
    (over the texels of ``mask``, where given)."""
    a = ndimage.gaussian_filter(luminance(result), sigma_px, mode=("nearest", "wrap"))
    b = ndimage.gaussian_filter(luminance(source), sigma_px, mode=("nearest", "wrap"))
    if mask is not None:
        a, b = a[mask], b[mask]
    return float(np.corrcoef(a.ravel(), b.ravel())[0, 1])


def hull_excess(result, colours):
    """Largest distance (RGB) by which a colour of ``result`` lies beyond the hull of ``colours``."""
    hull = ConvexHull(np.unique(np.asarray(colours, dtype=np.float64).reshape(-1, 3), axis=0))
    x = np.asarray(result, dtype=np.float64).reshape(-1, 3)
    worst = 0.0
    for s in range(0, len(x), 1 << 14):
        worst = max(worst, float(np.max(x[s:s + (1 << 14)] @ hull.equations[:, :3].T + hull.equations[:, 3])))
    return worst


def _sphere_run(settings, image, uvs, vertices, faces):
    from cp_stylize.pipeline import ColourInput, Texture, stylize

    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool), ("repeat", "clamp"))])
    result = stylize(vertices, faces, colours, settings, uvs=uvs)
    return result


def _painterly(out, source, unit, mask=None):
    """The painterly measures of an image against its source, ``unit`` object units a texel."""
    return {"coherence_0.12": coherence(out, 0.12 / unit, mask), "coherence_0.018": coherence(out, 0.018 / unit, mask),
            "stroke_aspect": stroke_aspect(out, mask=mask),
            "star_yellows": star_yellows(out if mask is None else out[mask]),
            "luminance_correlation": luminance_correlation(out, source, 0.03 / unit, mask)}


def run(out_dir="looks_out", *, size=1024, log=print):
    """The looks' figures on the forest-photo sphere and on the demo's Suzanne; returns them as a dict.

    Each run at the presets' own grid spacing (Standard), 1024 x 1024 atlases on the objects' own UVs.
    """
    import os

    from cp_stylize.presets import load_preset
    from cp_stylize.texture import bilinear, texel_centres, write_png

    from . import scene

    os.makedirs(out_dir, exist_ok=True)
    photo = scene.photo_texture("forest")
    vertices, faces, uvs = photo_sphere()
    u, v = texel_centres(size, size)
    clean = bilinear(photo, np.column_stack([u.ravel(), v.ravel()]), wrap=("repeat", "clamp")).reshape(size, size, 3)
    rows = equator_rows(size)
    unit = 2 * np.pi / size
    figures = {}

    def sphere(name, settings, image):
        result = _sphere_run(settings.replace(image_size=size), image, uvs, vertices, faces)
        write_png(os.path.join(out_dir, f"sphere_{name}.png"), result.image)
        excess = hull_excess(result.image[result.atlas.coverage.reshape(size, size)],
                             np.vstack([image.reshape(-1, 3), np.array(settings.palette).reshape(-1, 3)]))
        log(f"  sphere {name}: {result.seconds:.0f} s, {result.band_size:,} band points, outside the input "
            f"colours' hull by at most {excess:.4f}")
        return result.image[rows], excess

    near_zero = load_preset("denoise_eed").replace(T=1e-6)
    out, excess = sphere("time0", near_zero, clean)
    figures["time0"] = {"psnr": psnr(out, clean[rows]), "hull_excess": excess}
    out, _ = sphere("time0_detail0", near_zero.replace(detail=0.0), clean)
    figures["time0"]["psnr_band_only"] = psnr(out, clean[rows])
    log(f"time ~0 (T = 1e-6): {figures['time0']['psnr']:.1f} dB; without the detail "
        f"{figures['time0']['psnr_band_only']:.1f} dB")

    noisy = np.clip(clean + np.random.default_rng(1).normal(0, 0.1, clean.shape), 0, 1).astype(np.float32)
    figures["noisy"] = {"psnr": psnr(noisy[rows], clean[rows]), "edges": edge_sharpness(noisy[rows], clean[rows])}
    log(f"noisy photo (std 0.1): {figures['noisy']['psnr']:.2f} dB, edges {figures['noisy']['edges']:.2f}")
    for name in ("denoise_eed", "perona_malik"):
        out, excess = sphere(name, load_preset(name), noisy)
        figures[name] = {"psnr": psnr(out, clean[rows]), "edges": edge_sharpness(out, clean[rows]),
                         "hull_excess": excess}
        log(f"{name}: {figures[name]['psnr']:.2f} dB ({figures[name]['psnr'] - figures['noisy']['psnr']:+.2f}), "
            f"edges {figures[name]['edges']:.2f}")

    for name in ("starry_night", "starry_night_paper"):
        out, excess = sphere(name, load_preset(name), clean)
        figures[f"sphere_{name}"] = {**_painterly(out, clean[rows], unit), "hull_excess": excess}
        log(f"{name} on the sphere: " + ", ".join(f"{k} {v:.2f}" for k, v in figures[f"sphere_{name}"].items()))

    # Suzanne: the demo's object and photograph; measured over her atlas's islands
    from cp_stylize.pipeline import ColourInput, Texture, stylize

    from .demo import save_mesh_arrays

    arrays = np.load(save_mesh_arrays(os.path.join(out_dir, "suzanne.npz")))
    colours = ColourInput(textures=[Texture(arrays["image"], arrays["uvs"], np.ones(len(arrays["faces"]), bool))])

    def suzanne(settings):
        return stylize(arrays["vertices"], arrays["faces"], colours, settings.replace(image_size=size),
                       uvs=arrays["uvs"])

    source = suzanne(near_zero)
    mask = source.atlas.coverage.reshape(size, size)
    v, f = arrays["vertices"], arrays["faces"]
    scale = 2.0 / float(np.ptp(v[np.unique(f)], axis=0).max())
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum() * scale**2
    texel = float(np.sqrt(area / mask.sum()))          # object units a texel, on average over the islands
    for name in ("starry_night", "starry_night_paper"):
        result = suzanne(load_preset(name))
        write_png(os.path.join(out_dir, f"suzanne_{name}.png"), result.image)
        figures[f"suzanne_{name}"] = _painterly(result.image, source.image, texel, mask)
        log(f"{name} on Suzanne ({result.seconds:.0f} s): "
            + ", ".join(f"{k} {v:.2f}" for k, v in figures[f"suzanne_{name}"].items()))
    return figures
