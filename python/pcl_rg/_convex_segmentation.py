"""Scale-free patch growth and a convexity merge on the region graph."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._far_points import warn_far_points
from ._params import check_fields, param, resolve_arguments, to_core
from ._validation import as_points

__all__ = ["ConvexSegmentationParams", "convex_segmentation"]


@dataclass(frozen=True, kw_only=True, slots=True)
class ConvexSegmentationParams:
    """Parameters of :func:`convex_segmentation` (mirrors ``pcl_rg::ConvexSegmentationParams``)."""

    k: int = param(
        15,
        minimum=6,
        bits=32,
        help="neighbours per point, itself included, for normals, curvatures, growth and "
        "the region graph",
    )
    smoothness_deg: float = param(
        10.0,
        above=0.0,
        below=180.0,
        unit="deg",
        help="max angle between neighbouring normals within a patch",
    )
    curvature_threshold: float = param(
        0.8,
        minimum=0.0,
        help="joined points with curvedness x (k-th neighbour distance) <= this grow "
        "further; no unit, the same at any point spacing",
    )
    concavity_tolerance_deg: float = param(
        0.0,
        minimum=0.0,
        below=90.0,
        unit="deg",
        help="adjacent patches merge when each centroid lies at most this elevation angle "
        "above the other's mean plane",
    )
    min_cluster_size: int = param(
        20,
        minimum=1,
        help="smaller patches join their most connected neighbour; smaller segments are dropped "
        "(points of the voxel grid when noise_leaves uses one)",
    )
    noise_leaves: float = param(
        10.0,
        minimum=0.0,
        help="segment a voxel grid of this many times the measured surface noise when "
        "that is coarser than the point spacing (0: never)",
    )
    viewpoint: tuple[float, float, float] | None = param(
        None,
        axes=3,
        unit="m",
        optional=True,
        help="sensor position x,y,z in the caller's coordinates: normals are turned towards "
        "it (unset: the origin when the points lie near it, as in a sensor's own frame, "
        "else one box diagonal above the points' bounding box, an airborne sensor)",
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _core.ConvexSegmentationParams:
        return to_core(self, _core.ConvexSegmentationParams())


@fill_docstring
def convex_segmentation(
    points: npt.ArrayLike,
    *,
    k: int | None = None,
    smoothness_deg: float | None = None,
    curvature_threshold: float | None = None,
    concavity_tolerance_deg: float | None = None,
    min_cluster_size: int | None = None,
    noise_leaves: float | None = None,
    viewpoint: tuple[float, float, float] | None = None,
    params: ConvexSegmentationParams | None = None,
) -> np.ndarray:
    """Segment points into objects: smooth patches merged across convex edges.

    Parameters
    ----------
    %(points)s
    k : int, optional
        Neighbourhood size, the point itself included (default 15), for the
        normals, the curvatures, the growth and the region graph; >= 6, < N
        and at most 2^31 / N (a table of 4 bytes per point and neighbour,
        kept within 8 GiB).
    smoothness_deg : float, optional
        A neighbour joins a patch when the angle between its normal and the
        current patch point's normal is at most this, in degrees, in (0, 180)
        (default 10).
    curvature_threshold : float, optional
        A joined point grows further when its curvedness times the distance
        to its k-th neighbour is <= this (no unit: a curvature
        measured in neighbourhood radii, so the same value serves raw Kinect
        frames, voxel grids and airborne tiles) (default 0.8).
    concavity_tolerance_deg : float, optional
        Two adjacent patches merge when each one's centroid lies at most this
        elevation angle above the other's mean plane, in degrees, in [0, 90)
        (default 0: the cross-validated choice).
    min_cluster_size : int, optional
        Patches with fewer points take no part in the convexity test and join
        the segment of the one large patch they share most neighbour pairs with
        (not the segment summed over its patches: step 5 of the Notes); segments
        with fewer points are dropped (-1) (default 20). On the voxel grid
        (`noise_leaves`) the points counted are the grid's centroids, not the
        input points they stand for: on a raw Kinect frame (leaves of about
        4.5 mm) an object needs some 60-100 input points to stay.
    noise_leaves : float, optional
        When this many times the measured noise (:func:`pcl_rg.point_scale`)
        exceeds the point spacing, the steps below run on a voxel grid of that
        leaf and every point takes its voxel's label (default 10; 0: never).
        A raw Kinect frame (1.5 mm spacing, 0.5 mm noise) is segmented on a
        grid of about 4.5 mm; data already that coarse is segmented as it is.
        The grid is anchored at multiples of the leaf in world coordinates, as
        :func:`pcl_rg.voxel_grid`'s: a cloud moved by other than whole leaves
        is cut into other voxels, and labels near voxel boundaries change: on a
        Kinect frame of mOSD moved by (500 km, 5,000 km), 16 % of the labels and
        one segment more (``noise_leaves=0``, or a move by whole leaves: none).
        The noise is read on surface neighbourhoods only, so vegetation (thick
        volumes of points) does not count as sensor noise.
    viewpoint : sequence of 3 float, optional
        Sensor position, caller's coordinates. Default: the origin when the
        points lie within 100 diagonals of their bounding box from it (a
        Kinect or terrestrial frame, whose sensor is its origin); otherwise,
        as for a tile in UTM coordinates, an airborne sensor one diagonal
        above the top of the bounding box over its centre. The box's x and y
        leave out stray points (beyond 4 interquartile ranges of the
        quartiles), such as a record at (0, 0, 0) in a projected tile. Give it for
        data in other frames (an airborne tile in local coordinates near the
        origin, a mobile scan).
    %(params)s

    Returns
    -------
    numpy.ndarray
        int32 (N,): segment label per point, -1 for dropped points, numbered
        0, 1, ... by each segment's smallest point index.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, or a parameter out of range
        (``k < 6``, ``k >= N``, an angle out of range, a negative threshold).
    %(far_points_value_error)s
    %(type_error)s

    Notes
    -----
    0. The grid: leaf = `noise_leaves` x noise, used when it is larger than the
       spacing (:func:`pcl_rg.point_scale`) and leaves more than k centroids; the
       centroids are segmented, and labels are numbered again by the smallest
       input index.
    1. Normals, Gaussian curvature K and mean curvature H of every point as
       :func:`pcl_rg.normals` computes them, on its k nearest neighbours; r is
       the distance to the k-th of them, and the measure is the curvedness
       sqrt((k1^2 + k2^2) / 2) times r.
    2. Patches: the growth of :func:`pcl_rg.region_growing` with that measure
       (seeds in increasing measure, a neighbour joins when the normals are
       within `smoothness_deg`, and grows further when its measure is <=
       `curvature_threshold`), no size limit.
    3. Normals are turned towards `viewpoint` (the one used is in
       :func:`pcl_rg.collect_diagnostics`). Per patch: centroid c and mean
       oriented normal m (normalized sum). Two patches are adjacent when a
       point of one lists a point of the other among its k neighbours; the
       pair's weight is the number of such entries.
    4. An adjacent pair of patches a, b with >= `min_cluster_size` points each
       is convex when ``(c_b - c_a) . m_a <= sin(tol) |c_b - c_a|`` and
       ``(c_a - c_b) . m_b <= sin(tol) |c_a - c_b|``: each centroid lies below
       (behind) the other's plane, as across a box's edge, and not above it, as
       a box standing on a table lies above the table's plane (a concave
       crease). Segments are the connected components over convex pairs.
    5. A smaller patch joins the segment of its heaviest adjacent large patch
       (equal weights: the smaller segment id), else it is dropped; segments
       with fewer than `min_cluster_size` points are dropped.

    Every step is order-independent except the growth's tie breaks (as in
    :func:`pcl_rg.region_growing`) and the voxel grid's leaf, which comes from
    :func:`pcl_rg.point_scale`'s sample of every s-th point in input order
    (a permuted Kinect frame: leaf 5.576 against 5.582 mm, 143 of 91k labels
    changed); the result does not depend on the number of threads.

    %(far_points)s
    Far points are labelled -1, and the default viewpoint, the scale and the
    grid are those of the other points.

    The defaults were chosen by leave-one-scene-out cross-validation over the
    seven mOSD learn scenes (Kinect, raw frames and 3 to 8 mm voxel grids,
    ``benchmarks/studies/segmentation_mosd.py``) and six synthetic airborne
    scenes (2 to 20 points per m^2, raw and 0.5 and 1 m voxel grids, ground
    removed, ``benchmarks/studies/segmentation_airborne.py``); see
    benchmarks/RESULTS.md. On whole airborne tiles (ground kept) at 2 points
    per m^2 the sparse walls of most buildings join the ground's segment.

    References
    ----------
    S. C. Stein, M. Schoeler, J. Papon, F. Woergoetter, "Object partitioning
    using local convexity", CVPR 2014 (LCCP: convex and concave connections
    between adjacent patches, segments as components over convex ones).
    T. Rabbani, F. van den Heuvel, G. Vosselman, "Segmentation of point clouds
    using smoothness constraint", ISPRS Archives XXXVI-5, 2006 (the growth).

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> table = np.column_stack([rng.uniform(-0.3, 0.3, (3000, 2)), np.zeros(3000)])
    >>> table = table[(np.abs(table[:, 0]) > 0.1) | (np.abs(table[:, 1]) > 0.1)]
    >>> u = rng.uniform(-0.1, 0.1, (3, 600, 2))
    >>> box = np.vstack([  # the three faces a camera at (0.5, -1, 1) sees
    ...     np.column_stack([u[0, :, 0], u[0, :, 1], np.full(600, 0.2)]),
    ...     np.column_stack([u[1, :, 0], np.full(600, -0.1), u[1, :, 1] + 0.1]),
    ...     np.column_stack([np.full(600, 0.1), u[2, :, 0], u[2, :, 1] + 0.1]),
    ... ])
    >>> labels = pcl_rg.convex_segmentation(np.vstack([table, box]), viewpoint=(0.5, -1, 1))
    >>> on_table, on_box = labels[:len(table)], labels[len(table):]
    >>> box_label = np.bincount(on_box).argmax()  # faces merged: one segment
    >>> table_label = np.bincount(on_table).argmax()
    >>> float(np.mean(on_box == box_label).round(2)), bool(box_label != table_label)
    (0.99, True)
    """
    p = resolve_arguments(ConvexSegmentationParams, locals())
    xyz = as_points(points)
    labels, normals_s, growth_s, merge_s, leaf, viewpoint, far = _core.convex_segmentation(
        xyz, p.to_core()
    )
    record(
        "convex_segmentation",
        points=len(xyz),
        leaf=leaf,
        viewpoint=tuple(viewpoint),
        clusters=int(labels.max(initial=-1)) + 1,
        normals_seconds=normals_s,
        growth_seconds=growth_s,
        merge_seconds=merge_s,
        far_points=far,
    )
    warn_far_points("convex_segmentation", far, len(xyz), "they are labelled -1")
    return labels
