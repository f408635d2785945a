"""Progressive TIN densification ground filter (seed 002: LiDAR360's parameters)."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._final_pass import final_pass_param
from ._params import (
    check_fields,
    check_number,
    deprecated_preset,
    param,
    preset,
    resolve_arguments,
    spacing_length,
    to_core,
)
from ._point_spacing import lattice_length
from ._validation import MAX_POINTS_INT32, as_points

__all__ = ["TinGroundParams", "tin_ground"]


@dataclass(frozen=True, kw_only=True, slots=True)
class TinGroundParams:
    """Parameters of :func:`tin_ground` (mirrors ``pcl_rg::TinGroundParams``).

    The six settings of LiDAR360's "Classify Ground Points" and seven improvements
    (``opening_rank`` off in the defaults). The defaults are the :meth:`isprs`
    preset, chosen on the ISPRS samples, which gives a complete ground class at 1-20
    pts/m^2; :meth:`lidar360` is LiDAR360's own set (the seed's definition), which
    keeps only a sparse key-point set as ground on such data (see the README).

    The four lengths that depend on the point spacing (``stop_edge``,
    ``near_vertex_distance``, ``seed_cell``, ``final_cell``) are None ("unset")
    by default: each call takes ``m = SPACING_MULTIPLES[name] * spacing`` with
    its points' spacing (:func:`pcl_rg.point_spacing`, 1 m where undefined), and
    ``min(cap, m)`` with ``cap = SPACING_CAPS[name]``, or for the seed and final
    cells (on the world lattice of their size, which one stray point nudging the
    spacing must not move) the largest ``cap * 2**(-j / 8)``, j >= 0, at most m.
    The caps are the ISPRS samples' lengths (2, 1, 2, 3 m) and each multiple
    is its cap / 0.95 m: data as sparse as those samples (spacing 0.99-2.41 m)
    gets the ISPRS lengths, denser data about its spacing's share. The stop
    edge's multiple is a 4 m stop edge's (on ISPRS every one of 2-6 m scores
    the same; a shorter one inserts far more points into the TIN on dense
    data): it stays 2 m down to a spacing of 0.475 m (at 0.5 m: 2, 0.53, 1 and
    1.5 m). A number fixes the length; 0 still switches the last three off.
    :func:`pcl_rg.collect_diagnostics` gives the spacing and lengths a call
    used; :meth:`at_spacing` fixes them ahead (say for all tiles of a survey).
    """

    SPACING_CAPS: ClassVar[Mapping[str, float]] = MappingProxyType(
        {"stop_edge": 2.0, "near_vertex_distance": 1.0, "seed_cell": 2.0, "final_cell": 3.0}
    )
    """The unset lengths' largest values, m: the ISPRS preset's (C++: kTin*Cap)."""
    SPACING_MULTIPLES: ClassVar[Mapping[str, float]] = MappingProxyType(
        {name: cap / 0.95 for name, cap in SPACING_CAPS.items()} | {"stop_edge": 4.0 / 0.95}
    )
    """Multiples of the point spacing the unset lengths take below their caps (C++:
    kTin*PerSpacing, each cap / kTinFullLengthSpacing = 0.95 m, the stop edge's
    4 m / 0.95 m)."""

    max_building_size: float = param(
        40.0,
        above=0.0,
        unit="m",
        help="seed-grid cell: the lowest point of each cell is a seed; must exceed the "
        "largest building (LiDAR360 Max Building Size)",
    )
    max_terrain_angle: float = param(
        88.0,
        above=0.0,
        below=90.0,
        unit="deg",
        help="a point is not accepted while it would form a steeper triangle with its "
        "triangle's vertices (LiDAR360 Max Terrain Angle)",
    )
    iteration_angle: float = param(
        30.0,
        above=0.0,
        maximum=90.0,
        unit="deg",
        help="largest angle between the triangle's plane and the lines from its vertices to "
        "a point (LiDAR360 Iteration Angle)",
    )
    iteration_distance: float = param(
        1.4,
        above=0.0,
        unit="m",
        help="largest distance from a point to its triangle's plane (LiDAR360 Iteration Distance)",
    )
    reduce_angle_edge: float = param(
        0.01,
        above=0.0,
        unit="m",
        help="in triangles whose longest edge L is shorter, the angle limit is "
        "iteration_angle * L / reduce_angle_edge (LiDAR360 Reduce Iteration Angle When Edge "
        "Length <)",
    )
    stop_edge: float | None = spacing_length(
        above=0.0,
        help="triangles whose longest edge is shorter accept ground points without inserting "
        "them (LiDAR360 Stop Triangulation When Edge Length <); unset: min(2 m, 4.2 x the point "
        "spacing)",
    )
    near_vertex_distance: float | None = spacing_length(
        minimum=0.0,
        help="improvement (0: off): in the angle test a point's distance to a vertex counts "
        "as at least this much, so points (nearly) above a vertex are judged by their "
        "distance to the plane (helps on coarse or repeated XY); unset: min(1 m, 1.05 x the "
        "point spacing)",
    )
    seed_cell: float | None = spacing_length(
        minimum=0.0,
        help="improvement (0: off): seeds are the lowest points of seed_cell cells lying "
        "within seed_tolerance of the grey opening of those heights by a max_building_size "
        "window (dense seeds, none on roofs; after Zhao et al. 2016); unset: the largest "
        "2 m x 2^(-j/8) at most 2.1 x the point spacing",
    )
    seed_tolerance: float = param(
        0.5,
        minimum=0.0,
        unit="m",
        help="height above the opened surface a seed may lie (with seed_cell)",
    )
    outlier_depth: float = param(
        5.0,
        minimum=0.0,
        unit="m",
        help="improvement (0: off; with seed_cell): a cell more than this below the 9th "
        "lowest of its 5 x 5 cells gives no seed (low outliers)",
    )
    opening_rank: int = param(
        1,
        minimum=1,
        maximum=8,
        help="improvement (1: off, the plain opening; with seed_cell): the opening's "
        "erosion takes the opening_rank-th lowest cell of each window, so that fewer low "
        "cells than that cannot lower the opened surface and take the seeds around them",
    )
    border_vertices: bool = param(
        True,
        help="improvement (False: off): virtual vertices along the XY box's long sides as well "
        "as at its corners, about s = max(max_building_size, the shorter XY extent) to 2 s apart, "
        "each at its nearest seed's height, so that a corridor's border triangles do not "
        "reach corners kilometres away",
    )
    final_cell: float | None = final_pass_param("final_cell", None, optional=True)
    final_above: float = final_pass_param("final_above", 0.5)
    final_below: float = final_pass_param("final_below", 5.0)
    final_slope: float = final_pass_param("final_slope", 1.0)
    final_low_depth: float = final_pass_param("final_low_depth", 2.0)
    densify_lowest: bool = param(
        False,
        help="improvement (False: off; with final_cell): the densification tests only the "
        "lowest point of each final_cell / 2 cell; the final pass classifies every point",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def at_spacing(self, spacing: float) -> TinGroundParams:
        """These parameters with every unset length set for a point spacing.

        Parameters
        ----------
        spacing : float
            Metres (> 0), e.g. ``pcl_rg.point_spacing(points)``.

        Returns
        -------
        TinGroundParams
            A copy in which each length that was None is set as the class
            docstring says; a call with it gives what a call with these
            parameters gives on points of that spacing.

        Examples
        --------
        >>> from pcl_rg import TinGroundParams
        >>> TinGroundParams().at_spacing(2.0) == TinGroundParams(
        ...     stop_edge=2.0, near_vertex_distance=1.0, seed_cell=2.0, final_cell=3.0
        ... )  # ISPRS density: the caps
        True
        >>> dense = TinGroundParams().at_spacing(0.25)  # 16 points per m^2
        >>> [round(v, 3) for v in (dense.stop_edge, dense.seed_cell, dense.final_cell)]
        [1.053, 0.5, 0.75]
        """
        spacing = check_number("spacing", spacing, float, above=0.0)
        unset = {
            name: (lattice_length if name in ("seed_cell", "final_cell") else min)(
                self.SPACING_CAPS[name], multiple * spacing
            )
            for name, multiple in self.SPACING_MULTIPLES.items()
            if getattr(self, name) is None
        }
        return dataclasses.replace(self, **unset) if unset else self

    @preset
    def isprs(cls, **overrides: Any) -> TinGroundParams:
        """The defaults: one set chosen on the seven ISPRS samples (mean total error).

        Chosen by ``benchmarks/studies/tin_isprs_params.py`` (two stages: the
        densification's fields, then the final pass's); the scores are in
        ``benchmarks/RESULTS.md``. Against :meth:`lidar360` it switches the angle
        reduction off (no ISPRS triangle has a longest edge under 1 cm), keeps
        the 2 m stop edge (the search picks 0.01 m: 3.1461 against 3.1464 %
        after the final pass, in twice the time) and switches six improvements
        on. On the seven ISPRS samples it scores 3.15 % fitted and 3.97 % left one
        sample out (``benchmarks/studies/ground_isprs_cv.py``), better than the
        searches whose lengths follow the point spacing; so the lengths are those
        fitted on ISPRS at its spacing (0.95 m and more) and shrink with the
        spacing on denser data (:attr:`SPACING_CAPS`, :attr:`SPACING_MULTIPLES`;
        the four are unset here). `overrides` replace single fields.

        Examples
        --------
        >>> from pcl_rg import TinGroundParams
        >>> TinGroundParams.isprs() == TinGroundParams()
        True
        """
        return cls(**overrides)

    @preset
    def lidar360(cls, **overrides: Any) -> TinGroundParams:
        """LiDAR360's "Classify Ground Points" defaults (seed 002), improvements off.

        Faithful to the product, and the seed's definition, but at 1-3 m point
        spacing its 8 degree iteration angle and 2 m stop edge keep only a sparse
        key-point set as ground (see the README); `overrides` replace single fields.

        Examples
        --------
        >>> from pcl_rg import TinGroundParams
        >>> TinGroundParams.lidar360().iteration_angle
        8.0
        """
        values: dict[str, Any] = {
            "max_building_size": 20.0,
            "max_terrain_angle": 88.0,
            "iteration_angle": 8.0,
            "iteration_distance": 1.4,
            "reduce_angle_edge": 5.0,
            "stop_edge": 2.0,
            "near_vertex_distance": 0.0,
            "seed_cell": 0.0,
            "seed_tolerance": 0.5,
            "outlier_depth": 0.0,
            "opening_rank": 1,
            "border_vertices": False,
            "final_cell": 0.0,
            "final_above": 0.5,
            "final_below": 5.0,
            "final_slope": 1.0,
            "final_low_depth": 0.0,
            "densify_lowest": False,
        }
        return cls(**{**values, **overrides})

    tuned_isprs = deprecated_preset("tuned_isprs", "isprs")

    def to_core(self) -> _core.TinGroundParams:
        return to_core(self, _core.TinGroundParams())


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
    densify_lowest: bool | None = None,
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
    densify_lowest : bool, optional
        Default False (used with ``final_cell > 0``). The densification tests
        only the lowest point (ties: index) of each ``final_cell / 2`` cell of the
        world lattice, and the final pass classifies every point: its TIN takes
        the lowest ground point of each final cell, nearly always one of those,
        so on dense data the densification handles a fraction of the points.
        Ties go to the smaller index, as the seeds' do. Leave ``final_cell`` unset
        with it on dense data: a 3 m cell at 50 pts/m^2 (110 points per half
        cell) misses ground, 11.2 % total error against 7.8 % without it.
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
    on the seven ISPRS samples, with six improvements on (``opening_rank`` off);
    its scores are in ``benchmarks/RESULTS.md``. The lengths ``stop_edge``,
    ``near_vertex_distance``, ``seed_cell`` and ``final_cell`` are unset there: each
    call takes the ISPRS preset's lengths (2, 1, 2, 3 m) where the mean spacing of
    its points (:func:`pcl_rg.point_spacing`, 2-D, airborne; 1 m where undefined) is
    at least 0.95 m, and shorter ones in proportion to the spacing on denser data
    (the stop edge only below 0.475 m: :class:`TinGroundParams`), so the preset
    keeps its ISPRS results and works at 20 points per m^2 too.
    ``collect_diagnostics()`` reports the spacing (``point_spacing``, NaN when every
    length was given) and the four lengths used. :meth:`TinGroundParams.lidar360`,
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
