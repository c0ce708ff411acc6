"""The surface-intrinsic structure tensor (paper, sections 2.2, 2.5 and 3.1, Algorithm 1 steps 2-6).

``J_{sigma,rho}[u] = K_rho * (grad_S u_sigma grad_S u_sigma^T)``, with both
smoothings done as surface heat solves (to times ``sigma`` and ``rho``), the
mean over colour channels (eq. (11)), and its reduction to the tangent plane
``J~ = Q^T J Q`` (eq. (25)), whose eigen-decomposition (eq. (26)) is taken in
closed form.

Tensor fields are stored as rows (6, N) in the order of
:data:`~cp_stylize.stencils.TENSOR_COMPONENTS`.

The diffusions (:func:`cp_stylize.diffuse`) take the tensor's smoothings from
:class:`HeatSmoothing` (Algorithm 1 as written: heat flows) or
:class:`GridSmoothing` (Gaussians on the grid, the fast scheme);
:func:`grid_gradients` gives the gradients at every band point whose
neighbours are in the band, kept with the band for re-runs.
"""

from __future__ import annotations

import numpy as np

from .heat_flow import PAPER_CFL, heat_rows
from .smoothing import GaussianSmoother, GridGaussian, taper
from .sparse import SplitMatrix
from .stencils import TENSOR_COMPONENTS, gradient_matrices

__all__ = ["products", "outer_products", "invariants", "structure_tensor", "reduce_to_tangent", "eigen_2x2", "along_structure",
           "grid_gradients", "HeatSmoothing", "GridSmoothing"]


def products(channels, gradients):
    """Mean over channels of ``grad v grad v^T`` (6, N) where the gradients have rows; zero elsewhere.

    ``channels`` are band values as rows (C, N); ``gradients`` the three
    central difference matrices (see :func:`~cp_stylize.stencils.gradient_matrices`).
    """
    J = np.zeros((6, channels.shape[1]), dtype=channels.dtype)
    for v in channels:
        g = [D @ v for D in gradients]
        for k, (a, b) in enumerate(TENSOR_COMPONENTS):
            J[k] += g[a] * g[b]
    J /= len(channels)
    return J


def invariants(J):
    """Trace and second invariant (the sum of the principal 2x2 minors) of a tensor field J (6, N).

    For a tangent tensor (rank at most 2), the second invariant is the
    determinant of its 2x2 tangent form ``J~``.
    """
    return J[0] + J[1] + J[2], J[0] * J[1] + J[0] * J[2] + J[1] * J[2] - J[3] ** 2 - J[4] ** 2 - J[5] ** 2


def outer_products(band, channels, gradients):
    """Mean over channels of ``grad v grad v^T`` at inner points, extended to the band: (6, N).

    The raw products (:func:`products`) live on the inner points; the
    extension E makes them a closest point extension over the whole band.
    """
    J0 = products(channels, gradients)
    E = band.extension_matrix(channels.dtype)
    for k in range(6):
        J0[k] = E @ J0[k]
    return J0


def structure_tensor(band, channels, sigma, rho, gradients, *, dt, progress=None):
    """``J_{sigma,rho}`` (6, N) of band values given as rows (C, N) (Algorithm 1, steps 2-4)."""
    smoothed = channels.copy()
    report = None if progress is None else (lambda f: progress(0.2 * f))
    heat_rows(band, smoothed, sigma, tau=dt, progress=report)
    J = outer_products(band, smoothed, gradients)
    report = None if progress is None else (lambda f: progress(0.2 + 0.8 * f))
    heat_rows(band, J, rho, tau=dt, progress=report)
    return J


