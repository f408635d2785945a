"""The PCD header: its grammar, the parsed header, and the header PCL writes.

PCD is PCL's Point Cloud Data format (v0.7; v0.5/v0.6 headers are read too). The
header is ASCII lines ``VERSION``, ``FIELDS`` (or the v0.5 ``COLUMNS``), ``SIZE``,
``TYPE``, ``COUNT``, ``WIDTH``, ``HEIGHT``, ``VIEWPOINT``, ``POINTS`` and ``DATA``,
with ``#`` comments; the data start right after the DATA line. The rules are
those of :func:`pcl_rg.io.read_pcd`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from ._columns import DECIMAL_INTEGER

__all__ = [
    "DEFAULT_VIEWPOINT",
    "ENCODINGS",
    "KEYWORDS",
    "MAX_HEADER_BYTES",
    "PAD",
    "PcdField",
    "PcdHeader",
    "bad_pcd",
    "format_header",
    "parse_header",
]

ENCODINGS = ("ascii", "binary", "binary_compressed")
_VERSIONS = ("0.7", ".7", "0.6", ".6", "0.5", ".5")
KEYWORDS = (
    "VERSION",
    "FIELDS",
    "COLUMNS",
    "SIZE",
    "TYPE",
    "COUNT",
    "WIDTH",
    "HEIGHT",
    "VIEWPOINT",
    "POINTS",
    "DATA",
)
DEFAULT_VIEWPOINT = (0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0)
# (TYPE, SIZE) -> little-endian NumPy dtype; PCL has no 1- or 2-byte floats.
_PCD_DTYPES = {
    ("I", 1): np.dtype("i1"),
    ("I", 2): np.dtype("<i2"),
    ("I", 4): np.dtype("<i4"),
    ("I", 8): np.dtype("<i8"),
    ("U", 1): np.dtype("u1"),
    ("U", 2): np.dtype("<u2"),
    ("U", 4): np.dtype("<u4"),
    ("U", 8): np.dtype("<u8"),
    ("F", 4): np.dtype("<f4"),
    ("F", 8): np.dtype("<f8"),
}
PAD = "_"
# The header ends with the DATA line; real headers are a few hundred bytes.
MAX_HEADER_BYTES = 1 << 20
_MAX_PCD_COUNT = 1 << 16
_CONTROL = re.compile(r"[\x00-\x08\x0a-\x1f\x7f]")  # all but tab
_REAL = re.compile(
    r"[+-]?([0-9]+\.?[0-9]*|\.[0-9]+)([eE][+-]?[0-9]+)?|[+-]?(inf|nan)", re.IGNORECASE
)


class PcdField(NamedTuple):
    """One FIELDS entry: name, storage type and COUNT."""

    name: str
    dtype: np.dtype  # little-endian scalar dtype
    count: int


class PcdHeader(NamedTuple):
    """A parsed header; `data` is the encoding, `data_offset` where the data start."""

    fields: list[PcdField]
    width: int
    height: int
    points: int
    viewpoint: tuple[float, ...]
    data: str
    data_offset: int


def bad_pcd(path: str, problem: str) -> ValueError:
    """The ValueError for a damaged PCD file, naming the file."""
    return ValueError(f"invalid PCD file {path!r}: {problem}")


def _parse_ints(path: str, key: str, tokens: list[str], minimum: int) -> list[int]:
    values = []
    for tok in tokens:
        # Decimal digits only: Python's int() also takes "1_0" (as 10), which no PCD
        # reader in C++ would.
        if not DECIMAL_INTEGER.fullmatch(tok):
            raise bad_pcd(path, f"{key} value {tok!r} is not an integer")
        value = int(tok)
        if value < minimum:
            raise bad_pcd(path, f"{key} value {value} must be >= {minimum}")
        values.append(value)
    return values


def parse_header(path: str, head: bytes) -> PcdHeader:
    """Parse the header at the start of `head`; see read_pcd for the rules."""
    entries: dict[str, list[str]] = {}
    pos = 0
    data_offset = -1
    line_no = 0  # counted as the lines go: recounting from the start made it quadratic
    while pos < len(head):
        end = head.find(b"\n", pos)
        if end < 0:
            break
        raw = head[pos:end].strip()
        line_no += 1
        pos = end + 1
        if not raw or raw.startswith(b"#"):
            continue
        try:
            line = raw.decode("ascii")
        except UnicodeDecodeError:
            line = None
        # Control characters (NUL, ...) are ASCII but no header's text: a field name
        # holding them could be read but never written back.
        if line is None or _CONTROL.search(line):
            what = "not a PCD file" if not entries else "header is not ASCII text"
            if "POINTS" in entries:  # the last keyword before DATA: binary data follows?
                what = "no DATA line before what looks like the point data"
            raise bad_pcd(path, f"{what} (line {line_no}: {raw[:40]!r})")
        tokens = line.split()
        key = tokens[0]
        if key not in KEYWORDS:
            if not entries:
                raise bad_pcd(path, f"not a PCD file (line {line_no}: {line[:40]!r})")
            raise bad_pcd(path, f"unknown header keyword {key!r} on line {line_no}")
        if key == "COLUMNS":  # the v0.5 spelling of FIELDS
            key = "FIELDS"
        if key in entries:
            raise bad_pcd(path, f"header has {key} twice (line {line_no})")
        entries[key] = tokens[1:]
        if key == "DATA":
            data_offset = pos
            break
    if data_offset < 0:
        if not head:
            raise bad_pcd(path, "file is empty")
        if not entries:
            raise bad_pcd(path, "not a PCD file (no header keywords found)")
        if len(head) >= MAX_HEADER_BYTES:
            raise bad_pcd(path, f"no DATA line within the first {MAX_HEADER_BYTES} bytes")
        rest = head[pos:].strip()
        if "POINTS" in entries and rest and not b"DATA".startswith(rest[:4]):
            # Bytes after POINTS that end no line and start no DATA keyword: binary data.
            raise bad_pcd(
                path, f"no DATA line before what looks like the point data ({rest[:40]!r})"
            )
        raise bad_pcd(path, "header is truncated (file ends before the DATA line)")

    version = entries.get("VERSION")
    if version is not None and (len(version) != 1 or version[0] not in _VERSIONS):
        raise bad_pcd(path, f"unsupported VERSION {' '.join(version)!r} (expected 0.7, 0.6 or 0.5)")

    data = entries["DATA"]
    if len(data) != 1 or data[0] not in ENCODINGS:
        raise bad_pcd(path, f"DATA must be one of {', '.join(ENCODINGS)}, got {' '.join(data)!r}")

    names = entries.get("FIELDS")
    if not names:
        raise bad_pcd(path, "header has no FIELDS")
    n_fields = len(names)
    # v0.5/v0.6 headers may omit SIZE, TYPE and COUNT; PCL then assumes float32, count 1.
    for key in ("SIZE", "TYPE", "COUNT"):
        if key in entries and len(entries[key]) != n_fields:
            raise bad_pcd(
                path, f"{key} has {len(entries[key])} values but FIELDS has {n_fields} names"
            )
    sizes = _parse_ints(path, "SIZE", entries.get("SIZE", ["4"] * n_fields), 1)
    types = entries.get("TYPE", ["F"] * n_fields)
    counts = _parse_ints(path, "COUNT", entries.get("COUNT", ["1"] * n_fields), 1)
    if max(counts) > _MAX_PCD_COUNT:  # PCL's widest descriptors hold a few hundred values
        raise bad_pcd(path, f"COUNT value {max(counts)} is above the supported {_MAX_PCD_COUNT}")

    fields = []
    seen = set()
    for name, size, typ, count in zip(names, sizes, types, counts):
        dtype = _PCD_DTYPES.get((typ, size))
        if dtype is None:
            raise bad_pcd(
                path,
                f"field {name!r} has unsupported TYPE {typ!r} with SIZE {size} "
                "(TYPE I or U with SIZE 1, 2, 4, 8; TYPE F with SIZE 4, 8)",
            )
        if name != PAD:
            if name in seen:
                raise bad_pcd(path, f"field {name!r} appears twice in FIELDS")
            seen.add(name)
        fields.append(PcdField(name, dtype, count))
    for axis in ("x", "y", "z"):
        if axis not in seen:
            raise bad_pcd(path, f"FIELDS has no {axis!r} (got {' '.join(names)})")
        count = next(f.count for f in fields if f.name == axis)
        if count != 1:
            raise bad_pcd(path, f"field {axis!r} must have COUNT 1, got {count}")

    def one_int(key: str) -> int | None:
        if key not in entries:
            return None
        if len(entries[key]) != 1:
            raise bad_pcd(path, f"{key} must be one integer, got {' '.join(entries[key])!r}")
        return _parse_ints(path, key, entries[key], 0)[0]

    width, height, n_points = one_int("WIDTH"), one_int("HEIGHT"), one_int("POINTS")
    if width is None and n_points is None:
        raise bad_pcd(path, "header has neither WIDTH nor POINTS")
    if width is None:
        if height is not None and height != 1:
            raise bad_pcd(path, f"HEIGHT {height} given without WIDTH")
        width, height = n_points, 1
    if height is None:
        height = 1
    if n_points is None:
        n_points = width * height
    if width * height != n_points:
        raise bad_pcd(
            path,
            f"WIDTH {width} x HEIGHT {height} = {width * height} does not equal POINTS {n_points}",
        )

    viewpoint = DEFAULT_VIEWPOINT
    if "VIEWPOINT" in entries:
        tokens = entries["VIEWPOINT"]
        if len(tokens) != 7:
            raise bad_pcd(
                path, f"VIEWPOINT needs 7 numbers (tx ty tz qw qx qy qz), got {len(tokens)}"
            )
        # Decimal numbers only: float() also takes "1_0" (as 10).
        if not all(_REAL.fullmatch(t) for t in tokens):
            raise bad_pcd(path, f"VIEWPOINT has a non-numeric value: {' '.join(tokens)!r}")
        viewpoint = tuple(float(t) for t in tokens)
        if not all(math.isfinite(v) for v in viewpoint):
            # Refused here, not when the cloud is written back (write_pcd's check).
            raise bad_pcd(path, f"VIEWPOINT has a value that is not finite: {' '.join(tokens)!r}")

    return PcdHeader(fields, width, height, n_points, viewpoint, data[0], data_offset)


def _format_number(value: float) -> str:
    text = repr(float(value))
    return text[:-2] if text.endswith(".0") else text


def format_header(
    names: list[str],
    columns: list[np.ndarray],
    width: int,
    height: int,
    viewpoint: Sequence[float],
    encoding: str,
) -> bytes:
    """PCL's v0.7 header (``pcl::PCDWriter``) for `columns`, 1-D or (N, count), named `names`."""
    counts = [1 if a.ndim == 1 else a.shape[1] for a in columns]
    types = ["F" if a.dtype.kind == "f" else a.dtype.kind.upper() for a in columns]
    return "".join(
        [
            "# .PCD v0.7 - Point Cloud Data file format\n",
            "VERSION 0.7\n",
            f"FIELDS {' '.join(names)}\n",
            f"SIZE {' '.join(str(a.dtype.itemsize) for a in columns)}\n",
            f"TYPE {' '.join(types)}\n",
            f"COUNT {' '.join(str(c) for c in counts)}\n",
            f"WIDTH {width}\n",
            f"HEIGHT {height}\n",
            f"VIEWPOINT {' '.join(_format_number(v) for v in viewpoint)}\n",
            f"POINTS {width * height}\n",
            f"DATA {encoding}\n",
        ]
    ).encode("ascii")
