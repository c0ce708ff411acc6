"""The step operator of the diffusions: the diffusion tensor G of the current values and ``A(G) = div(G grad)``.

:class:`StepOperators` builds, for one mode of :func:`cp_stylize.diffuse`,
the operator of one explicit step from the current band values (the paper's
Algorithm 1, steps 2-8): the structure tensor (its smoothings from
:mod:`cp_stylize.structure`), its reduction to the tangent plane, the mode's
diffusivities, G, and the 19-point weights of ``div(G grad)`` (eq. (51)).
The module notes of :mod:`cp_stylize.diffusion` give each mode's tensor.
"""

from __future__ import annotations

import numpy as np

from .arrays import unit_rows
from .cache import digest
from .parameters import DEFAULTS
from .sparse import SplitMatrix, map_parallel
from .stencils import TENSOR_COMPONENTS, DivergenceOperator, gershgorin_step
from .structure import eigen_2x2, reduce_to_tangent
from .tangent import surface_normals, tangent_basis

__all__ = ["StepOperators", "TINY"]

#: A floor for scales that divide: a picture without edges or contrast divides by this, not by 0.
TINY = 1e-30


class StepOperators:
    """Builds the step operator ``A(G)`` of one mode from the current values (Algorithm 1, steps 2-8).

    The structure tensor's smoothings come from ``smoothing``
    (:class:`~cp_stylize.structure.HeatSmoothing` or :class:`~cp_stylize.structure.GridSmoothing`); everything else, the
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
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, TINY)
        if not beltrami:
            g = (1.0 / (1.0 + trace / lam2)).astype(self.work)
            return self._fill(_isotropic(g)), None
        # det of the tangent tensor: J is tangent (rank <= 2), so det J~ is its second invariant;
        # in float64, where lam2**2 stays a number
        trace, second = trace.astype(np.float64, copy=False), second.astype(np.float64, copy=False)
        inv = (0.5 / (1.0 + trace / lam2 + second / lam2**2)).astype(self.work)
        return self._fill(_isotropic(inv)), inv.astype(self.dtype)


    def _field_tensor(self, rows, progress=None):
        """Diewald and Rumpf's ``G = g P + c (alpha - g) e e^T`` (6, N): ``alpha`` along the field's direction e,
        ``g = beta / (1 + |grad u_sigma|^2 / lambda^2)`` across it, isotropic ``g`` where the confidence c is 0."""
        p = self.params
        trace, _ = self.smoothing.invariants(self.smoothing.presmoothed(rows), False)
        if progress is not None:
            progress(1.0)
        lam2 = max((p["lambda_rel"] * self.scale) ** 2, TINY)
        g = (p["beta"] / (1.0 + trace / lam2)).astype(self.work)
        along = self.confidence * (p["alpha"] - g)
        e = self.direction
        G = np.empty((6, self.band.size), dtype=self.work)
        for k, (a, b) in enumerate(TENSOR_COMPONENTS):
            np.multiply(g, self.projector[k], out=G[k])
            G[k] += along * e[a] * e[b]
        return G


def _diffusivities(mode, c, p, scale):
    """EED's or CED's ``(kappa1, kappa2)`` from the coherence ``c`` and ``scale = ||c0||_inf``."""
    with np.errstate(over="ignore"):
        if mode == "eed":
            lam = max(p["lambda_rel"] * scale, TINY)
            return 1.0 / (1.0 + (c / lam) ** 2), np.ones_like(c)
        B = p["b_rel"] * scale
        safe = np.where(c > 0, c, 1.0)
        k2 = p["alpha"] + (1.0 - p["alpha"]) * np.where(c > 0, np.exp(-((B / safe) ** 2)), 0.0)
        return np.full_like(c, p["alpha"]), k2


def _isotropic(g):
    zeros = np.zeros_like(g)
    return np.stack([g, g, g, zeros, zeros, zeros])
