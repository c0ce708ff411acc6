"""A new UV atlas for large meshes in seconds: charts that face an axis, projected on its plane.

xatlas makes good atlases, but its time grows faster than the mesh: 14 s at
100,000 triangles on two cores, and more than eight minutes at 500,000.  For larger
meshes :func:`projected_charts` makes an atlas whose cost is linear:

1. Every face takes one of the six signed axes: the one its normal, smoothed
   over its neighbourhood (so that a scan's noise does not cut the surface
   into crumbs), points along most, but never one its own normal makes an
   angle of more than about 84 degrees with.
2. Charts are the pieces of faces with the same axis that are connected
   through their edges.
3. A chart is projected orthogonally on its axis's plane (turned so that its
   box is wider than high), and the boxes, ``padding`` texels apart, are
   packed on shelves at the largest scale that fits.  Every
   chart has the same texels per unit of its projection.
4. Where a chart's projection folds over itself (a crumpled patch of a scan:
   two faces of the chart hold the same texel centre), the faces involved
   leave the chart, as pieces of their own, and the layout is made again.

A face's texels per unit of surface are ``cos`` of its normal's angle to its
axis (at least 0.1, and above 0.577 but where the smoothing turned it) times
the atlas's in one direction: the bake-out reads
the surface at each texel's own point, so this costs sharpness, never
correctness.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .raster import rasterise

__all__ = ["projected_charts"]

#: Passes of the normals' smoothing over the faces that share a vertex.
_SMOOTHING = 3
#: Least cosine between a face's normal and the axis it is projected along.
_LEAST_COS = 0.1
#: The packing's scale is searched to within this factor.
_SCALE_TOLERANCE = 1e-3
#: Rounds in which faces that overlap others of their chart leave it in pieces, then one by one
#: (the layout's scale changes with the charts, and with it the texel centres that show a fold).
_ROUNDS = 2
_LAST_ROUNDS = 6
#: The two in-plane axes of each axis (u, v with u x v along the axis).
_PLANE = np.array([[1, 2], [2, 0], [0, 1]])


def projected_charts(mesh, size, padding):
    """Per-corner UVs (K, 3, 2) of the mesh's kept faces, in charts projected along the axes.

    Parameters
    ----------
    mesh : TriangleMesh
    size : int
        Texels a side of the square atlas.
    padding : int
        Texels between charts, and between a chart and the atlas's border.

    Returns
    -------
    uv : ndarray, shape (K, 3, 2)
    raster : tuple
        :func:`cp_stylize.raster.rasterise` of the result: the covered texels, their triangles,
        barycentric coordinates and the number of texels inside two triangles.
    charts : int
        The number of charts.

    Raises
    ------
    ValueError
        When the charts do not fit in the atlas, or still overlap after
        every round of splitting; the message says which.
    """
    vertices, faces = mesh.vertices, mesh.faces
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    links = _edge_links(faces)
    axis = _axes(len(vertices), faces, normal)
    flat = _project(np.stack([a, b, c], axis=1), axis)
    chart = _pieces(links, axis)
    for _ in range(_ROUNDS):                     # crumpled patches leave their charts, in pieces of their own
        folded = _folds(faces, chart, flat)
        if not folded.any():
            break
        chart = _pieces(links, np.where(folded, chart.max() + 1 + axis, chart))
    alone = np.zeros(len(faces), dtype=bool)
    for attempt in range(_ROUNDS + _LAST_ROUNDS):
        uv = _layout(flat, chart, size, padding)
        raster = rasterise(uv, size)
        if raster[3] == 0:
            return uv, raster, int(chart.max()) + 1
        # the faces of a chart that still overlap one another (a fold wider than a vertex's faces)
        # leave it: in pieces of their own, and in the last rounds each alone, which cannot overlap
        folded = np.zeros(len(faces), dtype=bool)
        folded[rasterise(uv, size, overlapping=True)[4]] = True
        if attempt < _ROUNDS:
            chart = _pieces(links, np.where(folded, chart.max() + 1 + axis, chart))
        else:
            alone |= folded
            chart = _pieces(links, np.where(alone, chart.max() + 1 + np.arange(len(faces)), chart))
    raise ValueError(f"its surface folds over itself in too many places for charts projected along the axes "
                     f"(they still overlapped after {_ROUNDS + _LAST_ROUNDS} rounds of splitting): add a UV map "
                     f"(for example with Smart UV Project)")


def _edge_links(faces):
    """Pairs of faces (f1, f2) that share an edge (at a non-manifold edge, the faces in a row)."""
    edges = np.sort(np.stack([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]], axis=1).reshape(-1, 2), axis=1)
    key = edges[:, 0] * (int(faces.max()) + 1) + edges[:, 1]
    order = np.argsort(key, kind="stable")
    key, owner = key[order], order // 3
    same = np.flatnonzero(key[1:] == key[:-1])
    return owner[same], owner[same + 1]


def _axes(n_vertices, faces, normal):
    """The signed axis ``2 k + (component < 0)`` each face is projected along (K,): the one its normal,
    smoothed over the faces that share its vertices (a few passes), points along most, among those its
    own normal allows (cosine at least ``_LEAST_COS``; its own normal's main axis always is)."""
    n = len(faces)
    incidence = sp.csr_matrix((np.ones(3 * n), (np.repeat(np.arange(n), 3), faces.ravel())),
                              shape=(n, n_vertices))
    smooth = normal
    for _ in range(_SMOOTHING):
        smooth = incidence @ (incidence.T @ smooth)
    smooth /= np.maximum(np.linalg.norm(smooth, axis=1, keepdims=True), 1e-300)
    directions = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], dtype=np.float64)
    return np.argmax(np.where(normal @ directions.T >= _LEAST_COS, smooth @ directions.T, -np.inf), axis=1)


