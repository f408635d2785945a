"""Mean XY point spacing: the length the density-aware defaults of the ground filters
scale with."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TypeVar

import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._validation import as_points

__all__ = ["lattice_length", "lengths_spacing", "point_spacing", "with_spacing_lengths"]

P = TypeVar("P")
LATTICE_RUNGS = 8.0  # rungs per halving of lattice_length (C++: kTinLatticeRungs)


@fill_docstring
def point_spacing(points: npt.ArrayLike) -> float:
    """Mean XY spacing of the points, from the area of the grid cells they occupy.

    Parameters
    ----------
    %(points)s

    Returns
    -------
    float
        Metres: ``sqrt(M * c**2 / N)``, the side of the square each point would
        have if the occupied area were shared evenly; NaN when undefined (fewer
        than 2 points, or no XY area: all on one line along x or y, such as a
        vertical wall).

    Raises
    ------
    %(points_value_error)s
        Also when the XY extent, or its area w * h, is not finite in float64
        (coordinates near 1e308, or an extent beyond 1e154 on both axes).
    %(type_error)s

    Notes
    -----
    With N points of XY extent w by h (max - min), the cells are squares of side
    ``c = max(3 * sqrt(w * h / N), max(w, h) / 65536)`` (9 points per cell if
    the box were evenly covered; the second term bounds the number of cells of a
    slim cloud) from the minimum corner, a point's cell is
    ``floor((x - xmin) / c), floor((y - ymin) / c)`` in float64, and M counts the
    cells holding a point. Empty cells (water, gaps wider than about three
    spacings, the outside of an irregular outline) do not count, so a half-empty
    tile has the spacing of its points, not of its box. Every return counts:
    vegetation and walls make it smaller than the spacing of the ground alone.

    A box less than a quarter occupied (more than 36 points per occupied cell,
    against 9 when the box is covered) may be set by a few points far from the
    rest (a bad GPS fix, a point at (0, 0, 0)), which would make the cells far
    too coarse. When the bulk of the points, from the 1st to the 99th
    percentile of x and of y (with 100 points or more), spans less than a
    sixteenth of the box, the cells follow its box instead:
    ``c = max(3 * sqrt(bulk area / N), its larger side / 65536, max(w, h) / 2**31)``,
    and M is counted again. One point 700 km from an ISPRS sample moves its
    spacing by at most 2 %. Data that fill little of their box for other
    reasons (a corridor along its diagonal, scattered clusters) keep the
    measure on the box.

    The unset lengths of :class:`TinGroundParams` (``stop_edge``,
    ``near_vertex_distance``, ``seed_cell``, ``final_cell``, ``densify_cell``:
    the ISPRS lengths, capped at a multiple of this) and :class:`GridGroundParams`
    (``cell_size``: at most 2 of this) follow it (1 m where it is NaN),
    measured on the points of each call; the value used is in
    :func:`collect_diagnostics`. The C++ core computes it in O(N) (and a sort
    of the cells when the bulk sets them), equal to the NumPy reference
    :func:`pcl_rg.reference.point_spacing`.

    It is the airborne ground filters' measure, 2-D and per m^2 of ground
    plan; :func:`pcl_rg.point_scale` is another, for
    :func:`pcl_rg.convex_segmentation`: the 3-D median nearest-neighbour
    distance on a scanned surface, with the surface noise.

    On the ISPRS filter-test samples it is 1.0-1.1 m (urban, samp1x-4x) and
    2.3-2.4 m (rural, samp5x-6x).

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> xy = np.stack(np.meshgrid(np.arange(100.0), np.arange(100.0)), -1).reshape(-1, 2)
    >>> round(pcl_rg.point_spacing(np.c_[xy * 0.5, np.zeros(len(xy))]), 2)  # a 0.5 m grid
    0.5
    >>> half = np.c_[xy[xy[:, 0] < 50] * 0.5, np.zeros(5000)]  # half of it: same spacing
    >>> round(pcl_rg.point_spacing(half), 2)
    0.5
    """
    xyz = as_points(points)
    spacing = float(_core.point_spacing(xyz))
    record("point_spacing", points=len(xyz), point_spacing=spacing)
    return spacing


def lattice_length(cap: float, length: float) -> float:
    """The largest ``cap * 2**(-j / 8)``, j >= 0 whole, at most `length` (to rounding: at
    an exact rung, one either side), with C++'s operations (tin_lattice_length): a cell
    on the world lattice of its size in exact proportion to the spacing moved the cells
    far from the world origin by metres when one stray point nudged the spacing (UTM:
    508 of 60,000 labels changed)."""
    ratio = cap / length if length > 0.0 else math.inf
    if not math.isfinite(ratio):  # a length below cap / DBL_MAX: as min(cap, length)
        return min(cap, length)
    if ratio <= 1.0:  # C++ gets there through log2(0) = -inf for an infinite length
        return cap
    rungs = math.ceil(LATTICE_RUNGS * math.log2(ratio))
    return cap * 2.0 ** (-max(0.0, rungs) / LATTICE_RUNGS)


def lengths_spacing(spacing: float) -> float:
    """The spacing (m) the unset lengths follow: `spacing`, or 1 m where it is NaN
    (too few points, no XY area), as in the C++ core."""
    return 1.0 if math.isnan(spacing) else spacing


def with_spacing_lengths(params: P, spacing: Callable[[], float]) -> P:
    """`params` with its unset lengths set for the point spacing `spacing()` (m).

    `spacing` is called only when some length is unset (see :func:`lengths_spacing`
    for NaN). Serves the references and the batch engine (one spacing per survey).
    """
    if not any(getattr(params, name) is None for name in getattr(params, "SPACING_MULTIPLES", ())):
        return params
    return params.at_spacing(lengths_spacing(spacing()))  # type: ignore[attr-defined]
