"""The seed 004 pipeline: SOR -> VoxelGrid -> normals and curvature -> region growing."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from ._convex_segmentation import ConvexSegmentationParams
from ._diagnostics import collect_diagnostics
from ._docstrings import fill_docstring
from ._params import check_flag
from ._point_scale import point_scale
from ._region_growing import RegionGrowingParams, region_growing
from ._statistical_outlier_removal import (
    StatisticalOutlierRemovalParams,
    statistical_outlier_removal,
)
from ._validation import MAX_POINTS_UINT32, as_points
from ._voxel_grid import VoxelGridParams, voxel_grid

__all__ = ["PipelineReport", "Seed004Result", "StageReport", "auto_leaf_size", "seed004"]

#: Leaf size in units of the measured noise (see :func:`auto_leaf_size`): the default
#: ``noise_leaves`` of :class:`pcl_rg.ConvexSegmentationParams`.
NOISE_LEAVES = ConvexSegmentationParams().noise_leaves


@dataclass(frozen=True, slots=True)
class StageReport:
    """One timed stage of :func:`seed004`."""

    name: str
    points_in: int
    points_out: int  # points passed on (region growing: points left with a label)
    seconds: float


@dataclass(frozen=True, slots=True)
class PipelineReport:
    """Point counts and times of every stage, printable like the paper's Table 1."""

    stages: tuple[StageReport, ...]
    clusters: int
    #: (points, seconds) of normals + growth run on the unprocessed cloud, when asked.
    original: tuple[int, float] | None = None

    @property
    def total_seconds(self) -> float:
        return float(sum(s.seconds for s in self.stages))

    @property
    def segmentation_seconds(self) -> float:
        """Normals and curvature plus region growing: the paper's "split time"."""
        return float(sum(s.seconds for s in self.stages if s.name in ("normals", "region growing")))

    def table(self) -> str:
        """Plain-text table of the stages (and Table 1 of the paper when available)."""
        lines = [f"{'stage':<28}{'points in':>12}{'points out':>12}{'time (s)':>11}"]
        for s in self.stages:
            lines.append(f"{s.name:<28}{s.points_in:>12}{s.points_out:>12}{s.seconds:>11.3f}")
        lines.append(f"{'total':<28}{'':>12}{'':>12}{self.total_seconds:>11.3f}")
        lines.append(f"{self.clusters} clusters")
        if self.original is not None:
            segmented = next(s for s in self.stages if s.name == "normals").points_in
            lines += [
                "",
                f"{'segmentation':<28}{'points':>12}{'split time (s)':>17}",
                f"{'original point cloud':<28}{self.original[0]:>12}{self.original[1]:>17.3f}",
                f"{'simplified point cloud':<28}{segmented:>12}{self.segmentation_seconds:>17.3f}",
            ]
        return "\n".join(lines)


class Seed004Result(NamedTuple):
    """Result of :func:`seed004`."""

    labels: np.ndarray
    """int32 (N,): cluster of every input point; -1 for SOR outliers, points of voxels
    under ``min_points_per_voxel`` and dropped regions."""
    inlier: np.ndarray
    """bool (N,): the SOR mask (all True when SOR is skipped)."""
    segment_of_point: np.ndarray
    """intp (N,): row of ``points`` each input point went into; -1 for SOR outliers and
    points of voxels under ``min_points_per_voxel``."""
    points: np.ndarray
    """float64 (M, 3): the preprocessed points that were segmented."""
    point_labels: np.ndarray
    """int32 (M,): the region growing labels of ``points``."""
    report: PipelineReport


def _number_by_first_index(labels: np.ndarray) -> np.ndarray:
    """Renumber labels >= 0 as 0, 1, ... in order of their smallest index."""
    out = np.full(labels.shape, -1, dtype=np.int32)
    kept = labels >= 0
    if not kept.any():
        return out
    ids, first = np.unique(labels[kept], return_index=True)
    rank = np.empty(ids.size, dtype=np.int32)
    rank[np.argsort(first)] = np.arange(ids.size, dtype=np.int32)
    out[kept] = rank[np.searchsorted(ids, labels[kept])]
    return out


