"""The world lattice that the ground filters anchor their grids at."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["lattice_floor", "lowest_in_cells"]


def lowest_in_cells(z: np.ndarray, cx: np.ndarray, cy: np.ndarray) -> np.ndarray:
    """Positions of the lowest of `z` (ties: the smaller position) in each cell (cx, cy)
    that holds any, ordered by cell: as ``lowest_in_cells`` in ``cpp/src/cell_lowest.cpp``
    (the final pass's vertices, tin_ground's densified points)."""
    if len(z) == 0:
        return np.zeros(0, dtype=np.intp)
    order = np.lexsort((np.arange(len(z)), z, cy, cx))
    first = np.r_[True, (cx[order][1:] != cx[order][:-1]) | (cy[order][1:] != cy[order][:-1])]
    return order[first]


def lattice_floor(low: float, size: float) -> float:
    """The largest ``k * size`` (k a whole number, the product in float64) <= `low`.

    The corner of the lattice of step `size` at or below `low`, so that grids
    anchored there line up across tiles. ``floor(low / size) * size`` alone can
    land above `low`, as the quotient may round up to a whole number; then k
    goes down by one. Returns `low` itself when ``|low / size| >= 2**52``, where
    whole numbers are no longer all representable. Same operations as
    ``lattice_floor`` in ``cpp/src/points.cpp``.

    Examples
    --------
    >>> from pcl_rg.reference import lattice_floor
    >>> lattice_floor(71.5, 30.0), lattice_floor(-0.5, 30.0), lattice_floor(60.0, 30.0)
    (60.0, -30.0, 60.0)
    """
    # The core's lattice steps are validated parameters; here the caller's are checked
    # (a negative step would loop for ever below: each step down moves the corner up).
    if not (math.isfinite(size) and size > 0.0):
        raise ValueError(f"size must be finite and > 0, got {size!r}")
    if not math.isfinite(low):
        raise ValueError(f"low must be finite, got {low!r}")
    quotient = low / size
    if not abs(quotient) < 2.0**52:
        return low
    k = float(math.floor(quotient))
    corner = k * size
    while corner > low:
        k -= 1.0
        corner = k * size
    return corner
