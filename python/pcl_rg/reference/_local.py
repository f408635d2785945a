"""The local frame of the k-nearest-neighbour references, and the far points it leaves out."""

from __future__ import annotations

import numpy as np

__all__ = [
    "FLOAT32_REACH",
    "ORIGIN_FENCE",
    "fenced_box",
    "float32_origin",
    "local_frame",
    "max_far_points",
    "near_rows",
]

#: How far from the local origin (float32_origin) a coordinate may lie: 2^24 x 0.1,
#: where float32's step reaches 0.125. The core's kFloat32Reach (points.hpp). A point
#: beyond it on some axis is far (near_rows).
FLOAT32_REACH = 2.0**24 * 0.1


#: The fence of float32_origin in interquartile ranges below the first quartile (the
#: core's kOriginFence, points.hpp).
ORIGIN_FENCE = 4.0


def float32_origin(xyz: np.ndarray) -> np.ndarray:
    """The local origin of the core's float32 frames (points.hpp, float32_origin): per
    axis the least coordinate not below q1 - ORIGIN_FENCE * (q3 - q1), the quartiles
    being the elements at (N - 1) // 4 and 3 (N - 1) // 4 in sorted order. The minimum
    corner, unless a stray point lies far below the rest: then it would carry the frame
    away from them."""
    return fenced_box(xyz)[0]


def fenced_box(xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The bounding box of the points within q1 - ORIGIN_FENCE * (q3 - q1) and
    q3 + ORIGIN_FENCE * (q3 - q1) per axis (the core's fenced_box, points.hpp): the box
    without stray points; its lower corner is :func:`float32_origin`."""
    if len(xyz) == 0:
        return np.zeros(3), np.zeros(3)
    low, high = zip(*(fenced_range(xyz[:, a]) for a in range(3)), strict=True)
    return np.array(low), np.array(high)


def fenced_range(values: np.ndarray, min_reach: float = 0.0) -> tuple[float, float]:
    """The range of `values` (N > 0) within max(min_reach, ORIGIN_FENCE * (q3 - q1)) of
    their quartiles q1 and q3 (the core's fenced_range, points.hpp)."""
    first, third = (len(values) - 1) // 4, 3 * (len(values) - 1) // 4
    quartiles = np.partition(values, [first, third])
    q1, q3 = quartiles[first], quartiles[third]
    reach = max(min_reach, ORIGIN_FENCE * (q3 - q1))
    return float(values[values >= q1 - reach].min()), float(values[values <= q3 + reach].max())


def max_far_points(n: int) -> int:
    """How many far points (:func:`near_rows`) a step leaves out of `n`: 1 % of n, at
    least one (the core's max_far_points, points.hpp)."""
    return max(1, n // 100)


def near_rows(xyz: np.ndarray) -> np.ndarray | None:
    """The rows of `xyz` (non-empty) that are not far, or None when none is far.

    A point is far when it lies more than FLOAT32_REACH from :func:`float32_origin`
    on some axis: a stray point that float32 cannot place among the rest. The
    k-nearest-neighbour steps leave up to :func:`max_far_points` of them out, running on
    the other rows as if they were absent (the core's float32_frame, points.hpp); more
    raise ValueError, with the core's message.
    """
    with np.errstate(over="ignore"):  # 1e308 - -1e308: inf, far all the same
        near = (np.abs(xyz - float32_origin(xyz)) <= FLOAT32_REACH).all(axis=1)
    far = len(xyz) - int(near.sum())
    if far == 0:
        return None
    if far > max_far_points(len(xyz)):
        raise ValueError(
            f"points: {far} of {len(xyz)} points lie more than 2^24 x 0.1 = 1677721.6 "
            "(metres for LiDAR) from the local origin on some axis, where float32, which "
            "this step computes in, resolves no better than 0.125; up to 1 % of the points "
            "(at least one) are taken for stray points and left out, more mean a cloud too "
            "wide for one float32 frame: split it into tiles"
        )
    return np.flatnonzero(near)


def local_frame(xyz: np.ndarray) -> np.ndarray:
    """`xyz` less :func:`float32_origin` (float64), for a cloud without far points."""
    return xyz - float32_origin(xyz)
