"""What a look delivers, measured: the photo sphere and the figures of each preset's promise.

- :func:`photo_sphere`: a UV sphere (diameter 2) wearing an equirectangular
  photograph through its own UVs, as plain arrays;
- :func:`psnr`, :func:`edge_sharpness`: a denoiser against the clean picture;
- :func:`edge_survival`, :func:`hue_difference`, :func:`speckle`,
  :func:`dab_aspects`: whether a painterly look keeps the subject (its
  strongest edges and its hues), draws no speckle, and paints dabs 3 to 5
  times longer than wide;
- :func:`hull_excess`: how far colours lie outside the input colours' hull;
- :func:`seam_step`: how far the two sides of a UV seam differ, against neighbours inside.

The images measured are equirectangular (the sphere's own UVs): a texel is
``2 pi / width`` units wide at the equator, and the measures keep to the band
within 45 degrees of it, where a texel's width shrinks by at most 1/sqrt(2).
"""

from __future__ import annotations

import contextlib

import numpy as np
from scipy import ndimage
from scipy.spatial import ConvexHull

__all__ = ["photo_sphere", "city_plane", "psnr", "edge_sharpness", "edge_survival", "hue_difference", "speckle",
           "dab_aspects", "hull_excess", "luminance", "equator_rows", "seam_step"]

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


def city_plane(columns=128, rows=64):
    """``(vertices, faces, uvs)`` of a flat 2 x 1 rectangle of triangles in the xy-plane with UVs over [0, 1]^2:
    a picture frame for a photograph of twice its height in width."""
    x, y = np.meshgrid(np.linspace(-1.0, 1.0, columns + 1), np.linspace(-0.5, 0.5, rows + 1))
    vertices = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    index = np.arange(len(vertices)).reshape(rows + 1, columns + 1)
    a, b, c, d = index[:-1, :-1].ravel(), index[:-1, 1:].ravel(), index[1:, 1:].ravel(), index[1:, :-1].ravel()
    faces = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    uv = np.column_stack([(vertices[:, 0] + 1.0) / 2.0, vertices[:, 1] + 0.5])
    return vertices, faces, uv[faces]


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


def _colour_gradient(image, sigma_px):
    """The colour gradient's size (H, W): the root of the summed squared Gaussian derivatives (deviation
    ``sigma_px``) of the image's three OKLab channels."""
    from cp_stylize.oklab import to_oklab

    lab = to_oklab(np.clip(np.asarray(image, dtype=np.float64)[..., :3], 0, 1))
    total = np.zeros(lab.shape[:2])
    for c in range(3):
        gy = ndimage.gaussian_filter(lab[..., c], sigma_px, order=(1, 0), mode="nearest")
        gx = ndimage.gaussian_filter(lab[..., c], sigma_px, order=(0, 1), mode="nearest")
        total += gx * gx + gy * gy
    return np.sqrt(total)


def _inner(mask, reach):
    """The texels of ``mask`` whose neighbours within ``reach`` texels are all in it (or all, without one)."""
    if mask is None:
        return None
    return ndimage.binary_erosion(mask, iterations=max(1, int(np.ceil(reach))))


def edge_survival(result, source, scale_px, mask=None, share=0.02):
    """The share of the source's strongest edges that are still edges in the result, above chance.

    At the scale of a stroke's width (Gaussian derivatives of deviation
    ``scale_px``, half the stroke's width in texels), the source's
    strongest edges are its ``share`` of texels with the largest OKLab colour
    gradient; the result's edges are its own strongest ``5 * share`` of
    texels, widened by ``scale_px`` (an edge may move by a little).  A source
    edge survives where a result edge lies.  Random strokes put result edges
    on ``chance``, the share of all texels the widened result edges cover;
    the score is ``(hit - chance) / (1 - chance)``: 1 when every strong edge
    survives, 0 when no more survive than at random.  Only texels whose
    neighbours within three deviations lie in ``mask`` count.
    """
    inner = _inner(mask, 3 * scale_px)
    valid = np.ones(np.shape(source)[:2], bool) if inner is None else inner
    source_edges, result_edges = _colour_gradient(source, scale_px), _colour_gradient(result, scale_px)
    strong = valid & (source_edges >= np.quantile(source_edges[valid], 1.0 - share))
    edges = valid & (result_edges >= np.quantile(result_edges[valid], 1.0 - 5 * share))
    near = ndimage.binary_dilation(edges, iterations=max(1, int(round(scale_px))))
    hit, chance = float(near[strong].mean()), float(near[valid].mean())
    return (hit - chance) / (1.0 - chance)


