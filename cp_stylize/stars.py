"""Stars: the picture's sky painted with the stars of van Gogh's "The Starry Night" (1889).

In the painting each star is a bright core ringed by halos of short strokes that
circle it, pale yellow and blue-white by turns, in a sky of swirling blues.  Here
stars go at the picture's lights: in its sky, a part that is light and calm (no
buildings, branches or lettering there to hide), where it stands out lightest
from the picture about it (the sun behind cloud, a gap in a canopy), found on
the surface itself, so a star crosses UV seams whole:

- **found** on the band: the picture's OKLab lightness is smoothed over a star's
  core (a Gaussian of deviation ``radius``,
  :class:`~cp_stylize.smoothing.GridGaussian`) and over its halo (:data:`HALO`
  radii).  A star may go where the halo's lightness is at least
  :data:`SKY_LIGHT` (and among the picture's lightest :data:`SKY` share), where
  the picture's spread about the core's smoothed lightness, over the halo, is
  among its calmest :data:`CALM` share (or below :data:`STILL`), where the
  core stands out from the halo by at most :data:`MIN_CONTRAST` (no edge runs
  through it; lighter by up to :data:`GLOW`: a light's glow), and with its whole
  halo clear of the mesh's open border.  Of those places, stars go at the
  picture's lights alone: where the core's smoothed lightness stands out from
  the picture's about it (over :data:`AROUND` radii) within :data:`LIGHTS` of
  the most.  The place that stands out most takes the first star, the largest;
  the others are taken in a random order (``seed``), each with its own
  radius, so the stars scatter over the lights in several sizes, at most
  ``count`` of them, their halos kept apart by at least -:data:`OVERLAP` of
  their reach.  A grey sky with one bright patch (the sun behind cloud) gets its
  star there, not in the dull sky about it;
- **painted into the picture**, before the palette maps its colours, so the
  palette gives a star its own colours: a :data:`CORE` colour over the core
  (:data:`CORE_SHARE` of the radius) and around it, out to :data:`HALO` radii,
  rings a stroke's width apart of :data:`RINGS` colours by turns, fading out
  over the halo's outer :data:`FADE`.  Each star's radius is drawn between :data:`SIZES` times the
  radius asked for, evenly in its logarithm (as many small stars as large): the stars differ in size
  as the painting's do;
- **each its own**, as no two of the painting's stars are alike: its rings
  are lobed (:data:`WOBBLE`), a little wider or narrower apart (:data:`RING_SPREAD`),
  begin with either colour, and its core runs from :data:`CORE` at the centre
  to a deeper yellow (:data:`CORE_RIM`) at its edge;
- **with a field** the strokes follow (``field=`` of
  :func:`cp_stylize.painting.painting`): about each star's centre, each
  star turning its own way, so strokes ring the halo, a little loose
  (:data:`HALO_TILT`), and turn in a little more over the core (:data:`CORE_TILT`).

A point belongs to a star where it lies within the halo (straight-line distance) and its normal is
within :data:`FACING` of the star's: the other side of a thin part, or a sheet that passes close, is
left alone.  Lengths are those of the object normalised to a diameter of 2.
"""

from __future__ import annotations

import numpy as np

from .oklab import to_oklab

__all__ = ["Stars", "find_stars", "on_band", "on_picture"]

