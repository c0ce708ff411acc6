"""How fast this computer runs the core, next to the one the run estimate was measured on.

The time constants of :func:`cp_stylize.estimate.estimate` were measured on a
quiet two-core machine.  :func:`measure` times a short job of the same kinds of
work (sparse products on arrays larger than a processor's cache, as the
extension and the diffusion steps make, sorting and gathers, as the closest
point search and the bake-out make) in processor time, the least of several
runs, so that other work on the computer counts as little as it can, and
:func:`machine_speed` divides it by that machine's time: the factor the estimate's times are multiplied by.  It says
how fast the computer is, not how busy: a run on a computer busy with other
work takes longer than its estimate.  It is measured once a session and kept,
in memory and, given a path, in a small JSON file that keeps the least of all
sessions' measures; a file made on another computer (another name, processor or
core count) counts for nothing.
"""

from __future__ import annotations

import json
import os
import platform
import threading
import time

__all__ = ["measure", "machine_speed", "REFERENCE_SECONDS"]

#: Seconds of processor time :func:`measure` takes on the machine the estimate's constants were measured on
#: (two cores): the lower tenth of 47 timings there through a day of other work, which slows even processor time.
REFERENCE_SECONDS = 0.03
#: The factor is kept within these bounds: a measurement disturbed by other work never makes the
#: estimate absurd.
SPEED_LIMITS = (0.25, 8.0)
#: The job's size: rows of its sparse matrix (32 MiB of entries, more than a processor's cache holds,
#: as a band's matrices are), entries a row, products, and points sorted.
_ROWS, _ENTRIES, _PRODUCTS, _POINTS = 1 << 17, 32, 4, 1 << 16

_speed = {}
_lock = threading.Lock()


def _job():
    """The calibration job's work, made ready; returns the function whose time is measured."""
    import numpy as np
    import scipy.sparse as sp

    rng = np.random.default_rng(0)
    rows = np.repeat(np.arange(_ROWS, dtype=np.int32), _ENTRIES)
    columns = (rows + rng.integers(-4096, 4096, rows.size, dtype=np.int32)) % _ROWS   # near the diagonal, as a band's
    start = np.arange(0, rows.size + 1, _ENTRIES, dtype=np.int32)
    matrix = sp.csr_matrix((rng.random(rows.size, dtype=np.float32), columns, start), shape=(_ROWS, _ROWS))
    vector = rng.random(_ROWS, dtype=np.float32)
    points = rng.random((_POINTS, 3))

    def work():
        v = vector
        for _ in range(_PRODUCTS):
            v = matrix @ v
            v /= v.max()
        order = np.argsort(points @ [0.3, 0.5, 0.7])
        np.einsum("ij,ij->i", points[order], points)
    return work


def measure(repeat=7):
    """The least processor time (seconds) of ``repeat`` runs of the calibration job, about 0.03 s each

    Processor time, on one thread: how fast this computer is, whatever else
    it runs at the moment (the estimate's constants were measured quiet).
    """
    work = _job()
    work()                                     # the first run pages in its arrays
    best = float("inf")
    for _ in range(repeat):
        start = time.thread_time()
        work()
        best = min(best, time.thread_time() - start)
    return best


def _machine():
    """What tells this computer from another: its name, processor and cores."""
    return {"node": platform.node(), "processor": platform.processor() or platform.machine(),
            "cores": os.cpu_count()}


def machine_speed(path=None):
    """How many times longer than the reference machine this computer takes: the estimate's time factor.

    Measured once a session (:func:`measure`, well under a second) and kept in
    memory; with ``path``, the least time of every session is kept in that
    JSON file: other work slows even processor time (its caches are shared),
    so the least measure is the computer's own speed.  A file that cannot be
    read, or was written on another computer, counts for nothing; one that
    cannot be written is left as it is.
    """
    key = os.fspath(path) if path is not None else None
    with _lock:
        if key in _speed:
            return _speed[key]
        kept = _read(key) if key else None
        seconds = _speed.get("measured") or measure()
        _speed["measured"] = seconds
        if kept is not None and kept <= seconds:
            seconds = kept
        elif key:
            _write(key, seconds)
        low, high = SPEED_LIMITS
        _speed[key] = min(max(seconds / REFERENCE_SECONDS, low), high)
        return _speed[key]


def _read(path):
    try:
        with open(path, encoding="utf-8") as f:
            kept = json.load(f)
        if kept.get("machine") == _machine() and float(kept["seconds"]) > 0:
            return float(kept["seconds"])
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        pass
    return None


def _write(path, seconds):
    try:
        os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
        with open(path, "w", encoding="utf-8") as f:
            json.dump({"seconds": seconds, "machine": _machine(), "measured": time.strftime("%Y-%m-%d")}, f)
    except OSError:
        pass
