"""Grid region-growing ground filter (seed 000): one seed per block, slope-limited growth."""

from __future__ import annotations

import dataclasses
import math
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
    format_value,
    param,
    preset,
    resolve_arguments,
    to_core,
)
from ._validation import as_points

__all__ = ["GridGroundParams", "grid_ground"]


@dataclass(frozen=True, kw_only=True, slots=True)
class GridGroundParams:
    """Parameters of :func:`grid_ground` (mirrors ``pcl_rg::GridGroundParams``).

    The defaults are the :meth:`isprs` preset, chosen once by the mean total
    error over the seven ISPRS samples (``benchmarks/studies/ground_isprs.py --search``),
    not tuned per sample. :meth:`definition` gives the plain rule of the seed
    (algorithms.md section 3), with every option off.

    ``cell_size`` is None ("unset") by default: each call then takes, per axis,
    ``block_size / k`` with k the smallest whole number that makes the cell at
    most ``SPACING_MULTIPLES["cell_size"]`` times the spacing of its points
    (:func:`pcl_rg.point_spacing`, 1 m where that is undefined): cells follow the
    density and still line up with the blocks. The spacing and the cell size a
    call used are in :func:`pcl_rg.collect_diagnostics`; :meth:`at_spacing` fixes
    them ahead.
    """

    SPACING_MULTIPLES: ClassVar[Mapping[str, float]] = MappingProxyType({"cell_size": 2.0})
    """The largest cell an unset cell_size takes, in point spacings (C++:
    kGridCellPerSpacing)."""

    block_size: tuple[float, float] = param(
        (30.0, 30.0),
        axes=2,
        above=0.0,
        unit="m",
        help="block edge length, one value or x,y: one seed per block; should exceed the "
        "largest building",
    )
    cell_size: tuple[float, float] | None = param(
        None,
        axes=2,
        optional=True,
        above=0.0,
        unit="m",
        help="cell edge length, one value or x,y (<= block_size): points link within the "
        "3 x 3 cells around them; unset: block_size / k, the largest such cell of at most "
        "2 x the point spacing",
    )
    slope: float = param(
        0.3, minimum=0.0, help="tangent of the steepest terrain: link when |dz| <= slope * d + tol"
    )
    height_tolerance: float = param(
        0.0, minimum=0.0, unit="m", help="height difference always allowed between linked points"
    )
    min_seed_component: int = param(
        10,
        minimum=1,
        help="robust seed: lowest point whose component holds at least this many points "
        "(1: the lowest point)",
    )
    outlier_depth: float = param(
        2.0,
        minimum=0.0,
        unit="m",
        help="low outliers (0: off): a point whose 3 x 3 cells hold other points, all more "
        "than this above it, is never ground, never a seed and never a final-pass vertex",
    )
    grow_across_blocks: bool = param(
        True, help="links also join points of neighbouring blocks (one seed per block)"
    )
    filter_passes: int = param(
        2,
        minimum=0,
        maximum=64,
        help="slope pre-filter passes (0: off): drop points higher than a neighbour by more "
        "than filter_slope * d + filter_tolerance; later passes test only against the "
        "previous ground (a pass that changes nothing ends them)",
    )
    filter_slope: float = param(0.7, minimum=0.0, help="slope of the pre-filter")
    filter_tolerance: float = param(
        0.5, minimum=0.0, unit="m", help="height tolerance of the pre-filter"
    )
    final_cell: float = final_pass_param("final_cell", 4.0)
    final_above: float = final_pass_param("final_above", 0.5)
    final_below: float = final_pass_param("final_below", 5.0)
    final_slope: float = final_pass_param("final_slope", 2.0)
    final_low_depth: float = final_pass_param("final_low_depth", 2.0)
    final_passes: int = param(
        2,
        minimum=1,
        maximum=64,
        help="rounds of the final pass (with final_cell > 0): each round after the first "
        "builds its TIN from the previous round's ground (a round that changes nothing "
        "ends them)",
    )

    def __post_init__(self) -> None:
        check_fields(self)
        for axis, block, cell in zip("xy", self.block_size, self.cell_size or self.block_size):
            if cell > block:
                raise ValueError(
                    f"cell_size must be <= block_size ({format_value(block)}) on {axis}, "
                    f"got {format_value(cell)}"
                )

    def at_spacing(
        self, spacing: float, multiples: Mapping[str, float] | None = None
    ) -> GridGroundParams:
        """These parameters with ``cell_size``, if unset, set for a point spacing.

        Parameters
        ----------
        spacing : float
            Metres (> 0), e.g. ``pcl_rg.point_spacing(points)``.
        multiples : mapping of str to float, optional
            Another multiple than :attr:`SPACING_MULTIPLES` (for parameter
            studies).

        Returns
        -------
        GridGroundParams
            A copy whose ``cell_size``, if it was None, is per axis
            ``block_size / k``, k the smallest whole number with
            ``block_size / k <= SPACING_MULTIPLES["cell_size"] * spacing``; a call
            with it gives what a call with these parameters gives on points of
            that spacing.

        Examples
        --------
        >>> from pcl_rg import GridGroundParams
        >>> GridGroundParams().at_spacing(1.0).cell_size  # 30 m blocks, 15 cells
        (2.0, 2.0)
        >>> GridGroundParams().at_spacing(0.25).cell_size  # 60 cells per block
        (0.5, 0.5)
        """
        spacing = check_number("spacing", spacing, float, above=0.0)
        chosen = {**self.SPACING_MULTIPLES, **(multiples or {})}
        if set(chosen) != set(self.SPACING_MULTIPLES):
            raise ValueError(f"multiples: unknown names {sorted(set(chosen) - {'cell_size'})}")
        multiple = check_number("multiples['cell_size']", chosen["cell_size"], float, above=0.0)
        if self.cell_size is not None:
            return self
        largest = multiple * spacing
        for block in self.block_size:
            # Far beyond the core's 2^40 cells per axis, which it checks against the
            # extent; here ceil() would meet infinity (a subnormal spacing).
            if not (largest > 0.0 and block / largest < 2.0**62):  # the product may underflow
                raise ValueError(
                    f"spacing {format_value(spacing)}: cells of at most "
                    f"{format_value(largest)} m would split a {format_value(block)} m block "
                    "into more than 2^62 cells; set cell_size"
                )
        cell = tuple(block / max(1.0, math.ceil(block / largest)) for block in self.block_size)
        return dataclasses.replace(self, cell_size=cell)

    @preset
    def isprs(cls, **overrides: Any) -> GridGroundParams:
        """The defaults: one set chosen on the seven ISPRS samples (mean total error).

        Chosen by ``benchmarks/studies/ground_isprs.py --search`` (a coordinate
        descent over the growth's and the pre-filter's slopes, the low-outlier
        depth, the cell size and the final pass with its depths and rounds, from
        the definition with every option on at a middle value, low outliers
        off and one final round) with the "resolution" rule: ``cell_size``
        follows the point spacing (unset: at most 2 spacings,
        :attr:`SPACING_MULTIPLES`; 1.5 fitted ISPRS a little better but split
        the ground of the dense synthetic scene, so the search starts at 2),
        the final pass's 4 m cell and the 30 m blocks stay in metres. Among the
        rules for the lengths (every one in metres, every one in spacings, only
        the cell) it has the lowest
        leave-one-sample-out error on the seven ISPRS samples: 3.90 % fitted,
        4.03 % cross-validated (kappa 0.871; 4.04 and 4.02 % before
        ``final_low_depth`` joined the search), against 5.24 % for the same
        search with 3 m cells, 5.15 % for the preset before low outliers, final
        rounds and the deeper final_below (4.64 % fitted) and 10.8 % for the
        former default (``benchmarks/studies/ground_isprs_cv.py``). With cells
        in metres its grower took objects on dense data; with the cell
        following the spacing it holds from 2 to 20 points per m^2
        (``benchmarks/studies/ground_density.py``; scores in
        ``benchmarks/RESULTS.md``). `overrides` replace single fields.

        Examples
        --------
        >>> from pcl_rg import GridGroundParams
        >>> GridGroundParams.isprs() == GridGroundParams()
        True
        """
        return cls(**overrides)

    @preset
    def definition(cls, **overrides: Any) -> GridGroundParams:
        """The plain rule of algorithms.md section 3: every option off.

        ``min_seed_component=1, outlier_depth=0, grow_across_blocks=False,
        filter_passes=0``,
        no final pass (``final_cell=0``, ``final_passes=1``) and the seed's pure slope rule
        ``height_tolerance=0``; the other fields keep their defaults unless
        given in `overrides`.
        """
        values: dict[str, Any] = {
            "height_tolerance": 0.0,
            "min_seed_component": 1,
            "outlier_depth": 0.0,
            "grow_across_blocks": False,
            "filter_passes": 0,
            "final_cell": 0.0,
            "final_low_depth": 0.0,
            "final_passes": 1,
        }
        values.update(overrides)
        return cls(**values)

    def to_core(self) -> _core.GridGroundParams:
        return to_core(self, _core.GridGroundParams())