#: A star's halo reaches this many core radii from its centre.
HALO = 2.6
#: Two stars' halos may overlap by at most this share of the sum of their reaches (below 0: they keep that
#: share of it apart, so the stars scatter over the sky instead of standing halo to halo).
OVERLAP = -0.35
#: A star's core may be darker than its halo by at most this much (OKLab; smoothed): no edge runs through it ...
MIN_CONTRAST = 0.03
#: ... and lighter by at most this much: a light's glow, not a lit window in a dark wall.
GLOW = 0.15
#: Stars go at the picture's lights: where the core's smoothed OKLab lightness stands out from the picture's
#: over :data:`AROUND` radii by within this of the place a star may go that stands out most.
LIGHTS = 0.08
AROUND = 8.0
#: Stars go where the halo's smoothed OKLab lightness is at least this ...
SKY_LIGHT = 0.6
#: ... and among this share of the picture's lightest (a quantile) ...
SKY = 0.6
#: ... and where the picture is among its calmest this share (its lightness's spread about its smoothed
#: self, over the halo).
CALM = 0.25
#: ... a spread of at most this (OKLab) is calm in any picture.
STILL = 0.01
#: The largest and smallest stars' radii, as shares of the radius asked for (the smallest star's core is
#: still about as wide as the finest dabs, which would otherwise paint over it and leave a hollow ring).
SIZES = (1.5, 0.75)
#: The core's colour and the halo rings' colours, taken by turns (sRGB, in the picture: the palette
#: mapping makes them the palette's own).
CORE = (1.0, 0.94, 0.62)
#: The core's colour at its edge: a deeper yellow of about its lightness, so the core reads as a whirl of two
#: yellows, not a flat disc (and draws no ink line between them).
CORE_RIM = (1.0, 0.87, 0.4)
RINGS = ((1.0, 0.96, 0.78), (0.78, 0.87, 1.0))
#: The core is this share of a star's radius; rings fill the rest of the halo.
CORE_SHARE = 0.6
#: A point belongs to a star's side of the surface where its normal is within this angle of the star's
#: (its cosine).
FACING = 0.5
#: The halo's rings fade out over this share of the halo, towards its edge.
FADE = 0.35
#: A star's rings are lobed: each star's shapes are drawn in by up to this share of their radius, in
#: 3 to 5 lobes about its centre.
WOBBLE = (0.06, 0.16)
#: Each star's rings are this share wider or narrower apart than asked, at most.
RING_SPREAD = 0.2
#: The strokes' angle to the circles about a star (radians, each star a draw between these): rings of dabs
#: about it, a little loose in the halo and more in the core (a star is a core ringed by halos; the spiral
#: is the sky's); each star turns one way or the other.
HALO_TILT = (0.03, 0.15)
CORE_TILT = (0.3, 0.5)
#: Of the places a star may go, this many of the lightest are looked at.
CANDIDATES = 20000


