"""pcl_rg.evaluation.ground_errors: Sithole & Vosselman's errors and Cohen's kappa."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from pcl_rg.evaluation import GroundErrors, ground_errors


def labels_from_counts(a: int, b: int, c: int, d: int, seed: int = 0):
    """truth, predicted holding a, b, c, d points of each cell, in shuffled order."""
    truth = np.r_[np.ones(a + b, bool), np.zeros(c + d, bool)]
    predicted = np.r_[np.ones(a, bool), np.zeros(b, bool), np.ones(c, bool), np.zeros(d, bool)]
    order = np.random.default_rng(seed).permutation(len(truth))
    return truth[order], predicted[order]


def test_hand_computed_table():
    # a = 5 ground kept, b = 2 ground lost, c = 3 objects accepted, d = 10 objects rejected.
    # n = 20; Type I = 2/7; Type II = 3/13; total = 5/20;
    # p_o = 15/20, p_e = (7 * 8 + 13 * 12) / 400 = 212/400, kappa = (300 - 212) / (400 - 212).
    e = ground_errors(*labels_from_counts(5, 2, 3, 10))
    assert isinstance(e, GroundErrors)
    assert e.confusion.dtype == np.int64
    np.testing.assert_array_equal(e.confusion, [[5, 2], [3, 10]])
    assert e.type_i == pytest.approx(2 / 7, rel=1e-15)
    assert e.type_ii == pytest.approx(3 / 13, rel=1e-15)
    assert e.total == pytest.approx(0.25, rel=1e-15)
    assert e.kappa == pytest.approx(88 / 188, rel=1e-15)


def test_perfect_and_inverted_predictions():
    truth, _ = labels_from_counts(6, 0, 0, 6)
    perfect = ground_errors(truth, truth)
    assert (perfect.type_i, perfect.type_ii, perfect.total, perfect.kappa) == (0, 0, 0, 1)
    inverted = ground_errors(truth, ~truth)
    assert (inverted.type_i, inverted.type_ii, inverted.total, inverted.kappa) == (1, 1, 1, -1)


def test_all_ground_truth_and_prediction():
    """No true object: Type II is NaN; identical constant labelings: kappa NaN (p_e = 1)."""
    truth = np.ones(7, bool)
    e = ground_errors(truth, truth)
    np.testing.assert_array_equal(e.confusion, [[7, 0], [0, 0]])
    assert e.type_i == 0.0 and e.total == 0.0
    assert math.isnan(e.type_ii) and math.isnan(e.kappa)


def test_no_ground_at_all():
    """No true ground: Type I is NaN."""
    truth = np.zeros(5, bool)
    e = ground_errors(truth, truth)
    np.testing.assert_array_equal(e.confusion, [[0, 0], [0, 5]])
    assert math.isnan(e.type_i) and math.isnan(e.kappa)
    assert e.type_ii == 0.0 and e.total == 0.0
    missed = ground_errors(truth, np.ones(5, bool))
    assert math.isnan(missed.type_i)
    assert (missed.type_ii, missed.total, missed.kappa) == (1.0, 1.0, 0.0)


def test_all_ground_predicted_as_object():
    e = ground_errors(np.ones(4, bool), np.zeros(4, bool))
    np.testing.assert_array_equal(e.confusion, [[0, 4], [0, 0]])
    assert e.type_i == 1.0 and e.total == 1.0 and e.kappa == 0.0
    assert math.isnan(e.type_ii)


def test_constant_prediction_on_mixed_truth_has_zero_kappa():
    truth, _ = labels_from_counts(30, 0, 0, 11)
    for constant in (True, False):
        e = ground_errors(truth, np.full(len(truth), constant))
        assert e.kappa == 0.0


def test_empty_input():
    e = ground_errors(np.zeros(0, bool), np.zeros(0, bool))
    np.testing.assert_array_equal(e.confusion, np.zeros((2, 2)))
    assert all(math.isnan(v) for v in (e.type_i, e.type_ii, e.total, e.kappa))


def test_lists_are_accepted():
    e = ground_errors([True, False, True], [True, True, False])
    np.testing.assert_array_equal(e.confusion, [[1, 1], [1, 0]])
    empty = ground_errors([], [])  # [] is float64 to NumPy
    assert empty.confusion.sum() == 0 and math.isnan(empty.total)


def test_masked_arrays_are_refused_not_unmasked():
    masked = np.ma.masked_array([True, False, True], mask=[0, 0, 1])
    with pytest.raises(ValueError, match="masked"):
        ground_errors(masked, np.ones(3, bool))


@pytest.mark.parametrize(
    ("truth", "predicted", "error", "match"),
    [
        (np.ones(3, bool), np.ones(4, bool), ValueError, "same length, got 3 and 4"),
        (np.ones(3, int), np.ones(3, bool), TypeError, "truth must be a boolean array, got dtype"),
        (np.ones(3, bool), np.ones(3, float), TypeError, "predicted must be a boolean array"),
        (np.ones((2, 2), bool), np.ones((2, 2), bool), ValueError, "truth must be one-dimensional"),
        (np.ones(2, bool), np.bool_(True), ValueError, "predicted must be one-dimensional"),
    ],
)
def test_bad_input(truth, predicted, error, match):
    with pytest.raises(error, match=match):
        ground_errors(truth, predicted)


@settings(max_examples=examples(200), deadline=None)
@given(
    pair=st.integers(0, 60).flatmap(
        lambda n: st.tuples(hnp.arrays(np.bool_, n), hnp.arrays(np.bool_, n))
    )
)
def test_identities(pair):
    truth, predicted = pair
    e = ground_errors(truth, predicted)
    (a, b), (c, d) = e.confusion.tolist()
    n = len(truth)
    assert a + b + c + d == n
    assert a + b == truth.sum() and a + c == predicted.sum()
    if n:
        assert e.total == pytest.approx(np.mean(truth != predicted), rel=1e-12)
    # The closed form of kappa for a 2 x 2 table, 2 (ad - bc) / ((a+b)(b+d) + (a+c)(c+d)).
    denominator = (a + b) * (b + d) + (a + c) * (c + d)
    if denominator:
        assert e.kappa == pytest.approx(2 * (a * d - b * c) / denominator, rel=1e-12, abs=1e-15)
        assert -1.0 <= e.kappa <= 1.0
    else:
        assert math.isnan(e.kappa)
    # Swapping the roles of ground and object swaps the two error types.
    swapped = ground_errors(~truth, ~predicted)
    np.testing.assert_equal((swapped.type_i, swapped.type_ii), (e.type_ii, e.type_i))
