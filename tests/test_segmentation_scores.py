"""Tests of segmentation_scores on small hand-made cases (pcl_rg._segmentation_scores)."""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np
import pytest
from conftest import examples
from hypothesis import given, settings
from hypothesis import strategies as st

from pcl_rg.evaluation import segmentation_scores


def ari_by_pair_counting(truth: list[int], labels: list[int]) -> float:
    """ARI straight from its definition over all point pairs (slow, obvious)."""
    n = len(truth)
    both = same_t = same_c = 0
    for i, j in combinations(range(n), 2):
        t, c = truth[i] == truth[j], labels[i] == labels[j]
        both += t and c
        same_t += t
        same_c += c
    pairs = n * (n - 1) / 2
    if pairs == 0:
        return 1.0  # one point: both partitions trivial
    expected = same_t * same_c / pairs
    maximum = (same_t + same_c) / 2
    return 1.0 if maximum == expected else (both - expected) / (maximum - expected)


def test_perfect_segmentation() -> None:
    truth = [1, 1, 1, 20, 20, 30, 30, 30, 30]
    labels = [5, 5, 5, 0, 0, 7, 7, 7, 7]  # any cluster ids
    s = segmentation_scores(truth, labels)
    assert s.mean_iou == 1.0 and s.adjusted_rand_index == 1.0
    assert (s.over_segmented, s.under_segmented, s.n_clusters) == (0, 0, 3)
    assert s.segment_ids.tolist() == [1, 20, 30] and s.best_iou.tolist() == [1.0, 1.0, 1.0]


def test_over_segmentation_counts_splits_of_ten_percent() -> None:
    # Segment 1 (20 points): split 10/9/1 -> clusters 0 and 1 hold >= 10 %, cluster 2
    # holds 5 %: over-segmented once. Segment 2 (10 points): 9/1 -> the 1 is exactly
    # 10 %, so it counts too.
    truth = [1] * 20 + [2] * 10
    labels = [0] * 10 + [1] * 9 + [2] + [3] * 9 + [4]
    s = segmentation_scores(truth, labels)
    assert s.over_segmented == 2 and s.under_segmented == 0
    assert s.best_iou.tolist() == [0.5, 0.9]
    assert s.mean_iou == pytest.approx(0.7)


def test_under_segmentation_counts_clusters_covering_two_segments() -> None:
    # Cluster 0 takes all of segment 1 and 2 of segment 2's 10 points (20 % >= 10 %):
    # under-segmented. Cluster 1 takes the rest of segment 2 and 1 of segment 3's 20
    # points (5 %): not counted.
    truth = [1] * 10 + [2] * 10 + [3] * 20
    labels = [0] * 12 + [1] * 9 + [2] * 19
    s = segmentation_scores(truth, labels)
    assert s.under_segmented == 1 and s.over_segmented == 1  # segment 2 split 2/8
    iou1 = 10 / 12
    iou2 = 8 / (10 + 9 - 8)
    iou3 = 19 / 20
    np.testing.assert_allclose(s.best_iou, [iou1, iou2, iou3])


def test_unassigned_and_invalid_points() -> None:
    # truth 0 points are ignored entirely (even when clustered); label -1 points lower
    # their segment's IoU and are left out of the ARI.
    truth = [0, 0, 1, 1, 1, 1, 2, 2]
    labels = [3, 3, 3, 3, -1, -1, 4, 4]
    s = segmentation_scores(truth, labels)
    assert s.best_iou.tolist() == [0.5, 1.0]
    assert s.n_clusters == 2
    assert s.adjusted_rand_index == 1.0  # on the 4 assigned points the match is perfect
    assert s.over_segmented == 0  # -1 is no cluster
    other_negative = segmentation_scores(truth, [3, 3, 3, 3, -7, -2, 4, 4])
    assert other_negative.best_iou.tolist() == [0.5, 1.0]


def test_doc_example_ari_by_hand() -> None:
    # Assigned points: truth 1,1,1,1,2,2,2 vs clusters 0,0,1,1,2,2,2.
    # Same-cluster pairs within truth: 1 + 1 + 3 = 5; truth pairs 6 + 3 = 9; cluster
    # pairs 1 + 1 + 3 = 5; all pairs 21. ARI = (5 - 45/21) / ((9 + 5)/2 - 45/21) = 10/17.
    s = segmentation_scores([1, 1, 1, 1, 2, 2, 2, 2, 0], [0, 0, 1, 1, 2, 2, 2, -1, 5])
    assert s.adjusted_rand_index == pytest.approx(10 / 17)
    assert s.mean_iou == pytest.approx((0.5 + 0.75) / 2)


