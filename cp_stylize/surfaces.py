"""Analytic surfaces given by their closest point functions.

A surface, for the closest point method, is just its closest point function
(paper, section 4.1): ``closest_point(x) -> (cp, dist)`` maps points of the
embedding space to their nearest surface points.  Conventions, as in
cp_matrices: ``dist`` is the signed distance, negative inside a closed surface.

Every surface here also gives

- ``normal(cp)``: the outward unit normal at surface points;
- ``bounds()``: an axis-aligned box ``(lo, hi)`` that holds the surface;
- ``area``: its surface area;
- ``point(s, t)``: a parametrisation, used to draw flattened maps of surface
  functions (``s`` and ``t`` in [0, 1)), and its inverse ``parameters(p)``.

What is not checked: points exactly on the medial axis (the sphere's centre,
the torus axis, the ellipsoid's inner focal disc) have no unique closest
point; an arbitrary one of the closest points is returned there.
"""

from __future__ import annotations

import numpy as np

from .arrays import as_points, unit_rows

__all__ = ["Sphere", "Torus", "Ellipsoid"]


def _unit_sphere_point(s, t):
    """Points (..., 3) of the unit sphere at longitude ``2 pi s - pi`` and latitude ``pi t - pi/2``."""
    lon = 2.0 * np.pi * np.asarray(s, dtype=np.float64) - np.pi
    lat = np.pi * np.asarray(t, dtype=np.float64) - 0.5 * np.pi
    return np.stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)], axis=-1)


def _unit_sphere_parameters(d):
    """``(s, t)`` of the directions ``d`` (M, 3): the inverse of :func:`_unit_sphere_point`."""
    lon = np.arctan2(d[:, 1], d[:, 0])
    lat = np.arcsin(np.clip(d[:, 2] / np.linalg.norm(d, axis=1).clip(1e-300), -1.0, 1.0))
    return (lon + np.pi) / (2.0 * np.pi), (lat + 0.5 * np.pi) / np.pi


class Sphere:
    """The sphere of radius ``radius`` about ``center``.

    Parameters
    ----------
    radius : float
        Positive radius.
    center : sequence of 3 floats
        Centre of the sphere.

    Notes
    -----
    ``cp(x) = c + R (x - c) / |x - c|`` and ``dist = |x - c| - R``.
    ``point(s, t)`` is the longitude-latitude parametrisation: longitude
    ``2 pi s - pi``, latitude ``pi t - pi/2`` (the layout of an equirectangular
    image and of Blender's UV sphere).
    """

    def __init__(self, radius=1.0, center=(0.0, 0.0, 0.0)):
        radius = float(radius)
        if not np.isfinite(radius) or radius <= 0:
            raise ValueError(f"radius must be a positive number, got {radius!r}")
        self.radius = radius
        self.center = np.asarray(center, dtype=np.float64).reshape(3)

    def __repr__(self):
        return f"Sphere(radius={self.radius!r}, center={tuple(self.center.tolist())!r})"

    @property
    def area(self):
        return 4.0 * np.pi * self.radius**2

    def bounds(self):
        return self.center - self.radius, self.center + self.radius

    def closest_point(self, x):
        x = as_points(x)
        d = x - self.center
        u, n = unit_rows(d, (0.0, 0.0, 1.0))
        return self.center + self.radius * u, n - self.radius

    def normal(self, cp):
        return unit_rows(as_points(cp) - self.center, (0.0, 0.0, 1.0))[0]

    def point(self, s, t):
        return self.center + self.radius * _unit_sphere_point(s, t)

    def parameters(self, p):
        """``(s, t)`` of surface points ``p`` (M, 3): the inverse of :meth:`point`."""
        d = as_points(p) - self.center
        return _unit_sphere_parameters(d)


class Torus:
    """The torus ``(R - sqrt(x^2 + y^2))^2 + z^2 = r^2`` about ``center`` (paper, eq. (54)).

    It lies in the xy-plane with axis z.

    Parameters
    ----------
    R : float
        Distance from the axis to the centre of the tube.
    r : float
        Radius of the tube, ``0 < r < R``.
    center : sequence of 3 floats
        Centre of the torus.

    Notes
    -----
    With ``q`` the nearest point of the core circle, ``cp(x) = q + r (x - q) / |x - q|``
    and ``dist = |x - q| - r``.  ``point(s, t)`` takes ``s`` around the axis and
    ``t`` around the tube (``t = 0`` on the outer equator).
    """

    def __init__(self, R=1.0, r=0.4, center=(0.0, 0.0, 0.0)):
        R, r = float(R), float(r)
        if not (np.isfinite(R) and np.isfinite(r)) or not 0 < r < R:
            raise ValueError(f"the torus needs 0 < r < R, got R={R!r}, r={r!r}")
        self.R, self.r = R, r
        self.center = np.asarray(center, dtype=np.float64).reshape(3)

    def __repr__(self):
        return f"Torus(R={self.R!r}, r={self.r!r}, center={tuple(self.center.tolist())!r})"

    @property
    def area(self):
        return 4.0 * np.pi**2 * self.R * self.r

    def bounds(self):
        e = np.array([self.R + self.r, self.R + self.r, self.r])
        return self.center - e, self.center + e

    def _core(self, d):
        """Nearest points of the core circle to the offsets ``d`` from the centre."""
        planar = np.column_stack([d[:, 0], d[:, 1], np.zeros(len(d))])
        u, _ = unit_rows(planar, (1.0, 0.0, 0.0))
        return self.R * u

    def closest_point(self, x):
        d = as_points(x) - self.center
        q = self._core(d)
        u, n = unit_rows(d - q, (0.0, 0.0, 1.0))
        return self.center + q + self.r * u, n - self.r

    def normal(self, cp):
        d = as_points(cp) - self.center
        return unit_rows(d - self._core(d), (0.0, 0.0, 1.0))[0]

    def point(self, s, t):
        phi = 2.0 * np.pi * np.asarray(s, dtype=np.float64)
        theta = 2.0 * np.pi * np.asarray(t, dtype=np.float64)
        rad = self.R + self.r * np.cos(theta)
        p = np.stack([rad * np.cos(phi), rad * np.sin(phi), self.r * np.sin(theta)], axis=-1)
        return self.center + p

    def parameters(self, p):
        """``(s, t)`` of surface points ``p`` (M, 3): the inverse of :meth:`point`."""
        d = as_points(p) - self.center
        phi = np.arctan2(d[:, 1], d[:, 0])
        theta = np.arctan2(d[:, 2], np.hypot(d[:, 0], d[:, 1]) - self.R)
        return np.mod(phi / (2.0 * np.pi), 1.0), np.mod(theta / (2.0 * np.pi), 1.0)


