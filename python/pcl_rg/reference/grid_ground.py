"""NumPy/SciPy reference for :func:`pcl_rg.grid_ground`."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .._grid_ground import GridGroundParams
from .._params import format_value, resolve_arguments
from .._point_spacing import with_spacing_lengths
from .._validation import as_points
from ._final_pass import final_pass
from ._lattice import lattice_floor
from .point_spacing import point_spacing

__all__ = ["GridNeighbours", "grid_ground", "grid_neighbours"]


class GridNeighbours(NamedTuple):
    """Every neighbour pair of :func:`grid_neighbours`, each once (i < j)."""

    i: np.ndarray
    """intp (P,): first point of each pair."""
    j: np.ndarray
    """intp (P,): second point of each pair."""
    d: np.ndarray
    """float64 (P,): ``sqrt(dx*dx + dy*dy)`` of the local x, y differences."""
    dz: np.ndarray
    """float64 (P,): ``l_z(i) - l_z(j)``."""
    same_block: np.ndarray
    """bool (P,): both points in one block."""
    block: np.ndarray
    """intp (N,): block number of every point (0, 1, ... over the occupied blocks)."""
    z: np.ndarray
    """float64 (N,): local z of every point."""
    block_xy: np.ndarray
    """int64 (N, 2): block index of every point on x and y, ``floor(l_xy / block_size)``:
    the world lattice's index less a constant of the call."""
    origin: np.ndarray
    """float64 (3,): the origin ``o`` of the local coordinates ``l = p - o``."""
    params: GridGroundParams
    """The parameters used: an unset cell_size filled in from the point spacing."""


def grid_neighbours(points: npt.ArrayLike, params: GridGroundParams) -> GridNeighbours:
    """All pairs of points whose cells differ by at most 1 on x and on y.

    In float64 local coordinates ``l = p - o``: block ``floor(l_xy / block_size)``,
    cell ``floor(l_xy / cell_size)``. The origin ``o`` is, on x and y, the corner
    of the world lattice of blocks at or below the minimum corner
    (:func:`lattice_floor`), and the minimum z, so blocks (and cells, when
    block_size is a whole multiple of cell_size) line up across tiles. An unset
    cell_size comes from the spacing of the points (``GridGroundParams.at_spacing``).
    """
    xyz = as_points(points)
    unset = params.cell_size is None
    params = with_spacing_lengths(params, lambda: point_spacing(xyz))
    lowest = xyz.min(axis=0)
    origin = np.array(
        [
            lattice_floor(float(lowest[0]), params.block_size[0]),
            lattice_floor(float(lowest[1]), params.block_size[1]),
            lowest[2],
        ]
    )
    for a, axis in enumerate("xy"):  # the core's bound on cell indices, and its words
        extent = float(xyz[:, a].max()) - float(origin[a])
        if not extent / params.cell_size[a] < 2.0**40:
            if not unset:
                raise ValueError(
                    f"cell_size is too small for the extent of points: more than 2^40 cells "
                    f"on {axis}"
                )
            raise ValueError(
                f"points: the extent on {axis} ({format_value(extent)} m from the block "
                f"corner) is more than 2^40 cells of {format_value(params.cell_size[a])} m "
                "(cell_size unset: from the point spacing); a stray point far from the rest? "
                "drop it, or set cell_size"
            )
    local = xyz - origin
    block_xy = np.floor(local[:, :2] / np.asarray(params.block_size)).astype(np.int64)
    block = np.unique(block_xy, axis=0, return_inverse=True)[1].ravel().astype(np.intp)
    scaled = local[:, :2] / np.asarray(params.cell_size)
    cell = np.floor(scaled).astype(np.int64)
    # Cells at most 1 apart hold points less than 2 cell widths apart on each axis, so
    # the Chebyshev pairs within 2 (in cell units) are a superset of the neighbours.
    pairs = cKDTree(scaled).query_pairs(2.0, p=np.inf, output_type="ndarray")
    i, j = pairs[:, 0].astype(np.intp), pairs[:, 1].astype(np.intp)
    near = (np.abs(cell[i] - cell[j]) <= 1).all(axis=1)
    i, j = i[near], j[near]
    order = np.lexsort((j, i))
    i, j = i[order], j[order]
    # Same operations in the same order as the core.
    dx = local[i, 0] - local[j, 0]
    dy = local[i, 1] - local[j, 1]
    d = np.sqrt(dx * dx + dy * dy)
    dz = local[i, 2] - local[j, 2]
    return GridNeighbours(
        i, j, d, dz, block[i] == block[j], block, local[:, 2], block_xy, origin, params
    )


def _slope_filter(nb: GridNeighbours, p: GridGroundParams, against: np.ndarray) -> np.ndarray:
    """Candidates: no tested neighbour lies lower by more than the filter allows."""
    threshold = p.filter_slope * nb.d + p.filter_tolerance
    i_too_high = (nb.dz > threshold) & against[nb.j]
    j_too_high = (-nb.dz > threshold) & against[nb.i]
    candidate = np.ones(len(nb.z), dtype=bool)
    candidate[nb.i[i_too_high]] = False
    candidate[nb.j[j_too_high]] = False
    return candidate


