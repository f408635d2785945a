"""The horizontal extent of a point file: from the header for LAS/LAZ, else from the points."""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from ._formats import check_magic, format_of
from ._las import _bad_las, _laspy
from ._las_header import check_las_header

__all__ = ["Extent", "read_extent"]


class Extent(NamedTuple):
    """Bounding box of a file's points and their number."""

    xmin: float
    ymin: float
    zmin: float
    xmax: float
    ymax: float
    zmax: float
    points: int
    from_header: bool
    """True when read from a LAS/LAZ header without reading any point."""


def _las_extent(path: str) -> Extent:
    """The header's bounds and point count, after the header checks of every read."""
    laspy = _laspy()
    with open(path, "rb") as stream:
        facts = check_las_header(path, stream)
        stream.seek(0)
        try:
            with laspy.open(stream, closefd=False) as reader:
                header = reader.header
                mins, maxs = np.asarray(header.mins, float), np.asarray(header.maxs, float)
        except Exception as error:  # laspy raises many kinds on a damaged header
            raise _bad_las(os.fspath(path), error) from None
    if not (np.isfinite(mins).all() and np.isfinite(maxs).all() and (mins <= maxs).all()):
        if facts.point_count:
            raise ValueError(
                f"invalid LAS/LAZ file {path!r}: header bounds {mins.tolist()} .. "
                f"{maxs.tolist()} are not a box"
            )
    return Extent(*mins.tolist(), *maxs.tolist(), int(facts.point_count), True)


def read_extent(path: str | os.PathLike[str], *, format: str | None = None) -> Extent:
    """The bounding box and point count of a point file.

    LAS/LAZ: from the header alone (checked against the file size as
    :func:`read_points` checks it), without decoding a point. Other formats
    store no bounds: the points are read and the box is that of the finite ones.

    Examples
    --------
    >>> import os, tempfile
    >>> import numpy as np
    >>> from pcl_rg.io import read_extent, write_points
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "tile.laz")
    ...     write_points(path, np.array([[10.0, 20.0, 1.0], [12.5, 21.0, 3.0]]))
    ...     extent = read_extent(path)
    >>> extent.xmin, extent.ymax, extent.points, extent.from_header
    (10.0, 21.0, 2, True)
    """
    from . import read_points  # the package imports this module

    name = os.fspath(path)
    fmt = format_of(name, format)
    if fmt in ("las", "laz"):
        check_magic(name, fmt)
        return _las_extent(name)
    cloud = read_points(name, format=format)
    finite = cloud.points[np.isfinite(cloud.points).all(axis=1)]
    if len(finite) == 0:
        return Extent(*([np.nan] * 6), len(cloud), False)
    low, high = finite.min(axis=0), finite.max(axis=0)
    return Extent(*low.tolist(), *high.tolist(), len(cloud), False)
