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

__all__ = ["band_points"]

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