@fill_docstring
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
    """Classify ground points by region growing from the lowest point of each block.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Coordinates in metres (any real float or integer dtype, C or F order),
        z up.
    block_size : float or sequence of 2 floats, optional
        Block edge length (dx, dy) in metres, one value for both axes or one
        per axis. Each block gets its own seed, so it should exceed the largest
        building. Default 30 m.
    cell_size : float or sequence of 2 floats, optional
        Cell edge length (bx, by) in metres, at most `block_size`. A point
        links to points of its own and the 8 neighbouring cells. Default: unset,
        per axis ``block_size / k`` with k the smallest whole number that makes
        it at most 2 point spacings (:func:`pcl_rg.point_spacing`): 2 m at
        spacings of 1 to 1.07 m (three urban ISPRS samples), 1.875 m just below 1 m
        (samp31, 0.99 m), 0.5 m at 0.25 m. A cell far below
        the spacing is allowed, as the definition allows it, but its cells
        seldom have a neighbour holding a point, so ground grows little from
        the seeds (without the final pass, about one point per block).
    slope : float, optional
        S, tangent of the steepest terrain slope (>= 0). Default 0.3.
    height_tolerance : float, optional
        t, height difference in metres always allowed between linked points
        (>= 0). Default 0, the seed's pure slope rule.
    min_seed_component : int, optional
        Robust seed against low outliers (>= 1): the seed of a block is its
        lowest point whose connected component holds at least this many
        points; 1 takes the lowest point as the definition does. Default 10.
    outlier_depth : float, optional
        Metres (>= 0; 0 = off, as in the definition): a point that has other
        points (not copies of it) in its 3 x 3 cells, every one more than this
        above it, is a
        low outlier (a multipath echo under the terrain) and never ground.
        Default 2 m.
    grow_across_blocks : bool, optional
        Let links join points of neighbouring blocks; seeds stay one per
        block and ground is the union of their components. Default True
        (False in the definition).
    filter_passes : int, optional
        Passes of a slope pre-filter (0 to 64; 0 = off, as in the definition).
        A pass whose ground is the previous one's ends them, as every later
        pass would give it again. Default 2.
    filter_slope : float, optional
        The pre-filter drops a point lying higher than a point of its 3 x 3
        cells by more than ``filter_slope * d + filter_tolerance``. Default 0.7.
    filter_tolerance : float, optional
        Metres; see `filter_slope`. Default 0.5 m.
    final_cell : float, optional
        Metres (>= 0; 0 = off, as in the definition). Final pass: a TIN is
        built from the lowest ground point of each ``final_cell`` cell, and
        every point is classified again by its height above it (see Notes).
        Default 4 m.
    final_above : float, optional
        Metres: with the final pass, a point up to this high above the TIN is
        ground on flat terrain. Default 0.5 m.
    final_below : float, optional
        Metres: with the final pass, a point down to this deep below the TIN
        is ground. Default 5 m (low outliers excepted, see `outlier_depth`).
    final_slope : float, optional
        Metres per unit gradient: with the final pass, the height allowed
        above the TIN is ``final_above + final_slope * |grad z_TIN|``, so
        steep terrain, where a coarse TIN cuts under the surface, keeps its
        points. Default 2 m.
    %(final_low_depth)s
    final_passes : int, optional
        Rounds of the final pass (1 to 64; with ``final_cell > 0``): each round
        after the first builds its TIN from the previous round's ground; a
        round that changes nothing ends them. Default 2 (1 in the definition).
    params : GridGroundParams, optional
        All parameters at once (defaults: the ``isprs`` preset); keywords given
        explicitly override it. ``GridGroundParams.definition()`` is the plain
        seed rule.

    Returns
    -------
    numpy.ndarray
        bool (N,): True for ground points.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, a block or cell size <= 0, a cell
        larger than the block, a negative slope or tolerance,
        a negative ``outlier_depth``, ``min_seed_component < 1``,
        ``filter_passes < 0`` or
        ``final_passes < 1``.
    %(type_error)s

    Notes
    -----
    The definition (algorithms.md section 3). Blocks are anchored at
    multiples of block_size in world coordinates so that tiles of a survey
    share one lattice: a tile cut at block boundaries has the blocks it has in
    the merged cloud. Cells start at the same corner, so they line up across
    tiles too whenever block_size is a whole multiple of cell_size (as an
    unset cell_size always is, though tiles of different spacings may get
    different cells: fix them with :meth:`GridGroundParams.at_spacing`). Let
    ``l = p - o`` be the points in float64 local coordinates, with ``o_x, o_y``
    the block corner at or below the input's minimum corner,
    ``floor(min / block_size) * block_size`` per axis (one block lower where
    rounding puts that above the minimum), and ``o_z`` the minimum z. A
    translation by whole blocks leaves the blocks, the cells and, up to float64
    rounding, the result unchanged; any other may move block and cell
    boundaries through the points.

    1. Block of a point: ``floor(l_xy / block_size)``; cell:
       ``floor(l_xy / cell_size)``, both per axis in float64. Two points are
       neighbours when their cell indices differ by at most 1 on x and on y.
    2. Neighbours p and q of the same block are linked when
       ``|l_z(p) - l_z(q)| <= slope * d + height_tolerance`` with
       ``d = sqrt(dx*dx + dy*dy)`` of their local x, y differences.
    3. The seed of a block is its lowest point (ties: the lowest index); its
       connected component through the links is ground, everything else is
       object.

    Options, measured on the ISPRS samples and on by default (each lowers the
    mean total error there;
    ``benchmarks/studies/ground_isprs.py``):

    * ``min_seed_component = m > 1``: the seed is the lowest point whose
      component has at least m points, so low outliers (isolated below the
      terrain) are skipped; if no component of the block is that large, the
      lowest point's component is ground.
    * ``outlier_depth = h > 0``: a point p with at least one point q at
      another position in its 3 x 3 cells (any block), and ``l_z(q) - l_z(p) > h`` for every such
      q, is a low outlier: no seed, no link, no pre-filter test against it,
      and object after every round of the final pass (so never a vertex of
      its TIN).
    * ``grow_across_blocks``: links also join neighbours in different blocks;
      the ground is the union of the seeds' components.
    * ``filter_passes = k > 0`` (G. Vosselman's slope filter as a
      pre-filter): before growing, a point p is dropped (object, never
      linked, never a seed) when some neighbour q, in any block, has
      ``l_z(p) - l_z(q) > filter_slope * d + filter_tolerance``. In pass 1
      every point counts as q; in each further pass only the ground of the
      previous pass does, and the growth is repeated.
    * ``final_cell = c > 0`` (a final pass, as TerraScan classifies points by
      their distance to the ground TIN, with Zhao et al. 2016's
      slope-adaptive threshold): the lowest ground point of each c x c cell
      (anchored on the world lattice of c) is a vertex of a Delaunay TIN;
      its virtual vertices are the extent's four corners, at the height of
      their nearest vertex, and on each side one per vertex of an outermost
      cell, continuing a rise from the next cell inwards, up to the height of
      the cell's ground point nearest the side (so that an uphill border strip
      is not left below the surface). Every point, the grower's ground
      included, is then ground
      when ``-final_below <= z - z_TIN <= final_above + final_slope * g``,
      with z_TIN and g = |grad z_TIN| from the TIN's triangle under the
      point. A grower's ground that took low objects along gets the lower
      surface of its cells' minima, and terrain points the growth missed
      join it.
    * ``final_passes = r > 1``: the final pass runs r
      times, each round's TIN from the previous round's ground, as
      TerraScan's routines are run again on their own result. Where the
      growth took an object as the lowest ground point of a cell, the first
      round may have classified a lower terrain point there, and the next
      TIN runs under the object instead of over it.

    Limitation on small clips: a cluster of at least ``min_seed_component``
    low points (multipath echoes under the terrain), whose points vouch for
    each other in the low-outlier test, is the seed of every block it
    reaches. On a clip of one block, or of 2 x 2 blocks with the cluster at
    their common corner, no terrain point is then seeded: the cluster is the
    only ground (20 points 8 m deep in a 30 m clip at 2.2 points per m^2).
    Larger clips are seeded in their other blocks. Set ``min_seed_component``
    above the cluster's size on such clips (``pcl-rg denoise`` removed the
    20 points but not 50). Seed tests against the median of the cells
    around, or against the largest component, fixed such clusters but
    raised the mean total error on the ISPRS samples by 0.05-0.33 points,
    so none is in the filter.

    ``collect_diagnostics()`` reports the spacing an unset cell size took
    (``point_spacing``, NaN when cell_size was given), the ``cell_size`` used,
    the pre-filter passes and final-pass rounds run (``filter_passes_run``,
    ``final_passes_run``; fewer than asked for when one changed nothing), and the
    core's wall time by stage (``prepare_seconds``: bounding box, spacing and cell
    grid; ``growth_seconds``: low outliers, pre-filter and components;
    ``final_pass_seconds``: every final-pass round).

    Links are symmetric, so the growth does not depend on the visiting
    order. The final pass's TIN breaks exact co-circular ties by input index,
    so permuted input can change a few labels there (one point of samp52's
    53k in three of six permutations; none with ``final_cell=0``). The C++
    core (a counting sort into a flat CSR cell grid, a lock-free union-find
    over the links and the seeds picked per block, all parallel with OpenMP
    and the GIL released) equals the NumPy/SciPy reference
    :func:`pcl_rg.reference.grid_ground` point for point (with the final
    pass, wherever the TIN is unique: four or more co-circular vertices may
    be triangulated differently). No PCL
    class implements this filter; ``pcl::ProgressiveMorphologicalFilter`` is
    the baseline of ``benchmarks/studies/ground_isprs.py``.

    References
    ----------
    Seed 000: a blog reproduction of "LiDAR point cloud data filtering based
    on regional growth" (blocks dx x dy, cells bx x by, lowest seed, slope
    rule h = S * d); G. Vosselman, "Slope based filtering of laser altimetry
    data", IAPRS 33(B3/2), 2000; Terrasolid, TerraScan User Guide
    ("Ground" and "By distance to ground TIN" routines); Zhao et al., ISPRS
    J. Photogramm. Remote Sens. 117, 2016 (slope-adaptive thresholds).

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(0, 60, (8000, 2))
    >>> z = 0.05 * xy[:, 0]                           # a gentle 5 % slope
    >>> roof = (np.abs(xy - 30) < 6).all(axis=1)      # a 12 m box, 6 m high
    >>> z[roof] += 6.0
    >>> ground = pcl_rg.grid_ground(np.c_[xy, z])
    >>> bool(ground[~roof].all()), bool(ground[roof].any())
    (True, False)
    >>> plain = pcl_rg.GridGroundParams.definition(block_size=60, cell_size=1, slope=0.3)
    >>> bool((pcl_rg.grid_ground(np.c_[xy, z], params=plain) == ~roof).all())
    True
    """
    p = resolve_arguments(GridGroundParams, locals())
    xyz = as_points(points)
    ground, stats = _core.grid_ground(xyz, p.to_core())
    record("grid_ground", points=len(xyz), ground=int(ground.sum()), **stats)
    return ground