def auto_leaf_size(points: npt.ArrayLike) -> float | None:
    """The voxel leaf size :func:`seed004` uses when given none: from the data's noise.

    Parameters
    ----------
    points : array_like
        (N, 3) points.

    Returns
    -------
    float or None
        ``NOISE_LEAVES * noise`` (10 times the noise of
        :func:`pcl_rg.point_scale`) when that is larger than the point
        spacing; None otherwise (no grid) and for 16 points or fewer. The same
        rule as :func:`pcl_rg.convex_segmentation`'s ``noise_leaves``.

    Notes
    -----
    Depth noise, not point spacing, limits what normals and curvatures can
    resolve in dense scans: a raw Kinect frame 1 m away has about 1.5 mm
    spacing and 0.5 mm noise, and segments best on a grid of about 5 mm
    (benchmarks/RESULTS.md). Sparser data, whose noise is small against its
    spacing (8 mm grids of the same frames, sparse airborne tiles), gets no
    grid. The noise is read on surface neighbourhoods only, so vegetation
    (airborne points without their ground are mostly trees) does not count
    as noise (RESULTS.md, segmentation of airborne scenes).

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.pipeline import auto_leaf_size
    >>> rng = np.random.default_rng(0)
    >>> dense = np.column_stack([rng.uniform(0, 1, (200000, 2)), rng.normal(0, 1e-3, 200000)])
    >>> round(auto_leaf_size(dense), 3)  # 10 x the measured noise, above the 1.5 mm spacing
    0.006
    >>> print(auto_leaf_size(dense[:1000]))  # 15 mm spacing: already coarser
    None
    """
    scale = point_scale(points)
    leaf = NOISE_LEAVES * scale.noise
    return leaf if leaf > scale.spacing else None


_DEFAULT_SOR = StatisticalOutlierRemovalParams()
_DEFAULT_REGION = RegionGrowingParams()