class Stars:
    """Stars at ``centres`` (k, 3) with unit ``normals`` (k, 3) and core ``radii`` (k,), their halos'
    rings about ``ring`` apart (see the module's notes); ``seed`` draws each star's own shape."""

    def __init__(self, centres, normals, radii, ring, seed=0):
        self.centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        self.normals = np.asarray(normals, dtype=np.float64).reshape(-1, 3)
        self.radii = np.broadcast_to(np.asarray(radii, dtype=np.float64), (len(self.centres),)).copy()
        self.ring = float(ring)
        k = len(self.centres)
        rng = np.random.default_rng([int(seed), 11])
        self.rings = self.ring * (1.0 + RING_SPREAD * rng.uniform(-1.0, 1.0, k))
        self.first = rng.integers(0, len(RINGS), k)                      # the colour of the innermost ring
        self.wobble = rng.uniform(*WOBBLE, k)
        self.lobes = rng.integers(3, 6, k)
        self.turn = rng.uniform(0.0, 2.0 * np.pi, k)
        spin = np.where(rng.random(k) < 0.5, -1.0, 1.0)
        self.halo_tilt = spin * rng.uniform(*HALO_TILT, k)
        self.core_tilt = spin * rng.uniform(*CORE_TILT, k)
        # a frame of each star's tangent plane, for the angle about its centre
        helper = np.where(np.abs(self.normals[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        self.axis_u = np.cross(self.normals, helper)
        self.axis_u /= np.maximum(np.linalg.norm(self.axis_u, axis=1, keepdims=True), 1e-12)
        self.axis_v = np.cross(self.normals, self.axis_u)

    def __len__(self):
        return len(self.centres)

    def _nearest(self, points, normals, reach):
        """The star each of ``points`` (M, 3) belongs to within ``reach`` of its radii from its centre
        (M,: -1 for none), and its distance from it (M,); ``normals(index)`` gives the unit normals
        (m, 3) of the points ``index``, asked for those within reach alone."""
        which = np.full(len(points), -1, dtype=np.int64)
        distance = np.full(len(points), np.inf)
        for k, centre in enumerate(self.centres):
            d = np.linalg.norm(points - centre, axis=1)
            closer = (d < reach * self.radii[k]) & (d < distance)
            which[closer], distance[closer] = k, d[closer]
        inside = np.flatnonzero(which >= 0)
        if len(inside):
            away = np.einsum("ij,ij->i", normals(inside), self.normals[which[inside]]) <= FACING
            which[inside[away]], distance[inside[away]] = -1, np.inf
        return which, distance

    def _shaped(self, points, which, d):
        """The distances ``d`` of ``points`` (m, 3) from their stars ``which`` (m,), stretched by each star's
        lobes: a shape of the star's is its circle drawn in, by at most its :data:`WOBBLE`, between lobes."""
        offset = points - self.centres[which]
        angle = np.arctan2(np.einsum("ij,ij->i", offset, self.axis_v[which]),
                           np.einsum("ij,ij->i", offset, self.axis_u[which]))
        lobe = 0.5 * (1.0 + np.sin(self.lobes[which] * angle + self.turn[which]))
        return d / (1.0 - self.wobble[which] * lobe)

    def paint(self, points, normals, colours):
        """``colours`` (M, C, sRGB) of surface ``points`` (M, 3), with the stars painted over them (a copy);
        ``normals(index)``: the unit normals (m, 3) of the points ``index``."""
        out = np.array(colours, dtype=np.float32)
        if not len(self):
            return out
        which, d = self._nearest(np.asarray(points, dtype=np.float64), normals, HALO)
        inside = np.flatnonzero(which >= 0)
        if not len(inside):
            return out
        star = which[inside]
        d, r = self._shaped(np.asarray(points, dtype=np.float64)[inside], star, d[inside]), self.radii[star]
        inner = CORE_SHARE * r
        core = np.clip((1.2 * inner - d) / (0.2 * inner), 0.0, 1.0)     # the core, its edge soft
        lane = (np.floor(np.maximum(d - inner, 0.0) / self.rings[star]).astype(np.int64)
                + self.first[star]) % len(RINGS)
        fade = np.clip((HALO * r - d) / (FADE * (HALO - 1.0) * r), 0.0, 1.0)
        ring = np.asarray(RINGS, dtype=np.float32)[lane]
        rim = np.clip(d / inner, 0.0, 1.0)[:, None] ** 2                # white-hot centre, deeper yellow edge
        core_colour = np.float32(CORE) + rim * (np.float32(CORE_RIM) - np.float32(CORE))
        colour = core[:, None] * core_colour + (1.0 - core[:, None]) * ring
        amount = np.maximum(core, fade)[:, None]
        out[inside, :3] = out[inside, :3] + amount * (colour - out[inside, :3])
        return out

    def field(self, points, normals):
        """The strokes' directions about the stars (M, 3) at surface ``points`` (M, 3) (``normals`` as for
        :meth:`paint`): unit vectors in the tangent plane about each star's centre, at the star's angle
        to the circles (:data:`HALO_TILT` in its halo, :data:`CORE_TILT` in its core), over its
        halo and a little beyond (their length falls to 0 from :data:`HALO` to 1.3 :data:`HALO` radii); 0
        elsewhere."""
        points = np.asarray(points, dtype=np.float64)
        out = np.zeros((len(points), 3))
        if not len(self):
            return out
        which, d = self._nearest(points, normals, 1.3 * HALO)
        inside = np.flatnonzero((which >= 0) & (d > 1e-9))
        if not len(inside):
            return out
        star, normal = which[inside], normals(inside)
        around = np.cross(normal, points[inside] - self.centres[star])
        around /= np.maximum(np.linalg.norm(around, axis=1, keepdims=True), 1e-12)
        outward = np.cross(around, normal)
        inner = CORE_SHARE * self.radii[star]
        into_core = np.clip((1.2 * inner - d[inside]) / (0.4 * inner), 0.0, 1.0)
        tilt = self.halo_tilt[star] + into_core * (self.core_tilt[star] - self.halo_tilt[star])
        direction = np.cos(tilt)[:, None] * around + np.sin(tilt)[:, None] * outward
        reach = HALO * self.radii[star]
        trust = np.clip((1.3 * reach - d[inside]) / (0.3 * reach), 0.0, 1.0)
        out[inside] = trust[:, None] * direction
        return out


def on_picture(stars, mesh, picture_at):
    """``picture_at(face, bary)`` (the picture's colours at points of the mesh) with ``stars`` painted in."""
    if not len(stars):
        return picture_at

    def at(face, bary):
        face, bary = np.asarray(face), np.asarray(bary, dtype=np.float64)
        points = np.einsum("nk,nkj->nj", bary, mesh.vertices[mesh.input_faces[face]])
        return stars.paint(points, lambda index: mesh.normal(points[index], face[index], bary[index]),
                           picture_at(face, bary))
    return at


def on_band(stars, mesh, band, colours):
    """The band's ``colours`` (N, C) with ``stars`` painted in, and the strokes' field about them (N, 3)."""
    def normals(index):
        return mesh.normal(band.cp[index].astype(np.float64), band.face[index], band.bary[index])

    return stars.paint(band.cp, normals, colours), stars.field(band.cp, normals)


def _border_points(mesh, spacing):
    """Points (B, 3) along the mesh's open border (the edges that only one of its kept faces has, by vertex
    position: vertices split at a UV seam are one there), at most ``spacing`` apart along each edge, its ends
    included."""
    corners = [[0, 1], [1, 2], [2, 0]]
    ends = mesh.input_faces[mesh.face_index][:, corners].reshape(-1, 2)            # vertex numbers
    keys = np.sort(mesh.welded_faces[mesh.face_index][:, corners].reshape(-1, 2), axis=1)   # positions
    _, first, counts = np.unique(keys, axis=0, return_index=True, return_counts=True)
    open_edges = ends[first[counts == 1]]
    if not len(open_edges):
        return np.zeros((0, 3))
    a, b = mesh.vertices[open_edges[:, 0]], mesh.vertices[open_edges[:, 1]]
    pieces = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / spacing).astype(np.int64))
    edge = np.repeat(np.arange(len(open_edges)), pieces + 1)
    start = np.cumsum(pieces + 1) - (pieces + 1)
    t = (np.arange(len(edge)) - start[edge]) / pieces[edge]
    return a[edge] + t[:, None] * (b[edge] - a[edge])


def find_stars(mesh, band, colours, count, radius, ring, seed=0):
    """Up to ``count`` :class:`Stars` of core ``radius`` (rings ``ring`` apart) in the sky of the band's
    sRGB ``colours`` (N, C): at its lights, its light, calm parts that stand out lightest (see the module's notes)."""
    from scipy.spatial import cKDTree

    from .smoothing import GridGaussian

    none = Stars(np.zeros((0, 3)), np.zeros((0, 3)), radius, ring, seed)
    if count <= 0 or band.size == 0:
        return none
    lightness = to_oklab(np.asarray(colours).reshape(band.size, -1)[:, :3])[:, 0].astype(np.float32)
    core = GridGaussian(band, 0.5 * radius**2)
    halo = core.at_time(0.5 * (HALO * radius) ** 2)
    spot = core(lightness[None, :])[0]
    around, spread = halo(np.stack([lightness, (lightness - spot) ** 2]))
    near = np.abs(band.dist) <= band.h                   # points next to the surface stand for it
    light = around >= max(float(np.quantile(lightness[near], SKY)), SKY_LIGHT)
    calm = spread <= max(float(np.quantile(spread[near], CALM)), STILL**2)
    calm &= (around - spot <= MIN_CONTRAST) & (spot - around <= GLOW)
    candidates = np.flatnonzero(near & light & calm)
    if not len(candidates):
        return none
    # how far each place stands out from the picture about it: a light (the sun behind cloud, a gap in a
    # canopy) does, an even sky does not
    stands = spot - core.at_time(0.5 * (AROUND * radius) ** 2)(lightness[None, :])[0]
    lights = candidates[stands[candidates] >= stands[candidates].max() - LIGHTS]
    first = lights[np.argmax(stands[lights])]
    rng = np.random.default_rng([int(seed), 7])
    others = rng.permutation(lights[lights != first])[:CANDIDATES]   # scattered over the lights, not in a row
    candidates = np.concatenate([[first], others])
    radii = radius * SIZES[1] * (SIZES[0] / SIZES[1]) ** rng.random(len(candidates))   # as many small as large
    radii[0] = radius * SIZES[0]                          # the place that stands out most: the largest star
    border = _border_points(mesh, 0.5 * radius)
    if len(border):                                      # a whole star, not one cut by the border
        clear, _ = cKDTree(border).query(band.cp[candidates])
        whole = clear >= HALO * radii
        candidates, radii = candidates[whole], radii[whole]
    points = band.cp[candidates].astype(np.float64)
    chosen = []
    for i, p in enumerate(points):
        if all(np.linalg.norm(p - points[j]) >= (1.0 - OVERLAP) * HALO * (radii[i] + radii[j]) for j in chosen):
            chosen.append(i)
            if len(chosen) == count:
                break
    picked = candidates[chosen]
    if not len(picked):
        return none
    normals = mesh.normal(band.cp[picked].astype(np.float64), band.face[picked], band.bary[picked])
    return Stars(band.cp[picked], normals, radii[chosen], ring, seed)
