"""Scores of filters and segmenters against ground truth (flat module of functions)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ._segmentation_scores import SegmentationScores, segmentation_scores
from ._validation import as_labels

__all__ = ["GroundErrors", "SegmentationScores", "ground_errors", "segmentation_scores"]


class GroundErrors(NamedTuple):
    """Result of :func:`ground_errors` (Sithole & Vosselman 2004)."""

    type_i: float
    """Ground classified as object / all true ground (NaN when there is no true ground)."""
    type_ii: float
    """Object classified as ground / all true object (NaN when there is no true object)."""
    total: float
    """All misclassified points / all points (NaN for empty input)."""
    kappa: float
    """Cohen's kappa of the 2 x 2 table (NaN when chance agreement is 1, see Notes)."""
    confusion: np.ndarray
    """int64 (2, 2): rows truth (ground, object), columns predicted (ground, object)."""


def _labels(name: str, value: npt.ArrayLike) -> np.ndarray:
    array = np.asarray(value)
    if array.dtype != np.bool_ and not (array.size == 0 and array.dtype.kind == "f"):
        raise TypeError(f"{name} must be a boolean array, got dtype {array.dtype}")
    return as_labels(name, value, np.bool_)


def ground_errors(truth: npt.ArrayLike, predicted: npt.ArrayLike) -> GroundErrors:
    """Type I, Type II and total error and Cohen's kappa of a ground mask.

    Parameters
    ----------
    truth : array_like of bool, shape (N,)
        True ground labels (True = ground, False = object).
    predicted : array_like of bool, shape (N,)
        Labels from a filter, same length as `truth`.

    Returns
    -------
    GroundErrors
        ``type_i``, ``type_ii``, ``total`` and ``kappa`` as fractions (float,
        not percent) and ``confusion`` int64 (2, 2) ``[[a, b], [c, d]]`` with
        a = ground kept as ground, b = ground rejected (Type I errors),
        c = object accepted as ground (Type II errors), d = object rejected.

    Raises
    ------
    TypeError
        If an input is not a boolean array (segmentation_scores likewise
        refuses labels that are not integers).
    ValueError
        If an input is not one-dimensional, or the lengths differ.

    Notes
    -----
    The definitions of Sithole & Vosselman: Type I = b / (a + b),
    Type II = c / (c + d), total = (b + c) / n, and Cohen's kappa
    ``(p_o - p_e) / (1 - p_e)`` with observed agreement ``p_o = (a + d) / n``
    and chance agreement
    ``p_e = ((a + b)(a + c) + (c + d)(b + d)) / n**2``.

    Degenerate cases return NaN, without a warning, where a ratio has a zero
    denominator: Type I when there is no true ground, Type II when there is
    no true object, total and kappa for empty input, and kappa whenever
    ``p_e = 1``, which happens exactly when truth and prediction are both
    constant and equal (all ground, or all object, in both): agreement beyond
    chance is then undefined, not perfect. A constant prediction against a
    mixed truth gives kappa 0.

    References
    ----------
    G. Sithole and G. Vosselman, "Experimental comparison of filter
    algorithms for bare-Earth extraction from airborne laser scanning point
    clouds", ISPRS J. Photogramm. Remote Sens. 59(1-2), 2004;
    J. Cohen, "A coefficient of agreement for nominal scales", Educational
    and Psychological Measurement 20(1), 1960.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.evaluation import ground_errors
    >>> truth = np.array([True, True, True, True, False, False])
    >>> predicted = np.array([True, True, True, False, True, False])
    >>> e = ground_errors(truth, predicted)
    >>> e.type_i, e.type_ii, round(e.total, 4), round(e.kappa, 4)
    (0.25, 0.5, 0.3333, 0.25)
    >>> e.confusion.tolist()
    [[3, 1], [1, 1]]
    """
    t = _labels("truth", truth)
    p = _labels("predicted", predicted)
    if len(t) != len(p):
        raise ValueError(
            f"truth and predicted must have the same length, got {len(t)} and {len(p)}"
        )
    a = int(np.count_nonzero(t & p))
    b = int(np.count_nonzero(t & ~p))
    c = int(np.count_nonzero(~t & p))
    d = int(np.count_nonzero(~t & ~p))
    n = a + b + c + d
    confusion = np.array([[a, b], [c, d]], dtype=np.int64)

    def ratio(numerator: float, denominator: float) -> float:
        return numerator / denominator if denominator else float("nan")

    type_i = ratio(b, a + b)
    type_ii = ratio(c, c + d)
    total = ratio(b + c, n)
    # Integer arithmetic for the chance term, so p_e == 1 is detected exactly.
    chance = (a + b) * (a + c) + (c + d) * (b + d)
    kappa = ratio((a + d) * n - chance, n * n - chance)
    return GroundErrors(type_i, type_ii, total, kappa, confusion)
