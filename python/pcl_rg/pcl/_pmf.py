"""``pcl::ProgressiveMorphologicalFilter`` and its approximate variant on NumPy arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import _pcl
from .._diagnostics import record
from .._docstrings import fill_docstring
from .._params import check_fields, param, resolve_arguments, to_core
from .._validation import as_points

__all__ = ["ProgressiveMorphologicalFilterParams", "progressive_morphological_filter"]


@dataclass(frozen=True, kw_only=True, slots=True)
class ProgressiveMorphologicalFilterParams:
    """Parameters of :func:`progressive_morphological_filter` (PCL's tutorial defaults).

    Mirrors ``pcl_rg::ProgressiveMorphologicalFilterParams``.
    """

    max_window_size: int = param(
        20,
        minimum=1,
        bits=32,
        help="largest window: metres in the point-wise filter, cells in the approximate one "
        "(setMaxWindowSize)",
    )
    slope: float = param(1.0, minimum=0.0, unit="m/m", help="terrain slope (setSlope)")
    initial_distance: float = param(
        0.5, minimum=0.0, unit="m", help="height threshold of the first window (setInitialDistance)"
    )
    max_distance: float = param(
        3.0, minimum=0.0, unit="m", help="cap of the height threshold (setMaxDistance)"
    )
    cell_size: float = param(1.0, above=0.0, unit="m", help="grid cell size (setCellSize)")
    base: float = param(2.0, above=0.0, help="base of the window progression (setBase)")
    exponential: bool = param(
        True, help="windows grow exponentially, else linearly (setExponential)"
    )
    approximate: bool = param(
        False,
        help="pcl::ApproximateProgressiveMorphologicalFilter (cell minima) instead of the "
        "point-wise filter",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _pcl.ProgressiveMorphologicalFilterParams:
        return to_core(self, _pcl.ProgressiveMorphologicalFilterParams())


@fill_docstring
def progressive_morphological_filter(
    points: npt.ArrayLike,
    *,
    max_window_size: int | None = None,
    slope: float | None = None,
    initial_distance: float | None = None,
    max_distance: float | None = None,
    cell_size: float | None = None,
    base: float | None = None,
    exponential: bool | None = None,
    approximate: bool | None = None,
    params: ProgressiveMorphologicalFilterParams | None = None,
) -> np.ndarray:
    """Classify ground with PCL's progressive morphological filter.

    Parameters
    ----------
    %(points)s
    max_window_size : int, optional
        Largest morphological window (default 20; ``setMaxWindowSize``). PCL
        compares it with the window in metres in the point-wise filter,
        ``cell_size * (2 * base**k + 1)``, and in cells in the approximate one,
        ``2 * int(base**k) + 1``: the two agree only where ``cell_size`` is 1.
    slope : float, optional
        Terrain slope for the height thresholds, m per m (default 1;
        ``setSlope``); >= 0.
    initial_distance : float, optional
        Height threshold of the first window, metres (default 0.5;
        ``setInitialDistance``); >= 0.
    max_distance : float, optional
        Cap of the height threshold, metres (default 3; ``setMaxDistance``).
    cell_size : float, optional
        Cell size of the grid, metres (default 1; ``setCellSize``); > 0.
    base : float, optional
        Base of the window-size progression (default 2; ``setBase``); > 0.
    exponential : bool, optional
        Windows grow as base**k (default True) or linearly
        (``setExponential``).
    approximate : bool, optional
        Run ``pcl::ApproximateProgressiveMorphologicalFilter`` (openings of
        the grid of cell minima, much faster) instead of
        ``pcl::ProgressiveMorphologicalFilter`` (default False).
    %(params)s

    Returns
    -------
    numpy.ndarray
        bool (N,): True for ground.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, a parameter out of range, or one that
        PCL cannot run with on these points: a window series that does not
        grow or takes more than 64 steps, values beyond float32, more than
        2^24 cells on an axis, or (approximate) grids of more than 2^28 cells
        or more than 1e11 cell comparisons, or (point-wise) more than 1e10
        points collected from the octree: every point gathers the points of a
        box one window wide, twice per window, which PCL cannot interrupt
        (counted from the points in cells a quarter window wide, which can
        exceed PCL's count by up to a half for evenly spread points).
        PCL would loop, abort, exhaust memory or run for minutes there.
    %(type_error)s

    Notes
    -----
    Defaults are those of PCL's tutorial "Identifying ground returns using
    ProgressiveMorphologicalFilter segmentation". The filter runs on the
    points minus the local origin, as float32.

    The point-wise filter is slow, and PCL cannot stop it once it runs (Ctrl-C
    waits for the end): with these defaults it took 2.3, 14 and 79 s for
    10,000, 41,000 and 166,000 points of ``pcl_rg.datasets.synthetic_scene``
    on two cores, against 0.09, 0.10 and 0.22 s with ``approximate=True``. For
    a whole tile, use the approximate filter.

    References
    ----------
    Zhang et al., "A progressive morphological filter for removing nonground
    measurements from airborne LIDAR data", IEEE TGRS 41(4), 2003.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 40, (4000, 2))
    >>> box = (np.abs(xy - 20) < 4).all(axis=1)
    >>> pts = np.column_stack([xy, np.where(box, 6.0, 0.0)])
    >>> ground = pcl_rg.pcl.progressive_morphological_filter(pts)
    >>> bool(ground[~box].all()), bool(ground[box].any())
    (True, False)
    """
    p = resolve_arguments(ProgressiveMorphologicalFilterParams, locals())
    xyz = as_points(points)
    ground = _pcl.progressive_morphological_filter(xyz, p.to_core())
    record("pcl.progressive_morphological_filter", points=len(xyz), ground=int(ground.sum()))
    return ground
