"""Speed benchmark: ``python -m cp_stylize bench``.

Times band construction and one explicit closest point step (evolve with L,
extend with E) on the unit sphere, grey and RGB.  Speed targets are checked
here, never in the tests.
"""

from __future__ import annotations

import time

import numpy as np

from .band import Band
from .heat import heat
from .surfaces import Sphere


def _best(fn, repeat):
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def heat_steps(spacings=(0.05, 0.025), steps=20, repeat=3, log=print):
    """Rows (h, band points, build s, s/step grey, s/step RGB) on the unit sphere."""
    rows = []
    log(f"{'h':>7} {'band points':>12} {'build s':>8} {'step ms (1 ch)':>15} {'step ms (3 ch)':>15}")
    for h in spacings:
        start = time.perf_counter()
        band = Band.build(Sphere(), h)
        build = time.perf_counter() - start
        grey = band.cp[:, 2].astype(np.float32)
        rgb = np.repeat(grey[:, None], 3, axis=1)
        dt = 0.1 * h * h
        t1 = _best(lambda: heat(band, grey, steps * dt, dt=dt), repeat) / steps
        t3 = _best(lambda: heat(band, rgb, steps * dt, dt=dt), repeat) / steps
        rows.append((h, band.size, build, t1, t3))
        log(f"{h:7.4f} {band.size:12,d} {build:8.2f} {1e3 * t1:15.2f} {1e3 * t3:15.2f}")
    return rows


def run(quick=False, log=print):
    log("closest point heat step on the unit sphere (tricubic E, 7-point L, float32)")
    heat_steps((0.1, 0.05) if quick else (0.05, 0.025), steps=5 if quick else 20,
               repeat=1 if quick else 3, log=log)
