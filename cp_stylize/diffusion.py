"""Surface-intrinsic diffusion filters with the closest point method (paper, sections 2-4).

:func:`diffuse` runs one of five filters on band values:

- ``"gaussian"``: the surface heat equation (linear blur);
- ``"perona_malik"``: ``u_t = div_S(g(|grad_S u|^2) grad_S u)``;
- ``"eed"``: Weickert's edge-enhancing diffusion (eqs. (7)-(8));
- ``"ced"``: Weickert's coherence-enhancing diffusion (eq. (9));
- ``"beltrami"``: the colour Beltrami flow in the decoupled form of seed 001, eq. (90).

Each step builds the diffusion tensor G from the current values (Algorithm 1),
takes an explicit step of ``div(G grad v)`` with the 19-point scheme (eq. (51))
and extends (eq. (50)): ``v <- E (v + tau A(G) v)``.
"""

from __future__ import annotations

import numpy as np

from .heat import heat_rows, time_steps
from .stencils import TENSOR_COMPONENTS, DivergenceOperator, gradient_matrices
from .structure import eigen_2x2, outer_products, reduce_to_tangent, structure_tensor
from .tangent import tangent_basis

__all__ = ["diffuse", "MODES", "DEFAULTS", "PAPER_CFL"]

MODES = ("gaussian", "perona_malik", "eed", "ced", "beltrami")

#: Default parameters by mode (surface units; times in length^2).  EED and
#: Perona-Malik follow the paper's Fig. 4, CED its eq. (55).
DEFAULTS = {
    "gaussian": {},
    "perona_malik": {"sigma": 1.2e-4, "lambda_rel": 1.0 / 13.0},
    "eed": {"sigma": 1.2e-4, "rho": 3.5e-4, "lambda_rel": 1e-3},
    "ced": {"sigma": 1e-4, "rho": 4e-4, "alpha": 1e-3, "b_rel": 1e-3},
    "beltrami": {"sigma": 0.0, "lambda_rel": 0.1},
}

#: The paper's time step, tau = 0.15 h^2 (section 5).
PAPER_CFL = 0.15

_TINY = 1e-30