def reduce_to_tangent(J, q0, q1):
    """``J~ = Q^T J Q`` (eq. (25)): returns its entries ``(a, b, d)`` of ``[[a, b], [b, d]]``.

    ``J`` is the tensor field as rows (6, N); ``q0``, ``q1`` (3, N) are the two
    tangent vectors of ``Q = [q0 q1]`` by axis (``tangent_basis(band).transpose(2, 1, 0)``).
    Computed in their precision, with ``b = q0 . (J q1)``.
    """
    component = {pair: k for k, pair in enumerate(TENSOR_COMPONENTS)}
    full = [[J[component[min(i, j), max(i, j)]] for j in range(3)] for i in range(3)]
    Jq0 = [full[i][0] * q0[0] + full[i][1] * q0[1] + full[i][2] * q0[2] for i in range(3)]
    Jq1 = [full[i][0] * q1[0] + full[i][1] * q1[1] + full[i][2] * q1[2] for i in range(3)]
    a = q0[0] * Jq0[0] + q0[1] * Jq0[1] + q0[2] * Jq0[2]
    b = q0[0] * Jq1[0] + q0[1] * Jq1[1] + q0[2] * Jq1[2]
    d = q1[0] * Jq1[0] + q1[1] * Jq1[1] + q1[2] * Jq1[2]
    return a, b, d


def eigen_2x2(a, b, d):
    """Closed-form eigen-decomposition of symmetric ``[[a, b], [b, d]]`` (eq. (26)).

    Returns ``mu1 >= mu2`` and the unit eigenvector ``(c1, s1)`` of ``mu1``
    (across the visual edge).  Where ``mu1 == mu2`` any unit vector is an
    eigenvector and ``(1, 0)`` is returned; no NaN arises.
    """
    half_trace = 0.5 * (a + d)
    radius = np.hypot(0.5 * (a - d), b)
    mu1, mu2 = half_trace + radius, half_trace - radius
    # (mu1 - d, b) and (b, mu1 - a) are both eigenvectors; take the longer one
    x1, y1 = mu1 - d, b
    x2, y2 = b, mu1 - a
    first = x1 * x1 + y1 * y1 >= x2 * x2 + y2 * y2
    x, y = np.where(first, x1, x2), np.where(first, y1, y2)
    norm = np.hypot(x, y)
    degenerate = norm <= 1e-30
    safe = np.where(degenerate, 1.0, norm)
    c1 = np.where(degenerate, 1.0, x / safe)
    s1 = np.where(degenerate, 0.0, y / safe)
    return mu1, mu2, c1, s1


def along_structure(J, q0, q1):
    """Of tangent structure tensors: the unit direction along the structure (N, 3; the eigenvector of the
    smaller eigenvalue, along the visual edge), the larger eigenvalue ``mu1`` (N,) and the coherence
    ``(mu1 - mu2) / (mu1 + mu2)`` (N,).  ``J``, ``q0``, ``q1`` as for :func:`reduce_to_tangent`."""
    mu1, mu2, c, s = eigen_2x2(*reduce_to_tangent(J, q0, q1))
    return np.ascontiguousarray((q1 * c - q0 * s).T), mu1, (mu1 - mu2) / np.maximum(mu1 + mu2, 1e-12)


def grid_gradients(band, dtype=np.float32):
    """The central gradient matrices (3, as :class:`~cp_stylize.sparse.SplitMatrix`) in ``dtype`` wherever
    the band has the points: around the surface and at every point E reads; kept with the band for
    re-runs (:meth:`cp_stylize.band.Band.structure`)."""
    dtype = np.dtype(dtype)
    return band.structure("gradients", dtype.str,
                          lambda: [SplitMatrix(D) for D in gradient_matrices(band, dtype, rows="all")])


