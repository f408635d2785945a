"""Segmentation scores against ground truth (algorithms.md, Evaluation).

Re-exported as :func:`pcl_rg.evaluation.segmentation_scores`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ._validation import as_labels

__all__ = ["SegmentationScores", "segmentation_scores"]

#: Share of a truth segment a cluster must hold to count in over/under-segmentation.
COVER_FRACTION = 0.1


class SegmentationScores(NamedTuple):
    """Result of :func:`segmentation_scores`."""

    mean_iou: float
    """Mean over truth segments of the IoU of the best-matching cluster (NaN: no segment)."""
    over_segmented: int
    """Truth segments split over >= 2 clusters each holding >= 10 % of the segment."""
    under_segmented: int
    """Clusters holding >= 10 % of each of >= 2 truth segments."""
    adjusted_rand_index: float
    """ARI over the points with a truth segment and a cluster (NaN when none)."""
    segment_ids: np.ndarray
    """Truth segment ids (sorted), the rows of ``best_iou``."""
    best_iou: np.ndarray
    """float64: IoU of each truth segment with its best-matching cluster (0 if none)."""
    n_clusters: int
    """Clusters (labels >= 0) that touch at least one evaluated point."""


def _check_labels(name: str, values: npt.ArrayLike) -> np.ndarray:
    array = as_labels(name, values, np.int64)
    if array.dtype.kind not in "iu":
        raise TypeError(f"{name} must be an integer array, got dtype {array.dtype}")
    if array.dtype.kind == "u" and array.size and array.max() > np.iinfo(np.int64).max:
        # int64 would wrap them to negative ids, read as "unassigned"
        raise ValueError(f"{name} has ids above 2**63 - 1, got {array.max()}")
    return array.astype(np.int64)


def _pairs(counts: np.ndarray) -> float:
    """Sum of count * (count - 1) / 2, in float64 (exact up to 2**53)."""
    c = counts.astype(np.float64)
    return float((c * (c - 1.0) / 2.0).sum())


def _adjusted_rand_index(truth: np.ndarray, labels: np.ndarray) -> float:
    """Hubert & Arabie's ARI from the contingency table (the permutation model)."""
    n = truth.size
    if n == 0:
        return float("nan")
    _, t = np.unique(truth, return_inverse=True)
    _, c = np.unique(labels, return_inverse=True)
    _, cell = np.unique(t.astype(np.int64) * (c.max() + 1) + c, return_counts=True)
    index = _pairs(cell)
    rows = _pairs(np.bincount(t))
    cols = _pairs(np.bincount(c))
    total = n * (n - 1) / 2.0
    expected = rows * cols / total if total > 0 else 0.0
    maximum = (rows + cols) / 2.0
    if maximum == expected:  # both partitions trivial (one block, or all singletons)
        return 1.0
    return float((index - expected) / (maximum - expected))


def segmentation_scores(truth: npt.ArrayLike, labels: npt.ArrayLike) -> SegmentationScores:
    """Score a segmentation against ground truth segments.

    Parameters
    ----------
    truth : array_like of int, shape (N,)
        Ground-truth segment per point; 0 means "no truth" (e.g. mOSD's
        invalid points) and such points are ignored entirely.
    labels : array_like of int, shape (N,)
        Cluster per point, -1 (any negative value) for unassigned points.

    Returns
    -------
    SegmentationScores
        ``mean_iou``, ``over_segmented``, ``under_segmented``,
        ``adjusted_rand_index``, plus ``segment_ids``/``best_iou`` per truth
        segment and ``n_clusters``.

    Raises
    ------
    TypeError
        Non-integer arrays.
    ValueError
        Arrays of different lengths or not one-dimensional, or a negative truth
        id (map unlabelled points to 0).

    Notes
    -----
    Only points with ``truth != 0`` are evaluated. On those:

    * IoU of truth segment T and cluster C is ``|T & C| / |T | C|``; each T
      is scored by its best cluster. Unassigned points (label < 0) belong to
      no cluster: they lower the IoU of their segment (they are in T but in
      no C) and never form a match. ``mean_iou`` averages over segments.
    * Over-segmentation: segments T with at least two clusters C each holding
      ``|T & C| >= 0.1 |T|``.
    * Under-segmentation: clusters C holding ``|T & C| >= 0.1 |T|`` for at
      least two segments T.
    * Adjusted Rand index (Hubert & Arabie 1985) over the points that have a
      truth segment and a cluster (unassigned points excluded). It is 1.0 when
      both partitions of those points are trivial in the same way (e.g. one
      block each), NaN when no point remains.

    References
    ----------
    algorithms.md, Evaluation; Hubert & Arabie, "Comparing partitions",
    Journal of Classification 2, 1985.

    Examples
    --------
    >>> from pcl_rg.evaluation import segmentation_scores
    >>> truth = [1, 1, 1, 1, 2, 2, 2, 2, 0]
    >>> labels = [0, 0, 1, 1, 2, 2, 2, -1, 5]
    >>> s = segmentation_scores(truth, labels)
    >>> s.best_iou.tolist(), s.over_segmented, s.under_segmented
    ([0.5, 0.75], 1, 0)
    >>> round(s.adjusted_rand_index, 4)
    0.5882
    """
    t = _check_labels("truth", truth)
    c = _check_labels("labels", labels)
    if t.shape != c.shape:
        raise ValueError(f"truth and labels must have the same length, got {t.size} and {c.size}")
    if t.size and t.min() < 0:
        # A negative id is another convention's "unlabelled"; read as a segment it
        # would lower every score silently.
        raise ValueError(
            f"truth ids must be >= 0 (0: no truth), got {t.min()} at "
            f"{int(np.count_nonzero(t < 0))} points; map unlabelled points to 0"
        )
    evaluated = t != 0
    t, c = t[evaluated], c[evaluated]
    c = np.where(c < 0, -1, c)

    segment_ids, segment_of, segment_size = np.unique(t, return_inverse=True, return_counts=True)
    assigned = c >= 0
    cluster_ids, cluster_of, cluster_size = np.unique(
        c[assigned], return_inverse=True, return_counts=True
    )
    n_seg, n_clu = segment_ids.size, cluster_ids.size
    # Sparse contingency table over assigned points: (segment, cluster) -> count.
    key = segment_of[assigned].astype(np.int64) * max(n_clu, 1) + cluster_of
    cells, overlap = np.unique(key, return_counts=True)
    cell_segment, cell_cluster = cells // max(n_clu, 1), cells % max(n_clu, 1)

    union = segment_size[cell_segment] + cluster_size[cell_cluster] - overlap
    iou = overlap / union
    best_iou = np.zeros(n_seg)
    np.maximum.at(best_iou, cell_segment, iou)

    big = overlap >= COVER_FRACTION * segment_size[cell_segment]
    over = int((np.bincount(cell_segment[big], minlength=n_seg) >= 2).sum())
    under = int((np.bincount(cell_cluster[big], minlength=n_clu) >= 2).sum())

    return SegmentationScores(
        mean_iou=float(best_iou.mean()) if n_seg else float("nan"),
        over_segmented=over,
        under_segmented=under,
        adjusted_rand_index=_adjusted_rand_index(t[assigned], c[assigned]),
        segment_ids=segment_ids,
        best_iou=best_iou,
        n_clusters=int(n_clu),
    )
