"""Helpers of the PCD tests (test_io_pcd*.py): synthetic clouds of every storable
dtype and bit-exact comparisons."""

from __future__ import annotations

import numpy as np

from pcl_rg.io import PointFile

ENCODINGS = ("ascii", "binary", "binary_compressed")


def data_offset(raw: bytes) -> int:
    """Offset of the first byte after the DATA line."""
    return raw.index(b"\n", raw.index(b"\nDATA ") + 1) + 1


def bits(array: np.ndarray) -> np.ndarray:
    """The raw bits of an array, so that comparisons are exact for NaN and -0.0."""
    array = np.ascontiguousarray(array)
    return array.view(f"u{array.dtype.itemsize}")


def assert_same_cloud(a: PointFile, b: PointFile) -> None:
    assert a.points.dtype == b.points.dtype == np.float64
    np.testing.assert_array_equal(bits(a.points), bits(b.points))
    assert list(a.fields) == list(b.fields)
    for name in a.fields:
        assert a.fields[name].dtype == b.fields[name].dtype, name
        assert a.fields[name].shape == b.fields[name].shape, name
        np.testing.assert_array_equal(bits(a.fields[name]), bits(b.fields[name]), err_msg=name)
    assert a.format == b.format == "pcd"
    assert a.header[2:] == b.header[2:]  # width, height, viewpoint (not encoding or xyz_dtype)


def synthetic_cloud(n: int, seed: int = 7) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """UTM-sized points with NaN rows and extra fields of every storable dtype."""
    rng = np.random.default_rng(seed)
    points = rng.uniform([5e5, 5.4e6, 200.0], [5.01e5, 5.401e6, 400.0], size=(n, 3))
    points[rng.random(n) < 0.2] = np.nan
    normals = rng.normal(size=(n, 3))
    normals[::7] = np.nan
    curvature = rng.random(n).astype(np.float32)
    tiny, big = np.finfo(np.float32).smallest_subnormal, np.finfo(np.float32).max
    specials = np.array([np.inf, -np.inf, -0.0, tiny, big, -big, np.nan], dtype=np.float32)
    curvature[: min(n, specials.size)] = specials[: min(n, specials.size)]
    fields = {
        "intensity": rng.integers(0, 2**16, n, dtype=np.uint16),
        "label": rng.integers(-(2**31), 2**31, n, dtype=np.int32),
        "offset": rng.integers(-(2**63), 2**63 - 1, n, dtype=np.int64, endpoint=True),
        "gps": rng.integers(0, 2**64 - 1, n, dtype=np.uint64, endpoint=True),
        "class": rng.integers(-128, 128, n, dtype=np.int8),
        "rgb": rng.integers(0, 2**24, n, dtype=np.uint32).view(np.float32),  # PCL packing
        "normal": normals,
        "curvature": curvature,
        "hist": rng.integers(0, 256, (n, 33), dtype=np.uint8),
        "ring": rng.integers(0, 2**16, (n, 2), dtype=np.uint16).astype(">u2"),  # big-endian in
    }
    return points, fields
