"""Sparse products on all cores: the same numbers as SciPy's, in row blocks on threads."""

import numpy as np
import scipy.sparse as sp

from cp_stylize import Band, Torus
from cp_stylize.sparse import SplitMatrix, map_parallel, map_windows, workers


def test_split_products_equal_the_plain_ones():
    band = Band.build(Torus(1.0, 0.4), 0.03)
    v = np.random.default_rng(1).random(band.size).astype(np.float32)
    split = SplitMatrix(band.extension_matrix(), parts=3)
    assert len(split.blocks) == 3
    np.testing.assert_array_equal(split @ v, band.extension_matrix() @ v)
    small = SplitMatrix(sp.identity(10, format="csr"), parts=4)  # too small to split
    assert len(small.blocks) == 1 and np.array_equal(small @ np.arange(10.0), np.arange(10.0))


def test_map_parallel_keeps_the_order_and_nests_without_waiting_forever():
    inner = lambda k: [k * 10 + j for j in range(3)]
    assert map_parallel(lambda k: map_parallel(lambda j: j, inner(k)), range(5)) == [inner(k) for k in range(5)]


def test_map_windows_yields_in_order_and_runs_only_a_window_ahead_of_its_consumer():
    started, seen = [], []

    def fn(k):
        started.append(k)
        return k * k

    for k, out in enumerate(map_windows(fn, range(40), progress=seen.append)):
        assert out == k * k
        assert max(started) < k + 2 * workers()           # no more than a window computed ahead of the consumer
    assert len(started) == 40
    assert seen == sorted(seen) and seen[-1] == 1.0
