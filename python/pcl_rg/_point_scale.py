"""Point spacing and surface noise of a cloud, measured from the data."""

from __future__ import annotations

from typing import NamedTuple

import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._far_points import warn_far_points
from ._validation import as_points

__all__ = ["PointScale", "point_scale"]

#: Neighbours (the point itself included) of each measurement (kPointScaleNeighbours).
NEIGHBOURS = 16
#: At most about this many points are measured (kPointScaleSamples).
SAMPLES = 20_000
#: A neighbourhood's residual counts as noise when its RMS thickness is at most this
#: times its second spread, sqrt(lambda0) <= SURFACE_RATIO sqrt(lambda1)
#: (kPointScaleSurfaceRatio).
SURFACE_RATIO = 0.3


class PointScale(NamedTuple):
    """Result of :func:`point_scale`, in the units of the points."""

    spacing: float
    """Median distance from a point to its nearest other point."""
    noise: float
    """Median RMS distance of a point's 16 nearest neighbours from their plane, over
    the neighbourhoods that are surfaces (thin against their spread)."""


@fill_docstring
def point_scale(points: npt.ArrayLike) -> PointScale:
    """Measure the point spacing and the surface noise of a cloud.

    Parameters
    ----------
    %(points)s

    Returns
    -------
    PointScale
        ``spacing`` and ``noise``, NaN both for 16 points or fewer; ``noise``
        NaN when no measured neighbourhood is a surface.

    Raises
    ------
    %(points_value_error)s
    %(far_points_value_error)s
    %(type_error)s

    Notes
    -----
    Measured at the points 0, s, 2s, ... (s = max(1, N // 20000)) over each
    one's 16 nearest points, the point itself included (the float32 k-d tree
    of :func:`pcl_rg.normals`): the spacing is the distance to the nearest
    other point, the noise sqrt(lambda0), lambda0 the smallest eigenvalue of
    the neighbours' covariance (the RMS residual of their least-squares
    plane; Pauly et al., IEEE Visualization 2002), about 0.9 sigma for
    Gaussian noise of sigma on a plane, as the fit absorbs part of it. Each
    is the lower median of its values; the noise's only over the surface
    neighbourhoods, those whose thickness sqrt(lambda0) is at most 0.3 times
    their second spread sqrt(lambda1) (`SURFACE_RATIO`). On a plane 16
    neighbours spread about 1.1 spacings, so noise of up to a third of the
    spacing is measured (a raw Kinect frame: 0.5 mm on 1.5 mm; larger noise
    is read from its thinner neighbourhoods, so it comes out low); a volume of
    scattered points (tree canopy, shrubs) is thick against its spread, and
    its thickness is structure, not sensor noise. Both scale with the data:
    the same cloud in millimetres gives values 1000 times larger. They are
    the units of the scale-free defaults of
    :func:`pcl_rg.convex_segmentation` and of the automatic voxel size of
    :func:`pcl_rg.pipeline.seed004`.

    Not to be confused with :func:`pcl_rg.point_spacing`, the 2-D mean XY
    spacing (occupied area per point) that the airborne ground filters
    (:func:`pcl_rg.tin_ground`, :func:`pcl_rg.grid_ground`) scale their unset
    lengths with: this spacing is 3-D, a median nearest-neighbour distance on
    a scanned surface, and comes with its noise.

    %(far_points)s
    Both are measured on the other points alone.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> plane = np.column_stack([rng.uniform(0, 1, (20000, 2)), rng.normal(0, 1e-3, 20000)])
    >>> scale = pcl_rg.point_scale(plane)
    >>> round(scale.noise, 4), round(scale.spacing, 4)  # the noise is 1 mm
    (0.0009, 0.0036)
    >>> canopy = rng.uniform(0, 1, (20000, 3)) + (0, 0, 1.5)  # a volume above it
    >>> round(pcl_rg.point_scale(np.vstack([plane, canopy])).noise, 4)  # still the plane's
    0.0009
    """
    xyz = as_points(points)
    spacing, noise, far = _core.point_scale(xyz)
    record("point_scale", points=len(xyz), point_spacing=spacing, noise=noise, far_points=far)
    warn_far_points("point_scale", far, len(xyz), "the spacing and noise are the other points'")
    return PointScale(spacing, noise)