def _low_outliers(nb: GridNeighbours, xyz: np.ndarray, depth: float) -> np.ndarray:
    """Points with a neighbour elsewhere, every such neighbour more than `depth` above.

    Copies (equal local coordinates) do not count, so duplicating a cloud changes nothing.
    """
    local = xyz - nb.origin
    other = (local[nb.i] != local[nb.j]).any(axis=1)
    i, j, dz = nb.i[other], nb.j[other], nb.dz[other]
    above = np.full(len(nb.z), np.inf)  # least z_q - z_p over the neighbours q of p
    np.minimum.at(above, i, -dz)
    np.minimum.at(above, j, dz)
    return np.isfinite(above) & (above > depth)


def _grow(nb: GridNeighbours, p: GridGroundParams, candidate: np.ndarray) -> np.ndarray:
    """Union of the components of the blocks' seeds, among the candidates."""
    n = len(nb.z)
    linked = np.abs(nb.dz) <= p.slope * nb.d + p.height_tolerance
    linked &= candidate[nb.i] & candidate[nb.j]
    if not p.grow_across_blocks:
        linked &= nb.same_block
    graph = coo_matrix(
        (np.ones(int(linked.sum()), dtype=np.int8), (nb.i[linked], nb.j[linked])), shape=(n, n)
    )
    _, component = connected_components(graph, directed=False)
    size = np.bincount(component[candidate], minlength=component.max() + 1)

    # Seeds: candidates in (block, z, index) order; per block the first whose
    # component is large enough, else the first.
    order = np.lexsort((np.arange(n), nb.z, nb.block))
    order = order[candidate[order]]
    blocks = nb.block[order]
    first = np.flatnonzero(np.r_[True, blocks[1:] != blocks[:-1]]) if len(order) else order
    end = np.r_[first[1:], len(order)]
    seed_component = component[order[first]]
    large = np.flatnonzero(size[component[order]] >= p.min_seed_component)
    k = np.searchsorted(large, first)
    found = k < len(large)
    found[found] = large[k[found]] < end[found]
    seed_component[found] = component[order[large[k[found]]]]

    seeded = np.zeros(len(size), dtype=bool)
    seeded[seed_component] = True
    return candidate & seeded[component]


def grid_ground(
    points: npt.ArrayLike,
    *,
    block_size: float | tuple[float, float] | None = None,
    cell_size: float | tuple[float, float] | None = None,
    slope: float | None = None,
    height_tolerance: float | None = None,
    min_seed_component: int | None = None,
    outlier_depth: float | None = None,
    grow_across_blocks: bool | None = None,
    filter_passes: int | None = None,
    filter_slope: float | None = None,
    filter_tolerance: float | None = None,
    final_cell: float | None = None,
    final_above: float | None = None,
    final_below: float | None = None,
    final_slope: float | None = None,
    final_low_depth: float | None = None,
    final_passes: int | None = None,
    params: GridGroundParams | None = None,
) -> np.ndarray:
    """Reference grid ground filter: same signature and result as :func:`pcl_rg.grid_ground`.

    Builds the whole neighbour graph (candidate pairs from a k-d tree,
    filtered by cell), applies the pre-filter and the link rule to it, labels
    the connected components with SciPy and takes per block the component of
    the seed; low outliers (``outlier_depth > 0``) from the same pairs. With
    ``final_cell > 0`` the final pass of
    :func:`pcl_rg.reference._final_pass.final_pass` follows, ``final_passes``
    times, each round on the ground of the one before.

    Raises
    ------
    ValueError, TypeError
        As :func:`pcl_rg.grid_ground`.
    QhullPrecisionError
        Where qhull cannot resolve the final pass's TIN vertices
        (:func:`pcl_rg.reference.tin_ground.triangulate`); the core has an
        answer there, this reference does not.

    Examples
    --------
    >>> from pcl_rg import reference
    >>> from pcl_rg import GridGroundParams
    >>> pts = [[0, 0, 0.0], [1, 0, 0.5], [2, 0, 5.0]]
    >>> plain = GridGroundParams.definition(block_size=10, cell_size=1, slope=1.0)
    >>> reference.grid_ground(pts, params=plain).tolist()
    [True, True, False]
    """
    p = resolve_arguments(GridGroundParams, locals())
    xyz = as_points(points)
    n = len(xyz)
    if n == 0:
        return np.empty(0, dtype=bool)
    nb = grid_neighbours(xyz, p)  # unresolved: its errors say whether cell_size was set
    p = nb.params
    kept = ~_low_outliers(nb, xyz, p.outlier_depth) if p.outlier_depth > 0 else np.ones(n, bool)
    candidate = kept.copy()
    ground = kept.copy()  # pass 1 tests against every point but the low outliers
    for done in range(max(p.filter_passes, 1)):
        if p.filter_passes > 0:
            candidate = _slope_filter(nb, p, against=ground) & kept
        last, ground = ground, _grow(nb, p, candidate)
        if done > 0 and np.array_equal(ground, last):
            break  # every later pass would test against this ground again
    if p.final_cell > 0:
        for _ in range(p.final_passes):
            last, ground = (
                ground,
                kept
                & final_pass(
                    xyz,
                    ground,
                    p.final_cell,
                    p.final_above,
                    p.final_below,
                    p.final_slope,
                    p.final_low_depth,
                ),  # fmt: skip
            )
            if np.array_equal(ground, last):
                break  # every later round would start from this ground again
    return ground