def _hsv(image):
    rgb = np.asarray(image, dtype=np.float64)[..., :3]
    high, low = rgb.max(axis=-1), rgb.min(axis=-1)
    saturation = np.where(high > 0, (high - low) / np.maximum(high, 1e-12), 0.0)
    r, g, b = np.moveaxis(rgb, -1, 0)
    hue = np.degrees(np.arctan2(np.sqrt(3) * (g - b), 2 * r - g - b)) % 360
    return hue, saturation, high


def hue_difference(result, source, mask=None, saturation=0.3):
    """The median hue difference in degrees (HSV hue) between result and source over the source's
    saturated texels (HSV saturation above ``saturation``, in ``mask``); and how many there were."""
    hue_r, _, _ = _hsv(result)
    hue_s, sat_s, _ = _hsv(source)
    chosen = sat_s > saturation
    if mask is not None:
        chosen &= mask
    difference = np.abs((hue_r - hue_s + 180.0) % 360.0 - 180.0)[chosen]
    return (float(np.median(difference)) if len(difference) else 0.0), int(chosen.sum())


def speckle(result, mask=None, threshold=0.25):
    """The share of texels whose luminance differs from the median of their 3 x 3 neighbours by more
    than ``threshold`` (over the texels of ``mask`` whose 3 x 3 neighbours all lie in it)."""
    lum = luminance(result)
    inner = _inner(mask, 1)
    off = np.abs(lum - ndimage.median_filter(lum, size=3, mode="nearest")) > threshold
    return float(off.mean() if inner is None else off[inner].mean())


def dab_aspects(dabs, texels, sample=500, seed=0):
    """Length over width (M,) of the drawn footprints of ``sample`` dabs: the extent of the texels each
    covers by more than half, along its direction and across its arc (on the surface, before any
    later dab covers it)."""
    from cp_stylize import canvas

    rng = np.random.default_rng(seed)
    which = np.sort(rng.choice(len(dabs), size=min(sample, len(dabs)), replace=False))
    sides = np.cross(dabs.normal, dabs.direction)
    i, j, alpha, _, _ = canvas._covering(dabs, canvas._Shapes(dabs), canvas._uv_axes(dabs, texels), texels, which)
    i, j = i[alpha > 0.5], j[alpha > 0.5]
    delta = texels.points[j] - dabs.centre[i]
    along = np.einsum("ij,ij->i", delta, dabs.direction[i])
    across = np.einsum("ij,ij->i", delta, sides[i])
    if dabs.bend is not None:                                 # a bent dab's width is across its arc
        across -= 0.5 * dabs.bend[i] * along**2
    aspects = []
    for d in np.unique(i):
        mine = i == d
        length = np.ptp(along[mine]) + texels.lengths[j[mine]].mean()
        width = np.ptp(across[mine]) + texels.lengths[j[mine]].mean()
        aspects.append(length / width)
    return np.array(aspects)


def hull_excess(result, colours):
    """Largest distance (RGB) by which a colour of ``result`` lies beyond the hull of ``colours``."""
    hull = ConvexHull(np.unique(np.asarray(colours, dtype=np.float64).reshape(-1, 3), axis=0))
    x = np.asarray(result, dtype=np.float64).reshape(-1, 3)
    worst = 0.0
    for s in range(0, len(x), 1 << 14):
        worst = max(worst, float(np.max(x[s:s + (1 << 14)] @ hull.equations[:, :3].T + hull.equations[:, 3])))
    return worst


#: The painterly presets the looks command measures.
PAINTERLY = ("starry_night", "van_gogh_form", "sunflower_vase")


def subjects(folder):
    """The three subjects: name -> ``(vertices, faces, uvs, image, wrap)``: the forest photograph on a UV
    sphere, the demo's Suzanne wearing it, and Blender's city photograph (buildings, a crane, road
    markings) in a 2 x 1 frame.  Needs Blender's Python module (for the photographs and Suzanne)."""
    import os

    from .demo import save_mesh_arrays
    from .scene import photo_texture

    vertices, faces, uvs = photo_sphere()
    found = {"sphere": (vertices, faces, uvs, photo_texture("forest"), ("repeat", "clamp"))}
    arrays = np.load(save_mesh_arrays(os.path.join(folder, "suzanne.npz")))
    found["suzanne"] = (arrays["vertices"], arrays["faces"], arrays["uvs"], arrays["image"], ("repeat", "repeat"))
    vertices, faces, uvs = city_plane()
    found["city"] = (vertices, faces, uvs, photo_texture("city"), ("clamp", "clamp"))
    return found


def _run(subject, settings, size):
    from cp_stylize.pipeline import ColourInput, Texture, stylize

    vertices, faces, uvs, image, wrap = subject
    colours = ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool), wrap)])
    return stylize(vertices, faces, colours, settings.replace(image_size=size), uvs=uvs)


