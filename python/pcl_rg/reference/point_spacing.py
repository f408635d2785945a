"""NumPy reference for :func:`pcl_rg.point_spacing` (the same float64 operations)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .._validation import as_points

__all__ = ["point_spacing"]


def point_spacing(points: npt.ArrayLike) -> float:
    """Mean XY spacing from the occupied cells; see :func:`pcl_rg.point_spacing`."""
    xyz = as_points(points)
    n = len(xyz)
    if n < 2:
        return math.nan
    x, y = xyz[:, 0], xyz[:, 1]
    xmin, ymin = float(x.min()), float(y.min())
    w, h = float(x.max()) - xmin, float(y.max()) - ymin
    if not w * h > 0.0:  # no XY area: no density to measure
        return math.nan
    c = max(3.0 * math.sqrt(w * h / n), max(w, h) / 65536.0)
    occupied = _occupied_cells(x - xmin, y - ymin, h, c)
    # A box less than a quarter occupied: cells of 3 x the spacing of the occupied area,
    # until fine enough, and not past a quarter of the distinct positions (copies).
    finest = max(w, h) / 2.0**31
    positions = 0  # counted when first needed
    while n > 36.0 * occupied:
        if positions == 0:
            positions = _occupied_cells(x - xmin, y - ymin, h, finest)
        if not 4 * occupied < positions:
            break
        finer = max(3.0 * math.sqrt(occupied * c * c / n), finest)
        if not finer < c:
            break
        c = finer
        occupied = _occupied_cells(x - xmin, y - ymin, h, c)
    return math.sqrt(occupied * c * c / n)


def _occupied_cells(dx: np.ndarray, dy: np.ndarray, h: float, c: float) -> int:
    """How many cells of side `c` from the minimum corner hold a point."""
    ny = math.floor(h / c) + 1
    ix = np.floor(dx / c).astype(np.int64)
    iy = np.floor(dy / c).astype(np.int64)
    return int(np.unique(ix * ny + iy).size)
