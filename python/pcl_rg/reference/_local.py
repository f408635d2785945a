"""The local frame of the k-nearest-neighbour references, and the reach it refuses."""

from __future__ import annotations

import numpy as np

__all__ = ["FLOAT32_REACH", "local_frame"]

#: How far from the local origin (the minimum corner) a coordinate may lie: 2^24 x 0.1,
#: where float32's step reaches 0.125. The core's kFloat32Reach (points.hpp), whose
#: message local_frame repeats, so that the reference refuses what the core refuses
#: (in float64 a stray point at 1e160 overflowed the deviation and made every point an
#: outlier).
FLOAT32_REACH = 2.0**24 * 0.1


def local_frame(xyz: np.ndarray) -> np.ndarray:
    """`xyz` less its minimum corner (float64), or ValueError beyond FLOAT32_REACH."""
    local = xyz - xyz.min(axis=0)
    if not (np.abs(local) <= FLOAT32_REACH).all():
        raise ValueError(
            "points: a coordinate lies more than 2^24 x 0.1 = 1677721.6 (metres for LiDAR) "
            "from the local origin on some axis, where float32, which this step computes "
            "in, resolves no better than 0.125; a stray point far from the rest? drop it, "
            "or split the cloud into tiles"
        )
    return local