def _normalised_mesh(subject):
    """The subject's mesh as a run sees it: normalised to a diameter of 2 (a :class:`TriangleMesh`)."""
    from cp_stylize.mesh import TriangleMesh
    from cp_stylize.pipeline import normalisation

    vertices, faces = subject[0], subject[1]
    centre, scale = normalisation(vertices, faces)
    return TriangleMesh((np.asarray(vertices) - centre) * scale, faces)


def _texel(subject, result):
    """The median texel length of a run's atlas on the subject, in the units its settings use."""
    from cp_stylize.baking import texel_lengths

    return float(np.median(texel_lengths(_normalised_mesh(subject), result.atlas, result.atlas.face)))


def _dabs(subject, settings, result):
    """The run's dabs and the atlas's texels, made again as the run made them (for :func:`dab_aspects`)."""
    from cp_stylize import Band
    from cp_stylize.baking import atlas_points, texel_lengths
    from cp_stylize.palette import map_to_palette
    from cp_stylize.pipeline import ColourInput, Texture, stencil_for
    from cp_stylize.sampling import sample_colours
    from cp_stylize.canvas import Texels
    from cp_stylize.strokes import Brush, place_dabs

    vertices, faces, uvs, image, wrap = subject
    mesh = _normalised_mesh(subject)
    band = Band.build(mesh, settings.spacing, stencil=stencil_for(settings.mode))
    sampled = sample_colours(band, ColourInput(textures=[Texture(image, uvs, np.ones(len(faces), bool), wrap)]))
    values = map_to_palette(sampled, settings.palette, settings.palette_weights or None, fidelity=settings.fidelity)
    atlas = result.atlas
    flat, points, face, bary = atlas_points(mesh, atlas, settings.margin)
    texels = Texels(points, mesh.normal(points, face, bary), mesh.piece[face], texel_lengths(mesh, atlas, face), flat,
                    len(atlas.texels), atlas.size, atlas.uvs, mesh.vertices[mesh.input_faces])
    brush = Brush(width=settings.stroke_width, length=settings.stroke_length, layers=settings.stroke_layers,
                  jitter=settings.stroke_jitter, swirl=settings.swirl, seed=settings.seed)
    return place_dabs(mesh, band, values, brush, texel=float(np.median(texels.lengths)), palette=settings.palette,
                      weights=settings.palette_weights or None), texels


def _denoisers(sphere, near_zero, size, out_dir, log):
    """A run that changes nothing, and the denoisers on the forest photograph with noise, on the sphere."""
    import os

    from cp_stylize.presets import load_preset
    from cp_stylize.texture import bilinear, texel_centres, write_png

    vertices, faces, uvs, photo, wrap = sphere
    u, v = texel_centres(size, size)
    clean = bilinear(photo, np.column_stack([u.ravel(), v.ravel()]), wrap=wrap).reshape(size, size, 3)
    rows = equator_rows(size)
    figures = {}

    def on_sphere(name, settings, image):
        result = _run((vertices, faces, uvs, image, wrap), settings, size)
        write_png(os.path.join(out_dir, f"sphere_{name}.png"), result.image)
        excess = hull_excess(result.image[result.atlas.coverage.reshape(size, size)], image.reshape(-1, 3))
        return result.image[rows], excess

    out, excess = on_sphere("time0", near_zero, clean)
    figures["time0"] = {"psnr": psnr(out, clean[rows]), "hull_excess": excess}
    out, _ = on_sphere("time0_detail0", near_zero.replace(detail=0.0), clean)
    figures["time0"]["psnr_band_only"] = psnr(out, clean[rows])
    log(f"time ~0 (T = 1e-6): {figures['time0']['psnr']:.1f} dB; without the detail "
        f"{figures['time0']['psnr_band_only']:.1f} dB")
    noisy = np.clip(clean + np.random.default_rng(1).normal(0, 0.1, clean.shape), 0, 1).astype(np.float32)
    figures["noisy"] = {"psnr": psnr(noisy[rows], clean[rows]), "edges": edge_sharpness(noisy[rows], clean[rows])}
    log(f"noisy photo (std 0.1): {figures['noisy']['psnr']:.2f} dB, edges {figures['noisy']['edges']:.2f}")
    for name in ("denoise_eed", "perona_malik"):
        out, excess = on_sphere(name, load_preset(name), noisy)
        figures[name] = {"psnr": psnr(out, clean[rows]), "edges": edge_sharpness(out, clean[rows]),
                         "hull_excess": excess}
        log(f"{name}: {figures[name]['psnr']:.2f} dB ({figures[name]['psnr'] - figures['noisy']['psnr']:+.2f}), "
            f"edges {figures[name]['edges']:.2f}")
    return figures


