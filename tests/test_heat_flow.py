"""Convergence of the closest point heat solve on the unit sphere."""

import numpy as np
import pytest

from cp_stylize import Band, Sphere, heat
from cp_stylize.heat_flow import time_steps

T = 0.02
SPACINGS = (0.1, 0.05, 0.025)


def _exact(cp, t):
    x, y, z = cp.T
    # z is an l = 1 spherical harmonic, xyz an l = 3 one: eigenvalues -2 and -12
    return np.column_stack([np.exp(-2 * t) * z, np.exp(-12 * t) * x * y * z])


@pytest.fixture(scope="module")
def error_table():
    rows = []
    for h in SPACINGS:
        band = Band.build(Sphere(), h)
        u = heat(band, _exact(band.cp, 0.0).astype(np.float32), T)
        rows.append((h, band.size, *np.abs(u - _exact(band.cp, T)).max(axis=0)))
    print("\n    h   band points   max error (z)   max error (xyz)")
    for h, n, e1, e3 in rows:
        print(f"{h:6.3f} {n:12d} {e1:15.3e} {e3:17.3e}")
    return np.array(rows)


@pytest.mark.parametrize("column, name", [(2, "z"), (3, "xyz")])
def test_heat_on_sphere_is_second_order(error_table, column, name):
    errors = error_table[:, column]
    orders = np.log2(errors[:-1] / errors[1:])
    print(f"orders for u0 = {name}: {orders}")
    assert np.all(orders >= 1.8), orders
    assert errors[-1] < 5e-5


def test_heat_conserves_constants_and_stays_in_range():
    band = Band.build(Sphere(), 0.1)
    np.testing.assert_allclose(heat(band, np.full(band.size, 0.7, np.float32), 0.02), 0.7, rtol=1e-5)
    u0 = (band.cp[:, 2] > 0).astype(np.float32)
    u = heat(band, u0, 0.02)
    assert u.min() > -0.02 and u.max() < 1.02
    assert u[band.cp[:, 2] > 0.5].min() > 0.9 and u[band.cp[:, 2] < -0.5].max() < 0.1


def test_time_steps_end_exactly_at_the_stop_time():
    n, tau = time_steps(0.1, 0.003)
    assert n == 34 and n * tau == pytest.approx(0.1) and tau <= 0.003
    assert time_steps(0.0, 0.1) == (0, 0.0)
    with pytest.raises(ValueError, match="non-negative"):
        time_steps(-1.0, 0.1)


def test_progress_is_reported_and_can_stop_the_solve():
    band = Band.build(Sphere(), 0.2)
    seen = []
    heat(band, band.cp[:, 2], 0.01, progress=seen.append)
    assert seen[-1] == 1.0 and np.all(np.diff(seen) > 0)

    class Stop(Exception):
        pass

    def stop(fraction):
        if fraction > 0.5:
            raise Stop

    with pytest.raises(Stop):
        heat(band, band.cp[:, 2], 0.01, progress=stop)