class Ellipsoid:
    """The ellipsoid ``sum_i ((x_i - c_i) / a_i)^2 = 1`` with semi-axes ``a = axes`` about ``center``.

    Notes
    -----
    The closest point of ``x`` (offset ``p`` from the centre) is
    ``a_i^2 p_i / (t + a_i^2)`` with ``t`` the root of
    ``F(t) = sum_i (a_i p_i / (t + a_i^2))^2 - 1`` right of ``-min a_i^2``.
    F is convex and decreasing there, and not negative at
    ``max_i (|a_i p_i| - a_i^2)``: Newton's method from there converges
    monotonically.  ``area`` is Thomsen's
    approximation (relative error under 1.1 %), used only for estimates.
    ``point(s, t)`` maps longitude and latitude as :class:`Sphere` does.
    """

    def __init__(self, axes=(1.0, 0.8, 0.6), center=(0.0, 0.0, 0.0)):
        axes = np.asarray(axes, dtype=np.float64).reshape(3)
        if not np.all(np.isfinite(axes)) or np.any(axes <= 0):
            raise ValueError(f"axes must be three positive numbers, got {tuple(axes.tolist())!r}")
        self.axes = axes
        self.center = np.asarray(center, dtype=np.float64).reshape(3)

    def __repr__(self):
        return f"Ellipsoid(axes={tuple(self.axes.tolist())!r}, center={tuple(self.center.tolist())!r})"

    @property
    def area(self):
        a, b, c = self.axes
        k = 1.6075
        return 4.0 * np.pi * (((a * b) ** k + (a * c) ** k + (b * c) ** k) / 3.0) ** (1.0 / k)

    def bounds(self):
        return self.center - self.axes, self.center + self.axes

    def closest_point(self, x):
        p = as_points(x) - self.center
        a2 = self.axes**2
        ap = np.abs(self.axes * p)
        small = int(np.argmin(self.axes))
        # F(t) = sum_i (a_i p_i / (t + a_i^2))^2 - 1 is convex and decreasing for t > -min a^2, and
        # F(-a_i^2 + |a_i p_i|) >= 0 for every i: Newton's method from the largest of these rises to the root
        t = np.maximum((ap - a2).max(axis=1), -a2[small])
        for _ in range(100):
            shifted = t[:, None] + a2
            q = np.divide(ap, shifted, out=np.zeros_like(ap), where=ap > 0) ** 2
            f = q.sum(axis=1) - 1.0
            df = -2.0 * np.divide(q, shifted, out=np.zeros_like(q), where=q > 0).sum(axis=1)
            step = np.where((f > 0) & (df < 0), f / np.where(df < 0, df, -1.0), 0.0)
            t = t - step
            if np.all(np.abs(step) <= 1e-15 * (1.0 + np.abs(t))):
                break
        shifted = t[:, None] + a2
        cp = np.divide(a2 * p, shifted, out=np.zeros_like(p), where=shifted > 0)
        # F < 0 already at t = -min a^2 (p on the focal disc, inside): the smallest axis' coordinate
        # is free and the two closest points are (cp, +-z); take the one on p's side
        disc = shifted[:, small] <= 0
        if disc.any():
            rest = [i for i in range(3) if i != small]
            left = 1.0 - np.sum((cp[disc][:, rest] / self.axes[rest]) ** 2, axis=1)
            side = np.where(p[disc, small] < 0, -1.0, 1.0)
            cp[disc, small] = side * self.axes[small] * np.sqrt(np.maximum(left, 0.0))
        dist = np.linalg.norm(p - cp, axis=1)
        inside = np.sum((p / self.axes) ** 2, axis=1) < 1.0
        return self.center + cp, np.where(inside, -dist, dist)

    def normal(self, cp):
        return unit_rows((as_points(cp) - self.center) / self.axes**2, (0.0, 0.0, 1.0))[0]

    def point(self, s, t):
        return self.center + self.axes * _unit_sphere_point(s, t)

    def parameters(self, p):
        """``(s, t)`` of surface points ``p`` (M, 3): the inverse of :meth:`point`."""
        d = (as_points(p) - self.center) / self.axes
        return _unit_sphere_parameters(d)