def run(out_dir="looks_out", *, size=1024, presets=PAINTERLY, oil=True, toon=True, hatching=True, watercolour=True,
        hand_painted=True, log=print):
    """The painterly presets' measures on the three subjects (see :func:`subjects`), with ``oil`` the Oil
    Paint preset's against Blender's Kuwahara node, with ``toon`` the Toon preset's (:func:`_toon`), with
    ``hatching`` the Ink Hatching preset's (:func:`_hatching`) and with ``watercolour`` the Watercolour
    preset's (:func:`_watercolour`) and with ``hand_painted`` the Hand-Painted preset's (:func:`_hand_painted`);
    returns them as a dict.

    Each preset runs as shipped at its own grid (Standard) into 1024 x 1024 atlases on the
    subjects' own UVs, and again with Fidelity 0.5 for the hue measure; the images go to
    ``out_dir``.  The denoisers are measured first, on the forest sphere with noise.
    """
    import os
    import tempfile

    from cp_stylize.presets import load_preset
    from cp_stylize.texture import write_png

    os.makedirs(out_dir, exist_ok=True)
    figures = {}
    with tempfile.TemporaryDirectory() as folder:
        found = subjects(folder)
    near_zero = load_preset("denoise_eed").replace(T=1e-6)
    figures.update(_denoisers(found["sphere"], near_zero, size, out_dir, log))
    for subject_name, subject in found.items():
        source = _run(subject, near_zero, size)
        mask = _mask(subject_name, source, size)
        texel = _texel(subject, source)
        for name in presets:
            settings = load_preset(name)
            result = _run(subject, settings, size)
            write_png(os.path.join(out_dir, f"{subject_name}_{name}.png"), result.image)
            if result.height is not None:
                height = result.height / max(float(result.height.max()), 1e-12)
                write_png(os.path.join(out_dir, f"{subject_name}_{name}_relief.png"), height[..., None])
            half = _run(subject, settings.replace(fidelity=0.5, hue_snap=0.0), size)
            scale_px = 0.5 * settings.stroke_width / texel
            hue, counted = hue_difference(half.image, source.image, mask)
            dabs, texels = _dabs(subject, settings, result)
            aspects = dab_aspects(dabs, texels)
            figures[f"{subject_name}_{name}"] = row = {
                "edges": edge_survival(result.image, source.image, scale_px, mask),
                "hue_at_fidelity_half": hue, "saturated_texels": counted,
                "speckle": speckle(result.image, mask),
                "dab_aspect": [float(np.min(dabs.aspect)), float(np.max(dabs.aspect))],
                "drawn_aspect": [float(np.quantile(aspects, 0.05)), float(np.median(aspects)),
                                 float(np.quantile(aspects, 0.95))],
                "seconds": result.seconds}
            log(f"{subject_name:8s} {name:15s} edges {row['edges']:.2f}, hue at fidelity 0.5 {hue:.1f} degrees "
                f"({counted:,} texels), speckle {100 * row['speckle']:.3f} %, dabs {row['dab_aspect'][0]:.2f} to "
                f"{row['dab_aspect'][1]:.2f} long over wide (drawn: median {row['drawn_aspect'][1]:.2f}), "
                f"{result.seconds:.0f} s")
        if oil:
            figures[f"{subject_name}_oil_paint"] = _oil_paint(subject_name, subject, source, mask, texel, near_zero,
                                                               size, log)
        if toon:
            figures[f"{subject_name}_toon"] = _toon(subject_name, subject, source, mask, size, log)
        if hatching:
            figures[f"{subject_name}_hatching"] = _hatching(subject_name, subject, source, mask, texel, size, out_dir,
                                                            log)
        if watercolour:
            figures[f"{subject_name}_watercolour"] = _watercolour(subject_name, subject, source, mask, texel, size,
                                                                  out_dir, log)
        if hand_painted:
            figures[f"{subject_name}_hand_painted"] = _hand_painted(subject_name, subject, source, mask, texel, size,
                                                                    out_dir, log)
    return figures


