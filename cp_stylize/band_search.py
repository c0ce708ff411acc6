"""The band's grid points near a triangle mesh, with their exact closest points.

The grid of spacing ``h`` is cut into blocks of ``4^3`` points.  A triangle is
a candidate of a block when the block meets the triangle's bounding box grown
by the band's width (Ruuth's ``tri2cp`` boxes, per block) and the block's
centre lies within that width plus the block's radius of the triangle's
plane.  The candidate lists then narrow through the blocks' ``2^3``
sub-blocks down to the points with the bounds of
:class:`~cp_stylize.nearest.TriangleSearch`.  Nothing scans the mesh's
bounding box.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .arrays import split_counts
from .sparse import map_parallel, workers

__all__ = ["band_points", "aabb_band_points", "use_aabb"]

#: Side, in grid points, of the blocks that start the band search.
_BLOCK = 4
#: Points handled at once, about.
_CHUNK = 1 << 17
#: Most block keys counted in a dense array when grouping the candidate pairs by block.
_DENSE_KEYS = 1 << 25


def band_points(search, h, width):
    """The grid points within ``width`` of the triangles of ``search`` (a
    :class:`~cp_stylize.nearest.TriangleSearch`) with their closest points, in chunks.

    Parameters
    ----------
    h : float
        Grid spacing; grid points are ``h * ijk``.
    width : float
        Band half-width.

    Yields
    ------
    ijk : ndarray of int64, shape (K, 3)
        Distinct integer grid coordinates, with every grid point within
        ``width`` among them exactly once over all chunks (and a few
        whose distance exceeds ``width`` by rounding: the caller keeps
        ``sqrt(d2) <= width``).
    tri, v, w, d2
        As :meth:`cp_stylize.nearest.TriangleSearch.nearest` returns them for ``h * ijk``.

    """
    h, width = float(h), float(width)
    if not np.isfinite(h) or h <= 0:
        raise ValueError(f"grid spacing h must be a positive number, got {h!r}")
    if not np.isfinite(width) or width < 0:
        raise ValueError(f"width must be a non-negative number, got {width!r}")
    blocks, pair_block, pair_tri = _block_pairs(search, h, width)
    local = np.stack(np.meshgrid(*[np.arange(_BLOCK)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    half = _BLOCK // 2
    corner = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    # a block's points by sub-block, each sub-block's in the same order: point 8 s + j of a block is
    # child j of its sub-block s, as the sub-block 8 b + s is child s of block b
    local = local[np.argsort(((local // half) * [4, 2, 1]).sum(axis=1), kind="stable")]
    sub_offset = half * corner + 0.5 * (half - 1)
    regular = [None, h * (sub_offset - 0.5 * (_BLOCK - 1)), h * (local[:8] - 0.5 * (half - 1))]
    # chunks of blocks with a bounded number of points and (sub-block, triangle) pairs
    per_block = np.bincount(pair_block, minlength=len(blocks))
    pair_start = np.r_[0, np.cumsum(per_block)]
    chunks = split_counts(np.maximum(8 * per_block, len(local)), 4 * _CHUNK)

    def chunk(bounds):
        s, e = bounds
        b = blocks[s:e]
        nb = len(b)
        p0, p1 = pair_start[s], pair_start[e]
        cells, tris = pair_block[p0:p1] - s, pair_tri[p0:p1]
        base = _BLOCK * b
        ijk = (base[:, None, :] + local[None, :, :]).reshape(-1, 3)
        centres = [
            np.ascontiguousarray((h * (base + 0.5 * (_BLOCK - 1))).T),
            np.ascontiguousarray((h * (base[:, None, :] + sub_offset[None, :, :])).reshape(-1, 3).T),
            np.ascontiguousarray((h * ijk).T),
        ]
        deltas = [np.full(nb, 0.5 * (_BLOCK - 1) * np.sqrt(3.0) * h * (1 + 1e-12)),
                  np.full(nb * 8, 0.5 * (half - 1) * np.sqrt(3.0) * h * (1 + 1e-12)),
                  np.zeros(len(ijk))]
        parents = [None, np.repeat(np.arange(nb), 8), np.repeat(np.arange(nb * 8), 8)]
        face, _ = search._descend(centres, deltas, parents, cells, tris, width=width, regular=regular)
        keep = np.flatnonzero(face >= 0)
        if len(keep) == 0:
            return None
        v, w, _, d2 = search._closest(centres[2][:, keep], face[keep])
        return ijk[keep], face[keep], v, w, d2

    # the chunks are independent: a few at a time, side by side on the worker threads
    spans = list(zip(chunks[:-1], chunks[1:]))
    step = 2 * workers()
    for k in range(0, len(spans), step):
        for found in map_parallel(chunk, spans[k:k + step]):
            if found is not None:
                yield found

def _block_pairs(search, h, width):
    """Blocks near the mesh and their candidate triangles.

    Returns the distinct block coordinates (B, 3) and the pairs (block
    index, triangle) sorted by block.
    """
    side = _BLOCK * h
    a, ab, ac = search.edges()
    corners = np.stack([a, a + ab, a + ac], axis=1)
    pad = 1e-9 * (1.0 + np.abs(corners).max() / side)
    lo = np.floor((corners.min(axis=1) - width) / side - pad).astype(np.int64)
    hi = np.floor((corners.max(axis=1) + width) / side + pad).astype(np.int64)
    extent = hi - lo + 1
    slack = (width + 0.5 * np.sqrt(3.0) * (_BLOCK - 1) * h) * (1 + 1e-9)
    origin = np.min(lo, axis=0)
    dims = np.max(hi, axis=0) - origin + 1
    strides = np.array([dims[1] * dims[2], dims[2], 1])
    # the signed distance of the block at lo + o from a triangle's plane is base + side * n.o
    base = np.einsum("ij,ij->i", h * (_BLOCK * lo + 0.5 * (_BLOCK - 1)) - a, search.normals)
    key_type = np.int32 if dims.prod() < 2**31 else np.int64
    lo_key = ((lo - origin) @ strides).astype(key_type)
    keys, owners = [], []
    # triangles with the same extent in blocks share their offsets: one broadcast per group and chunk
    big = int(extent.max()) + 1
    shapes, group = np.unique((extent[:, 0] * big + extent[:, 1]) * big + extent[:, 2], return_inverse=True)
    shapes = np.column_stack([shapes // (big * big), (shapes // big) % big, shapes % big])
    by_group = np.argsort(group, kind="stable")
    bounds = np.r_[0, np.cumsum(np.bincount(group, minlength=len(shapes)))]
    for g, shape in enumerate(shapes):
        members = by_group[bounds[g]:bounds[g + 1]]
        offsets = np.stack(np.meshgrid(*[np.arange(n) for n in shape], indexing="ij"), axis=-1).reshape(-1, 3)
        offset_key = (offsets @ strides).astype(key_type)
        step = max(1, (_CHUNK * 8) // len(offsets))
        for k in range(0, len(members), step):
            tri = members[k:k + step]
            plane = base[tri, None] + side * (search.normals[tri] @ offsets.T)
            near = np.abs(plane) <= slack
            row, col = np.nonzero(near)
            keys.append(lo_key[tri][row] + offset_key[col])
            owners.append(tri[row].astype(np.int32))
    keys, owners = np.concatenate(keys), np.concatenate(owners)
    if dims.prod() <= _DENSE_KEYS:
        # a counting sort: the blocks' keys index a dense array
        present = np.bincount(keys, minlength=int(dims.prod())) > 0
        unique = np.flatnonzero(present)
        compact = np.cumsum(present) - 1
        row = compact[keys]
    else:
        unique, row = np.unique(keys, return_inverse=True)
    del keys
    # grouped by block (a CSR pattern), each block's triangles in ascending order
    grouped = sp.csr_matrix((np.ones(len(owners), np.int8), (row, owners)), shape=(len(unique), len(search)))
    del row, owners
    pair_block = np.repeat(np.arange(len(unique)), np.diff(grouped.indptr))
    rel = np.column_stack([unique // (dims[1] * dims[2]), (unique // dims[2]) % dims[1], unique % dims[2]])
    return rel + origin, pair_block, grouped.indices


#: A band finds its points through libigl's AABB tree, where it can be imported (:func:`aabb_band_points`),
#: on meshes of at least this many triangles a band point (about; the blocks' search costs by the triangle,
#: the tree's by the band point: on a torus of 62,640 triangles they cross near a million band points) ...
AABB_TRIANGLES_PER_POINT = 0.06
#: ... and of at least this many triangles (below, the tree saves under half a second).
AABB_FACES = 50_000


def use_aabb(triangles, band_points):
    """Whether a band of about ``band_points`` points around ``triangles`` triangles is found through libigl's
    AABB tree (:func:`aabb_band_points`) rather than the blocks' search (:func:`band_points`)."""
    from .mesh_diffusion import available

    return triangles >= max(AABB_FACES, AABB_TRIANGLES_PER_POINT * band_points) and available()


