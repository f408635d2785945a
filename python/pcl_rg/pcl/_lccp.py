"""``pcl::SupervoxelClustering`` + ``pcl::LCCPSegmentation`` on NumPy arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from .. import _pcl
from .._diagnostics import record
from .._docstrings import fill_docstring
from .._params import check_fields, format_value, param, resolve_arguments, to_core
from .._validation import as_points

__all__ = ["LccpParams", "lccp"]

# PCL counts segment sizes in std::uint32_t.
_MAX_SEGMENT_SIZE = 2**32 - 1


@dataclass(frozen=True, kw_only=True, slots=True)
class LccpParams:
    """Parameters of :func:`lccp` (mirrors ``pcl_rg::LccpParams``).

    The defaults are those of PCL's LCCP example program, sized for Kinect
    frames in metres; colour is not used.
    """

    voxel_resolution: float = param(
        0.0075, above=0.0, unit="m", help="voxel edge of the supervoxel octree (voxel_resolution)"
    )
    seed_resolution: float = param(
        0.03,
        above=0.0,
        unit="m",
        help="spacing of the supervoxel seeds, >= voxel_resolution (seed_resolution)",
    )
    spatial_importance: float = param(
        1.0, minimum=0.0, help="weight of distance in supervoxel growth (setSpatialImportance)"
    )
    normal_importance: float = param(
        4.0, minimum=0.0, help="weight of normals in supervoxel growth (setNormalImportance)"
    )
    refinement_iterations: int = param(
        0, minimum=0, maximum=100, help="supervoxel refinement passes (refineSupervoxels)"
    )
    concavity_tolerance_deg: float = param(
        10.0,
        minimum=0.0,
        below=180.0,
        unit="deg",
        help="concave edges flatter than this count as convex (setConcavityToleranceThreshold)",
    )
    smoothness_threshold: float = param(
        0.1,
        minimum=0.0,
        help="step test: patches further apart than expected + this x voxel_resolution are "
        "cut (setSmoothnessCheck)",
    )
    k_factor: int = param(
        0,
        minimum=0,
        maximum=1,
        help="extended convexity: 1 asks a common neighbour convex to both (setKFactor)",
    )
    sanity_check: bool = param(False, help="cut singular convex connections (setSanityCheck)")
    min_segment_size: int = param(
        0,
        minimum=0,
        maximum=_MAX_SEGMENT_SIZE,
        unit="supervoxels",
        help="smaller segments join their largest neighbour (setMinSegmentSize)",
    )
    viewpoint: tuple[float, float, float] = param(
        (0.0, 0.0, 0.0),
        axes=3,
        unit="m",
        help="where the sensor was, in the points' coordinates: PCL flips normals towards it "
        "(a Kinect frame: 0,0,0)",
    )

    def __post_init__(self) -> None:
        check_fields(self)
        if self.seed_resolution < self.voxel_resolution:
            raise ValueError(
                f"seed_resolution must be >= voxel_resolution "
                f"({format_value(self.voxel_resolution)}), got {format_value(self.seed_resolution)}"
            )

    def to_core(self) -> _pcl.LccpParams:
        return to_core(self, _pcl.LccpParams())


@fill_docstring
def lccp(
    points: npt.ArrayLike,
    *,
    voxel_resolution: float | None = None,
    seed_resolution: float | None = None,
    spatial_importance: float | None = None,
    normal_importance: float | None = None,
    refinement_iterations: int | None = None,
    concavity_tolerance_deg: float | None = None,
    smoothness_threshold: float | None = None,
    k_factor: int | None = None,
    sanity_check: bool | None = None,
    min_segment_size: int | None = None,
    viewpoint: float | tuple[float, float, float] | None = None,
    params: LccpParams | None = None,
) -> np.ndarray:
    """Segment points with PCL's supervoxels and locally convex connected patches.

    Parameters
    ----------
    %(points)s
    voxel_resolution : float, optional
        Voxel edge of the supervoxel octree, metres (default 0.0075); > 0.
    seed_resolution : float, optional
        Spacing of the supervoxel seeds, metres (default 0.03);
        >= `voxel_resolution`.
    spatial_importance : float, optional
        Weight of the spatial distance in supervoxel growth (default 1); >= 0.
    normal_importance : float, optional
        Weight of the normal difference in supervoxel growth (default 4); >= 0.
    refinement_iterations : int, optional
        Supervoxel refinement passes (default 0), 0 to 100.
    concavity_tolerance_deg : float, optional
        Concave edges flatter than this count as convex, degrees (default 10),
        in [0, 180).
    smoothness_threshold : float, optional
        Step test: adjacent patches further apart than expected plus this many
        voxel edges are not joined (default 0.1); >= 0.
    k_factor : int, optional
        Extended convexity (default 0): with 1, a convex edge also needs a
        common neighbour convex to both patches.
    sanity_check : bool, optional
        Cut singular convex connections (default False).
    min_segment_size : int, optional
        Segments of fewer supervoxels join their largest neighbour (default 0).
    viewpoint : sequence of 3 floats, optional
        Where the sensor was, in the coordinates of `points` (default
        (0, 0, 0), the camera of a Kinect frame). PCL orients every normal
        towards it, and convexity is judged with those normals.
    %(params)s

    Returns
    -------
    numpy.ndarray
        int32 (N,) labels: the segment of each point's voxel, -1 where no
        supervoxel took the voxel, numbered 0, 1, ... by each segment's smallest
        point index. The stage times are recorded as ``supervoxel_seconds`` and
        ``segmentation_seconds`` under ``"pcl.lccp"`` in
        :func:`pcl_rg.collect_diagnostics`.

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, a parameter out of range, a
        resolution, importance or smoothness threshold that float32 cannot hold
        (PCL aborts or degenerates there), or a point more than 2**20 voxels
        from `viewpoint` (float32 would not resolve the voxels).
    %(type_error)s

    Notes
    -----
    As PCL 1.13 does it: ``pcl::SupervoxelClustering<PointXYZ>`` (colour
    importance 0, no single-camera transform) builds supervoxels; their
    adjacency goes to ``pcl::LCCPSegmentation``, whose smoothness (step) check
    is on. Labels are PCL's, per point through its voxel. PCL's classes run on
    one thread, in float32 on the points minus `viewpoint`: PCL flips the
    voxel and supervoxel normals towards the origin of its frame, so that
    origin must be the sensor for convex edges to come out convex.

    References
    ----------
    Stein, Schoeler, Papon and Woergoetter, "Object partitioning using local
    convexity", CVPR 2014. Papon, Abramov, Schoeler and Woergoetter, "Voxel
    cloud connectivity segmentation - supervoxels for point clouds", CVPR 2013.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> def cube(corner, side=0.1):  # the three faces a sensor at (-1, -1, 1) sees
    ...     faces = [rng.uniform(0, side, (800, 3)) for axis in range(3)]
    ...     for axis, face in enumerate(faces):
    ...         face[:, axis] = side if axis == 2 else 0.0
    ...     return np.vstack(faces) + corner
    >>> pts = np.vstack([cube((0.0, 0.0, 0.0)), cube((0.3, 0.05, 0.0))])
    >>> labels = pcl_rg.pcl.lccp(pts, viewpoint=(-1.0, -1.0, 1.0))
    >>> np.unique(labels[:2400]).tolist(), np.unique(labels[2400:]).tolist()
    ([0], [1])
    """
    p = resolve_arguments(LccpParams, locals())
    xyz = as_points(points)
    labels, supervoxel_seconds, segmentation_seconds = _pcl.lccp(xyz, p.to_core())
    record(
        "pcl.lccp",
        points=len(xyz),
        clusters=int(labels.max(initial=-1)) + 1,
        assigned=int((labels >= 0).sum()),
        supervoxel_seconds=supervoxel_seconds,
        segmentation_seconds=segmentation_seconds,
    )
    return labels
