"""Surface-intrinsic diffusion filters with the closest point method (paper, sections 2-4).

:func:`diffuse` runs one of six filters on band values:

- ``"gaussian"``: the surface heat equation (linear blur);
- ``"perona_malik"``: ``u_t = div_S(g(|grad_S u|^2) grad_S u)``;
- ``"eed"``: Weickert's edge-enhancing diffusion (eqs. (7)-(8));
- ``"ced"``: Weickert's coherence-enhancing diffusion (eq. (9));
- ``"beltrami"``: the colour Beltrami flow in the decoupled form of Malladi and Ravve's eq. (90);
- ``"flow"``: Diewald and Rumpf's flow texture along a direction field, with its contrast term.

Each step builds the diffusion tensor G from the current values (Algorithm 1),
takes an explicit step of ``div(G grad v)`` with the 19-point scheme (eq. (51))
and extends (eq. (50)): ``v <- E (v + tau A(G) v)``.  One engine (:class:`_StepOperators`)
takes these steps for both schemes; they differ only in how the structure
tensor's smoothings are done (:class:`~cp_stylize.structure.HeatSmoothing`, Algorithm 1 as written,
for ``"reference"``; :class:`~cp_stylize.structure.GridSmoothing`, grid Gaussians, for ``"fast"``, the
default) and in ``lag`` (the fast scheme rebuilds G only when the values have
changed; the reference at every step).  The sparse products run on all cores.

References
----------
- E. Naden, T. März and C. B. Macdonald, "Anisotropic diffusion filtering of
  images on curved surfaces", 2014 ("the paper": its sections and equations).
- R. Malladi and I. Ravve, "Fast difference scheme for anisotropic Beltrami
  smoothing and edge contrast enhancement of gray level and color images",
  2001 (the Beltrami flow).
- H. Biddle, "Nonlinear diffusion filtering on surfaces", MSc dissertation,
  University of Oxford, 2011 (Perona-Malik with the closest point method).
- U. Diewald and M. Rumpf, "Visualization of principal curvature directions
  by anisotropic diffusion", 2000 (the flow texture).
- C. Wu, J. Deng, F. Chen and X. Tai, "Scale-space analysis of discrete
  filtering over arbitrary triangulated surfaces", 2009 (the scale-space
  properties the tests check).
"""

from __future__ import annotations

import numpy as np

from .heat_flow import PAPER_CFL, heat, time_steps
from .parameters import DEFAULTS, DIRECTED_MODES, FILTER_PARAMETERS, MODES
from .sparse import SplitMatrix, map_parallel
from .stencils import TENSOR_COMPONENTS, DivergenceOperator, gershgorin_step
from .structure import GridSmoothing, HeatSmoothing, eigen_2x2, reduce_to_tangent
from .arrays import unit_rows
from .cache import digest
from .tangent import surface_normals, tangent_basis

__all__ = ["diffuse", "flow_noise", "MODES", "SCHEMES", "DEFAULTS", "PAPER_CFL"]

#: Time stepping schemes: see :func:`diffuse`.
SCHEMES = ("fast", "reference")

#: The fast scheme rebuilds the diffusion tensor once the values have changed
#: by this root-mean-square fraction of their range since the last rebuild.
LAG = 0.02

_TINY = 1e-30