def _hand_painted(subject_name, subject, source, mask, texel, size, out_dir, log):
    """The Hand-Painted preset on a subject, given the run that changes nothing (``source``), the texels
    measured and their length: the edge measure at half its oil paint's size, and what its painted light
    adds over the same run without it, at the texels, against the form light's facing ``n . l`` (the
    interpolated normal there): the correlation of the lightness added with it (none on a flat frame,
    which faces one way), and the lightness (OKLab L) and warmth (OKLab b) the texels facing the light
    (``n . l`` above 0.5) gain over those turned away (below -0.5)."""
    import os

    from cp_stylize.oklab import to_oklab
    from cp_stylize.presets import load_preset
    from cp_stylize.shading import LIGHT
    from cp_stylize.texture import write_png

    hand = load_preset("hand_painted")
    ours = _run(subject, hand, size)
    write_png(os.path.join(out_dir, f"{subject_name}_hand_painted.png"), ours.image)
    plain = _run(subject, hand.replace(shade_light=0.0, shade_edges=0.0), size)
    mesh = _normalised_mesh(subject)
    atlas = ours.atlas
    points = np.einsum("mk,mkd->md", atlas.bary, mesh.vertices[mesh.input_faces[atlas.face]])
    facing = mesh.normal(points, atlas.face, atlas.bary) @ LIGHT
    kept = mask.reshape(-1)[atlas.texels]
    added = (to_oklab(ours.image.reshape(-1, 3)[atlas.texels]) - to_oklab(plain.image.reshape(-1, 3)[atlas.texels]))
    added, facing = added[kept], facing[kept]
    lit, away = facing > 0.5, facing < -0.5
    row = {"edges": edge_survival(ours.image, source.image, 0.5 * hand.oil_size / texel, mask),
           "light_correlation": float(np.corrcoef(added[:, 0], facing)[0, 1]) if np.ptp(facing) > 0.1 else None,
           "lit_minus_away": [float(added[lit, k].mean() - added[away, k].mean()) if lit.any() and away.any()
                              else None for k in (0, 2)],
           "seconds": ours.seconds}
    correlation = "n/a" if row["light_correlation"] is None else f"{row['light_correlation']:.2f}"
    gain = ("n/a" if row["lit_minus_away"][0] is None
            else f"L {row['lit_minus_away'][0]:+.3f}, b {row['lit_minus_away'][1]:+.3f}")
    log(f"{subject_name:8s} hand_painted    edges {row['edges']:.2f}, light added against n.l: correlation "
        f"{correlation}, facing the light over turned away {gain}, {ours.seconds:.0f} s")
    return row


def lightness_levels(image, mask, levels, reach=0.02, iterations=30):
    """The share of the texels ``mask`` of ``image`` whose OKLab lightness lies within ``reach`` of one of
    ``levels`` values, those values placed by one-dimensional k-means (from evenly spread quantiles)."""
    from cp_stylize.oklab import to_oklab

    lightness = to_oklab(np.asarray(image)[mask][:, :3].astype(np.float64))[:, 0]
    centres = np.quantile(lightness, (np.arange(levels) + 0.5) / levels)
    for _ in range(iterations):
        nearest = np.argmin(np.abs(lightness[:, None] - centres[None, :]), axis=1)
        centres = np.array([np.median(lightness[nearest == k]) if np.any(nearest == k) else centres[k]
                            for k in range(levels)])
    return float(np.mean(np.min(np.abs(lightness[:, None] - centres[None, :]), axis=1) < reach))


def away(image, darker, step=0.02):
    """The texels (H, W) of a toon ``image`` on its lines (where ``darker``, the lightness the lines took
    away, is over 0.01, and their neighbours) or at its bands' steps (their 3 x 3 neighbours' OKLab
    lightness spans more than ``step``): those the levels measure leaves out."""
    from cp_stylize.oklab import to_oklab

    lightness = to_oklab(np.asarray(image)[..., :3].astype(np.float64))[..., 0]
    steps = ndimage.maximum_filter(lightness, 3) - ndimage.minimum_filter(lightness, 3) > step
    return steps | ndimage.binary_dilation(darker > 0.01, iterations=1)


def outline_coverage(inked, source, mask, reach=2, share=0.02):
    """The share of the source's strongest edges (its ``share`` of texels with the largest OKLab colour
    gradient at a deviation of one texel) that have an inked texel within ``reach`` texels."""
    inner = _inner(mask, 3)
    edges = _colour_gradient(source, 1.0)
    strong = inner & (edges >= np.quantile(edges[inner], 1.0 - share))
    near = ndimage.binary_dilation(inked, iterations=reach)
    return float(near[strong].mean())


