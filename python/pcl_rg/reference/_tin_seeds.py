"""The seeds of the NumPy reference :func:`pcl_rg.reference.tin_ground.tin_ground` (step 2,
before the TIN): the lowest point of each ``max_building_size`` cell, or the morphological
seeds of the ``seed_cell`` cells. The core's twin is ``cpp/src/tin_seeds.cpp``."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt
from scipy import ndimage

from .._point_spacing import with_spacing_lengths
from .._tin_ground import TinGroundParams
from .._validation import as_points
from ._lattice import lattice_floor
from .point_spacing import point_spacing

__all__ = ["CORRIDOR_OCCUPANCY", "seeds", "seeds_of"]


def _lowest_in_cells(xyz: np.ndarray, key: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(lowest point (ties: index) of each occupied cell, its cell key); `key`: each
    point's cell."""
    by_cell = np.lexsort((np.arange(len(xyz)), xyz[:, 2], key))
    first = by_cell[np.r_[True, key[by_cell][1:] != key[by_cell][:-1]]]
    return first, key[first]


def _close_gaps(index: np.ndarray, reach: int) -> tuple[np.ndarray, int]:
    """Each value's place (values >= 0) once every run of more than `reach` unused
    values is cut to `reach` + 1 steps, the run before the first used one (from 0, the
    full raster's border) included, and how many places there are."""
    used, inverse = np.unique(index, return_inverse=True)
    place = np.cumsum(np.minimum(np.diff(used, prepend=0), reach + 1))
    return place[inverse.ravel()], int(place[-1]) + 1


def _raster_limit(points: int) -> float:
    """The most cells the seed raster may have, as in the core: 4 per point + 2^22."""
    return 4.0 * points + 4194304.0


#: A corridor across the axes fills every row and column of its box: its seed raster
#: may hold up to 2^25 / opening_rank cells when at least this share of them hold a
#: point (the core's kCorridorOccupancy, tin_seeds.cpp).
CORRIDOR_OCCUPANCY = 0.01


def _morphological_seeds(
    xyz: np.ndarray, local: np.ndarray, ex: float, ey: float, p: TinGroundParams
) -> np.ndarray:
    """Seeds of the ``seed_cell`` option (``morphological_seeds`` in tin_seeds.cpp).

    The raster keeps the occupied columns and rows of cells with every longer run of
    empty ones between them cut to the reach of the windows + 1 (the opening reads 2r
    cells away, the outlier test 2), which gives each occupied cell the neighbourhood it
    has in the full raster: the same seeds, and a raster that fits when a few points lie
    far from the rest. The C++ core builds the full raster when that fits.
    """
    cell = p.seed_cell
    # As the core caps it; the quotient may be inf for a subnormal seed_cell.
    r = math.floor(min(p.max_building_size / (2.0 * cell), 2.0**40))
    limit = _raster_limit(len(xyz))
    # A full raster within the limit has quotients far below 2^62, so these alone tell
    # whether the columns and rows can be counted (inf for a subnormal cell).
    fits = float(ex) / cell < 2.0**62 and float(ey) / cell < 2.0**62
    if fits:
        column, ncx = _close_gaps(np.floor(local[:, 0] / cell).astype(np.int64), max(2 * r, 2))
        row, ncy = _close_gaps(np.floor(local[:, 1] / cell).astype(np.int64), max(2 * r, 2))
        cells = float(ncx) * float(ncy)
        corridor = max(limit, 2.0**25 / p.opening_rank)
        fits = cells <= limit or (
            cells <= corridor and np.unique(column * ncy + row).size >= CORRIDOR_OCCUPANCY * cells
        )
    if not fits:
        raise ValueError(
            f"seed_cell is too small for the XY extent of the points ({ex:g} x {ey:g} m: more "
            "than 4 cells per point, even with the empty rows and columns of cells between "
            "them cut short, and not a corridor of at most 2^25 / opening_rank cells, 1 % of "
            f"them holding a point), got {cell:g}; set a larger seed_cell"
        )
    lowest, cells = _lowest_in_cells(xyz, column * ncy + row)
    height = np.full(ncx * ncy, np.inf)
    height[cells] = local[lowest, 2]
    height = height.reshape(ncx, ncy)
    if p.outlier_depth > 0:
        while True:  # peel low outliers: below the 9th lowest of the 5 x 5 window
            ninth = ndimage.rank_filter(height, rank=8, size=5, mode="constant", cval=np.inf)
            bad = np.isfinite(height) & np.isfinite(ninth) & (height < ninth - p.outlier_depth)
            if not bad.any():
                break
            height[bad] = np.inf
    size = 2 * r + 1
    # A window wider than the raster reads only the padding beyond it (+inf for the
    # erosion, -inf for the dilation): clipped to 2n - 1 cells, which cover the raster
    # from any cell, it takes the same values, at a cost (and memory) that scipy's full
    # window would not bound (a max_building_size of 1e9 m took 4 GB).
    clipped = (min(size, 2 * ncx - 1), min(size, 2 * ncy - 1))
    eroded = ndimage.minimum_filter(height, size=clipped, mode="constant", cval=np.inf)
    # opening_rank: the rank-th lowest of the window, its lowest where the window holds
    # fewer finite cells (a window of fewer cells than the rank holds fewer).
    if 1 < p.opening_rank <= clipped[0] * clipped[1]:
        ranked = ndimage.rank_filter(
            height, rank=p.opening_rank - 1, size=clipped, mode="constant", cval=np.inf
        )
        eroded = np.where(np.isfinite(ranked), ranked, eroded)
    opened = ndimage.maximum_filter(
        np.where(np.isinf(eroded), -np.inf, eroded), size=clipped, mode="constant", cval=-np.inf
    )
    keep = (np.isfinite(height) & (height - opened <= p.seed_tolerance)).ravel()[cells]
    return np.sort(lowest[keep])