def diffuse(band, u0, *, mode, T, tau=None, scheme="fast", lag=LAG, clamp=True, normals=None, field=None,
            progress=None, **params):
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
    mode : {"gaussian", "perona_malik", "eed", "ced", "beltrami", "flow"}
        The filter.
    T : float
        Stop time, in squared surface units.
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
    field : ndarray (N, 3), optional
        The direction field the strokes follow at the band's closest points
        (a line field: ``e`` and ``-e`` are the same), such as
        ``principal_curvatures(band).e2``.  Its tangential part is used; its
        length, clipped to [0, 1], is the confidence ``w`` in it.  Needed by
        ``"flow"``: where ``w`` is 0 it falls back to Perona-Malik's isotropic
        ``g``.  Optional for ``"ced"``: the strokes' orientation blends from
        the texture's (the structure tensor's, where ``w`` is 0) to the
        field's (where it is 1), by the doubled angles of the two line fields
        weighted ``1 - w`` and ``w``; the diffusivities stay those of the
        texture's coherence.
    progress : callable, optional
        ``progress(fraction)`` as the run advances; an exception it raises
        stops the run and propagates (the input is never modified).
    **params
        The mode's filter parameters (:data:`cp_stylize.parameters.FILTERS`);
        those not given take the mode's defaults (:data:`DEFAULTS`).
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
        Perona-Malik, Beltrami and Flow: ``lambda = lambda_rel * ||grad u0_sigma||_inf``.
    beta, contrast : float, optional
        Flow (Diewald and Rumpf): the largest diffusivity across the field,
        ``G = beta / (1 + |grad u_sigma|^2 / lambda^2)``, and the strength of
        the contrast term ``f(u) = (1 - |u|)(|u| - 1/2) u`` (values scaled to
        their initial range), at the rate ``4 contrast / T``: a mid-grey
        moves ``contrast`` e-folds towards black or white over the run,
        whatever the size of the object.
    ink : float, optional
        Flow: 0 (the default) diffuses ``u0``.  Above 0 the flow runs on
        Diewald and Rumpf's initial data instead, white noise (seed :data:`INK_SEED`)
        smoothed over ``h^2 / 4``, and the darker half of that flow texture
        ``s`` (scaled to [0, 1]) darkens ``u0`` as strokes:
        ``u0 (1 - ink max(1 - 2 s, 0))``; ``u0`` keeps its tones.

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
    Biddle's dissertation, section 3.3), not the face-gradient form.  Beltrami uses the
    decoupled colour Beltrami flow of Malladi and Ravve, eq. (90),

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
    unknown = set(params) - set(FILTER_PARAMETERS)
    if unknown:
        raise TypeError(f"diffuse() got unexpected keyword argument(s) {sorted(unknown)}; "
                        f"filter parameters are {list(FILTER_PARAMETERS)}")
    given = params
    params = dict(DEFAULTS[mode])
    for name, value in given.items():
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
    u0 = band.check_values(u0)
    if not np.all(np.isfinite(u0)):
        raise ValueError("u0 holds NaN or infinite values")
    if mode == "flow" and field is None:
        raise ValueError("mode 'flow' needs field=, an (N, 3) direction field such as principal_curvatures(band).e2")
    if field is not None and mode not in DIRECTED_MODES:
        raise ValueError(f"field= is for the modes {' and '.join(map(repr, DIRECTED_MODES))} only, not {mode!r}")
    if field is not None:
        field = np.asarray(field, dtype=np.float64)
        if field.shape != (band.size, 3) or not np.all(np.isfinite(field)):
            raise ValueError(f"field must be a finite array of shape ({band.size}, 3), got shape {field.shape}")
    if mode == "flow" and params["ink"] > 0:
        return _inked(band, u0, T=T, tau=tau, scheme=scheme, lag=lag, clamp=clamp, normals=normals, field=field,
                      progress=progress, **params)
    tau = PAPER_CFL * band.h**2 if tau is None else float(tau)
    n_steps, tau = time_steps(T, tau)
    rows = np.array(u0.T if u0.ndim == 2 else u0[None, :], order="C")
    if n_steps == 0:
        return rows.T.copy() if u0.ndim == 2 else rows[0].copy()
    lo, hi = rows.min(axis=1, keepdims=True), rows.max(axis=1, keepdims=True)
    smoothing = HeatSmoothing if scheme == "reference" else GridSmoothing
    operators = _StepOperators(band, rows.dtype, mode, params, normals, smoothing, field)
    operators.normalise(rows)
    reaction = None
    if mode == "flow" and params["contrast"] > 0:
        reaction = operators.reaction(lo, hi, 4.0 * params["contrast"] / T)
    lag = 0.0 if scheme == "reference" else lag
    inner = band.inner
    span = np.maximum(hi - lo, np.finfo(rows.dtype).tiny)[:, 0]
    built_from = None
    for step in range(n_steps):
        if built_from is None or _rms_change(rows, built_from, inner, span) > lag:
            report = None if progress is None else (lambda f, s=step: progress((s + 0.9 * f) / n_steps))
            A, extra = operators.operator(rows, report)
            built_from = rows[:, inner].copy() if lag > 0 else None
        stable = operators.stable_step if reaction is None else min(operators.stable_step, operators.reaction_step)
        _step(rows, A, extra, operators.laplacian, operators.E, tau, stable, clamp and (lo, hi), reaction)
        _check(rows, step, n_steps, progress)
    return rows.T.copy() if u0.ndim == 2 else rows[0].copy()


