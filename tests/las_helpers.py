"""Helpers of the LAS/LAZ tests: seeded random LAS data with every dimension filled,
and the raw point records of a file."""

from __future__ import annotations

import laspy
import numpy as np


def random_las(
    version: str, point_format: int, n: int, seed: int, extra: bool = True
) -> laspy.LasData:
    """A LAS file with every dimension filled with seeded random values in range."""
    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(version=version, point_format=point_format)
    header.scales = [0.01, 0.01, 0.001]
    header.offsets = [512000.0, 5403000.0, 100.0]
    if extra:
        header.add_extra_dims(
            [
                laspy.ExtraBytesParams(name="amplitude", type=np.float32),
                laspy.ExtraBytesParams(name="deviation", type=np.uint16),
                laspy.ExtraBytesParams(name="echo_width", type=np.int8),
                laspy.ExtraBytesParams(name="normal", type="3f8"),
            ]
        )
    header.vlrs.append(
        laspy.VLR(
            user_id="pcl_rg_test",
            record_id=42,
            description="kept",
            record_data=bytes(rng.integers(0, 256, 37, dtype=np.uint8)),
        )
    )
    las = laspy.LasData(header)
    las.x = 512000.0 + rng.uniform(0, 200, n)
    las.y = 5403000.0 + rng.uniform(0, 200, n)
    las.z = 100.0 + rng.uniform(-5, 40, n)
    for dim in las.point_format.dimensions:
        if dim.name in ("X", "Y", "Z"):
            continue
        if dim.kind == laspy.DimensionKind.FloatingPoint:
            las[dim.name] = rng.uniform(
                -1e6, 1e6, (n, dim.num_elements) if dim.num_elements > 1 else n
            )
        else:
            low, high = max(int(dim.min), -1000), min(int(dim.max), 60000)
            las[dim.name] = rng.integers(low, high + 1, n)
    return las


def raw_points(path) -> np.ndarray:
    """The point records of a LAS/LAZ file as laspy reads them (scaled integers)."""
    with open(path, "rb") as stream:
        return laspy.read(stream, closefd=False).points.array
