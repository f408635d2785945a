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
    ny = math.floor(h / c) + 1
    ix = np.floor((x - xmin) / c).astype(np.int64)
    iy = np.floor((y - ymin) / c).astype(np.int64)
    occupied = np.unique(ix * ny + iy).size
    return math.sqrt(occupied * c * c / n)
