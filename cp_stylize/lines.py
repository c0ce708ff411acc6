"""Ink lines at the texels: the flow-based difference of Gaussians on the surface.

Kang, Lee and Chui, "Coherent line drawing" (NPAR 2007): across each point,
the picture's lightness is filtered by a difference of Gaussians (a centre of
deviation ``s``, a surround of ``1.6 s`` weighed :data:`SURROUND`), which is
negative on the dark side of an edge and on a thin dark line; that response
is then averaged along the edges' own direction over a few ``s`` (a Gaussian
along the flow), so that broken edges join into lines and speckle drops out;
ink goes where the averaged response is strongly negative.  The lines are as
sharp as the output's texels, and about ``2 s`` wide.

On the surface:

- the edges' direction is the structure tensor of the picture's gradient at
  the texels (Kang, Lee and Chui's edge tangent flow), its eigenvectors taken
  in the surface's metric (each texel's face's linear map), so a line is as
  wide on the surface whichever way its chart is stretched;
- the samples across and along are taken in the atlas, each texel's steps on
  the surface mapped into texels by its face's linear map (one texel's length
  on the surface, whatever the chart's scale); a margin texel steps by the
  map of the chart it borders, whose colours it continues (see
  :mod:`cp_stylize.baking`), so a line runs on across a chart's edge;
- the deviation ``s`` is a length on the surface (half the line's width, the
  object normalised to a diameter of 2), and at least :data:`MIN_SIGMA`
  texels, so that a line is always anti-aliased;
- how much ink is laid is measured against the picture's own edges (the
  99th percentile of the response), so a faint picture still has its
  strongest edges drawn: ``detail`` in [0, 1] lowers the share of that
  percentile where ink begins, from the strongest edges alone to most of
  them.
"""

from __future__ import annotations

import numpy as np

from .oklab import to_oklab

__all__ = ["Lines", "flow_dog", "inked", "SURROUND", "MIN_SIGMA"]

#: The surround's deviation over the centre's, and its weight (Kang, Lee and Chui's rho: below 1, a flat
#: colour gives a small positive response, so no ink).
SURROUND_RATIO = 1.6
SURROUND = 0.99
#: The Gaussian along the flow, in centre deviations (the paper's sigma_m = 3 sigma_c).
ALONG = 3.0
#: The smallest centre deviation, in texels.
MIN_SIGMA = 0.7
#: Samples across (each way): they reach three surround deviations.
ACROSS_STEPS = 8
#: Steps along the flow, each way, each one centre deviation long: they reach two Gaussian deviations.
ALONG_STEPS = 6
#: Ink begins where the response reaches this share of its 99th percentile, at Detail 0 and at Detail 1,
#: and is full at twice that.
START_LEAST, START_MOST = 0.5, 0.08
#: Pieces of ink (over SPECK_INK) smaller than this many texels of a 1024 x 1024 atlas are dropped: a line is
#: a line, not a comma of noise.
SPECK = 16
SPECK_INK = 0.3
#: The smallest 99th percentile taken (OKLab lightness): a flat picture draws no lines.
FLOOR = 0.004
#: The edges' direction: the picture's gradient after a Gaussian of this many texels, its structure
#: tensor smoothed over this many centre deviations (at least 1.5 texels).
PRESMOOTH = 1.0
STRUCTURE = 2.0
#: Lines are inked in this colour (sRGB) when none is given: black, as a pen draws.
INK = (0.02, 0.02, 0.02)


def inked(colours, amount, ink=None, darken=0.25):
    """sRGB ``colours`` (M, 3) inked ``amount`` (M,) in [0, 1]: towards the ``ink`` (sRGB: one colour (3,), or
    one for each (M, 3)), or, without one, towards ``darken`` times their own values."""
    target = darken * colours if ink is None else np.asarray(ink, dtype=colours.dtype)
    return colours + amount[:, None] * (target - colours)