def _toon(subject_name, subject, source, mask, size, log):
    """The Toon preset's measures on a subject, given the run that changes nothing (``source``): how many
    of the texels away from its lines and its bands' steps (:func:`away`) hold one of its levels of
    lightness, how many of the picture's
    strongest edges have a line along them, and the edge measure at a texel and a half."""
    from cp_stylize.presets import load_preset

    from cp_stylize.oklab import to_oklab

    toon = load_preset("toon")
    ours = _run(subject, toon, size)
    bare = _run(subject, toon.replace(line_width=0.0, toon_outlines=0.0), size)
    darker = to_oklab(bare.image[..., :3].astype(np.float64))[..., 0] - to_oklab(ours.image[..., :3].astype(np.float64))[..., 0]
    inked = mask & (darker > 0.05)
    row = {"levels": toon.toon_levels,
           "on_levels": lightness_levels(bare.image, mask & ~away(bare.image, darker), toon.toon_levels),
           "outlines": outline_coverage(inked, source.image, mask),
           "edges": edge_survival(ours.image, source.image, 1.5, mask), "seconds": ours.seconds}
    log(f"{subject_name:8s} toon            {100 * row['on_levels']:.0f} % of texels on its {row['levels']} levels, "
        f"outlines along {100 * row['outlines']:.0f} % of the strongest edges, edges {row['edges']:.2f}, "
        f"{ours.seconds:.0f} s")
    return row


def wash_rims(image, flat, mask, rim=2, inside=6, window=31, step=0.02):
    """How much darker the washes of a watercolour ``image`` are at their borders than inside.  ``flat``: the
    same run without edge darkening, so the two differ only there.  The borders are where ``flat``'s OKLab
    lightness spans more than ``step`` over 3 x 3 texels; each texel of ``mask`` within ``rim`` texels of
    one, on its darker side (the wash laid over the lighter, which dried there), is compared, by its
    luminance over ``flat``'s, with the texels at least ``inside`` texels from any border in the ``window``
    around it.  Returns ``(median share darker, share of those texels at least
    15 % darker)``."""
    from cp_stylize.oklab import to_oklab

    lightness = to_oklab(np.asarray(flat)[..., :3].astype(np.float64))[..., 0]
    border = ndimage.maximum_filter(lightness, 3) - ndimage.minimum_filter(lightness, 3) > step
    distance = ndimage.distance_transform_edt(~border)
    ratio = luminance(image) / np.maximum(luminance(flat), 1e-6)
    far = (mask & (distance >= inside)).astype(np.float64)
    count = ndimage.uniform_filter(far, window)
    mean = ndimage.uniform_filter(ratio * far, window) / np.maximum(count, 1e-12)
    darker_side = lightness < ndimage.maximum_filter(lightness, 2 * rim + 3) - step     # a lighter wash beside it
    edge = mask & (distance <= rim) & darker_side & (count > 0.05)
    darker = 1.0 - ratio[edge] / np.maximum(mean[edge], 1e-9)
    if not len(darker):
        return 0.0, 0.0
    return float(np.median(darker)), float(np.mean(darker >= 0.15))


def grain_contrast(image, smooth, mask, sigma=3.0):
    """The standard deviation of ``image``'s luminance about its Gaussian blur (deviation ``sigma`` texels): how
    strongly a fine texture (granulation) shows.  Over the texels of ``mask`` where ``smooth`` (the same run
    without the texture) is calm: no edge, rim or line within three deviations."""
    light = luminance(image)
    fine = light - ndimage.gaussian_filter(light, sigma)
    calm = ndimage.binary_erosion(_colour_gradient(smooth, 1.0) < 0.01, iterations=int(3 * sigma))
    calm &= _inner(mask, 3 * sigma)
    return float(fine[calm].std())


def _watercolour(subject_name, subject, source, mask, texel, size, out_dir, log):
    """The Watercolour preset's measures on a subject, given the run that changes nothing (``source``): how much
    darker its washes are at their borders (:func:`wash_rims`, over the borders that dried hard, without its pen
    lines and granulation), its granulation (:func:`grain_contrast`, against the washes without it), and the edge
    measure at half the oil paint's size."""
    import os

    from cp_stylize.presets import load_preset
    from cp_stylize.texture import write_png

    wash = load_preset("watercolour")
    ours = _run(subject, wash, size)
    write_png(os.path.join(out_dir, f"{subject_name}_watercolour.png"), ours.image)
    hard = wash.replace(line_width=0.0, wash_bleed=0.0, wash_granulation=0.0)
    rimmed = _run(subject, hard, size)
    flat = _run(subject, hard.replace(wash_edges=0.0), size)
    smooth = _run(subject, wash.replace(wash_granulation=0.0), size)
    darker, share = wash_rims(rimmed.image, flat.image, mask)
    row = {"rims_darker": darker, "rims_share_15": share,
           "grain": grain_contrast(ours.image, smooth.image, mask),
           "grain_without": grain_contrast(smooth.image, smooth.image, mask),
           "edges": edge_survival(ours.image, source.image, 0.5 * wash.oil_size / texel, mask),
           "seconds": ours.seconds}
    log(f"{subject_name:8s} watercolour     rims {100 * darker:.0f} % darker than inside (median; {100 * share:.0f} % "
        f"of the rims' texels at least 15 %), granulation {row['grain']:.3f} against {row['grain_without']:.3f} "
        f"without, edges {row['edges']:.2f}, {ours.seconds:.0f} s")
    return row


