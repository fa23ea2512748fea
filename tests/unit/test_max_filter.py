"""granflow.max_filter against scipy.ndimage.maximum_filter: the same values (signs of zero
included) and dtype for the windows, modes and dtypes the solver uses, plus wider windows than
the array and the argument checks."""
from __future__ import annotations

import doctest
import zlib

import numpy as np
import pytest
from scipy import ndimage

import granflow.max_filter
from granflow.max_filter import maximum_filter

MODES = ["nearest", "constant", "wrap", ("wrap", "nearest"), ("wrap", "constant")]


def sample(shape, dtype, rng):
    if dtype == "bool":
        return rng.random(shape) < 0.1
    if dtype == "int":
        return rng.integers(-5, 5, shape)
    a = np.where(rng.random(shape) < 0.5, 0.0, rng.random(shape))  # packing-like: many zeros
    a[rng.random(shape) < 0.1] = -0.0
    return a


@pytest.mark.parametrize("shape", [(1, 1), (1, 5), (7, 3), (3, 7), (40, 16), (2, 50), (64, 64)])
@pytest.mark.parametrize("size", [1, 3, 5, 9, 21, 41])
@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("dtype", ["bool", "float", "int"])
def test_equals_scipy(shape, size, mode, dtype):
    a = sample(shape, dtype, np.random.default_rng(zlib.crc32(repr((shape, size, mode, dtype)).encode())))
    expected, got = ndimage.maximum_filter(a, size=size, mode=mode), maximum_filter(a, size, mode)
    assert got.dtype == expected.dtype
    np.testing.assert_array_equal(got, expected)
    np.testing.assert_array_equal(np.signbit(got), np.signbit(expected))


def test_other_dimensions_and_the_input_untouched():
    a = sample((5, 6, 7), "float", np.random.default_rng(1))
    before = a.copy()
    np.testing.assert_array_equal(maximum_filter(a, 3, "nearest"), ndimage.maximum_filter(a, 3, mode="nearest"))
    np.testing.assert_array_equal(a, before)
    assert maximum_filter(a, 1) is not a


@pytest.mark.parametrize("size, mode", [(2, "nearest"), (0, "nearest"), (3, "reflect"), (3, ("wrap",))])
def test_refuses_what_it_does_not_implement(size, mode):
    with pytest.raises(ValueError):
        maximum_filter(np.zeros((3, 3)), size, mode)


def test_docstring_examples():
    result = doctest.testmod(granflow.max_filter)
    assert result.attempted > 0 and result.failed == 0