def flow_dog(image, position, across, along, sigma, steps=(ACROSS_STEPS, ALONG_STEPS), nearest_fill=None):
    """The flow-based difference of Gaussians of ``image`` (size, size) at texels ``position`` (M, 2; row,
    column): the response (M,), negative on the dark side of an edge and on a thin dark line.

    ``across`` and ``along`` (size, size, 2): at each texel, one texel's length on the surface across and
    along the edges, in texels (row, column); ``sigma`` (M,): each texel's centre deviation in those
    lengths.  The samples are read bilinearly; the curve along the flow follows the direction of the
    texel it reaches at each step, kept pointing the way it came.  ``nearest_fill``:
    :func:`cp_stylize.raster.nearest_texels` of ``position``, if made before."""
    from scipy import ndimage

    from .raster import nearest_filled

    size = image.shape[0]
    n_across, n_along = steps
    reach = 3.0 * SURROUND_RATIO
    offsets = np.linspace(-reach, reach, 2 * n_across + 1)               # in centre deviations
    kernel = np.exp(-0.5 * offsets**2) - SURROUND * np.exp(-0.5 * (offsets / SURROUND_RATIO) ** 2) / SURROUND_RATIO
    kernel *= offsets[1] - offsets[0]

    def read(field, where):
        return ndimage.map_coordinates(field, where.T, order=1, mode="nearest")

    def nearest(where):
        cell = np.clip(np.rint(where).astype(np.int64), 0, size - 1)
        return cell[:, 0] * size + cell[:, 1]

    centre = np.asarray(position, dtype=np.float64)
    sigma = np.asarray(sigma, dtype=np.float64)
    # the difference of Gaussians across the edges, once at each texel ...
    step = across.reshape(-1, 2)[nearest(centre)] * sigma[:, None]
    across_edges = sum(k * read(image, centre + o * step) for o, k in zip(offsets, kernel))
    field = nearest_filled(across_edges, nearest(centre), size, nearest_fill)
    # ... averaged along the flow, read where the curve through each texel passes
    weights = np.exp(-0.5 * (np.arange(n_along + 1) / ALONG) ** 2)
    total = weights[0] * across_edges
    flow = along.reshape(-1, 2)
    start = flow[nearest(centre)]
    for sign in (1.0, -1.0):
        where, heading = centre.copy(), sign * start
        for k in range(1, n_along + 1):
            where = where + heading * sigma[:, None]
            ahead = flow[nearest(where)]
            heading = np.where((np.einsum("ij,ij->i", ahead, heading) >= 0)[:, None], ahead, -ahead)
            total += weights[k] * read(field, where)
    return total / (2.0 * weights.sum() - weights[0])


class Lines:
    """Ink lines at the bake-out (``paint=`` of :func:`cp_stylize.baking.bake_to_atlas`), drawn by the
    flow-based difference of Gaussians (see the module's notes) of the picture's lightness.

    ``mesh``, ``atlas``: the surface and the atlas baked; ``width``: the lines' width (object normalised
    to a diameter of 2); ``detail`` in [0, 1]: from the strongest edges alone to most of them;
    ``strength`` in [0, 1]: the ink's opacity; ``ink``: its sRGB colour (None: :data:`INK`,
    black); ``source(faces, barys)``: the picture's colours at points of the mesh (default: the
    colours the bake-out has at its texels).  Reads no band columns and leaves no height.
    """

    columns = None

    def __init__(self, mesh, atlas, width, *, detail=0.5, strength=1.0, ink=None, source=None):
        self.mesh, self.atlas, self.source = mesh, atlas, source
        self.width, self.detail, self.strength = float(width), float(detail), float(strength)
        self.ink = None if ink is None else np.asarray(ink, dtype=np.float64)

    def amount(self, texels, colours):
        """How much ink (M,) in [0, 1] each texel takes."""
        from .baking import texel_lengths
        from .raster import nearest_filled, nearest_texels

        flat, points, faces, barys = texels
        atlas, size = self.atlas, self.atlas.size
        picture = colours if self.source is None else self.source(faces, barys)
        fill = nearest_texels(flat, size)
        image = nearest_filled(to_oklab(np.asarray(picture, dtype=np.float64)[:, :3])[:, 0], flat, size, fill)
        lengths = texel_lengths(self.mesh, atlas, faces)
        sigma = np.maximum(0.5 * self.width / lengths, MIN_SIGMA)
        metric = _metric(self.mesh, atlas, flat)
        across, along = _flow(image, flat, metric, lengths, max(1.5, STRUCTURE * float(np.median(sigma))))
        position = np.column_stack(np.divmod(flat, size)).astype(np.float64)
        response = flow_dog(image, position, across, along, sigma, nearest_fill=fill)
        covered = len(atlas.texels)
        scale = max(float(np.quantile(np.maximum(-response[:covered], 0.0), 0.99)) if covered else 0.0, FLOOR)
        start = START_LEAST + (START_MOST - START_LEAST) * self.detail
        return _without_specks(np.clip((-response / scale - start) / start, 0.0, 1.0), flat, size)

    def __call__(self, texels, colours, read, progress=None):
        colours = np.asarray(colours)
        out = colours.copy()
        amount = self.strength * self.amount(texels, colours)
        out[:, :3] = inked(colours[:, :3].astype(np.float64), amount, INK if self.ink is None else self.ink)
        if progress is not None:
            progress(1.0)
        return out, None