def diffuse(band, u0, *, mode, T, sigma=None, rho=None, alpha=None, b_rel=None, lambda_rel=None,
            tau=None, scheme="reference", clamp=True, normals=None, progress=None):
    """Filter band values by surface-intrinsic diffusion to time ``T``.

    Parameters
    ----------
    band : Band
        The computational band.  Every mode but ``"gaussian"`` needs a band
        built with ``stencil="anisotropic"`` (the 19-point stencil of eq. (51)).
    u0 : ndarray, shape (N,) or (N, C)
        Grey or colour values at the band points, as a closest point extension
        (e.g. a texture sampled at ``band.cp``).  float64 stays float64;
        anything else is computed in float32.
    mode : {"gaussian", "perona_malik", "eed", "ced", "beltrami"}
        The filter.
    T : float
        Stop time, in squared surface units.
    sigma : float, optional
        Pre-smoothing time of the structure tensor (Algorithm 1, step 2).  For
        Perona-Malik and Beltrami it sets the smoothing of the data whose
        largest gradient normalises ``lambda``.
    rho : float, optional
        Post-smoothing time of the structure tensor (step 4); EED and CED.
    alpha : float, optional
        CED's smallest diffusivity, eq. (9).
    b_rel : float, optional
        CED's ``B = b_rel * ||c0||_inf``, eq. (53), with ``c0`` the coherence of ``u0``.
    lambda_rel : float, optional
        Edge sensitivity.  EED: ``lambda = lambda_rel * ||c0||_inf`` (eq. (53));
        Perona-Malik and Beltrami: ``lambda = lambda_rel * ||grad u0_sigma||_inf``.
    tau : float, optional
        Time step; default the paper's ``0.15 h^2``.  A step that the current
        diffusion tensor makes unstable (Gershgorin bound) is split into
        smaller equal steps.
    scheme : {"reference"}
        ``"reference"`` rebuilds G at every step exactly as Algorithm 1 says.
    clamp : bool
        Clip each channel to its initial range after every step (tricubic
        interpolation overshoots, and unclamped overshoot drifts the image).
    normals : None, "jacobian" or ndarray (N, 3)
        Normals for the tangent basis (see :func:`cp_stylize.tangent.surface_normals`):
        by default the surface's own (analytic for Sphere and Torus), else the
        Jacobian of the closest point function (eqs. (32)-(33)).
    progress : callable, optional
        ``progress(fraction)`` as the run advances; an exception it raises
        stops the run and propagates (the input is never modified).

    Returns
    -------
    ndarray
        Filtered values, same shape as ``u0``.

    Notes
    -----
    EED and CED build ``G = Q G~ Q^T`` with ``G~ = kappa1 w w^T + kappa2 w_perp w_perp^T``
    from the eigenvectors of the tangent structure tensor ``J~ = Q^T J Q``
    (eqs. (25)-(29)).  With the coherence ``c = mu1 - mu2``:

    - EED: ``kappa1 = 1 / (1 + (c / lambda)^2)``, ``kappa2 = 1``: the Perona-Malik
      function of eq. (8) with ``c`` in the role of ``s``, so that the diffusivity
      depends only on ``c / ||c0||_inf`` as section 4.5's scaling requires; G = I
      where ``c = 0``.
    - CED: ``kappa1 = alpha``, ``kappa2 = alpha + (1 - alpha) exp(-B^2 / c^2)`` (eq. (9)).

    Perona-Malik uses ``G = g I`` with ``g`` from central differences at the
    grid nodes, averaged to the cell faces (the consistent Morton-Mayers form,
    thesis 002, section 3.3), not the face-gradient form.  Beltrami uses the
    decoupled colour Beltrami flow of seed 001, eq. (90),

    .. math:: u_t = \\tfrac12 \\operatorname{div}(\\nabla u / g) + \\tfrac12 \\Delta u / g,
              \\quad g = \\det(I + J~ / \\lambda^2) = 1 + \\operatorname{tr} J~ / \\lambda^2
              + \\det J~ / \\lambda^4,

    with ``J~`` the channel-mean tangent structure tensor of ``u_sigma``.  It is
    not a conservation law.

    Scaling: on a surface scaled by ``s``, use ``h``, ``sqrt`` of every time
    (``T``, ``sigma``, ``rho``, ``tau``) scaled by ``s``, i.e. times times
    ``s^2``; the relative parameters (``alpha``, ``b_rel``, ``lambda_rel``)
    stay, and the result is the same function on the surface (section 4.5).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if scheme != "reference":
        raise ValueError(f"scheme must be 'reference', got {scheme!r}")
    params = dict(DEFAULTS[mode])
    for name, value in (("sigma", sigma), ("rho", rho), ("alpha", alpha), ("b_rel", b_rel),
                        ("lambda_rel", lambda_rel)):
        if value is not None:
            value = float(value)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
            params[name] = value
    if mode == "ced" and not params["alpha"] <= 1:
        raise ValueError(f"alpha must lie in [0, 1], got {params['alpha']!r}")
    u0 = band._check_values(u0)
    if not np.all(np.isfinite(u0)):
        raise ValueError("u0 holds NaN or infinite values")
    h2 = band.h**2
    tau = PAPER_CFL * h2 if tau is None else float(tau)
    n_steps, tau = time_steps(T, tau)
    rows = np.array(u0.T if u0.ndim == 2 else u0[None, :], order="C")
    lo, hi = rows.min(axis=1, keepdims=True), rows.max(axis=1, keepdims=True)
    if n_steps:
        flow = _Flow(band, rows.dtype, mode, params, PAPER_CFL * h2, normals)
        flow.normalise(rows)
        E = band.extension_matrix(rows.dtype)
        for step in range(n_steps):
            report = None if progress is None else (lambda f, s=step: progress((s + 0.9 * f) / n_steps))
            A, extra = flow.operator(rows, report)
            sub = max(1, int(np.ceil(tau / DivergenceOperator.stable_step(A) - 1e-9)))
            dt = rows.dtype.type(tau / sub)
            for _ in range(sub):
                for j in range(len(rows)):
                    v = rows[j]
                    change = A @ v
                    if extra is not None:
                        change += extra * (flow.laplacian @ v)
                    rows[j] = E @ (v + dt * change)
                if clamp:
                    np.clip(rows, lo, hi, out=rows)
            if not np.all(np.isfinite(rows)):
                raise FloatingPointError(f"diffusion produced non-finite values at step {step + 1}")
            if progress is not None:
                progress((step + 1) / n_steps)
    return rows.T.copy() if u0.ndim == 2 else rows[0].copy()


class _Flow:
    """Builds the step operator of one mode from the current values."""

    def __init__(self, band, dtype, mode, params, smoothing_dt, normals):
        self.band, self.dtype, self.mode, self.params = band, dtype, mode, params
        self.smoothing_dt = smoothing_dt
        self.laplacian = band.laplacian_matrix(dtype)
        self.scale = 0.0
        self._initial = None
        if mode == "gaussian":
            return
        self.divergence = DivergenceOperator(band, dtype)
        self.gradients = gradient_matrices(band, dtype)
        if mode in ("eed", "ced"):
            self.Q = tangent_basis(band, normals)
            self.P = _projector(self.Q)

    def normalise(self, rows):
        """Scale-free parameters from the initial data (section 4.5)."""
        p = self.params
        if self.mode in ("eed", "ced"):
            self._initial = self._coherence(rows)  # the first step reuses it
            self.scale = float(self._initial[0].max())
        elif self.mode in ("perona_malik", "beltrami"):
            smoothed = rows.copy()
            heat_rows(self.band, smoothed, p["sigma"], dt=self.smoothing_dt)
            J = outer_products(self.band, smoothed, self.gradients)
            self.scale = float(np.sqrt(max(float((J[0] + J[1] + J[2]).max()), 0.0)))

    def _coherence(self, rows, progress=None):
        p = self.params
        J = structure_tensor(self.band, rows, p["sigma"], p["rho"], self.gradients,
                             dt=self.smoothing_dt, progress=progress)
        a, b, d = reduce_to_tangent(J.astype(np.float64), self.Q)
        mu1, mu2, c1, s1 = eigen_2x2(a, b, d)
        return np.maximum(mu1 - mu2, 0.0), c1, s1

    def operator(self, rows, progress=None):
        """``(A, extra)``: the step is ``v + dt (A v + extra * L v)`` (extra None but for Beltrami)."""
        if self.mode == "gaussian":
            if progress is not None:
                progress(1.0)
            return self.laplacian, None
        p = self.params
        if self.mode in ("eed", "ced"):
            if self._initial is not None:
                (c, c1, s1), self._initial = self._initial, None
            else:
                c, c1, s1 = self._coherence(rows, progress)
            if self.mode == "eed":
                lam = max(p["lambda_rel"] * self.scale, _TINY)
                k1, k2 = 1.0 / (1.0 + (c / lam) ** 2), np.ones_like(c)
            else:
                B = p["b_rel"] * self.scale
                safe = np.where(c > 0, c, 1.0)
                k2 = p["alpha"] + (1.0 - p["alpha"]) * np.where(c > 0, np.exp(-((B / safe) ** 2)), 0.0)
                k1 = np.full_like(c, p["alpha"])
            w = self.Q[:, :, 0] * c1[:, None] + self.Q[:, :, 1] * s1[:, None]
            G = np.stack([k2 * self.P[k] + (k1 - k2) * w[:, a] * w[:, b]
                          for k, (a, b) in enumerate(TENSOR_COMPONENTS)])
            return self.divergence.matrix(G), None
        # Perona-Malik and Beltrami: scalar edge stopping from the current gradient
        source = rows
        if p["sigma"] > 0 and self.mode == "beltrami":
            source = rows.copy()
            heat_rows(self.band, source, p["sigma"], dt=self.smoothing_dt)
        J = outer_products(self.band, source, self.gradients).astype(np.float64)
        if progress is not None:
            progress(1.0)
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, _TINY)
        trace = np.maximum(J[0] + J[1] + J[2], 0.0)
        if self.mode == "perona_malik":
            g = 1.0 / (1.0 + trace / lam2)
            return self.divergence.matrix(_isotropic(g)), None
        # det of the tangent tensor: J is tangent (rank <= 2), so det J~ is its second invariant
        second = (J[0] * J[1] + J[0] * J[2] + J[1] * J[2] - J[3] ** 2 - J[4] ** 2 - J[5] ** 2)
        metric = 1.0 + trace / lam2 + np.maximum(second, 0.0) / lam2**2
        inv = 0.5 / metric
        return self.divergence.matrix(_isotropic(inv)), inv.astype(self.dtype)


def _isotropic(g):
    zeros = np.zeros_like(g)
    return np.stack([g, g, g, zeros, zeros, zeros])


def _projector(Q):
    """Tangent projectors ``Q Q^T`` as rows (6, N)."""
    return np.stack([np.einsum("ni,ni->n", Q[:, a, :], Q[:, b, :]) for a, b in TENSOR_COMPONENTS])