class HeatSmoothing:
    """The structure tensor as Algorithm 1 writes it (``scheme="reference"``).

    The smoothings to times ``sigma`` and ``rho`` are closest point heat flows
    (steps of ``0.15 h^2``), the products ``grad v grad v^T`` are extended
    component by component, and G is computed in float64.
    """

    def __init__(self, band, dtype, params):
        self.band, self.params, self.dtype = band, params, dtype
        self.work = np.dtype(np.float64)
        self.dt = PAPER_CFL * band.h**2

    def builds(self):
        """What to build before the first step (the flow builds them side by side)."""
        return [self._build_gradients]

    def _build_gradients(self):
        self.gradients = gradient_matrices(self.band, self.dtype)

    def presmoothed(self, rows):
        """``u_sigma``: a heat flow to ``sigma`` of a copy of ``rows`` (C, N)."""
        if self.params["sigma"] == 0:
            return rows
        smoothed = rows.copy()
        heat_rows(self.band, smoothed, self.params["sigma"], tau=self.dt)
        return smoothed

    def tensor(self, rows, progress=None):
        """``J_{sigma,rho}`` (6, N) of band values ``rows`` (C, N), extended over the band."""
        p = self.params
        return structure_tensor(self.band, rows, p["sigma"], p["rho"], self.gradients, dt=self.dt, progress=progress)

    def gradient_scale(self, rows):
        """``||grad u_sigma||_inf``, the scale of lambda for Perona-Malik and Beltrami (section 4.5)."""
        J = outer_products(self.band, self.presmoothed(rows), self.gradients)
        return float(np.sqrt(max(float(invariants(J)[0].max()), 0.0)))

    def invariants(self, rows, second):
        """Trace (and, if ``second``, second invariant) of ``grad v grad v^T`` of ``rows`` (C, N), in float64."""
        trace, det = invariants(outer_products(self.band, rows, self.gradients).astype(np.float64))
        return np.maximum(trace, 0.0), (np.maximum(det, 0.0) if second else None)


class GridSmoothing:
    """The structure tensor from Gaussians on the grid (``scheme="fast"``), in the values' precision.

    ``sigma``: a Gaussian of deviation ``sqrt(2 sigma)`` on the band, by three
    sparse passes (:class:`~cp_stylize.smoothing.GaussianSmoother`); ``rho``: on
    a box grid up to four times coarser (:class:`~cp_stylize.smoothing.GridGaussian`),
    which also extends the tensor off the surface.  Gradients have rows at every
    point whose neighbours are in the band; Perona-Malik and Beltrami extend
    their invariants (one or two E products instead of six).
    """

    def __init__(self, band, dtype, params):
        self.band, self.params, self.dtype = band, params, np.dtype(dtype)
        self.work = self.dtype
        self.E = band.split_matrix("E", dtype)

    def builds(self):
        return [self._build_presmooth, self._build_gradients] + [self._build_postsmooth] * ("rho" in self.params)

    def _build_gradients(self):
        self.gradients = grid_gradients(self.band, self.dtype)

    def _build_presmooth(self):
        sigma, band = self.params.get("sigma", 0.0), self.band
        self._presmooth = None
        if sigma > 0:
            self._presmooth = band.structure(
                "presmooth", (sigma, self.dtype.str),
                lambda: GaussianSmoother(band, sigma, weights=taper(band.dist, band.width), dtype=self.dtype))

    def _build_postsmooth(self):
        # the tensor from a shell of three spacings about the surface; a rho narrower than a
        # grid spacing would not reach the band's rim, and E extends the raw tensor instead
        rho, band = self.params["rho"], self.band
        self._postsmooth = None
        if np.sqrt(2.0 * rho) >= band.h:
            self._postsmooth = band.structure(
                "postsmooth", (rho, self.dtype.str),
                lambda: GridGaussian(band, rho, weights=taper(band.dist, 3.0 * band.h), dtype=self.dtype))

    def presmoothed(self, rows):
        return rows if self._presmooth is None else self._presmooth(rows)

    def tensor(self, rows, progress=None):
        J = products(self.presmoothed(rows), self.gradients)
        if self._postsmooth is not None:
            return self._postsmooth(J)
        return np.stack([self.E @ j for j in J])

    def invariants(self, rows, second):
        trace, det = invariants(products(rows, self.gradients))
        return np.maximum(self.E @ trace, 0), (np.maximum(self.E @ det, 0) if second else None)

    def gradient_scale(self, rows):
        return float(np.sqrt(float(self.invariants(self.presmoothed(rows), False)[0].max())))