def aabb_band_points(search, vertices, faces, h, width):
    """:func:`band_points` through libigl's AABB tree over the triangles: the same chunks, with each point's
    closest triangle as the tree finds it (the same as :func:`band_points` finds, up to ties).

    ``vertices`` (V, 3) and ``faces`` (K, 3) are the triangles of ``search`` in its order.  The grid's
    points are found by an octree of cells of ``2^l`` points a side, from cells that hold the mesh's
    whole band down to single points: a cell whose centre lies farther than ``width`` plus its radius
    from the mesh holds no point of the band (the distance changes by at most the distance moved), so
    only the cells near the surface are split.  The tree's distance at each cell's centre is all the
    descent takes, about one and a half queries a band point, whatever the triangles' sizes.
    """
    import igl

    h, width = float(h), float(width)
    tree = igl.AABB()
    vertices = np.ascontiguousarray(vertices, dtype=np.float64)
    faces = np.ascontiguousarray(faces, dtype=np.int64)
    tree.init(vertices, faces)
    used = vertices[np.unique(faces)]
    lo = np.floor((used.min(axis=0) - width) / h).astype(np.int64)
    hi = np.ceil((used.max(axis=0) + width) / h).astype(np.int64)
    level = max(2, int(np.ceil(np.log2(max(1, (hi - lo).max()) / _TOP_CELLS))))
    n = 1 << level
    top = np.stack(np.meshgrid(*[np.arange(a // n, b // n + 1) for a, b in zip(lo, hi)], indexing="ij"),
                   axis=-1).reshape(-1, 3)
    slack = 1e-9 * (1.0 + np.abs(used).max() / h) * h
    corner = np.stack(np.meshgrid(*[np.arange(2)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)

    def near(cells, n):
        """The ``cells`` of ``n`` points a side that may hold points of the band, and at n = 1 the tree's
        closest triangle of each."""
        centre = h * (n * cells + 0.5 * (n - 1))
        d2, tri, _ = tree.squared_distance(vertices, faces, centre)
        keep = np.sqrt(d2) <= width + 0.5 * np.sqrt(3.0) * (n - 1) * h + slack
        return cells[keep], tri[keep]

    def children(cells):
        return (2 * cells[:, None, :] + corner[None, :, :]).reshape(-1, 3)

    cells = top
    while n > _BLOCK:                       # the coarse levels whole: few cells
        cells, _ = near(cells, n)
        cells, n = children(cells), n // 2
    cells, _ = near(cells, n)
    step = max(1, _CHUNK // n**3)
    for k in range(0, len(cells), step):    # then blocks of 4^3 points, a chunk's worth at a time
        points = cells[k:k + step]
        for size in (n // 2, 1):
            points, tri = near(children(points), size)
        if len(points):
            v, w, _, d2 = search._closest(np.ascontiguousarray((h * points).T), tri)
            yield points, tri, v, w, d2


#: The octree of :func:`aabb_band_points` starts from cells this many to the band's bounding box a side.
_TOP_CELLS = 16