def seeds_of(xyz: np.ndarray, ex: float, ey: float, p: TinGroundParams) -> np.ndarray:
    """Step 2's seeds, sorted; `ex`, `ey` the XY extent from the minimum corner."""
    cell = p.max_building_size
    if not (ex / cell < 2.0**31 and ey / cell < 2.0**31):
        raise ValueError(
            "max_building_size is too small for the XY extent (more than 2^31 seed cells "
            f"per axis), got {cell:g}"
        )
    # The seed cells on the world lattice of their size: their corner at or below the
    # minimum corner (as in tin_ground.cpp); z stays relative to the minimum.
    lowest = xyz.min(axis=0)
    size = p.seed_cell if p.seed_cell > 0 else cell
    origin = np.array(
        [lattice_floor(float(lowest[0]), size), lattice_floor(float(lowest[1]), size), lowest[2]]
    )
    local = xyz - origin
    sex, sey = local[:, 0].max(), local[:, 1].max()
    if not (math.isfinite(sex) and math.isfinite(sey)):
        raise ValueError("points: the XY extent is too large (not finite in float64)")
    if p.seed_cell > 0:
        return _morphological_seeds(xyz, local, sex, sey, p)
    ncy = math.floor(sey / cell) + 1
    key = np.floor(local[:, 0] / cell).astype(np.int64) * ncy + np.floor(local[:, 1] / cell).astype(
        np.int64
    )
    return np.sort(_lowest_in_cells(xyz, key)[0])


def seeds(points: npt.ArrayLike, params: TinGroundParams) -> np.ndarray:
    """Indices of the seeds of :func:`tin_ground`, sorted (step 2, before the TIN).

    The lowest point of every ``max_building_size`` cell, or with ``seed_cell > 0``
    the morphological seeds of the ``seed_cell`` cells; the cells are anchored at
    multiples of their size in world coordinates, so a tile cut at a cell boundary
    gets the cells of the merged cloud.

    Examples
    --------
    >>> from pcl_rg import TinGroundParams
    >>> from pcl_rg.reference.tin_ground import seeds
    >>> pts = [[15.0, 0.0, 5.0], [25.0, 0.0, 4.0], [18.0, 3.0, 6.0]]
    >>> seeds(pts, TinGroundParams.lidar360(max_building_size=20.0)).tolist()
    [0, 1]

    Cells [0, 20) and [20, 40) on x, not [15, 35) from the minimum corner.
    """
    xyz = as_points(points)
    if len(xyz) == 0:
        return np.empty(0, dtype=np.intp)
    ex, ey, _ = xyz.max(axis=0) - xyz.min(axis=0)
    return seeds_of(xyz, ex, ey, with_spacing_lengths(params, lambda: point_spacing(xyz)))
