"""Normals and curvatures from k-nearest neighbourhoods (PCA + local quadric)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from . import _core
from ._diagnostics import record
from ._docstrings import fill_docstring
from ._far_points import warn_far_points
from ._params import check_fields, param, resolve_arguments, to_core
from ._validation import MAX_POINTS_UINT32, as_points

__all__ = ["NormalsParams", "NormalsResult", "normals"]


#: The fewest neighbours (the point itself included) whose quadric fit gives curvatures;
#: with fewer they are NaN. The core's kMinCurvatureK (normals.hpp).
MIN_CURVATURE_K = 6


@dataclass(frozen=True, kw_only=True, slots=True)
class NormalsParams:
    """Parameters of :func:`normals` (mirrors ``pcl_rg::NormalsParams``)."""

    k: int = param(
        30, minimum=3, bits=32, help="neighbours per point, itself included, >= 3 (PCL setKSearch)"
    )

    def __post_init__(self) -> None:
        check_fields(self)

    def to_core(self) -> _core.NormalsParams:
        return to_core(self, _core.NormalsParams())


class NormalsResult(NamedTuple):
    """Result of :func:`normals`; every array has one row per input point."""

    normals: np.ndarray
    """float64 (N, 3): unit normals, oriented so that n_z > 0 (see Notes)."""
    surface_variation: np.ndarray
    """float64 (N,): lambda0 / (lambda0 + lambda1 + lambda2), PCL's ``curvature``."""
    gaussian_curvature: np.ndarray
    """float64 (N,): Gaussian curvature K of the local quadric (1/m^2)."""
    mean_curvature: np.ndarray
    """float64 (N,): mean curvature H, positive where the surface bends towards the normal (1/m)."""
    k1: np.ndarray
    """float64 (N,): larger principal curvature H + sqrt(max(H^2 - K, 0)) (1/m)."""
    k2: np.ndarray
    """float64 (N,): smaller principal curvature H - sqrt(max(H^2 - K, 0)) (1/m)."""


@fill_docstring
def normals(
    points: npt.ArrayLike, *, k: int | None = None, params: NormalsParams | None = None
) -> NormalsResult:
    """Estimate unit normals, surface variation and curvatures of every point.

    Parameters
    ----------
    %(points)s
    k : int, optional
        Neighbourhood size: the `k` nearest points, the point itself included
        (default 30). Must be >= 3 and < N; curvatures need k >= 6.
    %(params)s

    Returns
    -------
    NormalsResult
        ``normals`` float64 (N, 3); ``surface_variation``,
        ``gaussian_curvature``, ``mean_curvature``, ``k1``, ``k2`` float64 (N,).
        NaN marks an undefined value (see Notes).

    Raises
    ------
    ValueError
        Non-finite points, a wrong shape, ``k < 3`` or ``k >= N``.
    %(far_points_value_error)s
    %(type_error)s

    Notes
    -----
    Neighbours come from an exact k-d tree on float32 coordinates taken
    relative to a float64 local origin (equal distances by lower index; of
    several points tied at the k-th distance, the k-d tree keeps the first it
    meets, deterministically); all geometry is
    then computed in float64 from the caller's coordinates relative to the
    query point, so UTM-sized coordinates lose nothing.

    1. Normal: eigenvector of the smallest eigenvalue lambda0 of the
       neighbourhood covariance (least-squares plane, as
       ``pcl::NormalEstimation``). Normals are unoriented by nature; each gets
       one deterministic sign, n_z > 0 (for n_z == 0: n_y > 0, then n_x > 0),
       i.e. "up" for airborne LiDAR. PCL instead flips towards a viewpoint.
       Only the signs of ``mean_curvature``, ``k1`` and ``k2`` depend on it.
    2. Surface variation lambda0 / (lambda0 + lambda1 + lambda2), PCL's
       ``Normal::curvature`` (in [0, 1/3]).
    3. Quadric z = a x^2 + b xy + c y^2 + d x + e y + f fitted by least
       squares to the neighbours in the point's PCA frame (x: largest-variance
       axis, y = n x x, z = n), centred at the point itself. Then
       K = (4ac - b^2) / (1 + d^2 + e^2)^2,
       H = ((1 + e^2) a - d e b + (1 + d^2) c) / (1 + d^2 + e^2)^(3/2),
       k1,2 = H +- sqrt(max(H^2 - K, 0)), the curvatures of the fitted
       surface at the foot of the point (Besl & Jain 1986).

    Degenerate neighbourhoods never raise: when all k neighbours coincide,
    every output of that point is NaN; when k < 6, or the neighbours hold
    fewer than 6 distinct positions, or the quadric's design is rank deficient
    (e.g. collinear neighbours: a squared Cholesky pivot of the
    6 x 6 normal matrix / k, tangent coordinates scaled to unit RMS radius, is
    not above ``pcl_rg._core.QUADRIC_CONDITION_LIMIT`` = 1e-10), K, H, k1 and
    k2 are NaN while the normal and surface variation are kept (for collinear
    neighbours the normal is then an arbitrary unit vector perpendicular to
    the line, as in PCL).

    %(far_points)s
    Every output of a far point is NaN.

    Runs in parallel (OpenMP) with the GIL released; results do not depend on
    the number of threads.

    References
    ----------
    Seed 004 (Wang et al., ISPRS Archives XLII-3/W10, 2020), sections 3.1-3.2;
    Besl & Jain, "Invariant surface characteristics for 3D object recognition
    in range images", CVGIP 33, 1986.

    Examples
    --------
    >>> import numpy as np
    >>> import pcl_rg
    >>> rng = np.random.default_rng(0)
    >>> xy = rng.uniform(-1, 1, (400, 2))
    >>> sphere_cap = np.column_stack([xy, -np.sqrt(25.0 - (xy**2).sum(axis=1))])
    >>> result = pcl_rg.normals(sphere_cap, k=20)
    >>> result.normals.shape, bool(np.all(result.normals[:, 2] > 0))
    ((400, 3), True)
    >>> round(float(np.median(result.gaussian_curvature)), 3)  # 1 / r^2
    0.04
    >>> round(float(np.median(result.mean_curvature)), 2)  # bowl seen from above: +1 / r
    0.2
    """
    p = resolve_arguments(NormalsParams, locals())
    xyz = as_points(points, max_points=MAX_POINTS_UINT32)
    *fields, far = _core.normals(xyz, p.to_core())
    result = NormalsResult(*fields)
    record("normals", points=len(xyz), k=p.k, far_points=far)
    warn_far_points("normals", far, len(xyz), "their normals and curvatures are NaN")
    return result
