"""Per-building instance truth of the synthetic scenes (see pcl_rg.datasets)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.typing import NDArray

from .._params import check_number
from .._validation import as_points, as_real
from ._objects import BUILDING

__all__ = ["building_ids"]


def building_ids(
    points: npt.ArrayLike,
    labels: npt.ArrayLike,
    buildings: npt.ArrayLike,
    *,
    tolerance: float = 0.01,
) -> NDArray[np.int64]:
    """Truth instance of every building point: 1, 2, ... by row of `buildings`.

    Parameters
    ----------
    points : array_like of float, shape (N, 3)
        The scene's points (``scene.points``).
    labels : array_like of int, shape (N,)
        Their ASPRS classes (``scene.labels``).
    buildings : array_like of float, shape (B, >= 4)
        Footprints ``[xmin, ymin, xmax, ymax, ...]`` in the coordinates of
        `points`, as :func:`synthetic_scene` and :func:`isprs_like_scene` return
        them (``scene.buildings``).
    tolerance : float, default 0.01
        Metres a point may lie outside a footprint and still belong to it (the
        walls stand on the footprint's edges); >= 0.

    Returns
    -------
    ndarray of int64, shape (N,)
        ``i + 1`` for a :data:`BUILDING` point within `tolerance` of footprint
        ``i`` (roof and walls), 0 for every other point.

    Raises
    ------
    ValueError
        A wrong shape, lengths that differ, non-finite values, a negative
        `tolerance`, or a building point in two footprints (they overlap).
    TypeError
        Non-numeric input.

    Notes
    -----
    Both generators keep buildings at least 3 m apart, so with the default
    tolerance every building point lies in exactly one footprint.

    Examples
    --------
    >>> import numpy as np
    >>> from pcl_rg.datasets import building_ids, synthetic_scene
    >>> scene = synthetic_scene(seed=1, size=100.0, n_buildings=2, n_trees=5)
    >>> ids = building_ids(scene.points, scene.labels, scene.buildings)
    >>> np.unique(ids).tolist()
    [0, 1, 2]
    """
    xyz = as_points(points)
    classes = np.asarray(labels)
    if classes.dtype.kind not in "iu":  # bool or text labels matched no class: all 0
        raise TypeError(f"labels must be integer class codes, got dtype {classes.dtype}")
    if classes.shape != (len(xyz),):
        raise ValueError(f"labels must have shape ({len(xyz)},), got {classes.shape}")
    boxes = as_real("buildings", buildings)
    if boxes.ndim != 2 or boxes.shape[1] < 4:
        raise ValueError(f"buildings must have shape (B, >= 4), got {boxes.shape}")
    if not np.all(np.isfinite(boxes[:, :4])):
        raise ValueError("buildings must be finite")
    tolerance = check_number("tolerance", tolerance, float, minimum=0.0)
    ids = np.zeros(len(xyz), dtype=np.int64)
    candidates = np.flatnonzero(classes == BUILDING)
    x, y = xyz[candidates, 0], xyz[candidates, 1]
    for i, (xmin, ymin, xmax, ymax) in enumerate(boxes[:, :4]):
        inside = (
            (x >= xmin - tolerance)
            & (x <= xmax + tolerance)
            & (y >= ymin - tolerance)
            & (y <= ymax + tolerance)
        )
        if np.any(ids[candidates[inside]] != 0):
            raise ValueError(f"footprint {i} overlaps another one within {tolerance:g} m")
        ids[candidates[inside]] = i + 1
    return ids
