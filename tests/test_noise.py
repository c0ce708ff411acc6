"""Palette noise (paper, section 5.2.3)."""

import numpy as np
import pytest

from cp_stylize.noise import inject_noise


def test_noise_replaces_the_requested_fraction_with_palette_colours():
    values = np.full((20000, 3), 0.5, np.float32)
    palette = [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    out = inject_noise(values, 0.67, palette, weights=[1, 3], seed=4)
    changed = np.any(out != 0.5, axis=1)
    assert abs(changed.mean() - 0.67) < 0.02
    blue = np.all(out == (0.0, 0.0, 1.0), axis=1)
    assert abs(blue.sum() / changed.sum() - 0.75) < 0.03
    np.testing.assert_array_equal(inject_noise(values, 0.67, palette, weights=[1, 3], seed=4), out)
    assert np.all(values == 0.5)


def test_noise_rejects_a_palette_of_the_wrong_width():
    with pytest.raises(ValueError, match="palette must have shape"):
        inject_noise(np.zeros((5, 3)), 0.5, [(1.0, 0.0)])


def test_the_same_seed_gives_the_same_noise_and_another_seed_other_noise():
    values = np.zeros((5000, 3), np.float32)
    palette = [(1.0, 0.0, 0.0), (0.0, 0.0, 1.0)]
    a = inject_noise(values, 0.5, palette, seed=3)
    assert np.array_equal(a, inject_noise(values, 0.5, palette, seed=3))
    assert not np.array_equal(a, inject_noise(values, 0.5, palette, seed=4))
