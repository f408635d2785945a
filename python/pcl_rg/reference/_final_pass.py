"""NumPy/SciPy reference of the final pass of the ground filters (``final_pass.cpp``).

Every point is classified again by its height above a TIN of the lowest ground
point of each cell: TerraScan's "classify by distance to ground TIN", with the
slope-adaptive threshold of Zhao et al. 2016. The TIN comes from qhull
(:func:`pcl_rg.reference.tin_ground.triangulate`, qhull with co-circular vertices
given the core's diagonals) on the same snapped grid as the core's, so the two
agree point for point.
"""

from __future__ import annotations

import math

import numpy as np

from ._lattice import lattice_floor
from .tin_ground import grid_quantum, locate, triangulate, with_corners

__all__ = ["final_pass", "heights_above_tin"]


def final_pass(
    xyz: np.ndarray, ground: np.ndarray, cell: float, above: float, below: float, slope: float
) -> np.ndarray:
    """The final pass's ground mask of float64 (N, 3) points given the filter's `ground`.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.reference._final_pass import final_pass
    >>> xyz = np.array([[0, 0, 0], [9, 0, 0], [0, 9, 0], [9, 9, 0], [4, 4, 0.3], [5, 5, 2.0]])
    >>> ground = np.array([True, True, True, True, False, False])
    >>> final_pass(xyz, ground, cell=4.0, above=0.5, below=1.0, slope=1.0).tolist()
    [True, True, True, True, True, False]
    """
    heights = heights_above_tin(xyz, ground, cell)
    if heights is None:
        return np.zeros(len(xyz), dtype=bool)
    dz, gradient = heights
    return (dz >= -below) & (dz <= above + slope * gradient)


def heights_above_tin(
    xyz: np.ndarray, ground: np.ndarray, cell: float
) -> tuple[np.ndarray, np.ndarray] | None:
    """(z - z_TIN, |grad z_TIN|) per point for the final pass's TIN (None: no ground).

    The TIN is the final pass's: the lowest `ground` point of each `cell` cell; the
    errors study (benchmarks/studies/tin_isprs_errors.py) bins the errors by both.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.reference._final_pass import heights_above_tin
    >>> xyz = np.array([[0, 0, 0], [9, 0, 0], [0, 9, 0], [9, 9, 0], [5, 5, 2.0]])
    >>> dz, gradient = heights_above_tin(xyz, np.array([1, 1, 1, 1, 0], bool), cell=4.0)
    >>> dz.tolist(), gradient.tolist()
    ([0.0, 0.0, 0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 0.0, 0.0])
    """
    if len(xyz) == 0:
        return np.zeros(0), np.zeros(0)
    lowest, upper = xyz.min(axis=0), xyz.max(axis=0)
    ex, ey, _ = upper - lowest
    if not all(math.isfinite(v) for v in upper - lowest):
        raise ValueError("points: the extent is too large (not finite in float64)")
    cell_x0 = lattice_floor(float(lowest[0]), cell)
    cell_y0 = lattice_floor(float(lowest[1]), cell)
    if not ((upper[0] - cell_x0) / cell < 2.0**40 and (upper[1] - cell_y0) / cell < 2.0**40):
        raise ValueError(
            "final_cell is too small for the extent of points: more than 2^40 cells per axis"
        )
    q = grid_quantum(max(ex, ey))
    gx = np.rint((xyz[:, 0] - lowest[0]) / q).astype(np.int64) + 1
    gy = np.rint((xyz[:, 1] - lowest[1]) / q).astype(np.int64) + 1
    width, height = int(np.rint(ex / q)) + 2, int(np.rint(ey / q)) + 2
    z = xyz[:, 2] - lowest[2]

    # The lowest ground point of each cell (ties: index), then of each snapped XY.
    index = np.flatnonzero(ground)
    if index.size == 0:
        return None
    cx = np.floor((xyz[index, 0] - cell_x0) / cell).astype(np.int64)
    cy = np.floor((xyz[index, 1] - cell_y0) / cell).astype(np.int64)
    order = np.lexsort((index, z[index], cy, cx))
    first = np.r_[True, (cx[order][1:] != cx[order][:-1]) | (cy[order][1:] != cy[order][:-1])]
    vertex = index[order[first]]
    order = np.lexsort((vertex, z[vertex], gy[vertex], gx[vertex]))
    vertex = vertex[order]
    first = np.r_[True, (gx[vertex][1:] != gx[vertex][:-1]) | (gy[vertex][1:] != gy[vertex][:-1])]
    vertex = np.sort(vertex[first])

    # Corners of the box at the height of their nearest vertex (ties: index).
    vx, vy, vz = with_corners(gx, gy, z, vertex, vertex, width, height)

    tri, neighbors, vertex_to_simplex = triangulate(vx, vy, q)
    t = tri[locate(tri, neighbors, vertex_to_simplex, vx, vy, gx, gy)]
    x = (vx[t] - 1).astype(np.float64) * q
    y = (vy[t] - 1).astype(np.float64) * q
    tz = vz[t]
    ux, uy, uz = x[:, 1] - x[:, 0], y[:, 1] - y[:, 0], tz[:, 1] - tz[:, 0]
    wx, wy, wz = x[:, 2] - x[:, 0], y[:, 2] - y[:, 0], tz[:, 2] - tz[:, 0]
    nx = uy * wz - uz * wy
    ny = uz * wx - ux * wz
    nz = ux * wy - uy * wx
    px = (gx - 1).astype(np.float64) * q
    py = (gy - 1).astype(np.float64) * q
    surface = tz[:, 0] - (nx * (px - x[:, 0]) + ny * (py - y[:, 0])) / nz
    gradient = np.sqrt(nx * nx + ny * ny) / nz
    return z - surface, gradient