def paper_or_ink(image, mask, ink, paper, reach=0.15):
    """The share of the texels ``mask`` of ``image`` whose colour lies within ``reach`` (in each sRGB channel) of
    the ``paper`` or the ``ink``."""
    colours = np.asarray(image, dtype=np.float64)[mask][:, :3]
    near = np.minimum(np.abs(colours - paper).max(axis=1), np.abs(colours - ink).max(axis=1)) <= reach
    return float(near.mean())


def ink_share(image, ink, paper):
    """How far each texel's colour (H, W) lies from the ``paper`` towards the ``ink``, in [0, 1]."""
    span = np.asarray(ink, dtype=np.float64) - paper
    return np.clip((np.asarray(image, dtype=np.float64)[..., :3] - paper) @ span / (span @ span), 0.0, 1.0)


def line_widths(inked, mask):
    """The widths (texels) of the lines of a boolean ink image (H, W) within ``mask``: at each texel of a line's
    middle (a local maximum of its distance to the paper, over its 3 x 3 neighbours), twice that distance less
    one (a line one texel wide has its middle one texel from the paper)."""
    distance = ndimage.distance_transform_edt(inked)
    middle = inked & (distance >= ndimage.maximum_filter(distance, 3)) & _inner(mask, 3)
    return 2.0 * distance[middle] - 1.0


