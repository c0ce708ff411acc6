"""Diffusion filters on a triangle mesh's own vertices, with piecewise linear finite elements.

Colour that lives on the mesh (a scan's or a vertex-painted sculpt's colour
attribute) can be filtered where it is, with the discretisation whose
scale-space properties Wu, Deng, Chen and Tai prove ("Scale-space analysis of
discrete filtering over arbitrary triangulated surfaces", SIAM J. Imaging
Sciences, 2009):

- **elements**: values at the vertices, linear on each triangle, so each
  triangle has one gradient (``igl.grad``); the lumped (barycentric) mass
  matrix ``M`` (``igl.massmatrix``);
- **a diffusion tensor per triangle** ``D_T``, in the triangle's plane, and the
  stiffness ``K = sum_T |T| G_T^T D_T G_T`` (symmetric, positive semidefinite,
  constants in its null space; with ``D = I`` it is the cotangent Laplacian);
- **semi-implicit steps** ``(M + tau K(u^n)) u^{n+1} = M u^n``, ``K`` built from
  the values at the step's start: unconditionally stable, they keep the
  area-weighted mean exactly and lower the area-weighted variance at every
  step, and on meshes whose cotangent weights are positive (acute triangles)
  the linear and Perona-Malik filters keep the maximum-minimum principle.

The modes and their parameters are the band's (:func:`cp_stylize.diffuse`,
:mod:`cp_stylize.parameters`), in the same scale-free units: times in squared
lengths, ``lambda_rel`` and ``b_rel`` relative to the initial data's largest
gradient or coherence.

- ``"gaussian"``: ``D = I``;
- ``"perona_malik"``: ``D = g I``, ``g = 1 / (1 + |grad u|^2 / lambda^2)``,
  ``lambda = lambda_rel max |grad u0_sigma|``;
- ``"eed"``, ``"ced"``: from the structure tensor ``J_rho(grad u_sigma)``
  (the gradients of the values smoothed to time ``sigma``, summed over the
  channels, smoothed to time ``rho``), with its eigenvectors in the
  triangle's plane and the coherence ``c = mu1 - mu2``: EED
  ``kappa1 = 1 / (1 + (c / lambda)^2)`` across the edges and 1 along them,
  ``lambda = lambda_rel max c0``; CED ``alpha`` across and
  ``alpha + (1 - alpha) exp(-B^2 / c^2)`` along, ``B = b_rel max c0`` (the
  band's diffusivities, :func:`cp_stylize.diffusion_tensor._diffusivities`).

The smoothings to times ``sigma`` and ``rho`` are one implicit step of the
linear filter each (for the structure tensor, of its six components at the
vertices, back on the faces, where its part in each triangle's plane is read).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import scipy.sparse as sp

from .diffusion_tensor import _diffusivities
from .parameters import DEFAULTS

__all__ = ["MeshOperators", "mesh_diffuse", "MESH_MODES"]

#: The modes the mesh filter runs.
MESH_MODES = ("gaussian", "perona_malik", "eed", "ced")
#: The default time step, in squared mean edge lengths (the steps are stable at any size; this keeps the
#: nonlinear filters' lag behind their values small).
STEP_EDGES = 2.0
#: The conjugate gradient solves stop at this relative residual ...
RTOL = 1e-10
#: ... and those of the structure tensor's smoothings at this one: they only set the directions and
#: strengths the filter follows, which a residual this small does not move visibly.
TENSOR_RTOL = 1e-5
TINY = 1e-30
#: Solves to a relative residual this loose or looser run in single precision.
LOOSE = 1e-6


def _igl():
    try:
        import igl
    except ImportError as ex:
        raise ImportError("filtering on the mesh's vertices needs libigl (pip install libigl): "
                          f"{ex}") from None
    return igl


def step_count(T, tau):
    """The semi-implicit steps that split time ``T`` evenly into steps of ``tau`` or shorter (0 for ``T`` 0)."""
    return max(1, int(np.ceil(T / tau - 1e-9))) if T > 0 else 0


def available():
    """Whether libigl can be imported here: the mesh filters need it, and so does the band's AABB tree
    (:func:`cp_stylize.band_search.use_aabb`)."""
    try:
        _igl()
    except ImportError:
        return False
    return True


@dataclasses.dataclass
class MeshOperators:
    """The finite element operators of a triangle mesh: ``grad`` (3F, n), the gradient of a piecewise
    linear function on each face (x components of all faces, then y, then z); ``area`` (F,); ``mass``
    (n,), the lumped mass matrix's diagonal; ``edge``: the mean edge length; ``corners`` (F, 3): the faces' vertex numbers; ``basis`` (F, 3, 3): the gradients
    of each face's three hat functions (component, corner), read from ``grad``; ``laplacian``: the
    stiffness of the identity tensor, minus libigl's cotangent matrix; ``tangents`` (F, 2, 3): two unit
    vectors in each face's plane, at right angles."""

    grad: sp.csr_matrix
    area: np.ndarray
    mass: np.ndarray
    edge: float
    corners: np.ndarray
    basis: np.ndarray
    laplacian: sp.csr_matrix
    tangents: np.ndarray
    #: the stiffness's CSR pattern (indices, indptr): each vertex with itself and its neighbours
    pattern: tuple = dataclasses.field(init=False, repr=False)
    #: where each face's local 3 x 3 entries (F * 9, row by row) land in that pattern's data: a face's part is
    #: summed in by a bincount, without sorting
    slots: np.ndarray = dataclasses.field(init=False, repr=False)
    #: each face's ``|T| G_T^T G_T`` (F, 3, 3): its part of the stiffness of the identity tensor
    local: np.ndarray = dataclasses.field(init=False, repr=False)

    def __post_init__(self):
        n = len(self.mass)
        rows = np.repeat(self.corners, 3, axis=1).ravel().astype(np.int64)
        cols = np.tile(self.corners, (1, 3)).ravel().astype(np.int64)
        pattern = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
        pattern.sort_indices()
        self.pattern = (pattern.indices, pattern.indptr)
        # (row, col)'s place in the sorted pattern: the rank of its key row * n + col among the pattern's keys
        keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(pattern.indptr)) * n + pattern.indices
        self.slots = np.searchsorted(keys, rows * n + cols)
        self.local = np.einsum("fai,faj->fij", self.basis, self.basis) * self.area[:, None, None]

    @classmethod
    def of(cls, vertices, faces):
        igl = _igl()
        vertices = np.ascontiguousarray(vertices, dtype=np.float64)
        faces = np.ascontiguousarray(faces, dtype=np.int64)
        if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
            raise ValueError(f"vertices must be (n, 3) and faces (F, 3), got {vertices.shape} and {faces.shape}")
        corners = vertices[faces]
        cross = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        double = np.linalg.norm(cross, axis=1)
        if np.any(double <= 0):
            raise ValueError(f"{int(np.sum(double <= 0))} faces have no area; remove degenerate faces first")
        n = len(vertices)
        lumped = igl.massmatrix(vertices, faces, igl.MASSMATRIX_TYPE_BARYCENTRIC).diagonal()
        # libigl sizes its matrices by the vertices the faces use; a vertex no face uses keeps its value
        # (mass 1, no stiffness)
        mass = np.ones(n)
        mass[: len(lumped)] = np.where(lumped > 0, lumped, 1.0)
        grad = sp.csr_matrix(igl.grad(vertices, faces))
        grad = sp.csr_matrix((grad.data, grad.indices, grad.indptr), shape=(grad.shape[0], n))
        edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
        F = len(faces)
        rows = (np.arange(3)[:, None, None] * F + np.arange(F)[None, :, None]).repeat(3, axis=2)
        basis = np.asarray(grad[rows.ravel(), np.broadcast_to(faces, (3, F, 3)).ravel()]).reshape(3, F, 3)
        laplacian = -sp.csr_matrix(igl.cotmatrix(vertices, faces))
        laplacian = sp.csr_matrix((laplacian.data, laplacian.indices, laplacian.indptr), shape=(n, n))
        normal = cross / double[:, None]
        first = corners[:, 1] - corners[:, 0]
        first /= np.linalg.norm(first, axis=1, keepdims=True)
        tangents = np.stack([first, np.cross(normal, first)], axis=1)
        return cls(grad, 0.5 * double, mass, float(edges.mean()), faces, basis.transpose(1, 0, 2), laplacian,
                   tangents)

    @property
    def faces(self):
        return len(self.area)

    def gradients(self, values):
        """The faces' gradients (F, 3, C) of vertex ``values`` (n, C)."""
        return (self.grad @ values).reshape(3, self.faces, -1).transpose(1, 0, 2)

    def stiffness(self, tensor=None):
        """``K = sum_T |T| G_T^T D_T G_T`` (n, n, CSR) for face tensors ``tensor`` (F, 3, 3), or a face
        diffusivity (F,), or None (the identity: :attr:`laplacian`); assembled face by face from the
        hat functions' gradients."""
        if tensor is None:
            return self.laplacian
        tensor = np.asarray(tensor, dtype=np.float64)
        if tensor.ndim == 1:
            local = self.local * tensor[:, None, None]
        else:
            B = self.basis
            local = np.einsum("fai,fij->faj", np.einsum("fai,fab->fib", B, tensor), B) * self.area[:, None, None]
        return self._assembled(local)

    def directed_stiffness(self, along, across, direction):
        """The stiffness of the face tensors ``along P + (across - along) w w^T`` (``P`` the projector onto
        each face's plane, ``w`` (F, 3) a unit ``direction`` in it; ``along``, ``across`` (F,)): as
        :meth:`stiffness` of those tensors, from each face's ``|T| G^T G`` and ``G^T w`` (the hat
        functions' gradients lie in the face's plane, so ``P`` leaves them as they are)."""
        bw = np.einsum("fai,fa->fi", self.basis, direction)
        local = (self.local * along[:, None, None]
                 + (self.area * (across - along))[:, None, None] * (bw[:, :, None] * bw[:, None, :]))
        return self._assembled(local)

    def _assembled(self, local):
        """The CSR stiffness (n, n) that sums the faces' local matrices ``local`` (F, 3, 3)."""
        n = len(self.mass)
        indices, indptr = self.pattern
        data = np.bincount(self.slots, weights=local.ravel(), minlength=len(indices))
        return sp.csr_matrix((data, indices, indptr), shape=(n, n))

    def implicit_step(self, values, tau, K, rtol=RTOL):
        """``u`` with ``(M + tau K) u = M values`` (n, C), by conjugate gradients preconditioned with the
        diagonal, from ``values``: all channels at once (:func:`_block_cg`), to a relative residual ``rtol``."""
        A = (sp.diags(self.mass) + tau * K).tocsr()
        if rtol >= LOOSE:               # half the memory traffic: single precision holds such a residual
            A = A.astype(np.float32)
            return _block_cg(A, (self.mass[:, None] * values).astype(np.float32), values.astype(np.float32), rtol)
        return _block_cg(A, self.mass[:, None] * values, values, rtol)

    def smoothed(self, values, t, rtol=RTOL):
        """``values`` (n, C) smoothed by one implicit step of the linear filter to time ``t``."""
        return values if t <= 0 else self.implicit_step(values, t, self.laplacian, rtol)

    def smoothed_gradients(self, values, sigma):
        """The faces' gradients (F, 3, C) of vertex ``values`` (n, C) smoothed to time ``sigma``, for the
        structure tensor and Perona-Malik's scale.  The values are taken less their area-weighted means (the
        same gradients), so that the loose solve (:data:`TENSOR_RTOL`) starts from and stops near the same
        values whatever a shift of the grey levels."""
        centred = values - (self.mass @ values) / self.mass.sum()
        return self.gradients(self.smoothed(centred, sigma, TENSOR_RTOL))

    def structure(self, values, sigma, rho):
        """The structure tensor (F, 3, 3) of vertex ``values`` (n, C): the faces' gradients of the values
        smoothed to time ``sigma``, their outer products summed over the channels, smoothed to time
        ``rho`` (its six components at the vertices, area-weighted from the faces); only its part in each face's
        plane counts (:func:`_eigen_in_plane` reads that)."""
        g = self.smoothed_gradients(values, sigma)
        J = np.einsum("fic,fjc->fij", g, g)
        if rho > 0:
            upper = np.triu_indices(3)
            spread = self._to_vertices(J[:, upper[0], upper[1]])
            smooth = self._to_faces(self.smoothed(spread, rho, TENSOR_RTOL))
            J = np.empty_like(J)
            J[:, upper[0], upper[1]] = smooth
            J[:, upper[1], upper[0]] = smooth
        return J

    def _to_vertices(self, face_values):
        """Face values (F, k) averaged at the vertices, weighted by the faces' areas."""
        corners = self.corners
        n = len(self.mass)
        weights = np.repeat(self.area, 3)
        sums = np.stack([np.bincount(corners.ravel(), weights=weights * np.repeat(face_values[:, k], 3), minlength=n)
                         for k in range(face_values.shape[1])], axis=1)
        return sums / np.maximum(np.bincount(corners.ravel(), weights=weights, minlength=n), TINY)[:, None]

    def _to_faces(self, vertex_values):
        """Vertex values (n, k) averaged over each face's corners (F, k)."""
        return vertex_values[self.corners].mean(axis=1)


