"""Surface-intrinsic diffusion filters with the closest point method (paper, sections 2-4).

:func:`diffuse` runs one of five filters on band values:

- ``"gaussian"``: the surface heat equation (linear blur);
- ``"perona_malik"``: ``u_t = div_S(g(|grad_S u|^2) grad_S u)``;
- ``"eed"``: Weickert's edge-enhancing diffusion (eqs. (7)-(8));
- ``"ced"``: Weickert's coherence-enhancing diffusion (eq. (9));
- ``"beltrami"``: the colour Beltrami flow in the decoupled form of seed 001, eq. (90).

Each step builds the diffusion tensor G from the current values (Algorithm 1),
takes an explicit step of ``div(G grad v)`` with the 19-point scheme (eq. (51))
and extends (eq. (50)): ``v <- E (v + tau A(G) v)``.  Two schemes take these
steps: ``"reference"``, Algorithm 1 as written, and ``"fast"`` (the default),
which makes G from grid Gaussians, rebuilds it only when the values have
changed, and runs the sparse products on all cores.
"""

from __future__ import annotations

import numpy as np

from .heat_flow import heat_rows, time_steps
from .parameters import DEFAULTS, MODES
from .smoothing import GaussianSmoother, GridGaussian, taper
from .sparse import SplitMatrix, map_parallel
from .stencils import TENSOR_COMPONENTS, DivergenceOperator, gershgorin_step, gradient_matrices
from .structure import eigen_2x2, outer_products, reduce_to_tangent, structure_tensor
from .tangent import tangent_basis

__all__ = ["diffuse", "MODES", "SCHEMES", "DEFAULTS", "PAPER_CFL"]

#: Time stepping schemes: see :func:`diffuse`.
SCHEMES = ("fast", "reference")

#: The paper's time step, tau = 0.15 h^2 (section 5).
PAPER_CFL = 0.15

#: The fast scheme rebuilds the diffusion tensor once the values have changed
#: by this root-mean-square fraction of their range since the last rebuild.
LAG = 0.02

_TINY = 1e-30

_COMPONENT = {pair: k for k, pair in enumerate(TENSOR_COMPONENTS)}


