"""The parameters of tin_ground (seed 002): LiDAR360's six settings, the improvements,
the presets, and the lengths that follow the point spacing."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

from . import _core
from ._final_pass import final_pass_param
from ._params import (
    check_fields,
    check_number,
    deprecated_preset,
    param,
    preset,
    spacing_length,
    to_core,
)
from ._point_spacing import lattice_length

__all__ = ["TinGroundParams"]


@dataclass(frozen=True, kw_only=True, slots=True)
class TinGroundParams:
    """Parameters of :func:`tin_ground` (mirrors ``pcl_rg::TinGroundParams``).

    The six settings of LiDAR360's "Classify Ground Points" and seven improvements
    (``opening_rank`` off in the defaults). The defaults are the :meth:`isprs`
    preset, chosen on the ISPRS samples, which gives a complete ground class at 1-20
    pts/m^2; :meth:`lidar360` is LiDAR360's own set (the seed's definition), which
    keeps only a sparse key-point set as ground on such data (see the README).

    The five lengths that depend on the point spacing (``stop_edge``,
    ``near_vertex_distance``, ``seed_cell``, ``final_cell``, ``densify_cell``)
    are None ("unset") by default: each call takes ``m = SPACING_MULTIPLES[name]
    * spacing`` with its points' spacing (:func:`pcl_rg.point_spacing`, 1 m where
    undefined), and ``min(cap, m)`` with ``cap = SPACING_CAPS[name]``, or for the
    three cells (on the world lattice of their size, which one stray point
    nudging the spacing must not move) the largest ``cap * 2**(-j / 8)``, j >= 0,
    at most m. The caps are the ISPRS samples' lengths (2, 1, 2, 3 m; the
    densify cell half the final cell's) and each multiple is its cap / 0.95 m:
    data as sparse as those samples (spacing 0.99-2.41 m) gets the ISPRS
    lengths, denser data about its spacing's share. The stop edge's multiple is
    a 4 m stop edge's (on ISPRS every one of 2-6 m scores the same; a shorter
    one inserts far more points into the TIN on dense data): it stays 2 m down
    to a spacing of 0.475 m (at 0.5 m: 2, 0.53, 1, 1.5 and 0.75 m). A number
    fixes the length; 0 still switches the last four off.
    :func:`pcl_rg.collect_diagnostics` gives the spacing and lengths a call
    used; :meth:`at_spacing` fixes them ahead (say for all tiles of a survey).
    """

    SPACING_CAPS: ClassVar[Mapping[str, float]] = MappingProxyType(
        {
            "stop_edge": 2.0,
            "near_vertex_distance": 1.0,
            "seed_cell": 2.0,
            "final_cell": 3.0,
            "densify_cell": 1.5,
        }
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
    densify_cell: float | None = spacing_length(
        minimum=0.0,
        help="improvement (0: off; with final_cell): the densification tests only the lowest "
        "point of each cell of min(densify_cell, final_cell / 2); the final pass classifies "
        "every point; unset: the largest 1.5 m x 2^(-j/8) at most 1.58 x the point spacing "
        "(half the unset final cell)",
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
        ...     stop_edge=2.0, near_vertex_distance=1.0, seed_cell=2.0, final_cell=3.0,
        ...     densify_cell=1.5,
        ... )  # ISPRS density: the caps
        True
        >>> dense = TinGroundParams().at_spacing(0.25)  # 16 points per m^2
        >>> [round(dense.stop_edge, 3), dense.seed_cell, dense.final_cell, dense.densify_cell]
        [1.053, 0.5, 0.75, 0.375]
        """
        spacing = check_number("spacing", spacing, float, above=0.0)
        unset = {
            name: (lattice_length if name.endswith("_cell") else min)(
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
        after the final pass, in twice the time) and switches seven improvements
        on. On the seven ISPRS samples it scores 3.18 % fitted and 3.95 % left one
        sample out (``benchmarks/studies/ground_isprs_cv.py``), better than the
        searches whose lengths follow the point spacing; so the lengths are those
        fitted on ISPRS at its spacing (0.95 m and more) and shrink with the
        spacing on denser data (:attr:`SPACING_CAPS`, :attr:`SPACING_MULTIPLES`;
        the five are unset here). `overrides` replace single fields.

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
            "densify_cell": 0.0,
        }
        return cls(**{**values, **overrides})

    tuned_isprs = deprecated_preset("tuned_isprs", "isprs")

    def to_core(self) -> _core.TinGroundParams:
        return to_core(self, _core.TinGroundParams())