def _block_cg(A, B, X, rtol=RTOL):
    """``A^-1 B`` (n, C) for a symmetric positive definite CSR ``A``: the columns' conjugate gradients, each
    with its own step lengths, preconditioned with ``A``'s diagonal, from ``X``, run side by side (one
    sparse product a step for all of them), each stopped at a relative residual of ``rtol``; a
    FloatingPointError if they do not get there in ten times as many steps as ``A`` has rows."""
    inverse = 1.0 / A.diagonal()[:, None]
    X = np.array(X, dtype=B.dtype)
    R = B - A @ X
    Z = inverse * R
    P = Z.copy()
    rz = np.einsum("ij,ij->j", R, Z)
    size = np.linalg.norm(B, axis=0)
    # a column a hundred million times smaller than the largest (a tensor component that is all but 0)
    # is solved as far as the largest's round-off allows; squared, as the residuals' norms are
    goal = (rtol * np.maximum(size, 1e-8 * size.max(initial=0.0) + TINY)) ** 2
    for _ in range(10 * len(B)):
        going = np.einsum("ij,ij->j", R, R) > goal
        if not going.any():
            return X
        AP = A @ P
        step = _ratio(rz, np.einsum("ij,ij->j", P, AP), going)
        X += step * P
        R -= step * AP
        Z = inverse * R
        new = np.einsum("ij,ij->j", R, Z)
        P = Z + _ratio(new, rz, going) * P
        rz = new
    raise FloatingPointError("the implicit step did not converge (conjugate gradients)")