def diffuse(band, u0, *, mode, T, sigma=None, rho=None, alpha=None, b_rel=None, lambda_rel=None,
            tau=None, scheme="fast", lag=LAG, clamp=True, normals=None, progress=None):
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
    scheme : {"fast", "reference"}
        ``"reference"`` rebuilds G at every step exactly as Algorithm 1 says,
        with the structure tensor's smoothings done as closest point heat
        flows.  ``"fast"`` (the default) takes the same steps of the same
        scheme (51), with three changes (see Notes): the smoothings are
        Gaussians on the grid, G is rebuilt only when the values have changed
        (``lag``), and the sparse products run on all cores.
    lag : float
        Fast scheme: G is rebuilt before a step once the values have changed,
        since the last rebuild, by this root-mean-square fraction of their
        range at the points E reads; 0 rebuilds it at every step.
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

    The fast scheme smooths for the structure tensor with Gaussians of
    deviation ``sqrt(2 t)`` (the heat kernel at time ``t``): ``sigma`` on the
    band, by three sparse passes along the grid axes
    (:class:`~cp_stylize.smoothing.GaussianSmoother`); ``rho``, the wider one,
    on a box grid up to four times coarser
    (:class:`~cp_stylize.smoothing.GridGaussian`), which also extends the
    tensor off the surface without the six E products.  A 3-D Gaussian of a
    closest point extension is the surface Gaussian up to terms of relative
    size ``(sqrt(2 t) kappa)^2``.  Only the structure tensor is smoothed this
    way: on a sheet thinner than about three deviations, the tensor on one
    side also sees the edges of the other (the values are never mixed: the
    steps are the reference's), where the reference's heat solves mix the two
    sides only on sheets thinner than a few grid spacings.  Perona-Malik extends the gradient's
    squared length (one E product instead of six), Beltrami the two invariants
    it needs.  Each step's ``E (v + tau A v)`` is the reference's, with A
    assembled from the same weights.

    Scaling: on a surface scaled by ``s``, use ``h``, ``sqrt`` of every time
    (``T``, ``sigma``, ``rho``, ``tau``) scaled by ``s``, i.e. times times
    ``s^2``; the relative parameters (``alpha``, ``b_rel``, ``lambda_rel``)
    stay, and the result is the same function on the surface (section 4.5).
    """
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    params = dict(DEFAULTS[mode])
    for name, value in (("sigma", sigma), ("rho", rho), ("alpha", alpha), ("b_rel", b_rel),
                        ("lambda_rel", lambda_rel)):
        if value is not None:
            value = float(value)
            if not np.isfinite(value) or value < 0:
                raise ValueError(f"{name} must be a non-negative number, got {value!r}")
            params[name] = value
    lag = float(lag)
    if not np.isfinite(lag) or lag < 0:
        raise ValueError(f"lag must be a non-negative number, got {lag!r}")
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
    if n_steps and scheme == "reference":
        flow = _Flow(band, rows.dtype, mode, params, PAPER_CFL * h2, normals)
        flow.normalise(rows)
        E = band.extension_matrix(rows.dtype)
        for step in range(n_steps):
            report = None if progress is None else (lambda f, s=step: progress((s + 0.9 * f) / n_steps))
            A, extra = flow.operator(rows, report)
            _step(rows, A, extra, flow.laplacian, E, tau, DivergenceOperator.stable_step(A), clamp and (lo, hi))
            _check(rows, step, n_steps, progress)
    elif n_steps:
        flow = _FastFlow(band, rows.dtype, mode, params, normals)
        flow.normalise(rows)
        inner = band.inner
        span = np.maximum(hi - lo, np.finfo(rows.dtype).tiny)[:, 0]
        built_from = None
        for step in range(n_steps):
            if built_from is None or _rms_change(rows, built_from, inner, span) > lag:
                A, extra = flow.operator(rows)
                built_from = rows[:, inner].copy() if lag > 0 else None
            _step(rows, A, extra, flow.laplacian, flow.E, tau, flow.stable_step, clamp and (lo, hi))
            _check(rows, step, n_steps, progress)
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
            c, c1, s1 = _current_coherence(self, rows, progress)
            k1, k2 = _diffusivities(self.mode, c, p, self.scale)
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


def _step(rows, A, extra, laplacian, E, tau, stable_step, bounds):
    """One outer step ``v <- E (v + tau (A v + extra L v))`` in place, in equal parts where A needs them."""
    sub = max(1, int(np.ceil(tau / stable_step - 1e-9)))
    dt = rows.dtype.type(tau / sub)
    for _ in range(sub):
        for j in range(len(rows)):
            v = rows[j]
            change = A @ v
            if extra is not None:
                change += extra * (laplacian @ v)
            change *= dt
            change += v
            rows[j] = E @ change
        if bounds:
            np.clip(rows, *bounds, out=rows)


def _check(rows, step, n_steps, progress):
    if not np.all(np.isfinite(rows)):
        raise FloatingPointError(f"diffusion produced non-finite values at step {step + 1}")
    if progress is not None:
        progress((step + 1) / n_steps)


def _rms_change(rows, before, inner, span):
    """Largest root-mean-square change over the channels at the inner points, relative to each range."""
    return max(float(np.sqrt(np.mean((rows[j][inner] - before[j]) ** 2))) / float(span[j])
               for j in range(len(rows)))


def _current_coherence(flow, rows, *args):
    """``(c, c1, s1)``: for the first step the initial data's (computed by ``normalise``), then fresh."""
    if flow._initial is not None:
        found, flow._initial = flow._initial, None
        return found
    return flow._coherence(rows, *args)


def _diffusivities(mode, c, p, scale):
    """EED's or CED's ``(kappa1, kappa2)`` from the coherence ``c`` and ``scale = ||c0||_inf``."""
    with np.errstate(over="ignore"):
        if mode == "eed":
            lam = max(p["lambda_rel"] * scale, _TINY)
            return 1.0 / (1.0 + (c / lam) ** 2), np.ones_like(c)
        B = p["b_rel"] * scale
        safe = np.where(c > 0, c, 1.0)
        k2 = p["alpha"] + (1.0 - p["alpha"]) * np.where(c > 0, np.exp(-((B / safe) ** 2)), 0.0)
        return np.full_like(c, p["alpha"]), k2


def _isotropic(g):
    zeros = np.zeros_like(g)
    return np.stack([g, g, g, zeros, zeros, zeros])


def _projector(Q):
    """Tangent projectors ``Q Q^T`` as rows (6, N)."""
    return np.stack([np.einsum("ni,ni->n", Q[:, a, :], Q[:, b, :]) for a, b in TENSOR_COMPONENTS])


class _FastFlow:
    """The step operator of the fast scheme (see :func:`diffuse`)."""

    def __init__(self, band, dtype, mode, params, normals):
        self.band, self.dtype, self.mode, self.params = band, np.dtype(dtype), mode, params
        self.normals = normals
        self.E = band.split_matrix("E", dtype)
        self.laplacian = band.split_matrix("L", dtype) if mode in ("gaussian", "beltrami") else None
        self.scale = 0.0
        self.stable_step = np.inf
        self._initial = None
        if mode == "gaussian":
            self.stable_step = DivergenceOperator.stable_step(band.laplacian_matrix(dtype))
            return
        # the parts are independent: build them side by side on the worker threads
        parts = [self._build_presmooth, self._build_divergence]
        if mode in ("eed", "ced"):
            parts += [self._build_postsmooth, self._build_tangents]
        map_parallel(lambda build: build(), parts)

    def _build_divergence(self):
        self.divergence = DivergenceOperator(self.band, self.dtype)
        self._A = self.divergence.template()
        self.A = SplitMatrix(self._A)
        # gradients wherever the band has the points: around the surface and at every point E reads
        self.gradients = [SplitMatrix(D) for D in gradient_matrices(self.band, self.dtype, rows="all")]

    def _build_presmooth(self):
        sigma, band = self.params["sigma"], self.band
        self.presmooth = None
        if sigma > 0:
            self.presmooth = GaussianSmoother(band, sigma, weights=taper(band.dist, band.width), dtype=self.dtype)

    def _build_tangents(self):
        Q = tangent_basis(self.band, self.normals)
        self.Q = np.ascontiguousarray(Q.transpose(2, 1, 0), dtype=self.dtype)  # (2, 3, N): q0, q1 by axis

    def _build_postsmooth(self):
        # the tensor from a shell of three spacings about the surface; a rho narrower than a
        # grid spacing would not reach the band's rim, and E extends the raw tensor instead
        rho, band = self.params["rho"], self.band
        self.postsmooth = None
        if np.sqrt(2.0 * rho) >= band.h:
            self.postsmooth = GridGaussian(band, rho, weights=taper(band.dist, 3.0 * band.h), dtype=self.dtype)

    def _smoothed(self, rows):
        return rows if self.presmooth is None else self.presmooth(rows)

    def _products(self, rows):
        """Mean over channels of ``grad v grad v^T`` (6, N) where the gradients have rows; zero elsewhere."""
        J = np.zeros((6, self.band.size), dtype=self.dtype)
        for v in rows:
            g = [D @ v for D in self.gradients]
            for k, (a, b) in enumerate(TENSOR_COMPONENTS):
                J[k] += g[a] * g[b]
        J /= len(rows)
        return J

    def _coherence(self, rows):
        J = self._products(self._smoothed(rows))
        if self.postsmooth is not None:
            J = self.postsmooth(J)
        else:
            J = np.stack([self.E @ j for j in J])
        # the tangent tensor Q^T J Q (eq. (25)) from J's six rows
        full = [[J[_COMPONENT[min(a, b), max(a, b)]] for b in range(3)] for a in range(3)]
        q0, q1 = self.Q
        Jq0 = [full[a][0] * q0[0] + full[a][1] * q0[1] + full[a][2] * q0[2] for a in range(3)]
        Jq1 = [full[a][0] * q1[0] + full[a][1] * q1[1] + full[a][2] * q1[2] for a in range(3)]
        a = q0[0] * Jq0[0] + q0[1] * Jq0[1] + q0[2] * Jq0[2]
        b = q1[0] * Jq0[0] + q1[1] * Jq0[1] + q1[2] * Jq0[2]
        d = q1[0] * Jq1[0] + q1[1] * Jq1[1] + q1[2] * Jq1[2]
        mu1, mu2, c1, s1 = eigen_2x2(a, b, d)
        return np.maximum(mu1 - mu2, 0), c1, s1

    def _invariants(self, rows):
        """Extended trace and (for Beltrami) second invariant of the structure tensor."""
        J = self._products(rows)
        out = [J[0] + J[1] + J[2]]
        if self.mode == "beltrami":
            out.append(J[0] * J[1] + J[0] * J[2] + J[1] * J[2] - J[3] ** 2 - J[4] ** 2 - J[5] ** 2)
        return [np.maximum(self.E @ x, 0) for x in out]

    def normalise(self, rows):
        """Scale-free parameters from the initial data (section 4.5)."""
        if self.mode in ("eed", "ced"):
            self._initial = self._coherence(rows)
            self.scale = float(self._initial[0].max())
        elif self.mode in ("perona_malik", "beltrami"):
            self.scale = float(np.sqrt(float(self._invariants(self._smoothed(rows))[0].max())))

    def _fill(self, G):
        """Set A's weights from the tensor field G (6, N) and its stable step."""
        self.divergence.fill(G, self._A.data)
        self.stable_step = gershgorin_step(np.abs(self._A.data).reshape(-1, 19).sum(axis=1))
        return self.A

    def operator(self, rows):
        """``(A, extra)`` as in the reference flow, A split over the cores."""
        if self.mode == "gaussian":
            return self.laplacian, None
        p = self.params
        if self.mode in ("eed", "ced"):
            c, c1, s1 = _current_coherence(self, rows)
            k1, k2 = _diffusivities(self.mode, c, p, self.scale)
            q0, q1 = self.Q
            w = q0 * c1 + q1 * s1
            G = np.empty((6, self.band.size), dtype=self.dtype)
            for k, (a, b) in enumerate(TENSOR_COMPONENTS):
                # k2 Q Q^T + (k1 - k2) w w^T: the tangent projector Q Q^T = q0 q0^T + q1 q1^T
                np.multiply(q0[a], q0[b], out=G[k])
                G[k] += q1[a] * q1[b]
                G[k] *= k2
                G[k] += (k1 - k2) * w[a] * w[b]
            return self._fill(G), None
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, _TINY)
        if self.mode == "perona_malik":
            (trace,) = self._invariants(rows)
            g = (1.0 / (1.0 + trace / lam2)).astype(self.dtype)
            return self._fill(_isotropic(g)), None
        trace, second = self._invariants(self._smoothed(rows))
        inv = (0.5 / (1.0 + trace / lam2 + second / lam2 / lam2)).astype(self.dtype)
        return self._fill(_isotropic(inv)), inv