class _StepOperators:
    """Builds the step operator ``A(G)`` of one mode from the current values (Algorithm 1, steps 2-8).

    The structure tensor's smoothings come from ``smoothing``
    (:class:`HeatSmoothing` or :class:`GridSmoothing`); everything else, the
    tangent reduction, the diffusivities, G and the 19-point weights, is the
    same for both schemes, computed in the smoothing's precision.
    """

    def __init__(self, band, dtype, mode, params, normals, smoothing, field=None):
        self.band, self.dtype, self.mode, self.params = band, np.dtype(dtype), mode, params
        self.normals, self.field = normals, field
        self.E = band.split_matrix("E", dtype)
        self.laplacian = band.split_matrix("L", dtype) if mode in ("gaussian", "beltrami") else None
        self.scale = 0.0
        self._initial = None
        if mode == "gaussian":
            self.stable_step = DivergenceOperator.stable_step(band.laplacian_matrix(dtype))
            return
        self.smoothing = smoothing(band, dtype, {k: params[k] for k in DEFAULTS[mode]})  # the mode's own
        self.work = self.smoothing.work
        # the parts are independent: build them side by side on the worker threads, the large ones first
        smoothing_parts = self.smoothing.builds()
        parts = smoothing_parts[:1] + [self._build_divergence] + smoothing_parts[1:]
        map_parallel(lambda build: build(), parts + [self._build_tangents] * (mode in ("eed", "ced"))
                     + [self._build_field] * (mode == "flow"))
        self.orientation = None if mode != "ced" or field is None else self._field_orientation()

    def _build_divergence(self):
        self.divergence = self.band.structure("divergence", self.dtype.str,
                                              lambda: DivergenceOperator(self.band, self.dtype))
        self._A = self.divergence.template()
        self.A = SplitMatrix(self._A)

    def _build_tangents(self):
        def build():
            Q = tangent_basis(self.band, self.normals)
            return np.ascontiguousarray(Q.transpose(2, 1, 0), dtype=self.smoothing.work)  # (2, 3, N): q0, q1 by axis

        self.Q = self.band.structure("tangents", (digest(self.normals), np.dtype(self.smoothing.work).str), build)

    def _field_orientation(self):
        """The field's across-stroke line field in the tangent basis Q, as a doubled angle weighted by its
        confidence ``w``, and ``1 - w``: ``(w cos 2phi, w sin 2phi, 1 - w)``."""
        q0, q1 = self.Q
        fc, fs = np.sum(q0 * self.field.T, axis=0), np.sum(q1 * self.field.T, axis=0)
        length2 = fc * fc + fs * fs
        w = np.clip(np.sqrt(length2), 0.0, 1.0)
        scale = np.where(length2 > 0, w / np.where(length2 > 0, length2, 1.0), 0.0)
        # across the strokes: (-fs, fc); its doubled angle (fs^2 - fc^2, -2 fs fc) / length^2
        return tuple(a.astype(self.work) for a in (scale * (fs * fs - fc * fc), scale * (-2.0 * fs * fc), 1.0 - w))

    def _orient(self, c1, s1):
        """CED's across-stroke direction ``(c1, s1)`` blended with the field's (see :func:`diffuse`)."""
        if self.orientation is None:
            return c1, s1
        cos2, sin2, keep = self.orientation
        C = keep * (c1 * c1 - s1 * s1) + cos2
        S = keep * (2.0 * c1 * s1) + sin2
        r = np.sqrt(C * C + S * S)
        ok = r > 1e-6
        r = np.where(ok, r, 1.0)
        c = np.sqrt(np.clip(0.5 * (1.0 + C / r), 0.0, 1.0))
        s = np.copysign(np.sqrt(np.clip(0.5 * (1.0 - C / r), 0.0, 1.0)), S)
        own = ~ok | (keep >= 1)          # no field there: the texture's own, to the bit
        return np.where(own, c1, c), np.where(own, s1, s)

    def _build_field(self):
        """The field's unit tangent direction e (3, N), its confidence (N,) and the tangent projector (6, N)."""
        n = surface_normals(self.band, self.normals)
        tangential = self.field - np.sum(self.field * n, axis=1)[:, None] * n
        e, length = unit_rows(tangential, (1.0, 0.0, 0.0))
        self.confidence = np.clip(length, 0.0, 1.0).astype(self.work)
        self.direction = np.ascontiguousarray(e.T, dtype=self.work)
        self.projector = np.stack([float(a == b) - n[:, a] * n[:, b] for a, b in TENSOR_COMPONENTS]).astype(self.work)

    def reaction(self, lo, hi, rate):
        """The contrast term ``rate * f(v)`` of rows (C, N), with values scaled to ``[lo, hi]`` (C, 1).

        ``f(u) = (1 - |u|)(|u| - 1/2) u`` (Diewald and Rumpf, in its colour form); the
        step limit keeps ``rate * dt`` at most 1, where ``|f'| <= 1/2`` on [0, 1].
        """
        span = np.maximum(hi - lo, np.finfo(lo.dtype).tiny)
        self.reaction_step = 1.0 / rate

        def term(rows):
            u = (rows - lo) / span
            size = np.sqrt(np.sum(u * u, axis=0))
            return (rate * (1.0 - size) * (size - 0.5)) * u * span

        return term

    def normalise(self, rows):
        """Scale-free parameters from the initial data (section 4.5)."""
        if self.mode in ("eed", "ced"):
            self._initial = self._coherence(rows)  # the first step reuses it
            self.scale = float(self._initial[0].max())
        elif self.mode in ("perona_malik", "beltrami", "flow"):
            self.scale = self.smoothing.gradient_scale(rows)

    def _coherence(self, rows, progress=None):
        """``(c, c1, s1)``: the coherence ``mu1 - mu2`` and the direction of ``mu1`` of ``J~`` (eqs. (25)-(26))."""
        J = self.smoothing.tensor(rows, progress).astype(self.work, copy=False)
        mu1, mu2, c1, s1 = eigen_2x2(*reduce_to_tangent(J, *self.Q))
        return np.maximum(mu1 - mu2, 0), c1, s1

    def _fill(self, G):
        """A with the 19-point weights of the tensor field G (6, N), and its stable step (Gershgorin)."""
        self.divergence.fill(G, self._A.data)
        self.stable_step = gershgorin_step(np.abs(self._A.data).reshape(-1, 19).sum(axis=1))
        return self.A

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
            k1, k2 = _diffusivities(self.mode, c, p, self.scale)
            c1, s1 = self._orient(c1, s1)
            q0, q1 = self.Q
            w = q0 * c1 + q1 * s1
            G = np.empty((6, self.band.size), dtype=self.work)
            difference = k1 - k2
            for k, (a, b) in enumerate(TENSOR_COMPONENTS):
                # k2 Q Q^T + (k1 - k2) w w^T: the tangent projector Q Q^T = q0 q0^T + q1 q1^T
                np.multiply(q0[a], q0[b], out=G[k])
                G[k] += q1[a] * q1[b]
                G[k] *= k2
                G[k] += difference * w[a] * w[b]
            return self._fill(G), None
        if self.mode == "flow":
            return self._fill(self._field_tensor(rows, progress)), None
        # Perona-Malik and Beltrami: scalar edge stopping from the current gradient
        beltrami = self.mode == "beltrami"
        trace, second = self.smoothing.invariants(self.smoothing.presmoothed(rows) if beltrami else rows, beltrami)
        if progress is not None:
            progress(1.0)
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, _TINY)
        if not beltrami:
            g = (1.0 / (1.0 + trace / lam2)).astype(self.work)
            return self._fill(_isotropic(g)), None
        # det of the tangent tensor: J is tangent (rank <= 2), so det J~ is its second invariant;
        # in float64, where lam2**2 stays a number
        trace, second = trace.astype(np.float64, copy=False), second.astype(np.float64, copy=False)
        inv = (0.5 / (1.0 + trace / lam2 + second / lam2**2)).astype(self.work)
        return self._fill(_isotropic(inv)), inv.astype(self.dtype)


    def _field_tensor(self, rows, progress=None):
        """Seed 004's ``G = g P + c (alpha - g) e e^T`` (6, N): ``alpha`` along the field's direction e,
        ``g = beta / (1 + |grad u_sigma|^2 / lambda^2)`` across it, isotropic ``g`` where the confidence c is 0."""
        p = self.params
        trace, _ = self.smoothing.invariants(self.smoothing.presmoothed(rows), False)
        if progress is not None:
            progress(1.0)
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, _TINY)
        g = (p["beta"] / (1.0 + trace / lam2)).astype(self.work)
        along = self.confidence * (p["alpha"] - g)
        e = self.direction
        G = np.empty((6, self.band.size), dtype=self.work)
        for k, (a, b) in enumerate(TENSOR_COMPONENTS):
            np.multiply(g, self.projector[k], out=G[k])
            G[k] += along * e[a] * e[b]
        return G


