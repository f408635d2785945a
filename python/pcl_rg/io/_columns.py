"""Argument checks and column shaping shared by the readers and writers of :mod:`pcl_rg.io`."""

from __future__ import annotations

import os
import re
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "check_columns",
    "check_path",
    "check_xyz",
    "exact_float32",
    "field_name",
    "split_columns",
]


def check_path(path: object, argname: str = "path") -> str:
    """`path` as a str; TypeError unless it is a str or a text os.PathLike."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"{argname} must be a str or os.PathLike, got {type(path).__name__}")
    result = os.fspath(path)
    if not isinstance(result, str):
        raise TypeError(f"{argname} must be a text path, got {type(result).__name__}")
    return result


def check_xyz(points: ArrayLike) -> np.ndarray:
    """`points` as C-contiguous float64 (N, 3); NaN and signalling NaN kept, no warning."""
    if np.ma.is_masked(points):  # np.asarray would drop the mask and write the rows
        raise ValueError("points: masked arrays are not written; select the unmasked rows first")
    array = np.asarray(points)
    if array.dtype.kind not in "fiu":
        raise TypeError(f"points must be a real float or integer array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {array.shape}")
    with np.errstate(invalid="ignore"):  # signalling NaNs stay NaN without a warning
        return np.ascontiguousarray(array, dtype=np.float64)


def check_columns(
    fields: Mapping[str, ArrayLike] | None, classification: ArrayLike | None, n: int
) -> dict[str, np.ndarray]:
    """The per-point fields of write_points, `classification` merged in, checked for `n` points."""
    if fields is not None and not isinstance(fields, Mapping):
        raise TypeError(f"fields must be a mapping of name to array, got {type(fields).__name__}")
    columns: dict[str, np.ndarray] = {}
    for key, values in (fields or {}).items():
        if not isinstance(key, str) or not key:
            raise TypeError(f"fields keys must be non-empty str, got {key!r}")
        if key.lower() in ("x", "y", "z"):
            raise ValueError(f"fields[{key!r}]: x, y and z are given in points, not fields")
        if np.ma.is_masked(values):
            raise ValueError(f"fields[{key!r}]: masked arrays are not written; fill them first")
        array = np.asarray(values)
        if array.dtype.kind not in "biuf":
            raise TypeError(
                f"fields[{key!r}] must be a bool, integer or float array, got dtype {array.dtype}"
            )
        if array.ndim not in (1, 2) or array.shape[0] != n:
            raise ValueError(
                f"fields[{key!r}] must have shape ({n},) or ({n}, count), got {array.shape}"
            )
        columns[key] = array
    if classification is not None:
        codes = np.asarray(classification)
        if codes.dtype.kind not in "iu":
            raise TypeError(f"classification must be an integer array, got dtype {codes.dtype}")
        if codes.shape != (n,):
            raise ValueError(f"classification must have shape ({n},), got {codes.shape}")
        if n and (codes.min() < 0 or codes.max() > 255):
            raise ValueError(
                f"classification must be in [0, 255], got values from {codes.min()} to "
                f"{codes.max()}"
            )
        existing = columns.get("classification")
        dtype = existing.dtype if existing is not None else np.dtype(np.uint8)
        columns["classification"] = codes.astype(dtype)
    return columns


def exact_float32(xyz: np.ndarray) -> bool:
    """Whether every coordinate survives a round trip through float32 (NaN included)."""
    with np.errstate(invalid="ignore", over="ignore"):
        back = xyz.astype(np.float32).astype(np.float64)
    return bool(np.array_equal(back, xyz, equal_nan=True))


def field_name(key: str) -> str:
    """A field name as the text formats write it: trimmed, white space runs as ``_``."""
    return re.sub(r"\s+", "_", key.strip())


def split_columns(columns: Mapping[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """(name, 1-D array) pairs, (N, count) fields split into name_0, name_1, ..."""
    out = []
    for key, array in columns.items():
        key = field_name(key)
        if array.ndim == 1:
            out.append((key, array))
        else:
            out.extend((f"{key}_{i}", array[:, i]) for i in range(array.shape[1]))
    return out