@fill_docstring
def seed004(
    points: npt.ArrayLike,
    *,
    sor: StatisticalOutlierRemovalParams | None = _DEFAULT_SOR,
    voxel: VoxelGridParams | None = None,
    region: RegionGrowingParams = _DEFAULT_REGION,
    time_original: bool = False,
    auto_voxel: bool = True,
) -> Seed004Result:
    """Run the seed 004 pipeline and carry the labels back to every input point.

    Parameters
    ----------
    %(points)s
    sor : StatisticalOutlierRemovalParams or None, optional
        Denoising stage (default: PCL's tutorial values, mean_k 50, std_mul 1);
        None skips it.
    voxel : VoxelGridParams or None, optional
        Simplification stage. None (the default): a leaf size chosen from the
        data by :func:`auto_leaf_size` (the report's stage name says which),
        or no grid when `auto_voxel` is False. Either grid is anchored at
        multiples of the leaf in world coordinates (:func:`pcl_rg.voxel_grid`,
        so that tiles of a survey share it): a cloud moved by other than whole
        leaves is cut into other voxels, and some labels near voxel boundaries
        change; none degrade at large (UTM) coordinates.
    region : RegionGrowingParams, optional
        Normals, curvatures and curvature-seeded region growing.
    time_original : bool, default False
        Also time normals + growth on the cloud before SOR and VoxelGrid, to
        fill the paper's Table 1 (original against simplified).
    auto_voxel : bool, default True
        With ``voxel=None``, choose the leaf size from the data (True) or skip
        the voxel grid (False). A chosen leaf that would leave no more than
        ``region.k`` centroids is not used: the points are segmented as they
        are.

    Returns
    -------
    Seed004Result
        ``labels`` int32 (N,) per input point (-1: SOR outlier, a point of a
        voxel under ``min_points_per_voxel``, or a region outside the cluster
        sizes, which count the points segmented: the voxel centroids when
        there is a grid), numbered 0, 1, ... by each cluster's
        smallest input index; the SOR ``inlier`` mask; ``segment_of_point``
        (the preprocessed point holding each input point); the segmented
        ``points`` and their ``point_labels``; and the ``report``.

    Raises
    ------
    ValueError
        Non-finite points or a stage's parameter error (e.g. SOR's mean_k or
        region growing's k not below the number of points reaching it).
    %(type_error)s

    Notes
    -----
    Stages, each timed (wall clock): :func:`pcl_rg.statistical_outlier_removal`
    on all points; :func:`pcl_rg.voxel_grid` on the inliers (centroids);
    normals and curvatures, then region growing (:func:`pcl_rg.region_growing`)
    on what is left. An input point inherits the label of its voxel's
    centroid; SOR outliers get -1. ``report.table()`` lists point counts and
    times per stage, like Table 1 of the paper (which reports point counts
    and "split time" before and after preprocessing).

    References
    ----------
    Seed 004: Wang et al., "Point cloud segmentation based on improved region
    growing", ISPRS Archives XLII-3/W10, 2020, sections 2 and 3, Table 1.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import VoxelGridParams, RegionGrowingParams
    >>> from pcl_rg.pipeline import seed004
    >>> rng = np.random.default_rng(0)
    >>> floor = np.column_stack([rng.uniform(0, 2, (3000, 2)), np.zeros(3000)])
    >>> wall = np.column_stack([rng.uniform(0, 2, 3000), np.full(3000, 2.3),
    ...                         rng.uniform(0.3, 2, 3000)])
    >>> result = seed004(np.vstack([floor, wall]), voxel=VoxelGridParams(leaf_size=0.05),
    ...                  region=RegionGrowingParams(k=12, smoothness_deg=5))
    >>> kept = result.inlier  # SOR drops a few points along the borders
    >>> np.unique(result.labels[:3000][kept[:3000]]).tolist()
    [0]
    >>> np.unique(result.labels[3000:][kept[3000:]]).tolist()
    [1]
    >>> [stage.name for stage in result.report.stages]
    ['statistical outlier removal', 'voxel grid', 'normals', 'region growing']
    """
    if sor is not None and not isinstance(sor, StatisticalOutlierRemovalParams):
        raise TypeError(f"sor must be a StatisticalOutlierRemovalParams or None, got {sor!r}")
    if voxel is not None and not isinstance(voxel, VoxelGridParams):
        raise TypeError(f"voxel must be a VoxelGridParams or None, got {voxel!r}")
    if not isinstance(region, RegionGrowingParams):
        raise TypeError(f"region must be a RegionGrowingParams, got {region!r}")
    time_original = check_flag("time_original", time_original)
    auto_voxel = check_flag("auto_voxel", auto_voxel)
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)  # stages check their own limits
    n = len(xyz)
    stages: list[StageReport] = []

    original = None
    if time_original:
        with collect_diagnostics() as measured:
            region_growing(xyz, params=region)
        timing = measured["region_growing"]
        original = (n, timing["normals_seconds"] + timing["growth_seconds"])

    # 2.1 denoising
    if sor is not None:
        start = time.perf_counter()
        inlier = statistical_outlier_removal(xyz, params=sor)
        seconds = time.perf_counter() - start
        kept_index = np.flatnonzero(inlier)
        stages.append(StageReport("statistical outlier removal", n, kept_index.size, seconds))
    else:
        inlier = np.ones(n, dtype=bool)
        kept_index = np.arange(n)
    kept = xyz[kept_index]

    # 2.2 simplification
    auto = ""
    if voxel is None and auto_voxel:
        leaf = auto_leaf_size(kept)
        if leaf is not None:
            voxel = VoxelGridParams(leaf_size=leaf)
            auto = f" (auto leaf {leaf:.3g})"
    if voxel is not None:
        start = time.perf_counter()
        grid = voxel_grid(kept, params=voxel)
        seconds = time.perf_counter() - start
        if auto and len(grid.centroids) <= region.k < len(kept):
            # The chosen leaf would leave region growing too few points for its k
            # neighbours (a small noisy cloud): segment the points themselves, as
            # convex_segmentation does.
            voxel, auto = None, ""
        elif len(grid.centroids) <= region.k < len(kept):
            raise ValueError(
                f"the voxel grid (leaf_size {voxel.leaf_size}) leaves {len(grid.centroids)} "
                f"centroids, not more than the region growing's k = {region.k}; use a "
                "smaller leaf_size or k"
            )
        else:
            segmented, row_of_kept = grid.centroids, grid.voxel_of_point
            stages.append(StageReport("voxel grid" + auto, len(kept), len(segmented), seconds))
    if voxel is None:
        segmented, row_of_kept = kept, np.arange(len(kept), dtype=np.intp)

    # 3 normals and curvature, then region growing
    with collect_diagnostics() as measured:
        point_labels = region_growing(segmented, params=region)
    normals_s = measured["region_growing"]["normals_seconds"]
    growth_s = measured["region_growing"]["growth_seconds"]
    m = len(segmented)
    stages.append(StageReport("normals", m, m, normals_s))
    stages.append(StageReport("region growing", m, int((point_labels >= 0).sum()), growth_s))

    segment_of_point = np.full(n, -1, dtype=np.intp)
    segment_of_point[kept_index] = row_of_kept
    carried = np.full(n, -1, dtype=np.int64)
    has_row = segment_of_point >= 0
    carried[has_row] = point_labels[segment_of_point[has_row]]
    labels = _number_by_first_index(carried)
    clusters = int(labels.max()) + 1 if labels.size else 0
    return Seed004Result(
        labels=labels,
        inlier=inlier,
        segment_of_point=segment_of_point,
        points=segmented,
        point_labels=point_labels,
        report=PipelineReport(tuple(stages), clusters, original),
    )
