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

from ._lattice import lattice_floor, lowest_in_cells
from .tin_ground import grid_quantum, locate, triangulate, with_corners

__all__ = ["border_vertices", "final_pass", "heights_above_tin", "low_ground"]

#: The least width of low_ground's window (final_pass_low.hpp's kWindowMetres): its
#: 7 x 7 cells are taken every k cells, the least k >= 1 for which 6k + 1 cells span
#: this much, so the window spans 14-24 m whatever the cell.
WINDOW_METRES = 14.0


def final_pass(
    xyz: np.ndarray,
    ground: np.ndarray,
    cell: float,
    above: float,
    below: float,
    slope: float,
    low_depth: float = 0.0,
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
    heights = heights_above_tin(xyz, ground, cell, low_depth)
    if heights is None:
        return np.zeros(len(xyz), dtype=bool)
    dz, gradient = heights
    return (dz >= -below) & (dz <= above + slope * gradient)


def border_vertices(
    vx: np.ndarray,
    vy: np.ndarray,
    vz: np.ndarray,
    cells: np.ndarray,
    lattice: tuple[int, int],
    box: tuple[int, int],
    ground: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The final pass's virtual vertices on the sides of the TIN's box (grid x, y, z).

    Each vertex (grid `vx`, `vy`, height `vz`) whose cell (`cells`, column and row
    in a lattice of `lattice` columns and rows) lies in the outermost row or column
    on a side gets one there, at its own position moved onto the side (the box is
    [0, width] x [0, height], `box`). Its height continues a rise from the vertex
    of the next cell inwards, w, to this one, v, by at most that rise: z_v +
    max(z_v - z_w, 0) * min(d_side / d_vw, 1) with grid distances across the side;
    z_v without such a w or where d_vw is 0, and at most the height of the filter's
    ground point nearest the side in v's cell (ties: the lowest, then the smallest
    index). `ground`: the ground points' grid XY (G, 2), heights (G,) and cells
    (G, 2), by index. A lattice one cell wide or high gets none, nor a vertex
    within one grid step of a corner along the side. Of two at one place, the lower
    cell's stays.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.reference._final_pass import border_vertices
    >>> vx, vy, vz = np.array([5, 5, 13]), np.array([2, 6, 6]), np.array([0.0, 1.0, 2.0])
    >>> cells = np.array([[0, 0], [0, 1], [1, 1]])  # 2 x 2 cells of 8 grid steps
    >>> ground = (np.c_[np.r_[vx, 14], np.r_[vy, 10]], np.r_[vz, 2.5], np.r_[cells, [[1, 1]]])
    >>> bx, by, bz = border_vertices(vx, vy, vz, cells, (2, 2), (16, 16), ground)
    >>> list(zip(bx.tolist(), by.tolist(), bz.tolist()))  # bottom, top x 2, left x 2, right
    [(5, 0, 0.0), (5, 16, 1.0), (13, 16, 2.0), (0, 2, 0.0), (0, 6, 1.0), (16, 6, 2.375)]
    """
    if min(lattice) == 1:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    out: list[tuple[int, int, float]] = []
    ground_xy, ground_z, ground_cells = ground
    place = {(int(c), int(r)): k for k, (c, r) in enumerate(cells.tolist())}
    for axis, upper_side in ((1, False), (1, True), (0, False), (0, True)):  # bottom, top, ...
        edge, inward = (lattice[axis] - 1, lattice[axis] - 2) if upper_side else (0, 1)
        at = box[axis] if upper_side else 0
        across = vy if axis == 1 else vx
        # The cap: per outermost cell, the ground point nearest the side, then lowest.
        on_edge = np.flatnonzero(ground_cells[:, axis] == edge)
        if on_edge.size == 0:
            continue  # nor any vertex there
        gap = np.abs(at - ground_xy[on_edge, axis])
        along = ground_cells[on_edge, 1 - axis]
        order = np.lexsort((on_edge, ground_z[on_edge], gap, along))
        first = np.r_[True, along[order][1:] != along[order][:-1]]
        cap = dict(zip(along[order][first].tolist(), ground_z[on_edge][order][first].tolist()))
        side: list[tuple[int, int, float]] = []
        for k in sorted(np.flatnonzero(cells[:, axis] == edge), key=lambda k: cells[k, 1 - axis]):
            inner = cells[k].copy()
            inner[axis] = inward
            w = place.get((int(inner[0]), int(inner[1])))
            z = float(vz[k])
            if w is not None:
                d_side = at - across[k] if upper_side else across[k] - at
                d_vw = across[k] - across[w] if upper_side else across[w] - across[k]
                if d_vw > 0:
                    z = z + max(z - float(vz[w]), 0.0) * min(float(d_side) / float(d_vw), 1.0)
            z = min(z, cap[int(cells[k, 1 - axis])])
            point = (int(vx[k]), at, z) if axis == 1 else (at, int(vy[k]), z)
            along = int(vx[k] if axis == 1 else vy[k])
            if along <= 1 or along >= box[1 - axis] - 1:
                continue  # within a grid step of a corner
            if not side or side[-1][:2] != point[:2]:
                side.append(point)
        out.extend(side)
    if not out:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    bx, by, bz = zip(*out, strict=True)
    return np.array(bx, np.int64), np.array(by, np.int64), np.array(bz)


def heights_above_tin(
    xyz: np.ndarray, ground: np.ndarray, cell: float, low_depth: float = 0.0
) -> tuple[np.ndarray, np.ndarray] | None:
    """(z - z_TIN, |grad z_TIN|) per point for the final pass's TIN (None: no ground).

    The TIN is the final pass's: the lowest `ground` point of each `cell` cell (with
    `low_depth` > 0, of those not that far below their surroundings: low_ground); the
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

    if low_depth > 0:
        ground = ground & ~low_ground(xyz, z, ground, (cell_x0, cell_y0, cell), low_depth)
    # The lowest ground point of each cell (ties: index), then of each snapped XY.
    index = np.flatnonzero(ground)
    if index.size == 0:
        return None
    cx = np.floor((xyz[index, 0] - cell_x0) / cell).astype(np.int64)
    cy = np.floor((xyz[index, 1] - cell_y0) / cell).astype(np.int64)
    vertex = index[lowest_in_cells(z[index], cx, cy)]  # index ascends: ties by index
    order = np.lexsort((vertex, z[vertex], gy[vertex], gx[vertex]))
    vertex = vertex[order]
    first = np.r_[True, (gx[vertex][1:] != gx[vertex][:-1]) | (gy[vertex][1:] != gy[vertex][:-1])]
    vertex = np.sort(vertex[first])

    # Corners of the box at the height of their nearest vertex (ties: index), then the
    # virtual vertices on its sides.
    vx, vy, vz = with_corners(gx, gy, z, vertex, vertex, width, height)
    cells = np.c_[cx, cy][np.searchsorted(index, vertex)]  # vertex: sorted, within index
    lattice = (
        int(np.floor((upper[0] - cell_x0) / cell)) + 1,
        int(np.floor((upper[1] - cell_y0) / cell)) + 1,
    )
    bx, by, bz = border_vertices(
        gx[vertex], gy[vertex], z[vertex], cells, lattice, (width, height),
        (np.c_[gx[index], gy[index]], z[index], np.c_[cx, cy]),
    )  # fmt: skip
    vx, vy, vz = np.r_[vx[:4], bx, vx[4:]], np.r_[vy[:4], by, vy[4:]], np.r_[vz[:4], bz, vz[4:]]

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


