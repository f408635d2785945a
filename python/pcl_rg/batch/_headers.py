"""What the tiles' LAS/LAZ headers say, checked: the batch plans a survey from them.

Stage 0 reads each header's coordinate system and units (`crs_records`), and the run
refuses tiles in different systems (`check_one_crs`) or units (`survey_units`); stage
1, which decodes a tile anyway, checks that its header's box is its points'
(`check_header_box`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..io import PointFile
from ..io._crs import CoordinateUnits, crs_codes_of, metre_factors, units_of
from ._plan import Box

__all__ = [
    "check_header_box",
    "check_one_crs",
    "crs_records",
    "survey_units",
]


def crs_records(path: str) -> tuple[list[int], CoordinateUnits]:
    """The EPSG codes a LAS/LAZ file gives its horizontal CRS, in its GeoTIFF keys and
    its OGC WKT (VLRs or EVLRs), and the units those records state; from its header
    alone. No code when it has no such record or no code in them.

    Codes, not the records' bytes: one CRS is written in many ways (WKT 1 or 2, with or
    without GeoTIFF keys, other citations), and only different codes say that two
    tiles are in different systems.
    """
    import laspy

    with laspy.open(path) as reader:
        return crs_codes_of(reader.header), units_of(reader.header)


def survey_units(
    paths: Sequence[str], extents: Sequence[dict[str, Any]], given: str | None
) -> tuple[tuple[float, float, float], str]:
    """Metres per unit of x, y and z of the whole survey: `given` (a key of
    GIVEN_UNITS), else what the tiles' records state, which must agree. ValueError
    before any work for tiles in degrees, records that cannot be read, or tiles in
    different units: each tile's lengths would mean other distances. Also returns a
    few words on where the units come from."""
    if given is not None:
        return metre_factors(CoordinateUnits(), given)
    found: dict[tuple[float, float, float], tuple[str, str]] = {}  # a tile, its words
    for path, extent in zip(paths, extents, strict=True):
        if not extent["ok"]:
            continue
        try:
            factors, where = metre_factors(CoordinateUnits(*extent["units"]))
        except ValueError as error:
            raise ValueError(f"{os.path.basename(path)!r}: {error}") from None
        found.setdefault(factors, (os.path.basename(path), where))
    if len(found) > 1:
        tiles = " and ".join(f"{name!r} in {where}" for name, where in found.values())
        raise ValueError(
            f"the tiles are not in one unit: {tiles}; run each unit's tiles on their own"
        )
    if not found:
        return (1.0, 1.0, 1.0), "metre (no readable tile)"
    factors, (_, where) = next(iter(found.items()))
    return factors, where


def check_one_crs(paths: Sequence[str], extents: Sequence[dict[str, Any]]) -> None:
    """Refuse, before any work, tiles whose CRS records name different EPSG codes: their
    coordinates may overlap where the places do not (two UTM zones), and a tile would
    buffer a stranger. Tiles without a code are not compared."""
    coded = [
        (path, set(extent["crs"]))
        for path, extent in zip(paths, extents, strict=True)
        if extent["ok"] and extent.get("crs")
    ]
    for k, (path, codes) in enumerate(coded):
        for other, other_codes in coded[:k]:
            if not codes & other_codes:

                def named(codes: set[int]) -> str:
                    return " or ".join(f"EPSG:{code}" for code in sorted(codes))

                raise ValueError(
                    f"the tiles are not in one coordinate system: {os.path.basename(other)!r} "
                    f"is in {named(other_codes)} and {os.path.basename(path)!r} in "
                    f"{named(codes)} (their GeoTIFF keys or WKT); run each system's tiles "
                    "on their own"
                )


# How far a LAS/LAZ header's box may lie from its points' before the plan made from the
# headers is refused. Points outside it by more than a rounding (writers round the
# bounds; coarser scales round more) would miss the tiles they should buffer. A box
# wider than its points (some writers round it outwards) only adds a neighbour to read
# and moves the survey's spacing a little, up to a metre or 1 % of the tile on a side.
HEADER_BOX_ROUNDING = 0.01  # m
HEADER_BOX_SLACK = (1.0, 0.01)  # m, fraction of the tile's width or height


def check_header_box(path: str, header_box: Box, cloud: PointFile) -> None:
    """Raise ValueError when `header_box`, which stage 0 read from the header of the
    file at `path`, is not the box of its points (`cloud`).

    The run's plan comes from the headers: which tiles give each other a buffer, and
    the survey's point spacing, which sets every tile's unset lengths.
    """
    finite = cloud.points[np.isfinite(cloud.points).all(axis=1), :2]
    if len(finite) == 0 or header_box == Box(0.0, 0.0, 0.0, 0.0):
        return  # no box to plan with: the tile is nobody's neighbour
    low, high = finite.min(axis=0), finite.max(axis=0)
    points_box = Box(float(low[0]), float(low[1]), float(high[0]), float(high[1]))
    scales = getattr(cloud.header, "scales", None)
    rounding = max(
        [HEADER_BOX_ROUNDING, *(float(v) for v in (scales if scales is not None else [])[:2])]
    )
    size = max(points_box.xmax - points_box.xmin, points_box.ymax - points_box.ymin)
    slack = max(HEADER_BOX_SLACK[0], HEADER_BOX_SLACK[1] * size)
    h, p = header_box, points_box
    outside = max(h.xmin - p.xmin, h.ymin - p.ymin, p.xmax - h.xmax, p.ymax - h.ymax)
    wider = max(p.xmin - h.xmin, p.ymin - h.ymin, h.xmax - p.xmax, h.ymax - p.ymax)
    if outside > rounding or wider > slack:

        def shown(box: Box) -> str:
            return f"x {box.xmin:.3f} to {box.xmax:.3f}, y {box.ymin:.3f} to {box.ymax:.3f}"

        raise ValueError(
            f"{path!r}: the header's bounding box ({shown(header_box)}) is not that of "
            f"its points ({shown(points_box)}); a batch plans the survey from the headers "
            "(which tiles buffer each other, the point spacing of every tile's unset "
            "lengths), so this run's other tiles may be off too: rewrite the file with "
            "its true box (pcl_rg.io.read_points, then write_points) and run again"
        )
