"""The ISPRS filter-test samples: points and ground truth from the two PCD files."""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from ..io import read_pcd

__all__ = ["IsprsSample", "load_isprs"]


class IsprsSample(NamedTuple):
    """Result of :func:`load_isprs`."""

    points: np.ndarray
    """float64 (N, 3): every point of the full cloud, in file order."""
    ground: np.ndarray
    """bool (N,): True where the point is ground in the reference labelling."""


def _xyz(path: str | os.PathLike[str], name: str) -> np.ndarray:
    points = read_pcd(path).points
    finite = np.isfinite(points).all(axis=1)
    if not finite.all():
        raise ValueError(
            f"{name} ({os.fspath(path)}) has {int((~finite).sum())} point(s) with NaN or Inf "
            "coordinates; ISPRS samples have none"
        )
    return points


def load_isprs(all_pcd: str | os.PathLike[str], ground_pcd: str | os.PathLike[str]) -> IsprsSample:
    """Read an ISPRS sample and label its points from the ground-only file.

    Parameters
    ----------
    all_pcd : str or os.PathLike
        PCD file with every point of the sample (``sampNN-utm.pcd``).
    ground_pcd : str or os.PathLike
        PCD file with the ground points only (``sampNN-utm-ground.pcd``).

    Returns
    -------
    IsprsSample
        ``points`` float64 (N, 3), the full cloud in file order, and
        ``ground`` bool (N,), the reference labels.

    Raises
    ------
    ValueError
        If a file holds non-finite coordinates, or the ground file holds a
        point (or more copies of one) that the full file does not.
    FileNotFoundError, TypeError
        From :func:`pcl_rg.io.read_pcd`.

    Notes
    -----
    A point of the full cloud is ground when its exact x, y, z occur in the
    ground file. The two files are matched as multisets: when a coordinate
    triple occurs k times in the full file and g <= k times in the ground
    file, its first g copies (in file order) are ground and the other k - g
    are object, so the ground count always equals the ground file's length.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import write_pcd
    >>> from pcl_rg.datasets import load_isprs
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> full = np.array([[0.0, 0, 0], [1, 0, 5], [0, 0, 0], [2, 0, 0]])
    >>> write_pcd(folder / "all.pcd", full)
    >>> write_pcd(folder / "ground.pcd", full[[3, 0]])
    >>> load_isprs(folder / "all.pcd", folder / "ground.pcd").ground.tolist()
    [True, False, False, True]
    """
    points = _xyz(all_pcd, "all_pcd")
    ground_points = _xyz(ground_pcd, "ground_pcd")
    n = len(points)
    if n == 0 and len(ground_points) == 0:
        return IsprsSample(points, np.zeros(0, dtype=bool))
    # One integer key per distinct xyz triple across both files.
    _, key = np.unique(np.vstack([points, ground_points]), axis=0, return_inverse=True)
    key = key.ravel()
    key_all, key_ground = key[:n], key[n:]
    distinct = int(key.max()) + 1
    in_all = np.bincount(key_all, minlength=distinct)
    in_ground = np.bincount(key_ground, minlength=distinct)
    excess = in_ground > in_all
    if excess.any():
        raise ValueError(
            f"ground_pcd ({os.fspath(ground_pcd)}) holds {int((in_ground - in_all)[excess].sum())} "
            f"point(s) that all_pcd ({os.fspath(all_pcd)}) does not"
        )
    # Rank of each point among the copies of its triple, in file order.
    order = np.argsort(key_all, kind="stable")
    sorted_key = key_all[order]
    group_start = np.searchsorted(sorted_key, sorted_key, side="left")
    rank = np.empty(n, dtype=np.int64)
    rank[order] = np.arange(n) - group_start
    return IsprsSample(points, rank < in_ground[key_all])
