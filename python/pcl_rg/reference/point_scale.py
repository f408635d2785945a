"""NumPy reference for :func:`pcl_rg.point_scale`."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from .._point_scale import NEIGHBOURS, SAMPLES, SURFACE_RATIO, PointScale
from .._validation import as_points
from ._local import near_rows
from .normals import neighbour_lists

__all__ = ["point_scale"]


def _lower_median(values: np.ndarray) -> float:
    if values.size == 0:
        return float("nan")
    return float(np.sort(values)[(len(values) - 1) // 2])


def point_scale(points: npt.ArrayLike) -> PointScale:
    """Reference point scale: same signature and result as :func:`pcl_rg.point_scale`.

    Agrees with the core to rounding (LAPACK's eigenvalues against Eigen's),
    except where a neighbour list has a tie at its 16th place or a
    neighbourhood's thickness lies within rounding of the surface rule.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg import reference
    >>> rng = np.random.default_rng(0)
    >>> plane = np.column_stack([rng.uniform(0, 1, (2000, 2)), rng.normal(0, 1e-3, 2000)])
    >>> round(reference.point_scale(plane).noise, 4)
    0.0009
    """
    xyz = as_points(points)
    n = len(xyz)
    if n <= NEIGHBOURS:
        return PointScale(float("nan"), float("nan"))
    near = near_rows(xyz)
    if near is not None:  # measured on the others alone
        return point_scale(xyz[near])
    rows = np.arange(0, n, max(1, n // SAMPLES))
    relative = xyz[neighbour_lists(xyz, NEIGHBOURS)[rows]] - xyz[rows, None, :]
    spacing = np.linalg.norm(relative[:, 1], axis=1)
    centred = relative - relative.mean(axis=1, keepdims=True)
    covariance = np.einsum("mki,mkj->mij", centred, centred) / NEIGHBOURS
    eigenvalues = np.maximum(np.linalg.eigvalsh(covariance), 0.0)
    thickness, spread = np.sqrt(eigenvalues[:, 0]), np.sqrt(eigenvalues[:, 1])
    surface = thickness <= SURFACE_RATIO * spread
    return PointScale(_lower_median(spacing), _lower_median(thickness[surface]))
