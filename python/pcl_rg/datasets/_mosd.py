"""Reader of the modified Object Segmentation Database (mOSD) scenes.

Re-exported as :func:`pcl_rg.datasets.load_mosd`.
"""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from ..io import read_pcd

__all__ = ["MosdScene", "load_mosd"]


class MosdScene(NamedTuple):
    """One mOSD scene, valid points only."""

    points: np.ndarray
    """float64 (N, 3): x, y, z in metres, camera frame (z is depth)."""
    labels: np.ndarray
    """int32 (N,): ground-truth label; 1-9 table parts, 20-29 first object, ... (0: none)."""
    pixel: np.ndarray
    """intp (N,): flat pixel index ``row * width + col`` of each point in the image."""
    width: int
    """Image width (640)."""
    height: int
    """Image height (480)."""
    n_invalid: int
    """Number of pixels dropped because a coordinate was NaN or infinite."""


def load_mosd(path: str | os.PathLike[str]) -> MosdScene:
    """Read an mOSD scene: the valid points, their truth labels and pixels.

    Parameters
    ----------
    path : str or os.PathLike
        An organized PCD file of the database (fields ``label x y z rgba``,
        640 x 480).

    Returns
    -------
    MosdScene
        ``points`` float64 (N, 3), ``labels`` int32 (N,), ``pixel`` intp (N,)
        (flat index, ``divmod(pixel, width)`` gives row and column), the image
        ``width`` and ``height``, and ``n_invalid``, the number of pixels
        dropped.

    Raises
    ------
    ValueError
        If the file has no ``label`` field, one with more than one value per point
        or with values that are not whole numbers in [0, 2^31 - 1] on valid
        points, or is not organized (height 1).
    OSError
        If the file cannot be read.

    Notes
    -----
    Invalid pixels carry NaN coordinates (and label 0) in the database; they
    are dropped explicitly here and counted in ``n_invalid``, and ``pixel``
    keeps the way back to the image. The label scheme (mOSD README): 0 for
    invalid points, 1-9 for parts of the supporting table, 20-29 for the
    parts of the first object, 30-39 for the second, and so on; disjoint parts
    of one object carry different labels, so every label is one geometric
    segment, the ground truth for model-free segmentation.

    References
    ----------
    Richtsfeld et al., "Segmentation of unknown objects in indoor
    environments", IROS 2012 (OSD); modified by S. Alexandrov (mOSD).

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import write_pcd
    >>> from pcl_rg.datasets import load_mosd
    >>> xyz = np.array([[0.0, 0.0, 1.0], [np.nan, np.nan, np.nan],
    ...                 [0.1, 0.0, 1.0], [0.1, 0.1, 1.0]])
    >>> label = np.array([1, 0, 1, 20], dtype=np.uint32)
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "scene.pcd")
    ...     write_pcd(path, xyz, {"label": label}, width=2, height=2)
    ...     scene = load_mosd(path)
    >>> scene.labels.tolist(), scene.pixel.tolist(), scene.n_invalid
    ([1, 1, 20], [0, 2, 3], 1)
    """
    cloud = read_pcd(path)
    layout = cloud.header
    if "label" not in cloud.fields:
        raise ValueError(f"{os.fspath(path)}: no 'label' field; not an mOSD scene")
    if layout.height <= 1:
        raise ValueError(f"{os.fspath(path)}: not an organized cloud (height {layout.height})")
    label = np.asarray(cloud.fields["label"])
    if label.ndim != 1:
        raise ValueError(
            f"{os.fspath(path)}: the 'label' field holds {label.shape[1]} values per point; "
            "mOSD has one"
        )
    valid = np.isfinite(cloud.points).all(axis=1)
    # Labels are small whole numbers (0-9 the table, 20-29 the first object, ...): a
    # fractional, non-finite or out-of-range one is a damaged file, not a segment id.
    kept = label[valid]
    whole = np.isfinite(kept) & (kept == np.floor(kept)) if kept.dtype.kind == "f" else True
    if kept.size and not (np.all(whole) and kept.min() >= 0 and kept.max() <= 2**31 - 1):
        raise ValueError(
            f"{os.fspath(path)}: the 'label' field holds values that are not whole numbers "
            "in [0, 2^31 - 1]; not an mOSD label field"
        )
    pixel = np.flatnonzero(valid)
    return MosdScene(
        points=np.ascontiguousarray(cloud.points[valid]),
        labels=kept.astype(np.int32),
        pixel=pixel.astype(np.intp),
        width=int(layout.width),
        height=int(layout.height),
        n_invalid=int((~valid).sum()),
    )
