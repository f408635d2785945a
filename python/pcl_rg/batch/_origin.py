"""The float32 origin of one run over the merged survey, found from the tiles' sorted
coordinates without merging them: batch denoise decides its far points from it, so
they are exactly the merged run's.

The core's origin (``_core.float32_origin``) is, per axis, the least coordinate not
below the fence q1 - ORIGIN_FENCE * (q3 - q1), q1 and q3 the coordinates at sorted
positions (N - 1) // 4 and 3 (N - 1) // 4. Stage 1 stores each tile's usable
coordinates sorted, one file an axis; the quartiles are then found by bisection over
the float64 values, each step counting with a binary search in every tile's
memory-mapped file, so a survey of any size costs a few pages a tile.
"""

from __future__ import annotations

import os
import struct

import numpy as np

from .. import _core


def save_sorted_axes(folder: str, metres: np.ndarray) -> None:
    """Stage 1: the tile's usable points (N, 3), in metres, sorted per axis."""
    for axis in range(3):
        np.save(os.path.join(folder, f"sorted{axis}.npy"), np.sort(metres[:, axis]))


def _key(value: float) -> int:
    """An integer whose order is the order of the float64 values (finite ones)."""
    bits = struct.unpack("<q", struct.pack("<d", value))[0]
    return bits if bits >= 0 else -(bits & 0x7FFF_FFFF_FFFF_FFFF)


def _value(key: int) -> float:
    """The float64 of :func:`_key`."""
    bits = key if key >= 0 else (-key) | -0x8000_0000_0000_0000
    return struct.unpack("<d", struct.pack("<q", bits))[0]


def _at_sorted_position(columns: list[np.ndarray], position: int) -> float:
    """The value at `position` (0-based) of the columns' union in sorted order: the
    least value of them that has more than `position` values at or below it."""
    low = _key(min(float(c[0]) for c in columns if len(c)))
    high = _key(max(float(c[-1]) for c in columns if len(c)))
    while low < high:
        middle = (low + high) // 2
        below = sum(int(np.searchsorted(c, _value(middle), side="right")) for c in columns)
        low, high = (low, middle) if below > position else (middle + 1, high)
    return _value(low)


def merged_float32_origin(folders: list[str]) -> tuple[float, float, float]:
    """``_core.float32_origin`` of the union of the tiles' points saved by
    :func:`save_sorted_axes` in `folders`, exactly; zeros when there are none."""
    origin = []
    for axis in range(3):
        columns = [np.load(os.path.join(f, f"sorted{axis}.npy"), mmap_mode="r") for f in folders]
        n = sum(len(c) for c in columns)
        if n == 0:
            return (0.0, 0.0, 0.0)
        q1 = _at_sorted_position(columns, (n - 1) // 4)
        q3 = _at_sorted_position(columns, 3 * (n - 1) // 4)
        fence = q1 - _core.ORIGIN_FENCE * (q3 - q1)  # in float64, as the core
        lowest = q1  # the least coordinate not below the fence: q1 is one
        for column in columns:
            first = int(np.searchsorted(column, fence, side="left"))
            if first < len(column):
                lowest = min(lowest, float(column[first]))
        origin.append(lowest)
    return (origin[0], origin[1], origin[2])


def far_points_error(far: int, points: int) -> str | None:
    """The merged run's refusal of `far` far points among the survey's `points` (a
    ValueError's message), or None: up to _core.max_far_points of them may be far."""
    if far <= _core.max_far_points(points):
        return None
    return (
        f"points: {far} of the survey's {points} points lie more than 2^24 x "
        "0.1 = 1677721.6 (metres for LiDAR) from the survey's local origin on some axis, "
        "where float32, which outlier removal computes in, resolves no better than 0.125; "
        "up to 1 % of a survey's points (at least one) are taken for stray points and left "
        "out, as one run over the merged survey leaves them out: remove the bad records "
        "first, or check the tiles' coordinates"
    )