def low_ground(
    xyz: np.ndarray,
    z: np.ndarray,
    ground: np.ndarray,
    lattice: tuple[float, float, float],
    depth: float,
    reach: int = 3,
) -> np.ndarray:
    """The `ground` points more than `depth` below the median of the lowest `ground`
    heights `z` of the occupied cells of the (2 reach + 1)^2 window around their own
    cell (x0, y0, size of `lattice`), taken every `stride` cells (the least stride >= 1
    for which the window spans WINDOW_METRES), as final_pass_low.cpp (kWindowReach,
    window_stride).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.reference._final_pass import low_ground
    >>> xyz = np.array([[3 * x + 1.5, 3 * y + 1.5, 0.0] for x in range(5) for y in range(5)])
    >>> xyz[12, 2] = -9.0  # the middle cell's point, 9 m below the others
    >>> z = xyz[:, 2] - xyz[:, 2].min()
    >>> np.flatnonzero(low_ground(xyz, z, np.ones(25, bool), (0.0, 0.0, 3.0), 3.0)).tolist()
    [12]
    >>> # 1 m cells: the window takes every third cell, none of which holds a point here
    >>> xyz[:, :2] /= 3.0
    >>> np.flatnonzero(low_ground(xyz, z, np.ones(25, bool), (0.0, 0.0, 1.0), 3.0)).tolist()
    []
    """
    x0, y0, size = lattice
    stride = max(1, int(min(np.ceil((WINDOW_METRES / size - 1.0) / (2 * reach)), 2.0**40)))
    index = np.flatnonzero(ground)
    if index.size == 0:
        return np.zeros(len(xyz), dtype=bool)
    cx = np.floor((xyz[index, 0] - x0) / size).astype(np.int64)
    cy = np.floor((xyz[index, 1] - y0) / size).astype(np.int64)
    order = np.lexsort((z[index], cy, cx))
    first = np.r_[True, (np.diff(cx[order]) != 0) | (np.diff(cy[order]) != 0)]
    lowest = order[first]  # of index's positions: each occupied cell's lowest, by place
    ux, uy = np.unique(cx), np.unique(cy)
    cell_keys = np.searchsorted(ux, cx[lowest]) * len(uy) + np.searchsorted(uy, cy[lowest])

    def rank(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Each cell (x, y)'s place in `lowest`, or -1 where no ground cell is."""
        ix = np.minimum(np.searchsorted(ux, x), len(ux) - 1)
        iy = np.minimum(np.searchsorted(uy, y), len(uy) - 1)
        key = ix * len(uy) + iy
        place = np.minimum(np.searchsorted(cell_keys, key), len(cell_keys) - 1)
        found = (ux[ix] == x) & (uy[iy] == y) & (cell_keys[place] == key)
        return np.where(found, place, -1)

    heights = z[index[lowest]]
    window = np.full((len(lowest), (2 * reach + 1) ** 2), np.nan)
    offsets = range(-reach * stride, reach * stride + 1, stride)
    for column, (dx, dy) in enumerate((dx, dy) for dx in offsets for dy in offsets):
        place = rank(cx[lowest] + dx, cy[lowest] + dy)
        window[place >= 0, column] = heights[place[place >= 0]]
    threshold = np.nanmedian(window, axis=1) - depth
    own = rank(cx, cy)
    low = np.zeros(len(xyz), dtype=bool)
    low[index] = z[index] < threshold[own]
    return low
