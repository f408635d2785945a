"""The local frame of the k-nearest-neighbour references, and the reach it refuses."""

from __future__ import annotations

import numpy as np

__all__ = ["FLOAT32_REACH", "float32_origin", "local_frame"]

#: How far from the local origin (float32_origin) a coordinate may lie: 2^24 x 0.1,
#: where float32's step reaches 0.125. The core's kFloat32Reach (points.hpp), whose
#: message local_frame repeats, so that the reference refuses what the core refuses
#: (in float64 a stray point at 1e160 overflowed the deviation and made every point an
#: outlier).
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
    if len(xyz) == 0:
        return np.zeros(3)
    first, third = (len(xyz) - 1) // 4, 3 * (len(xyz) - 1) // 4
    quartiles = np.partition(xyz, [first, third], axis=0)
    q1, q3 = quartiles[first], quartiles[third]
    fence = q1 - ORIGIN_FENCE * (q3 - q1)
    return np.where(xyz >= fence, xyz, np.inf).min(axis=0)


def local_frame(xyz: np.ndarray) -> np.ndarray:
    """`xyz` less :func:`float32_origin` (float64), or ValueError beyond FLOAT32_REACH."""
    local = xyz - float32_origin(xyz)
    if not (np.abs(local) <= FLOAT32_REACH).all():
        raise ValueError(
            "points: a coordinate lies more than 2^24 x 0.1 = 1677721.6 (metres for LiDAR) "
            "from the local origin on some axis, where float32, which this step computes "
            "in, resolves no better than 0.125; a stray point far from the rest? drop it, "
            "or split the cloud into tiles"
        )
    return local