def _without_specks(ink, flat, size):
    """``ink`` (M,) at the texels ``flat`` (M,) without the specks and dashes: its connected pieces (over
    :data:`SPECK_INK`, neighbours across corners too) smaller than :data:`SPECK` texels of a 1024 x 1024
    atlas (four times as many at 2048) are dropped."""
    from scipy import ndimage

    image = np.zeros(size * size)
    image[flat] = ink
    labels, count = ndimage.label((image > SPECK_INK).reshape(size, size), structure=np.ones((3, 3)))
    if not count:
        return ink
    sizes = np.bincount(labels.ravel())
    small = sizes < SPECK * (size / 1024.0) ** 2
    small[0] = False
    # a speck's faint rim goes with it: the pieces grown by a texel
    gone = ndimage.binary_dilation(small[labels], structure=np.ones((3, 3))).ravel()[flat]
    return np.where(gone, 0.0, ink)


def _metric(mesh, atlas, flat):
    """At the texels ``flat`` (M,): the surface's metric (M, 2, 2) in texel steps (column, row), by the
    linear map of each texel's face; a margin texel takes that of the chart it borders, whose colours it
    continues (see :mod:`cp_stylize.baking`)."""
    from .raster import nearest_texels

    size = atlas.size
    owner = np.full(size * size, -1, dtype=np.int64)
    owner[atlas.texels] = atlas.face
    faces = owner[nearest_texels(atlas.texels, size)[flat]]
    uv = atlas.uvs[faces] * size
    corners = mesh.vertices[mesh.input_faces][faces]
    edges = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2)   # (M, 3, 2)
    steps = np.stack([uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]], axis=2)                       # (M, 2, 2)
    det = steps[:, 0, 0] * steps[:, 1, 1] - steps[:, 0, 1] * steps[:, 1, 0]
    usable = np.abs(det) > 1e-12
    inverse = np.stack([np.stack([steps[:, 1, 1], -steps[:, 0, 1]], 1),
                        np.stack([-steps[:, 1, 0], steps[:, 0, 0]], 1)], 1) / np.where(usable, det, 1.0)[:, None, None]
    A = edges @ inverse                                            # surface per texel step (M, 3, 2)
    G = np.einsum("mki,mkj->mij", A, A)
    typical = float(np.median(G[usable][:, [0, 1], [0, 1]])) if usable.any() else 1.0
    G[~usable] = typical * np.eye(2)
    return G


def _flow(image, flat, metric, lengths, rho):
    """The edges' tangent field of ``image`` (size, size) on the surface, as steps one texel length
    ``lengths`` (M,) long at the texels ``flat`` (M,) across and along the edges, each an image (size,
    size, 2) of (row, column) steps: the structure tensor of the image's gradient (Kang, Lee and Chui's
    edge tangent flow), smoothed over ``rho`` texels, its eigenvectors taken in the surface's
    ``metric`` (M, 2, 2)."""
    from scipy import ndimage

    from .structure import eigen_2x2

    size = image.shape[0]
    smooth = ndimage.gaussian_filter(image, PRESMOOTH)
    gx, gy = ndimage.sobel(smooth, axis=1) / 8.0, ndimage.sobel(smooth, axis=0) / 8.0   # per column, row step
    J = [ndimage.gaussian_filter(p, rho).ravel()[flat] for p in (gx * gx, gx * gy, gy * gy)]
    # in an orthonormal frame of the metric: G = L L^T, B = L^-1 J L^-T
    l11 = np.sqrt(metric[:, 0, 0])
    l21 = metric[:, 0, 1] / l11
    l22 = np.sqrt(np.maximum(metric[:, 1, 1] - l21**2, 1e-30))
    # L^-1 = [[1/l11, 0], [-l21/(l11 l22), 1/l22]]
    i11, i21, i22 = 1.0 / l11, -l21 / (l11 * l22), 1.0 / l22
    a = i11 * i11 * J[0]
    b = i11 * (i21 * J[0] + i22 * J[1])
    d = i21 * i21 * J[0] + 2.0 * i21 * i22 * J[1] + i22 * i22 * J[2]
    _, _, c, s = eigen_2x2(a, b, d)
    out = []
    for w0, w1 in ((c, s), (-s, c)):               # across, along; back by L^-T, one texel length long
        x = lengths * (i11 * w0 + i21 * w1)
        y = lengths * (i22 * w1)
        image_steps = np.zeros((size * size, 2))
        image_steps[flat] = np.column_stack([y, x])
        out.append(image_steps.reshape(size, size, 2))
    return out
