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
and extends (eq. (50)): ``v <- E (v + tau A(G) v)``.  One engine
(:class:`~cp_stylize.diffusion_tensor.StepOperators`)
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

Filter parameters
-----------------
:func:`diffuse` takes each mode's parameters by name (those not given take
the mode's defaults, :data:`DEFAULTS`; their limits are the parameter table's,
:mod:`cp_stylize.parameters`):

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

The method
----------
EED and CED build ``G = Q G~ Q^T`` with ``G~ = kappa1 w w^T + kappa2 w_perp w_perp^T``
from the eigenvectors of the tangent structure tensor ``J~ = Q^T J Q``
(eqs. (25)-(29)).  With the coherence ``c = mu1 - mu2``:

- EED: ``kappa1 = 1 / (1 + (c / lambda)^2)``, ``kappa2 = 1``: the Perona-Malik
  function of eq. (8) with ``c`` in the role of ``s``, so that the diffusivity
  depends only on ``c / ||c0||_inf`` as section 4.5's scaling requires; G = I
  where ``c = 0``.
- CED: ``kappa1 = alpha``, ``kappa2 = alpha + (1 - alpha) exp(-B^2 / c^2)`` (eq. (9)).
  With a direction ``field`` of confidence ``w``, the strokes' orientation
  blends from the texture's (the structure tensor's, where ``w`` is 0) to the
  field's (where it is 1), by the doubled angles of the two line fields
  weighted ``1 - w`` and ``w``; the diffusivities stay those of the texture's
  coherence.

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

from __future__ import annotations

import numpy as np

from .diffusion_tensor import TINY, StepOperators
from .heat_flow import PAPER_CFL, heat, time_steps
from .parameters import DEFAULTS, DIRECTED_MODES, FILTER_PARAMETERS, MODES
from .structure import GridSmoothing, HeatSmoothing

__all__ = ["diffuse", "flow_noise", "MODES", "SCHEMES", "DEFAULTS", "PAPER_CFL"]

#: Time stepping schemes: see :func:`diffuse`.
SCHEMES = ("fast", "reference")

#: The fast scheme rebuilds the diffusion tensor once the values have changed
#: by this root-mean-square fraction of their range since the last rebuild.
LAG = 0.02

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
        ``"reference"``: Algorithm 1 as written; ``"fast"`` (the default): the
        same steps with the smoothings on the grid and G rebuilt after ``lag``.
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
        (a line field), such as ``principal_curvatures(band).e2``: its
        tangential part, its length clipped to [0, 1] the confidence ``w`` in
        it.  Needed by ``"flow"`` (Perona-Malik's ``g`` where ``w`` is 0);
        for ``"ced"``, the orientation blends from the texture's to the
        field's with ``w`` (see the module's notes).
    progress : callable, optional
        ``progress(fraction)`` as the run advances; an exception it raises
        stops the run and propagates (the input is never modified).
    **params
        The mode's filter parameters by name (``sigma``, ``rho``, ``alpha``,
        ``b_rel``, ``lambda_rel``, ``beta``, ``contrast``, ``ink``; see the
        module's *Filter parameters*); those not given take the mode's
        defaults (:data:`DEFAULTS`).

    Returns
    -------
    ndarray
        Filtered values, same shape as ``u0``.

    Notes
    -----
    The module's *The method* gives the tensors of each mode, the fast
    scheme's smoothings and how the parameters scale with the surface.
    """
    params, lag, field = _checked(band, mode, scheme, params, lag, field)
    u0 = band.check_values(u0)
    if not np.all(np.isfinite(u0)):
        raise ValueError("u0 holds NaN or infinite values")
    if mode == "flow" and params["ink"] > 0:
        return _inked(band, u0, T=T, tau=tau, scheme=scheme, lag=lag, clamp=clamp, normals=normals, field=field,
                      progress=progress, **params)
    tau = PAPER_CFL * band.h**2 if tau is None else float(tau)
    n_steps, tau = time_steps(T, tau)
    rows = np.array(u0.T if u0.ndim == 2 else u0[None, :], order="C")
    if n_steps > 0:
        smoothing = HeatSmoothing if scheme == "reference" else GridSmoothing
        operators = StepOperators(band, rows.dtype, mode, params, normals, smoothing, field)
        _evolve(rows, operators, n_steps, tau, T, 0.0 if scheme == "reference" else lag, clamp, progress)
    return rows.T.copy() if u0.ndim == 2 else rows[0].copy()


def _checked(band, mode, scheme, given, lag, field):
    """The filter parameters of ``mode`` (its defaults with ``given`` over them), ``lag`` and the direction
    ``field`` (as float64, or None), each checked, and the mode and scheme checked; ValueError or TypeError
    naming what is wrong."""
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    unknown = set(given) - set(FILTER_PARAMETERS)
    if unknown:
        raise TypeError(f"diffuse() got unexpected keyword argument(s) {sorted(unknown)}; "
                        f"filter parameters are {list(FILTER_PARAMETERS)}")
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
    if mode == "flow" and field is None:
        raise ValueError("mode 'flow' needs field=, an (N, 3) direction field such as principal_curvatures(band).e2")
    if field is not None and mode not in DIRECTED_MODES:
        raise ValueError(f"field= is for the modes {' and '.join(map(repr, DIRECTED_MODES))} only, not {mode!r}")
    if field is not None:
        field = np.asarray(field, dtype=np.float64)
        if field.shape != (band.size, 3) or not np.all(np.isfinite(field)):
            raise ValueError(f"field must be a finite array of shape ({band.size}, 3), got shape {field.shape}")
    return params, lag, field


def _evolve(rows, operators, n_steps, tau, T, lag, clamp, progress):
    """``n_steps`` steps of ``tau`` of the diffusion ``operators`` on band values ``rows`` (C, N), in place;
    the diffusion tensor rebuilt once the values have changed by ``lag`` (0: at every step)."""
    params, band = operators.params, operators.band
    lo, hi = rows.min(axis=1, keepdims=True), rows.max(axis=1, keepdims=True)
    operators.normalise(rows)
    reaction = None
    if operators.mode == "flow" and params["contrast"] > 0:
        reaction = operators.reaction(lo, hi, 4.0 * params["contrast"] / T)
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


#: Seed of the white noise the ``ink`` of the flow mode draws its strokes from.
INK_SEED = 4


def flow_noise(band, seed=0, dtype=np.float64):
    """Diewald and Rumpf's initial data for a flow texture: white noise in [0, 1] on the band, extended and
    smoothed by a surface heat flow over ``h^2 / 4``."""
    noise = np.random.default_rng(seed).uniform(0.0, 1.0, band.size).astype(dtype)
    return heat(band, band.extend(noise), 0.25 * band.h**2)


def _inked(band, u0, *, ink, **kw):
    """Flow with ``ink``: Diewald and Rumpf's flow texture of :func:`flow_noise` laid over ``u0`` as dark strokes:
    ``u0 (1 - ink max(1 - 2 s, 0))`` with ``s`` the texture scaled to [0, 1], so that only its darker
    half draws."""
    s = diffuse(band, flow_noise(band, INK_SEED, u0.dtype), mode="flow", ink=0.0, **kw)
    s = (s - s.min()) / max(float(s.max() - s.min()), TINY)
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
