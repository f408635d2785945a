"""Input gate shared by every public function: points, labels and plain numbers."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = [
    "MAX_POINTS_INT32",
    "MAX_POINTS_UINT32",
    "as_labels",
    "as_points",
    "as_real",
]


# Largest clouds the core's index types can number: point ids are uint32 in the
# k-NN index, the radix sort and VoxelGrid; labels and triangle/vertex ids are int32.
MAX_POINTS_UINT32 = 2**32 - 1
MAX_POINTS_INT32 = 2**31 - 1


def as_points(
    points: npt.ArrayLike, name: str = "points", *, max_points: int = MAX_POINTS_INT32
) -> np.ndarray:
    """Return `points` as a C-contiguous float64 (N, 3) array, or raise.

    Accepts any real float or integer array-like of shape (N, 3) in C or F
    order. The input is never modified (a copy is made only when needed).
    `max_points` is the caller's index-type limit, checked before any copy.

    Raises
    ------
    TypeError
        For complex, boolean, object, string or other non-numeric dtypes.
    ValueError
        For a wrong shape, more than `max_points` rows, non-finite values (the
        count and first indices are named), or masked entries.
    """
    if np.ma.is_masked(points):  # np.asarray would drop the mask: masked rows would count
        raise ValueError(
            f"{name}: masked arrays are not accepted (their masked rows would be used); "
            "select the unmasked points first, e.g. points[~points.mask.any(axis=1)].data"
        )
    try:
        array = np.asarray(points)
    except ValueError:  # a ragged sequence: rows of different lengths
        raise ValueError(f"{name} must have shape (N, 3): its rows differ in length") from None
    kind = array.dtype.kind
    if kind not in "fiu":
        raise TypeError(f"{name} must be a real float or integer array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {array.shape}")
    if array.shape[0] > max_points:
        index_type = "uint32" if max_points == MAX_POINTS_UINT32 else "int32"
        raise ValueError(
            f"{name}: at most {max_points:,} points are supported (the core numbers points "
            f"with {index_type}), got {array.shape[0]:,}; split the cloud into tiles"
        )
    array = np.ascontiguousarray(array, dtype=np.float64)
    if not np.isfinite(array).all():  # one pass in the common, clean case
        bad = np.flatnonzero(~np.isfinite(array).all(axis=1))
        first = ", ".join(str(i) for i in bad[:5])
        more = ", ..." if bad.size > 5 else ""
        raise ValueError(
            f"{name} has {bad.size} point(s) with NaN or Inf coordinates "
            f"(rows {first}{more}); drop or fill them first"
        )
    return array


def as_labels(name: str, values: npt.ArrayLike, empty: npt.DTypeLike) -> np.ndarray:
    """`values` as a one-dimensional array of labels, or raise ValueError.

    A masked array is refused (np.asarray would drop its mask, and every point would
    be scored); an empty list, which NumPy makes float64, becomes an empty array of
    `empty`. The caller checks the dtype.
    """
    if np.ma.is_masked(values):
        raise ValueError(f"{name}: masked arrays are not scored; select the points first")
    array = np.asarray(values)
    if array.size == 0 and array.dtype.kind == "f":
        array = array.astype(empty)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    return array


def as_real(name: str, values: npt.ArrayLike) -> np.ndarray:
    """`values` as a float64 array, or raise naming `name`.

    Only real numbers (a float or integer dtype) pass: complex, bool, string and
    object input is a TypeError. ``np.asarray(values, dtype=float64)`` would drop an
    imaginary part with only a warning, and read True or "1" as 1.0.
    """
    if np.ma.is_masked(values):  # np.asarray would drop the mask and use the values
        raise ValueError(f"{name}: masked arrays are not accepted, got {values!r}")
    try:
        array = np.asarray(values)
    except ValueError:  # a ragged sequence
        raise ValueError(f"{name} must be an array of numbers, got {values!r}") from None
    if array.dtype.kind not in "fiu":
        raise TypeError(f"{name} must be real numbers (float or integer), got dtype {array.dtype}")
    # NumPy reads a bool among numbers as one: (True, 5) is the integer array [1, 5].
    if isinstance(values, (list, tuple)) and _holds_a_bool(values):
        raise TypeError(f"{name} must be real numbers (float or integer), got a bool among them")
    return array.astype(np.float64, copy=False)


def _holds_a_bool(values: list | tuple) -> bool:
    """Whether a bool (Python's, NumPy's, or a bool array) stands in `values` or in the
    lists, tuples and arrays inside it; by the items' types, without copying them."""
    types = set(map(type, values))
    if types & {bool, np.bool_}:
        return True
    for item in values if types & {list, tuple, np.ndarray} else ():
        if isinstance(item, np.ndarray) and item.dtype.kind in "bO":
            if item.dtype.kind == "b" or _holds_a_bool(item.ravel().tolist()):
                return True
        elif isinstance(item, (list, tuple)) and _holds_a_bool(item):
            return True
    return False