#: Seed of the white noise the ``ink`` of the flow mode draws its strokes from.
INK_SEED = 4


def flow_noise(band, seed=0, dtype=np.float64):
    """Seed 004's initial data for a flow texture: white noise in [0, 1] on the band, extended and
    smoothed by a surface heat flow over ``h^2 / 4``."""
    noise = np.random.default_rng(seed).uniform(0.0, 1.0, band.size).astype(dtype)
    return heat(band, band.extend(noise), 0.25 * band.h**2)


def _inked(band, u0, *, ink, **kw):
    """Flow with ``ink``: Diewald and Rumpf's flow texture of :func:`flow_noise` laid over ``u0`` as dark strokes:
    ``u0 (1 - ink max(1 - 2 s, 0))`` with ``s`` the texture scaled to [0, 1], so that only its darker
    half draws."""
    s = diffuse(band, flow_noise(band, INK_SEED, u0.dtype), mode="flow", ink=0.0, **kw)
    s = (s - s.min()) / max(float(s.max() - s.min()), _TINY)
    shade = (1.0 - ink * np.clip(1.0 - 2.0 * s, 0.0, 1.0)).astype(u0.dtype)   # its darker half: lines
    return u0 * (shade[:, None] if u0.ndim == 2 else shade)


def _step(rows, A, extra, laplacian, E, tau, stable_step, bounds, reaction=None):
    """One outer step ``v <- E (v + tau (A v + extra L v + r(v)))`` in place, in equal parts where A
    (or the reaction ``r``) needs them."""
    sub = max(1, int(np.ceil(tau / stable_step - 1e-9)))
    dt = rows.dtype.type(tau / sub)
    for _ in range(sub):
        react = None if reaction is None else reaction(rows)
        for j in range(len(rows)):
            v = rows[j]
            change = A @ v
            if extra is not None:
                change += extra * (laplacian @ v)
            if react is not None:
                change += react[j]
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