def _pieces(links, label):
    """Chart of every face (K,): the pieces of faces with one label, connected through shared edges."""
    f1, f2 = links
    n = len(label)
    link = label[f1] == label[f2]
    graph = sp.coo_matrix((np.ones(int(link.sum()), np.int8), (f1[link], f2[link])), shape=(n, n))
    return connected_components(graph, directed=False)[1].astype(np.int64)


def _project(corners, axis):
    """The corners (K, 3, 3) projected on the planes of their faces' axes (K,): (K, 3, 2), each face
    turning counter-clockwise where its normal has a positive component along its axis."""
    k, positive = axis // 2, axis % 2 == 0
    u = np.where(positive, _PLANE[k, 0], _PLANE[k, 1])                 # u x v along +axis, or along -axis
    v = np.where(positive, _PLANE[k, 1], _PLANE[k, 0])
    pick = lambda i: np.take_along_axis(corners, np.repeat(i[:, None, None], 3, axis=1), axis=2)[..., 0]
    return np.stack([pick(u), pick(v)], axis=2)


def _folds(faces, chart, flat):
    """Faces (K,) bool at the vertices where the projected faces of one chart turn round more than once.

    Every face of a chart turns counter-clockwise, so a chart is folded at a
    vertex where its faces' angles there add up to more than a full turn.
    """
    e1 = np.roll(flat, -1, axis=1) - flat                               # (K, 3, 2): each corner's two edges
    e2 = np.roll(flat, 1, axis=1) - flat
    angle = np.arctan2(np.abs(e1[..., 0] * e2[..., 1] - e1[..., 1] * e2[..., 0]),
                       (e1 * e2).sum(axis=2)).ravel()
    key = chart.repeat(3) * (int(faces.max()) + 1) + faces.ravel()
    unique, at = np.unique(key, return_inverse=True)
    total = np.bincount(at, weights=angle, minlength=len(unique))
    return (total[at] > 2.0 * np.pi * (1.0 + 1e-9)).reshape(-1, 3).any(axis=1)


def _layout(flat, chart, size, padding):
    """UVs (K, 3, 2) of the faces, from their projections ``flat`` (K, 3, 2), the charts packed on shelves."""
    n_charts = int(chart.max()) + 1
    lo = np.full((n_charts, 2), np.inf)
    hi = np.full((n_charts, 2), -np.inf)
    np.minimum.at(lo, chart, flat.min(axis=1))
    np.maximum.at(hi, chart, flat.max(axis=1))
    extent = hi - lo
    # turn tall charts a quarter (u, v) -> (v, hi_u - u), so that every box is wider than high
    tall = extent[:, 1] > extent[:, 0]
    turn = tall[chart]
    local = flat - lo[chart][:, None, :]
    turned = local[turn]
    local[turn] = np.stack([turned[..., 1], extent[chart[turn], 0][:, None] - turned[..., 0]], axis=2)
    extent[tall] = extent[tall][:, ::-1]
    scale, origin = _pack(extent, size, padding)
    return (local * scale + origin[chart][:, None, :]) / size


def _pack(extent, size, padding):
    """The largest texels per unit at which charts of ``extent`` (C, 2), ``padding`` texels apart, fit
    on shelves in a square of ``size`` texels, and each chart's lower left corner (C, 2) in texels."""
    area = float(np.prod(extent, axis=1).sum())
    top = size / max(float(extent.max()), 1e-300)
    if area > 0:
        top = min(top, size / np.sqrt(area))
    low, origin = top, _shelves(extent, top, size, padding)
    if origin is None:
        low = 0.0
        while top - low > _SCALE_TOLERANCE * top:
            mid = 0.5 * (low + top)
            packed = _shelves(extent, mid, size, padding)
            if packed is not None:
                low, origin = mid, packed
            else:
                top = mid
    if origin is None:
        raise ValueError(f"{len(extent)} charts with {padding} texels of padding do not fit in {size} x {size} "
                         f"texels: choose a larger image size")
    return low, origin


def _shelves(extent, scale, size, padding):
    """Lower left corners (C, 2) of the charts at ``scale`` on shelves, ``padding`` texels apart and
    from the border; None if they do not fit.

    First fit by decreasing height: the charts, tallest first, each go on the
    lowest shelf with room left, or open a new shelf above the others.
    """
    box = np.ceil(extent * scale) + 1 + padding                     # texels: a chart and the gap after it
    if box[:, 0].max() > size - padding:
        return None
    origin = np.empty((len(box), 2))
    fill = np.empty(len(box))                                       # each shelf's used width ...
    base = np.empty(len(box))                                       # ... and its bottom
    shelves, top = 0, float(padding)
    for i in np.argsort(-box[:, 1], kind="stable").tolist():
        w, h = box[i]
        s = int(np.argmax(fill[:shelves] <= size - w)) if shelves else 0
        if not shelves or fill[s] > size - w:
            if top + h > size:
                return None
            s, shelves = shelves, shelves + 1
            fill[s], base[s] = padding, top
            top += h
        origin[i] = fill[s], base[s]
        fill[s] += w
    return origin
