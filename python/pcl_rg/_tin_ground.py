"""Progressive TIN densification ground filter (seed 002: LiDAR360's parameters)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._params import resolve_arguments
from ._tin_ground_params import TinGroundParams
from ._validation import MAX_POINTS_INT32, as_points

__all__ = ["TinGroundParams", "tin_ground"]


@fill_docstring
def tin_ground(
    points: npt.ArrayLike,
    *,
    max_building_size: float | None = None,
    max_terrain_angle: float | None = None,
    iteration_angle: float | None = None,
    iteration_distance: float | None = None,
    reduce_angle_edge: float | None = None,
    stop_edge: float | None = None,
    near_vertex_distance: float | None = None,
    seed_cell: float | None = None,
    seed_tolerance: float | None = None,
    outlier_depth: float | None = None,
    opening_rank: int | None = None,
    border_vertices: bool | None = None,
    final_cell: float | None = None,
    final_above: float | None = None,
    final_below: float | None = None,
    final_slope: float | None = None,
    final_low_depth: float | None = None,
    densify_cell: float | None = None,
    params: TinGroundParams | None = None,
) -> np.ndarray:
    """Classify ground points by progressive TIN densification.

    Parameters
    ----------
    %(points)s
    max_building_size : float, optional
        Seed-grid cell in metres (default 40; LiDAR360 20): the lowest point of each cell is a
        seed. Must exceed the largest building, or its flat roof becomes ground.
    max_terrain_angle : float, optional
        Degrees in (0, 90) (default 88): a point is not accepted while any
        triangle it would form with its triangle's vertices is steeper.
    iteration_angle : float, optional
        Degrees in (0, 90] (default 30; LiDAR360 8): largest angle between the triangle's
        plane and the lines from its vertices to an accepted point.
    iteration_distance : float, optional
        Metres (default 1.4, as LiDAR360): largest distance from an accepted point to its
        triangle's plane.
    reduce_angle_edge : float, optional
        Metres (default 0.01; LiDAR360 5): in a triangle whose longest XY edge L is shorter, the
        angle limit is ``iteration_angle * L / reduce_angle_edge``.
    stop_edge : float, optional
        Metres (default: unset, min(2 m, 4.2 x the point spacing); LiDAR360 2): a
        triangle whose longest XY edge is shorter accepts ground points but does
        not get them inserted, which bounds the TIN's density.
    near_vertex_distance : float, optional
        Metres (default: unset, min(1 m, 1.05 x the point spacing); 0 is Axelsson's test,
        LiDAR360's). An improvement for data with coarse or repeated XY: in the
        angle test the distance from the point to a vertex counts as at least
        this much, so a point (nearly) above a vertex is accepted when
        ``d <= sin(limit) * near_vertex_distance`` instead of being judged by an
        angle close to 90 degrees minus the slope.
    seed_cell : float, optional
        Metres (default: unset, the largest 2 m x 2^(-j/8) at most 2.1 x the
        point spacing; 0: one seed per ``max_building_size`` cell, LiDAR360). After
        Zhao et al. 2016: the lowest point of every ``seed_cell`` cell is a seed
        when it lies at most ``seed_tolerance`` above the grey opening of those
        lowest heights by a ``max_building_size`` square window: dense seeds on
        open terrain and none on roofs.
    seed_tolerance : float, optional
        Metres (default 0.5): see ``seed_cell``.
    outlier_depth : float, optional
        Metres (default 5; 0: off; used with ``seed_cell``): a cell whose lowest
        point lies more than this below the 9th lowest of the 25 cells of its
        5 x 5 window gives no seed; repeated until none is found, so clusters
        of low outliers (multipath) are peeled from the rim in.
    opening_rank : int, optional
        In [1, 8] (default 1: the plain opening; used with ``seed_cell``): the
        opening's erosion takes the ``opening_rank``-th lowest of the cells of
        each window instead of the lowest (the lowest where a window holds
        fewer cells), so that fewer low cells than that, such as true ground at
        the foot of a step or low outliers shallower than ``outlier_depth``,
        cannot lower the opened surface, and drop the seeds, across a whole
        window: an erosion by a rank-order filter (Soille, "Morphological Image
        Analysis", 2nd ed., 2003). Off in the preset: its gain on ISPRS left one
        sample out did not survive mm-level noise (``benchmarks/RESULTS.md``,
        "selection procedures"). Under sloping terrain with multipath points
        shallower than ``outlier_depth``, 2 keeps the seeds the plain opening
        loses around each, and the densification runs faster.
    border_vertices : bool, optional
        Default True (LiDAR360: False, the corners only). Virtual vertices along
        the sides of the XY box too, each at the height of its nearest seed as
        the corners are: a side is cut into ``floor(side / s)`` equal parts (1 to
        65,536), ``s = max(max_building_size, the shorter XY extent)``, so a tile
        less than twice as long as wide gets none, a corridor one every ``s`` to
        ``2 s`` along its long sides. Without them a corridor's border triangles
        reach to corners kilometres away, and on a slope the uphill strip is lost
        (``benchmarks/studies/tin_corridor.py``: 28 % of its ground, 0.03 % with).
    final_cell : float, optional
        Metres (default: unset, the largest 3 m x 2^(-j/8) at most 3.16 x the
        point spacing; 0: off). After TerraScan's practice of classifying the
        points close to the final ground TIN: a TIN is built from the lowest
        ground point of each ``final_cell`` cell (anchored on the world lattice
        of that size), and every point is ground when
        ``-final_below <= z - z_TIN <= final_above + final_slope * g``, with
        ``g = |grad z_TIN|`` of the triangle under it (the slope-adaptive
        threshold of Zhao et al. 2016): it adds the points just above the TIN
        that the densification left out below the stop edge.
    final_above : float, optional
        Metres (default 0.5): see ``final_cell``.
    final_below : float, optional
        Metres (default 5): see ``final_cell``.
    final_slope : float, optional
        Metres per unit gradient (default 1): see ``final_cell``.
    %(final_low_depth)s
    densify_cell : float, optional
        Metres (default: unset, the largest 1.5 m x 2^(-j/8) at most 1.58 x the
        point spacing, half the unset final cell; 0: off; used with
        ``final_cell > 0``). The densification tests only the lowest point of
        each cell of side ``min(densify_cell, final_cell / 2)`` on the world
        lattice of that size (ties: index, as the seeds'; a point counts at its
        place on the TIN's grid, whose step is the power of two at or above the
        XY extent / 2^29, 4 um for 2 km), and the final pass classifies every
        point: its TIN
        takes the lowest ground point of each final cell, nearly always one of
        those, so the densification handles a fraction of the points (the speed
        and ISPRS figures are in ``benchmarks/RESULTS.md``). The cell follows the
        spacing because a fixed one does not carry over: at 50 pts/m^2 a 1.5 m
        cell holds about 110 points, and with the lengths fixed at the ISPRS
        values the total error was 11.2 % with it, 7.5 % with it unset.
    params : TinGroundParams, optional
        All parameters at once (defaults: the ``isprs`` preset); keywords given
        explicitly override it.

    Returns
    -------
    numpy.ndarray
        bool (N,): True for ground points.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, 1 or 2 points, points all collinear in
        XY, or a parameter out of range (sizes must be > 0, iteration_angle in
        (0, 90], max_terrain_angle in (0, 90)).
    %(type_error)s

    Notes
    -----
    Axelsson's progressive TIN densification with the six settings of
    LiDAR360's "Classify Ground Points" (which follows Zhao et al. 2016); the
    exact definition is section 4 of the project's algorithms document:

    1. The lowest point of each ``max_building_size`` cell is a seed (ground).
       Four virtual corners just outside the XY extent, at the height of their
       nearest seed, make every point fall inside the TIN; they are not output.
       With ``border_vertices``, so do virtual vertices along the long sides.
    2. A 2-D Delaunay TIN of the seeds is built (the project's own, with exact
       integer predicates on XY snapped to at most extent / 2^29: 2 um for 1 km).
       Co-circular ties are broken by coordinates (Edelsbrunner and Muecke 1990),
       so the TIN, built in parallel strips, does not depend on the order.
    3. Each iteration tests every unclassified point against the TIN as it was
       when the iteration began: with d its distance to its triangle's plane,
       it is accepted when ``d <= iteration_distance``, every angle
       ``asin(d / |p - v_i|)`` to the vertices is within the (possibly reduced)
       iteration angle and no triangle it would form is steeper than
       ``max_terrain_angle``. In a triangle whose longest edge is below
       ``stop_edge`` all accepted points are ground and none is inserted; in any
       other, only the accepted point closest to the plane (ties: lowest index)
       is ground and is inserted, as in Axelsson (one point per facet per
       iteration), and the others are tested again on the denser TIN.
    4. Iterations stop when one adds no ground point.
    5. With ``final_cell > 0``, the final pass (shared with
       :func:`grid_ground`) classifies every point again by its height above
       the TIN of the lowest ground point of each ``final_cell`` cell.

    The defaults are the :meth:`TinGroundParams.isprs` preset, the one set chosen
    on the seven ISPRS samples, with seven improvements on (``opening_rank`` off);
    its scores are in ``benchmarks/RESULTS.md``. The lengths ``stop_edge``,
    ``near_vertex_distance``, ``seed_cell``, ``final_cell`` and ``densify_cell``
    are unset there: each call takes the ISPRS preset's lengths (2, 1, 2, 3,
    1.5 m) where the mean spacing of its points (:func:`pcl_rg.point_spacing`,
    2-D, airborne; 1 m where undefined) is at least 0.95 m, and shorter ones in
    proportion to the spacing on denser data (the stop edge only below 0.475 m:
    :class:`TinGroundParams`), so the preset keeps its ISPRS results and works
    at 50 points per m^2 too.
    ``collect_diagnostics()`` reports the spacing (``point_spacing``, NaN when every
    length was given) and the five lengths used. :meth:`TinGroundParams.lidar360`,
    LiDAR360's own set, misses much ground on 1-3 m spaced data (8 degrees).

    The seed cells are anchored at multiples of their size in world
    coordinates so that tiles of a survey share one lattice: cells of
    ``seed_cell`` when it is > 0, else of ``max_building_size``, start at
    ``floor(min / cell) * cell`` per axis (one cell lower where rounding puts
    that above the input's minimum corner). The windows of the opening and of
    the outlier test are counted in those cells around each cell, so they
    follow. A tile cut at cell boundaries therefore has the seed cells of the
    merged cloud, and the same seeds away from the cut (with ``seed_cell``,
    farther than the windows reach); its TIN, which spans the tile, still
    differs from the merged cloud's near the tile's border. A translation by
    whole cells leaves the seed cells and, up to float64 rounding, the result
    unchanged; any other may move cell boundaries through the points. The
    TIN's snapping grid (step 2) stays at the minimum corner: its step depends
    on the extent, and it moves points by micrometres.

    A few points far from the rest (a bad GPS fix, a point at (0, 0, 0)) are
    taken: the spacing follows the occupied cells, not the box, and the seed
    raster leaves out the long empty runs of cells between them, which changes
    no seed. They join the TIN as seeds, though, and its triangles along the
    border of the data then reach them: on the seven ISPRS samples one point
    700 km away raises the mean total error from 3.15 to 3.58 %. Drop such
    points first (:func:`statistical_outlier_removal`, ``pcl-rg denoise``).

    The result does not depend on the order of the points except through ties
    broken by index, nor on the number of threads. The C++ core runs with the
    GIL released; the float64 input is shifted to a local origin first.
    There is no counterpart in PCL; the TIN is the project's own (no CGAL).

    References
    ----------
    Seed 002 (LiDAR360, "Classify Ground Points"); Axelsson, Int. Arch.
    Photogramm. Remote Sens. XXXIII-B4, 2000; Zhao et al., ISPRS J.
    Photogramm. Remote Sens. 117, 2016; Terrasolid, TerraScan User Guide
    ("By distance to ground TIN", the final pass).

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0.0, 60.0, (4000, 2))
    >>> z = 0.05 * xy[:, 0] + rng.normal(0.0, 0.02, 4000)
    >>> roof = (np.abs(xy - 30.0) < 6.0).all(axis=1)
    >>> z[roof] += 8.0
    >>> ground = pcl_rg.tin_ground(np.c_[xy, z])  # the isprs preset
    >>> bool(ground[~roof].mean() > 0.98), bool(ground[roof].any())
    (True, False)
    >>> cautious = pcl_rg.TinGroundParams.lidar360()
    >>> ground = pcl_rg.tin_ground(np.c_[xy, z], params=cautious)
    >>> bool(ground[~roof].mean() > 0.75), bool(ground[roof].any())
    (True, False)
    """
    p = resolve_arguments(TinGroundParams, locals())
    # The TIN numbers vertices (the points and its 8 frame corners) with int32.
    xyz = as_points(points, max_points=MAX_POINTS_INT32 - 8)
    ground, stats = _core.tin_ground(xyz, p.to_core())
    record("tin_ground", points=len(xyz), ground=int(ground.sum()), **stats)
    return ground
