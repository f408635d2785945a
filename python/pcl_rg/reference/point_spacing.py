"""NumPy reference for :func:`pcl_rg.point_spacing` (the same float64 operations)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from .._validation import as_points

__all__ = ["box_spacing", "point_spacing"]


def point_spacing(points: npt.ArrayLike) -> float:
    """Mean XY spacing from the occupied cells; see :func:`pcl_rg.point_spacing`."""
    xyz = as_points(points)
    n = len(xyz)
    box = _box_cells(xyz)
    if box is None:
        return math.nan
    c, occupied, xmin, ymin, w, h = box
    x, y = xyz[:, 0], xyz[:, 1]
    # A box less than a quarter occupied: the cell may follow the box of the bulk, from
    # the 1st to the 99th percentile on each axis, when that is under 1/16 of the box.
    trim = n // 100
    if n > 36.0 * occupied and trim > 0:
        xlow, xhigh = np.partition(x, [trim, n - 1 - trim])[[trim, n - 1 - trim]]
        ylow, yhigh = np.partition(y, [trim, n - 1 - trim])[[trim, n - 1 - trim]]
        bulk = float(xhigh - xlow) * float(yhigh - ylow)
        if bulk > 0.0 and 16.0 * bulk < w * h:
            c = max(
                3.0 * math.sqrt(bulk / n),
                max(float(xhigh - xlow), float(yhigh - ylow)) / 65536.0,
                max(w, h) / 2.0**31,
            )
            occupied = _occupied_cells(x - xmin, y - ymin, h, c)
    return _spacing(occupied, c, n)


def box_spacing(points: npt.ArrayLike) -> float:
    """The spacing with the cells set by the bounding box alone: the first measure of
    :func:`pcl_rg.point_spacing`, and its result on any box at least a quarter
    occupied, before the bulk's box may replace it (NaN when undefined)."""
    xyz = as_points(points)
    box = _box_cells(xyz)
    if box is None:
        return math.nan
    c, occupied = box[:2]
    return _spacing(occupied, c, len(xyz))  # as point_spacing rounds it


def _spacing(occupied: int, c: float, n: int) -> float:
    """sqrt(M c**2 / N), or c sqrt(M / N) where c**2 overflows (as the core)."""
    spacing = math.sqrt(occupied * c * c / n)
    return spacing if math.isfinite(spacing) else c * math.sqrt(occupied / n)


def _box_cells(xyz: np.ndarray) -> tuple[float, int, float, float, float, float] | None:
    """(cell side, occupied cells, xmin, ymin, w, h) of the cells set by the box; None
    when undefined (fewer than 2 points, no XY area)."""
    n = len(xyz)
    if n < 2:
        return None
    x, y = xyz[:, 0], xyz[:, 1]
    xmin, ymin = float(x.min()), float(y.min())
    w, h = float(x.max()) - xmin, float(y.max()) - ymin
    if not (math.isfinite(w) and math.isfinite(h) and math.isfinite(w * h)):
        raise ValueError(
            "points: the XY extent is too large to measure the point spacing (its area is "
            "not finite in float64); a stray point far from the rest?"
        )
    if not w * h > 0.0:  # no XY area: no density to measure
        return None
    c = max(3.0 * math.sqrt(w * h / n), max(w, h) / 65536.0)
    return c, _occupied_cells(x - xmin, y - ymin, h, c), xmin, ymin, w, h


def _occupied_cells(dx: np.ndarray, dy: np.ndarray, h: float, c: float) -> int:
    """How many cells of side `c` from the minimum corner hold a point."""
    ny = math.floor(h / c) + 1
    ix = np.floor(dx / c).astype(np.int64)
    iy = np.floor(dy / c).astype(np.int64)
    return int(np.unique(ix * ny + iy).size)
