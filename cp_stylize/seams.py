"""A texture's colour jumps along its UV seams, healed on the surface.

A texture is read through per-corner UVs: where two faces meet along an edge
but their UVs there differ (a UV seam), each side reads its own part of the
image, and unless the image was painted to match, the colour jumps along the
edge.  On the surface that jump is a line the picture never had (down the
crown of a head whose two halves were unwrapped apart); brush strokes would
stop at it and contour lines trace it.

:class:`SeamHealing` measures the jump at points along each seam (both sides'
colours at the same place on the surface) and moves the colours near the seam
by half of it, fading out within :data:`REACH` of the seam: the two sides meet
in their mean, and away from the seam nothing changes.  Where the image does
match across a seam (an equirectangular photograph around a sphere) the jump
is nought and so is the change.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .arrays import before, smooth_step

__all__ = ["SeamHealing", "seam_edges", "REACH"]

#: How far from a seam (in the units of an object normalised to a diameter of 2) its jump is spread.
REACH = 0.05
#: Points along a seam where the jump is measured, this share of :data:`REACH` apart.
STEP = 0.25
#: UVs of one corner that differ by more than this on the two sides of an edge make it a seam.
UV_TOLERANCE = 1e-5


def seam_edges(faces, uvs, chosen=None):
    """The UV seams among ``faces`` (F, 3) read through ``uvs`` (F, 3, 2).

    ``faces`` index the mesh's distinct vertex positions
    (:attr:`cp_stylize.mesh.TriangleMesh.welded_faces`), so that corners split
    at a seam are one.  An edge is a seam where exactly two faces meet, both
    ``chosen`` (F,) bool, and the UVs of a shared corner differ.  Returns
    ``(face_a, corners_a, face_b, corners_b)``: the two faces (E,) and, for
    each, its local corners (E, 2) at the edge's two ends in the same order.
    """
    corners = np.asarray(faces, dtype=np.int64)
    uvs = np.asarray(uvs, dtype=np.float64)
    chosen = np.ones(len(corners), bool) if chosen is None else np.asarray(chosen, bool)
    face = np.repeat(np.arange(len(corners)), 3)
    first = np.tile([0, 1, 2], len(corners))
    second = (first + 1) % 3
    ends = np.stack([corners[face, first], corners[face, second]], axis=1)
    keys = np.sort(ends, axis=1)
    order = np.lexsort((keys[:, 1], keys[:, 0]))
    keys = keys[order]
    same = np.all(keys[1:] == keys[:-1], axis=1)
    before = np.r_[False, same[:-1]]                                      # the key also came before
    after = np.r_[same[1:], False]                                        # and comes again after the pair
    starts = np.flatnonzero(same & ~before & ~after)                      # edges of exactly two faces
    a, b = order[starts], order[starts + 1]
    face_a, face_b = face[a], face[b]
    corners_a = np.stack([first[a], second[a]], axis=1)
    corners_b = np.stack([first[b], second[b]], axis=1)
    flip = ends[b, 0] != ends[a, 0]                                       # B's edge runs the other way
    corners_b[flip] = corners_b[flip][:, ::-1]
    jump = np.abs(uvs[face_a[:, None], corners_a] - uvs[face_b[:, None], corners_b]).max(axis=(1, 2))
    seam = (jump > UV_TOLERANCE) & chosen[face_a] & chosen[face_b] & (face_a != face_b)
    return face_a[seam], corners_a[seam], face_b[seam], corners_b[seam]


def _canonical(vertices, faces, seams):
    """The :func:`seam_edges` ``seams`` in an order that the surface alone decides, whatever the numbering of
    its faces and their corners: side A of each edge is the face whose corner off the edge comes first by
    position (:func:`cp_stylize.arrays.before`), the edge runs from its end that comes first, and the edges
    are sorted by their ends' positions and A's corner off the edge."""
    face_a, corners_a, face_b, corners_b = (np.array(part) for part in seams)

    def off(face, corners):
        return vertices[faces[face, 3 - corners.sum(axis=1)]]

    swap = before(off(face_b, corners_b), off(face_a, corners_a))
    face_a[swap], face_b[swap] = face_b[swap], face_a[swap]
    corners_a[swap], corners_b[swap] = corners_b[swap], corners_a[swap]
    ends = vertices[faces[face_a[:, None], corners_a]]                  # (E, 2, 3)
    flip = before(ends[:, 1], ends[:, 0])
    corners_a[flip], corners_b[flip], ends[flip] = corners_a[flip, ::-1], corners_b[flip, ::-1], ends[flip, ::-1]
    order = np.lexsort(np.column_stack([ends.reshape(-1, 6), off(face_a, corners_a)]).T[::-1])
    return face_a[order], corners_a[order], face_b[order], corners_b[order]


class SeamHealing:
    """The jumps of a colour along a mesh's UV seams, and colours near them moved to meet (see the module).

    Parameters
    ----------
    vertices : ndarray (V, 3)
        The mesh's vertices, normalised to a diameter of 2.
    faces : ndarray (F, 3)
        Its input faces.
    seams : tuple
        :func:`seam_edges` of the texture that makes the jumps.
    colour_at : callable
        ``colour_at(faces, barys)``: the colours (M, C) at points of the mesh (input faces (M,),
        barycentric coordinates (M, 3)).
    reach : float
        How far from a seam the jump is spread.
    """

    def __init__(self, vertices, faces, seams, colour_at, reach=REACH):
        self.vertices = np.asarray(vertices, dtype=np.float64)
        self.faces = np.asarray(faces, dtype=np.int64)
        self.reach = float(reach)
        face_a, corners_a, face_b, corners_b = _canonical(self.vertices, self.faces, seams)
        p0 = self.vertices[self.faces[face_a, corners_a[:, 0]]]
        p1 = self.vertices[self.faces[face_a, corners_a[:, 1]]]
        count = np.maximum(np.ceil(np.linalg.norm(p1 - p0, axis=1) / (STEP * self.reach)).astype(np.int64), 1)
        edge = np.repeat(np.arange(len(face_a)), count)
        t = (np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + 0.5) / np.repeat(count, count)
        self.points = p0[edge] + t[:, None] * (p1 - p0)[edge]
        self.start, self.end = p0[edge], p1[edge]                          # each point's seam edge
        self.face_a, self.face_b = face_a[edge], face_b[edge]

        def bary(corners):
            out = np.zeros((len(edge), 3))
            rows = np.arange(len(edge))
            out[rows, corners[edge, 0]] = 1.0 - t
            out[rows, corners[edge, 1]] += t
            return out

        self.colour_a = np.asarray(colour_at(self.face_a, bary(corners_a)), dtype=np.float64)
        self.colour_b = np.asarray(colour_at(self.face_b, bary(corners_b)), dtype=np.float64)
        # which side a point lies on: face A's interior, across the edge from its line (towards its corner
        # off the edge)
        off = self.vertices[self.faces[face_a, 3 - corners_a.sum(axis=1)]][edge]
        along = (p1 - p0)[edge] / np.maximum(np.linalg.norm(p1 - p0, axis=1), 1e-300)[edge, None]
        inward = off - self.points
        self.inward = inward - np.einsum("ij,ij->i", inward, along)[:, None] * along
        self.tree = cKDTree(self.points) if len(self.points) else None

    def __len__(self):
        """The points along the seams where the jump is measured."""
        return len(self.points)

    def __call__(self, face, bary, values):
        """``values`` (M, C), the colours at points of the mesh (input faces (M,), barycentrics (M, 3)),
        with those within :attr:`reach` of a seam moved by half the jump there, fading with the distance."""
        out = np.array(values, dtype=np.float32, copy=True)
        if self.tree is None or not len(out):
            return out
        face = np.asarray(face, dtype=np.int64)
        points = np.einsum("mk,mkd->md", np.asarray(bary, dtype=np.float64), self.vertices[self.faces[face]])
        distance, nearest = self.tree.query(points, distance_upper_bound=self.reach + STEP * self.reach)
        near = np.flatnonzero(np.isfinite(distance))
        if not len(near):
            return out
        k, at, face = nearest[near], points[near], face[near]
        # the distance to the nearest point's seam edge itself, not to the point: the two sides of the
        # seam meet exactly in their mean
        edge = self.end[k] - self.start[k]
        t = np.clip(np.einsum("ij,ij->i", at - self.start[k], edge)
                    / np.maximum(np.einsum("ij,ij->i", edge, edge), 1e-300), 0.0, 1.0)
        distance = np.linalg.norm(at - self.start[k] - t[:, None] * edge, axis=1)
        on_a = np.where(face == self.face_a[k], True,
                        np.where(face == self.face_b[k], False,
                                 np.einsum("ij,ij->i", at - self.points[k], self.inward[k]) > 0))
        own = np.where(on_a[:, None], self.colour_a[k], self.colour_b[k])
        other = np.where(on_a[:, None], self.colour_b[k], self.colour_a[k])
        fade = 1.0 - smooth_step(distance / self.reach)
        channels = min(out.shape[1], own.shape[1])
        out[near, :channels] += (0.5 * fade[:, None] * (other - own)[:, :channels]).astype(np.float32)
        return out
