"""Sparse products on several cores.

SciPy's CSR product runs on one core but releases the GIL, so a matrix split
into row blocks of equal work multiplies on as many threads as there are
blocks.  The blocks are views of the matrix's arrays: splitting costs no memory.
"""

from __future__ import annotations

import os
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy.sparse as sp

__all__ = ["SplitMatrix", "workers"]

#: Below this many stored entries a product is not worth splitting.
_MIN_SPLIT = 1 << 20

_pool = None
_pool_lock = threading.Lock()
_local = threading.local()


def workers():
    """Cores this process may use (at most 8)."""
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:
        n = os.cpu_count() or 1
    return max(1, min(n, 8))


def _executor():
    global _pool
    with _pool_lock:
        if _pool is None:
            _pool = ThreadPoolExecutor(max_workers=workers(), thread_name_prefix="cp_stylize")
        return _pool


def map_parallel(fn, items, progress=None):
    """``[fn(x) for x in items]`` on the worker threads (in order).

    Serial for one item, on one core, and inside a worker (a nested parallel
    map would wait for workers that wait for it).  ``progress(fraction)``, if
    given, is called with the share of items done as each finishes, one call
    at a time and rising, whichever worker finishes; an exception it raises
    stops the map.
    """
    items = list(items)
    if progress is not None:
        done, lock, inner = [0], threading.Lock(), fn

        def fn(x):
            out = inner(x)
            with lock:
                done[0] += 1
                progress(done[0] / len(items))
            return out

    if len(items) < 2 or workers() < 2 or getattr(_local, "worker", False):
        return [fn(x) for x in items]

    def run(x):
        _local.worker = True
        try:
            return fn(x)
        finally:
            _local.worker = False

    return list(_executor().map(run, items))


def map_windows(fn, items, progress=None):
    """``fn(x)`` for each of ``items``, yielded in order, as :func:`map_parallel` computes them, but only a
    few at a time (twice the workers): a consumer that folds each result in as it comes holds no more than
    that many in memory at once.  ``progress(fraction)`` as in :func:`map_parallel`, over all the items."""
    items = list(items)
    window = 2 * workers()
    for start in range(0, len(items), window):
        part = items[start:start + window]
        step = None
        if progress is not None:
            def step(fraction, start=start, k=len(part)):
                progress((start + fraction * k) / len(items))
        yield from map_parallel(fn, part, step)


class SplitMatrix:
    """A CSR matrix whose products with vectors run on all cores.

    ``M @ v`` for ``v`` of shape (n,) gives the same numbers as the CSR
    matrix's own product: each row is computed the same way, only on another
    thread.
    """

    def __init__(self, matrix, parts=None):
        matrix = sp.csr_matrix(matrix)
        self.matrix = matrix
        self.shape, self.dtype, self.nnz = matrix.shape, matrix.dtype, matrix.nnz
        parts = workers() if parts is None else int(parts)
        if parts < 2 or matrix.nnz < _MIN_SPLIT:
            self.bounds = [(0, matrix.shape[0])]
            self.blocks = [matrix]
            return
        indptr = matrix.indptr
        cuts = np.searchsorted(indptr, np.linspace(0, matrix.nnz, parts + 1)[1:-1])
        edges = [0, *sorted(set(int(c) for c in cuts)), matrix.shape[0]]
        self.bounds = [(s, e) for s, e in zip(edges[:-1], edges[1:]) if e > s]
        self.blocks = []
        for s, e in self.bounds:
            a, b = indptr[s], indptr[e]
            # set the arrays after construction: SciPy's constructor copies a view
            # of less than half its base array ("pruning"), which would double E
            block = sp.csr_matrix((e - s, matrix.shape[1]), dtype=matrix.dtype)
            block.indptr = (indptr[s:e + 1] - a).astype(indptr.dtype)
            block.indices = matrix.indices[a:b]
            block.data = matrix.data[a:b]
            self.blocks.append(block)

    @classmethod
    def stacked(cls, blocks, columns, dtype):
        """The rows of the CSR ``blocks``, one above the other, each block multiplied on its own thread."""
        self = cls.__new__(cls)
        rows = np.cumsum([0] + [b.shape[0] for b in blocks])
        self.shape, self.dtype = (int(rows[-1]), int(columns)), np.dtype(dtype)
        self.blocks = [sp.csr_matrix(b, dtype=dtype) for b in blocks]
        self.nnz = sum(b.nnz for b in self.blocks)
        self.bounds = list(zip(rows[:-1], rows[1:]))
        self.matrix = None
        return self

    def __matmul__(self, v):
        if v.ndim != 1:
            raise ValueError("SplitMatrix multiplies one vector at a time")
        if len(self.blocks) == 1:
            return self.blocks[0] @ v
        out = np.empty(self.shape[0], dtype=np.result_type(self.dtype, v.dtype))

        def part(k):
            s, e = self.bounds[k]
            out[s:e] = self.blocks[k] @ v

        map_parallel(part, range(len(self.blocks)))
        return out