def _ratio(a, b, where):
    """``a / b`` (C,) where ``where`` and ``b`` is not 0, else 0 (no floor: the products of a column
    whose values are all very small are very small too)."""
    ok = where & (b != 0)
    return np.where(ok, a / np.where(ok, b, 1.0), 0.0)


def _eigen_in_plane(ops, J):
    """The larger and smaller eigenvalues (F,) of symmetric face tensors (F, 3, 3) taken in their faces'
    planes (the 2 x 2 tensors in :attr:`MeshOperators.tangents`), and the unit eigenvector (F, 3) of the
    larger."""
    t1, t2 = ops.tangents[:, 0], ops.tangents[:, 1]
    a = np.einsum("fi,fij,fj->f", t1, J, t1)
    b = np.einsum("fi,fij,fj->f", t1, J, t2)
    c = np.einsum("fi,fij,fj->f", t2, J, t2)
    half = np.hypot(0.5 * (a - c), b)
    mean = 0.5 * (a + c)
    angle = 0.5 * np.arctan2(2.0 * b, a - c)             # the larger eigenvalue's direction in (t1, t2)
    return mean + half, mean - half, np.cos(angle)[:, None] * t1 + np.sin(angle)[:, None] * t2


def mesh_diffuse(vertices, faces, values, *, mode, T, tau=None, operators=None, progress=None, **params):
    """Filter vertex ``values`` (n,) or (n, C) of a triangle mesh by diffusion to time ``T`` (see the
    module's notes); returns the filtered values, same shape.  ``params``: the mode's filter parameters
    by name (``sigma``, ``rho``, ``lambda_rel``, ``alpha``, ``b_rel``; the rest of
    :data:`cp_stylize.parameters.DEFAULTS` is not used here); ``tau``: the time step (default
    :data:`STEP_EDGES` squared mean edge lengths, shortened to split ``T`` evenly); ``operators``: a
    :class:`MeshOperators` of the mesh, made before."""
    if mode not in MESH_MODES:
        raise ValueError(f"mode must be one of {MESH_MODES} on the mesh, got {mode!r}")
    T = float(T)
    if not np.isfinite(T) or T < 0:
        raise ValueError(f"T must be a non-negative number, got {T!r}")
    p = dict(DEFAULTS[mode])
    for name, value in params.items():
        if name not in p:
            raise TypeError(f"mode {mode!r} takes no parameter {name!r}; it takes {sorted(p)}")
        p[name] = float(value)
    ops = MeshOperators.of(vertices, faces) if operators is None else operators
    u = np.array(values, dtype=np.float64)
    flat = u.ndim == 1
    u = u[:, None] if flat else u
    if u.shape[0] != len(ops.mass):
        raise ValueError(f"values must have one row per vertex ({len(ops.mass)}), got {u.shape[0]}")
    if not np.all(np.isfinite(u)):
        raise ValueError("values hold NaN or infinite numbers")
    tau = STEP_EDGES * ops.edge**2 if tau is None else float(tau)
    steps = step_count(T, tau)
    dt = T / steps if steps else 0.0
    K = ops.stiffness() if mode == "gaussian" else None
    scale = None
    for step in range(steps):
        if mode == "perona_malik":
            if scale is None:
                smooth = ops.smoothed_gradients(u, p["sigma"])
                scale = float(np.sqrt(np.max(np.sum(smooth**2, axis=(1, 2)))))
            lam2 = max((p["lambda_rel"] * scale) ** 2, TINY)
            g = ops.gradients(u)
            K = ops.stiffness(1.0 / (1.0 + np.sum(g**2, axis=(1, 2)) / lam2))
        elif mode in ("eed", "ced"):
            mu1, mu2, w = _eigen_in_plane(ops, ops.structure(u, p["sigma"], p["rho"]))
            c = np.maximum(mu1 - mu2, 0.0)
            if scale is None:
                scale = max(float(c.max()), TINY)
            across, along = _diffusivities(mode, c, p, scale)
            K = ops.directed_stiffness(along, across, w)
        u = ops.implicit_step(u, dt, K)
        if progress is not None:
            progress((step + 1) / steps)
    return u[:, 0] if flat else u