def test_ari_known_values() -> None:
    # Independent labelings of a 2x2 balanced design give a negative ARI: -0.5.
    independent = segmentation_scores([1, 1, 2, 2], [0, 1, 0, 1])
    assert independent.adjusted_rand_index == pytest.approx(-0.5)
    # Everything in one cluster against two segments: 0.
    assert segmentation_scores([1, 1, 2, 2], [0, 0, 0, 0]).adjusted_rand_index == 0.0


@settings(max_examples=examples(200), deadline=None)
@given(data=st.lists(st.tuples(st.integers(0, 4), st.integers(-1, 4)), min_size=0, max_size=25))
def test_ari_matches_pair_counting_and_bounds(data: list[tuple[int, int]]) -> None:
    truth = [t for t, _ in data]
    labels = [c for _, c in data]
    s = segmentation_scores(np.array(truth, dtype=np.int64), np.array(labels, dtype=np.int64))
    kept = [(t, c) for t, c in data if t != 0 and c >= 0]
    if kept:
        expected = ari_by_pair_counting([t for t, _ in kept], [c for _, c in kept])
        assert s.adjusted_rand_index == pytest.approx(expected, abs=1e-12)
    else:
        assert math.isnan(s.adjusted_rand_index)
    segments = {t for t in truth if t != 0}
    assert len(s.best_iou) == len(segments)
    assert ((s.best_iou >= 0) & (s.best_iou <= 1)).all()
    assert 0 <= s.over_segmented <= len(segments)
    if not segments:
        assert math.isnan(s.mean_iou)


def test_relabeling_invariance() -> None:
    rng = np.random.default_rng(0)
    truth = rng.integers(1, 6, 500)
    labels = np.where(rng.random(500) < 0.8, truth, rng.integers(-1, 8, 500))
    a = segmentation_scores(truth, labels)
    perm = rng.permutation(10) + 100
    b = segmentation_scores(truth, np.where(labels >= 0, perm[np.maximum(labels, 0)], -1))
    assert a.mean_iou == b.mean_iou
    assert a.adjusted_rand_index == pytest.approx(b.adjusted_rand_index)
    assert (a.over_segmented, a.under_segmented) == (b.over_segmented, b.under_segmented)


def test_errors() -> None:
    with pytest.raises(ValueError, match="same length"):
        segmentation_scores([1, 2], [0])
    with pytest.raises(TypeError, match="truth must be an integer array"):
        segmentation_scores([1.0, 2.0], [0, 0])
    with pytest.raises(TypeError, match="labels must be an integer array"):
        segmentation_scores([1, 2], ["a", "b"])
    with pytest.raises(ValueError, match="one-dimensional"):
        segmentation_scores([[1, 2]], [[0, 0]])
    with pytest.raises(ValueError, match=r"truth ids must be >= 0.*got -1 at 2 points"):
        segmentation_scores([-1, 1, 1, -1], [0, 0, 0, 0])
    empty = segmentation_scores(np.empty(0, np.int32), np.empty(0, np.int32))
    assert math.isnan(empty.mean_iou) and empty.over_segmented == 0


def test_unsigned_ids_beyond_int64_and_masked_arrays_are_refused():
    big = np.array([2**64 - 1, 2**64 - 1, 5, 5], np.uint64)  # would wrap to -1
    with pytest.raises(ValueError, match=r"ids above 2\*\*63 - 1"):
        segmentation_scores(np.array([1, 1, 2, 2], np.uint64), big)
    fine = np.array([2**63 - 1, 2**63 - 1, 5, 5], np.uint64)
    assert segmentation_scores(np.array([1, 1, 2, 2]), fine).n_clusters == 2
    masked = np.ma.masked_array([1, 1, 2, 2], mask=[0, 0, 1, 1])
    with pytest.raises(ValueError, match="masked"):
        segmentation_scores(masked, np.array([1, 1, 2, 2]))


def test_empty_lists_are_empty_scores():
    scores = segmentation_scores([], [])
    assert scores.n_clusters == 0 and len(scores.segment_ids) == 0
