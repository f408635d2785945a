"""Argument checks and column shaping shared by the readers and writers of :mod:`pcl_rg.io`."""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterable, Mapping
from typing import TextIO

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "DECIMAL_INTEGER",
    "PRINTABLE_TOKEN",
    "check_columns",
    "check_path",
    "check_xyz",
    "column_array",
    "exact_float32",
    "field_name",
    "load_ascii_table",
    "named_columns",
    "split_columns",
]


#: A whole number as a header writes it: decimal digits (Python's int() also takes "1_0").
DECIMAL_INTEGER = re.compile(r"[+-]?[0-9]+")
#: A name a text header can hold: printable ASCII, no white space.
PRINTABLE_TOKEN = re.compile(r"[!-~]+")


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
    try:
        array = np.asarray(points)
    except ValueError:  # a ragged sequence
        raise ValueError("points must have shape (N, 3): its rows differ in length") from None
    if array.dtype.kind not in "fiu":
        raise TypeError(f"points must be a real float or integer array, got dtype {array.dtype}")
    if array.ndim != 2 or array.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {array.shape}")
    with np.errstate(invalid="ignore"):  # signalling NaNs stay NaN without a warning
        return np.ascontiguousarray(array, dtype=np.float64)


def column_array(name: str, values: ArrayLike, shape: str) -> np.ndarray:
    """`values` as an array, or ValueError naming the column when its rows differ in
    length (NumPy's message names no column)."""
    try:
        return np.asarray(values)
    except ValueError:
        raise ValueError(f"{name} must have shape {shape}: its rows differ in length") from None


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
        if field_name(key) in ("x", "y", "z"):  # " x" would be written as x
            raise ValueError(f"fields[{key!r}]: x, y and z are given in points, not fields")
        if np.ma.is_masked(values):
            raise ValueError(f"fields[{key!r}]: masked arrays are not written; fill them first")
        array = column_array(f"fields[{key!r}]", values, f"({n},) or ({n}, count)")
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
        if np.ma.is_masked(classification):
            raise ValueError("classification: masked arrays are not written; fill them first")
        codes = column_array("classification", classification, f"({n},)")
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


def named_columns(columns: Mapping[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """(name as the text formats write it, array) pairs.

    Raises ValueError when two fields would get one name ("a b" and "a_b"): a file
    would keep only one of them.
    """
    return _one_each([(field_name(key), key, array) for key, array in columns.items()])


def split_columns(columns: Mapping[str, np.ndarray]) -> list[tuple[str, np.ndarray]]:
    """(name, 1-D array) pairs, (N, count) fields split into name_0, name_1, ...

    Raises ValueError as named_columns does, and when a split name is taken ("c" of
    two values and "c_0").
    """
    columns_1d = []
    for key, array in columns.items():
        name = field_name(key)
        if array.ndim == 1:
            columns_1d.append((name, key, array))
        else:
            columns_1d.extend((f"{name}_{i}", key, array[:, i]) for i in range(array.shape[1]))
    return _one_each(columns_1d)


def _one_each(
    columns: list[tuple[str, str, np.ndarray]],
) -> list[tuple[str, np.ndarray]]:
    """(name, array) of (name, field, array) triples, or ValueError on a name given twice."""
    field_of: dict[str, str] = {}
    for name, key, _ in columns:
        if name in field_of:
            raise ValueError(
                f"fields {field_of[name]!r} and {key!r} would both be written as {name!r}; "
                "rename one"
            )
        field_of[name] = key
    return [(name, array) for name, _, array in columns]


def loadtxt_reason(error: ValueError, where: Callable[[int], str] | None = None) -> str:
    """np.loadtxt's reason for refusing rows, its row counted from 1 as in our other
    messages (it counts the row of a value it cannot convert from 0, and a row of too
    many or too few values from 1). `where(row)` names row `row` (from 1) in the file;
    by default "data row <row>"."""
    where = where or (lambda row: f"data row {row}")
    reason = str(error).split("; use `usecols`")[0]
    unconvertible = re.fullmatch(
        r"could not convert string (.*) to (\w+) at row (\d+), column (\d+)\.", reason
    )
    if unconvertible:
        token, dtype, row, column = unconvertible.groups()
        return f"{token} cannot be read as {dtype} ({where(int(row) + 1)}, value {column})"
    changed = re.fullmatch(
        r"the number of columns changed from (\d+) to (\d+) at row (\d+)", reason
    )
    if changed:
        before, after, row = changed.groups()
        return f"{where(int(row))} holds {after} values where the rows before it hold {before}"
    short = re.fullmatch(
        r"the dtype passed requires (\d+) columns but (\d+) were found at row (\d+)", reason
    )
    if short:
        _, found, row = short.groups()
        return f"{where(int(row))} holds {found} values"
    return reason


def load_ascii_table(rows: Iterable[str] | TextIO, record: np.dtype) -> np.ndarray:
    """Rows of white-space separated numbers (lines, or a text stream) as a table of
    `record` (fields of one value or a sub-array), like np.loadtxt, which it calls;
    ValueError "<k> values per row expected: <np.loadtxt's reason>" when a row does not
    parse.

    np.loadtxt makes a float32 value that overflows inf without a word, so float fields
    narrower than float64 are read as float64 (np.loadtxt parses every float as a double
    and casts it, so the values are the same) and narrowed here: ValueError names the
    first value beyond the field's range. "inf" and "nan" tokens stay what they say.
    """
    wide = np.dtype(
        {
            "names": list(record.names),
            "formats": [_widened(record.fields[name][0]) for name in record.names],
        }
    )
    try:
        table = np.loadtxt(rows, dtype=wide, ndmin=1, comments=None)
    except ValueError as exc:
        values = sum(int(np.prod(record.fields[name][0].shape)) for name in record.names)
        raise ValueError(f"{values} values per row expected: {loadtxt_reason(exc)}") from None
    if wide == record:
        return table
    for name in record.names:
        target = record.fields[name][0].base
        values = table[name]
        if target.kind == "f" and values.dtype.base != target:
            limit = float(np.finfo(target).max)
            with np.errstate(invalid="ignore"):
                beyond = np.isfinite(values) & (np.abs(values) > limit)
            # Values beyond max that round down to it are in range: compare after the cast.
            with np.errstate(over="ignore"):
                beyond &= np.isinf(values.astype(target))
            if beyond.any():
                row = int(np.flatnonzero(beyond.reshape(len(values), -1).any(axis=1))[0])
                value = values[row].flat[np.flatnonzero(beyond[row].ravel())[0]]
                raise ValueError(
                    f"{name} value {float(value)!r} in data row {row + 1} (counting from 1) "
                    f"is beyond the {target} range"
                )
    return table.astype(record)


def _widened(dtype: np.dtype) -> np.dtype | tuple:
    base = dtype.base
    wide = np.dtype(base.byteorder + "f8") if base.kind == "f" else base
    return (wide, dtype.shape) if dtype.shape else wide
