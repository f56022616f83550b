"""skelcore.distinct returns what np.unique returns, by sorting (numpy 2.4's np.unique hashes 1-D values and
compares rows as records, 70x and 4x slower at a million)."""
import numpy as np
import pytest

from skelcore.distinct import distinct, distinct_rows, row_groups


@pytest.mark.parametrize("high", [3, 1000, 2**40])
def test_distinct_values_and_rows_match_numpys_unique(high):
    rng = np.random.default_rng(high)
    values = rng.integers(-high, high, 5000)
    np.testing.assert_array_equal(distinct(values), np.unique(values))
    rows = rng.integers(-high, high, (5000, 3))
    np.testing.assert_array_equal(distinct_rows(rows), np.unique(rows, axis=0))
    _, inverse, counts = np.unique(rows, axis=0, return_inverse=True, return_counts=True)
    group, sizes = row_groups(rows)
    np.testing.assert_array_equal(group, inverse.ravel())
    np.testing.assert_array_equal(sizes, counts)


def test_empty_and_float_input():
    assert distinct(np.zeros(0, dtype=np.int64)).shape == (0,)
    assert distinct_rows(np.zeros((0, 2), dtype=np.int64)).shape == (0, 2)
    group, sizes = row_groups(np.zeros((0, 3)))
    assert group.shape == (0,) and sizes.shape == (0,)
    points = np.array([[0.5, 1.0, 2.0], [0.5, 1.0, 2.0], [-1.0, 0.0, 0.0]])
    np.testing.assert_array_equal(distinct_rows(points), np.unique(points, axis=0))
    np.testing.assert_array_equal(distinct(points[:, 0]), [-1.0, 0.5])
