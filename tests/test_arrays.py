"""Shared input checks and array helpers."""

import numpy as np
import pytest

from cp_stylize.arrays import as_points, count, expand_runs, split_counts, unit_rows


def test_count_names_the_value_and_the_limit():
    assert count(3, "n") == 3 and count(np.int64(0), "margin", minimum=0) == 0
    with pytest.raises(ValueError, match=r"^n must be a positive integer, got 0$"):
        count(0, "n")
    with pytest.raises(ValueError, match=r"^pad must be a non-negative integer number of texels, got -1$"):
        count(-1, "pad", minimum=0, unit=" number of texels")
    for bad in (2.0, True, "3"):
        with pytest.raises(TypeError, match="must be an integer"):
            count(bad, "n")


def test_unit_rows_keep_zero_rows_or_take_the_fallback():
    v = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 0.0]])
    unit, length = unit_rows(v)
    np.testing.assert_allclose(unit, [[0.6, 0.8, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_allclose(length, [5.0, 0.0])
    np.testing.assert_allclose(unit_rows(v, (0.0, 0.0, 1.0))[0][1], [0.0, 0.0, 1.0])


def test_runs_expand_and_chunks_split_by_their_counts():
    run, pos = expand_runs(np.array([2, 0, 3]))
    assert run.tolist() == [0, 0, 2, 2, 2] and pos.tolist() == [0, 1, 0, 1, 2]
    bounds = split_counts(np.array([5, 5, 5, 5, 5]), 10)
    assert bounds[0] == 0 and bounds[-1] == 5 and np.all(np.diff(bounds) > 0)


def test_points_must_be_finite_rows_of_three():
    assert as_points([[1, 2, 3]]).dtype == np.float64
    with pytest.raises(ValueError, match=r"points must have shape \(N, 3\), got \(3,\)"):
        as_points([1, 2, 3])
    with pytest.raises(ValueError, match=r"points must be finite, got \[nan, 0.0, 0.0\] at row 1"):
        as_points([[0, 0, 0], [np.nan, 0, 0]])