def tone_correlation(ink, lightness, mask, window=16):
    """The correlation, over ``window`` x ``window`` blocks wholly in ``mask``, of their mean ink and the mean
    lightness of the source under them."""
    h, w = ink.shape
    h, w = h - h % window, w - w % window

    def blocks(a):
        return a[:h, :w].reshape(h // window, window, w // window, window).mean(axis=(1, 3))

    whole = blocks(mask.astype(np.float64)) == 1.0
    return float(np.corrcoef(blocks(ink)[whole], blocks(lightness)[whole])[0, 1])


@contextlib.contextmanager
def kept_hatchings():
    """A context manager that yields a list, which collects each :class:`~cp_stylize.hatching.Hatching` the runs
    inside it make (for the measures that read a run's lines on the surface)."""
    from cp_stylize import hatching

    made, original = [], hatching.Hatching.__init__

    def keep(self, *args, **kwargs):
        original(self, *args, **kwargs)
        made.append(self)

    hatching.Hatching.__init__ = keep
    try:
        yield made
    finally:
        hatching.Hatching.__init__ = original


def hatch_spacings(hatch, probes=400, seed=0, darkness=0.3, reach=4.0):
    """The lines' spacing measured on the surface: from ``probes`` random points of a run's
    :class:`~cp_stylize.hatching.Hatching`, each walks ``reach`` spacings across the first layer's lines (along
    its nearest kernel's direction, in steps of a twentieth of a spacing, in the tangent plane) at one tone
    (``darkness``, whole lines of the first layer alone), and counts the lines it crosses; each probe's spacing
    is the distance from the first line's near edge to the last's over the lines between.  Returns the
    spacings (in the hatching's lengths) of the probes that crossed at least three lines."""
    mesh = hatch.mesh
    rng = np.random.default_rng(seed)
    points, faces, barys = mesh.sample(probes, rng)
    normals = mesh.normal(points, faces, barys)
    kernels = hatch._layers[0]
    _, nearest = hatch.tree.query(points)
    across = kernels.across[nearest]
    across -= np.einsum("ij,ij->i", across, normals)[:, None] * normals
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    steps = np.arange(0.0, reach, 0.05) * hatch.spacing
    at = (points[:, None, :] + steps[None, :, None] * across[:, None, :]).reshape(-1, 3)
    n = len(steps)
    ink = hatch.ink_at(at, np.repeat(normals, n, axis=0), np.repeat(mesh.piece[faces], n),
                       np.full(len(at), 0.05 * hatch.spacing), np.full(len(at), darkness)).reshape(probes, n)
    found = []
    for row in ink:
        rises = np.flatnonzero((row[1:] >= 0.5) & (row[:-1] < 0.5))
        if len(rises) >= 3:
            found.append((rises[-1] - rises[0]) / (len(rises) - 1) * 0.05 * hatch.spacing)
    return np.array(found)


def _hatching(subject_name, subject, source, mask, texel, size, out_dir, log):
    """The Ink Hatching preset's measures on a subject, given the run that changes nothing (``source``), of its
    hatching without its outlines: the share of texels on paper or ink, the lines' widths in texels (where the
    tone asks for the first layer alone), their spacing on the surface within one tone
    (:func:`hatch_spacings`), the correlation of ink and the source's lightness, and the edge measure at the
    scale of the lines' spacing."""
    import os

    from cp_stylize import hatching as module
    from cp_stylize.oklab import to_oklab
    from cp_stylize.pipeline import hatch_colours
    from cp_stylize.presets import load_preset
    from cp_stylize.texture import write_png

    settings = load_preset("hatching")
    with kept_hatchings() as made:
        ours = _run(subject, settings.replace(line_width=0.0), size)
    write_png(os.path.join(out_dir, f"{subject_name}_hatching.png"), ours.image)
    ink, paper = hatch_colours(settings)
    lightness = to_oklab(np.clip(source.image[..., :3], 0, 1).astype(np.float64))[..., 0]
    # the lines' widths where the tone asks for the first layer alone (no crossing lines to merge with)
    darkness = np.zeros_like(lightness)
    darkness[mask] = made[0].darkness(lightness[mask])
    first = mask & (darkness > 0) & (darkness < module.WIDEST)
    widths = line_widths(ink_share(ours.image, ink, paper) > 0.5, first)
    spacings = hatch_spacings(made[0])
    spacing_px = made[0].spacing / texel
    row = {"paper_or_ink": paper_or_ink(ours.image, mask, ink, paper),
           "widths": [float(np.quantile(widths, q)) for q in (0.05, 0.5, 0.95)],
           "spacing": made[0].spacing, "spacing_spread": float(np.std(spacings) / np.mean(spacings)),
           "probes": len(spacings),
           "tone_correlation": tone_correlation(ink_share(ours.image, ink, paper), lightness, mask),
           "edges": edge_survival(ours.image, source.image, spacing_px, mask), "seconds": ours.seconds}
    log(f"{subject_name:8s} hatching        {100 * row['paper_or_ink']:.0f} % of texels paper or ink, lines "
        f"{row['widths'][0]:.1f} / {row['widths'][1]:.1f} / {row['widths'][2]:.1f} texels wide (5th, 50th, 95th "
        f"percentile), spacing {row['spacing']:.4f} varying by {100 * row['spacing_spread']:.0f} % on "
        f"{row['probes']} probes, ink against lightness {row['tone_correlation']:.2f}, edges at {spacing_px:.1f} "
        f"texels {row['edges']:.2f}, {ours.seconds:.0f} s")
    return row


def _mask(subject_name, source, size):
    """The texels a subject's measures count: its atlas's, on the sphere within 45 degrees of the equator."""
    mask = source.atlas.coverage.reshape(size, size)
    if subject_name == "sphere":
        mask &= np.isin(np.arange(size), np.arange(size)[equator_rows(size)])[:, None]
    return mask


def seam_step(image, rows):
    """Across the UV seam of an equirectangular atlas (its first and last columns meet on the surface), at
    ``rows``: the mean colour difference there, and between neighbouring columns inside."""
    image = np.asarray(image, dtype=np.float64)[rows]
    inside = np.abs(np.diff(image, axis=1)).mean()
    return float(np.abs(image[:, 0] - image[:, -1]).mean()), float(inside)


def _oil_paint(subject_name, subject, source, mask, texel, near_zero, size, log):
    """The Oil Paint preset against Blender's Kuwahara node (:func:`cp_stylize_dev.scene.kuwahara_node`) on
    a subject's picture, given the run that changes nothing (``source``), the texels measured and their
    length: the edge measure of both, at half the filter's size, and on the sphere the step across its UV
    seam against the steps inside."""
    from cp_stylize.presets import load_preset

    from .scene import kuwahara_node

    oil = load_preset("oil_paint")
    vertices, faces, uvs, image, wrap = subject
    scale_px = 0.5 * oil.oil_size / texel
    ours = _run(subject, oil, size)
    node = _run((vertices, faces, uvs, kuwahara_node(np.asarray(image, np.float32)), wrap), near_zero, size)
    row = {"edges": edge_survival(ours.image, source.image, scale_px, mask),
           "node_edges": edge_survival(node.image, source.image, scale_px, mask), "seconds": ours.seconds}
    if subject_name == "sphere":
        rows = np.flatnonzero(mask[:, 0] & mask[:, -1])
        row["seam"], row["node_seam"] = seam_step(ours.image, rows), seam_step(node.image, rows)
    log(f"{subject_name:8s} oil_paint       edges {row['edges']:.2f} (Blender's Kuwahara node "
        f"{row['node_edges']:.2f}), "
        + (f"across the UV seam {row['seam'][0]:.4f} against {row['seam'][1]:.4f} inside (the node "
           f"{row['node_seam'][0]:.4f} against {row['node_seam'][1]:.4f}), " if "seam" in row else "")
        + f"{ours.seconds:.0f} s")
    return row
